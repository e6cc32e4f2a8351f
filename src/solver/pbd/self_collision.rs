//! Self-collision: every vertex keeps a thickness from every nearby triangle on the side it started
//! the substep on (the source's two constraint functions, `C = ±(q − p₁)·n̂ − h ≥ 0`, the sign being
//! that side), the triangle's own vertices excluded; and every edge keeps the thickness from every
//! nearby edge it shares no vertex with, on the side it started on, so that two triangles cannot pass
//! through each other edge first while no vertex crosses a face.
//!
//! Candidates come from spatial hashes with cells of about the mean edge length, rebuilt each
//! substep from the bounding boxes of the triangles and edges over the substep (start and predicted
//! positions, so nothing that moves through within a substep is missed) grown by the thickness. The
//! side is taken from the start positions. A vertex–triangle constraint acts where the vertex lies
//! over the triangle (or within a twentieth of its size outside it, overlapping its neighbours);
//! an edge–edge one between the edges' closest points along the direction they started apart.
//! Pairs are found in vertex (edge) order, candidates in increasing order: the same scene gives the
//! same pairs, bit for bit.

use glam::DVec3;

use super::contact::closest_on_triangle;
use crate::collision::SpatialHash;
use crate::energy::constraints::point_triangle;

/// A vertex–triangle pair of one substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    /// The vertex.
    pub vertex: u32,
    /// The triangle.
    pub triangle: u32,
    /// The side the vertex started on: +1 in front of the triangle, −1 behind.
    pub side: f64,
}

/// An edge–edge pair of one substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgePair {
    /// The two edges.
    pub edges: [u32; 2],
    /// The direction from the first edge to the second at the start of the substep (unit).
    pub normal: DVec3,
}

/// The self-collision pairs of the cloth, found anew each substep.
#[derive(Debug, Clone, Default)]
pub struct SelfCollision {
    triangles: SpatialHash,
    edge_hash: SpatialHash,
    candidates: Vec<u32>,
    /// The mesh's edges.
    pub edges: Vec<[usize; 2]>,
    /// This substep's vertex–triangle pairs.
    pub pairs: Vec<Pair>,
    /// This substep's edge–edge pairs.
    pub edge_pairs: Vec<EdgePair>,
}

/// The bounding box of some vertices over a substep (start and predicted), grown by `grow`.
fn swept(ids: &[usize], x: &[DVec3], p: &[DVec3], grow: f64) -> (DVec3, DVec3) {
    let (lo, hi) = ids
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| (lo.min(x[i]).min(p[i]), hi.max(x[i]).max(p[i])));
    (lo - DVec3::splat(grow), hi + DVec3::splat(grow))
}

/// Parameters `(s, t)` of the closest points `a₀ + s(a₁ − a₀)`, `b₀ + t(b₁ − b₀)` of two segments.
fn closest_on_segments(a0: DVec3, a1: DVec3, b0: DVec3, b1: DVec3) -> (f64, f64) {
    let (d1, d2, r) = (a1 - a0, b1 - b0, a0 - b0);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    if a <= 1e-300 || e <= 1e-300 {
        return (0.0, 0.0);
    }
    let (b, c) = (d1.dot(d2), d1.dot(r));
    let denom = a * e - b * b;
    let mut s = if denom > 1e-14 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

impl SelfCollision {
    /// Cells of side `cell` (about the mean edge length), for a mesh with these edges.
    pub fn new(cell: f64, edges: Vec<[usize; 2]>) -> Self {
        Self { triangles: SpatialHash::new(cell), edge_hash: SpatialHash::new(cell), edges, ..Self::default() }
    }

    /// Find the pairs of a substep from `x` (start) to `p` (predicted).
    pub fn find(&mut self, x: &[DVec3], p: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        self.triangles.rebuild(triangles.iter().map(|t| swept(t, x, p, thickness)));
        self.pairs.clear();
        for v in 0..x.len() {
            let (lo, hi) = swept(&[v], x, p, thickness);
            self.triangles.query_box(lo, hi, &mut self.candidates);
            for &t in &self.candidates {
                let tri = triangles[t as usize];
                if tri.contains(&v) {
                    continue;
                }
                let (c, _) = point_triangle(x[v], tri.map(|i| x[i]), 0.0, 1.0);
                if c.is_finite() {
                    self.pairs.push(Pair { vertex: v as u32, triangle: t, side: if c >= 0.0 { 1.0 } else { -1.0 } });
                }
            }
        }
        let edges = &self.edges;
        self.edge_hash.rebuild(edges.iter().map(|e| swept(e, x, p, thickness)));
        self.edge_pairs.clear();
        for (i, e) in edges.iter().enumerate() {
            let (lo, hi) = swept(e, x, p, thickness);
            self.edge_hash.query_box(lo, hi, &mut self.candidates);
            for &j in self.candidates.iter().filter(|&&j| j as usize > i) {
                let f = edges[j as usize];
                if f.contains(&e[0]) || f.contains(&e[1]) {
                    continue;
                }
                let (a0, a1, b0, b1) = (x[e[0]], x[e[1]], x[f[0]], x[f[1]]);
                let (s, t) = closest_on_segments(a0, a1, b0, b1);
                let gap = (b0 + (b1 - b0) * t) - (a0 + (a1 - a0) * s);
                let cross = (a1 - a0).cross(b1 - b0);
                let normal = if cross.length_squared() > 1e-12 * (a1 - a0).length_squared() * (b1 - b0).length_squared()
                {
                    let n = cross.normalize();
                    if n.dot(gap) >= 0.0 { n } else { -n }
                } else if gap.length_squared() > 0.0 {
                    gap.normalize()
                } else {
                    continue;
                };
                self.edge_pairs.push(EdgePair { edges: [i as u32, j], normal });
            }
        }
    }
}

/// Project one vertex–triangle pair: move the vertex and the triangle's vertices apart to `thickness`
/// on the pair's side (inverse masses `w`), if the vertex is over the triangle and too close.
pub fn project(pair: &Pair, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
    let (v, t) = (pair.vertex as usize, triangles[pair.triangle as usize]);
    let tri = t.map(|i| p[i]);
    let b = closest_on_triangle(p[v], tri[0], tri[1], tri[2]);
    let outside = (p[v] - (tri[0] * b[0] + tri[1] * b[1] + tri[2] * b[2])).length_squared();
    let size = (tri[1] - tri[0]).length().max((tri[2] - tri[0]).length());
    // Over the triangle: its projection is inside, or within a twentieth of its size beside it.
    let (c, g) = point_triangle(p[v], tri, thickness, pair.side);
    let plane = c + thickness;
    if c >= 0.0 || !c.is_finite() || outside - plane * plane > (0.05 * size).powi(2) {
        return;
    }
    let ids = [v, t[0], t[1], t[2]];
    let denominator: f64 = (0..4).map(|k| w[ids[k]] * g[k].length_squared()).sum();
    if denominator == 0.0 {
        return;
    }
    let lambda = -c / denominator;
    (0..4).for_each(|k| p[ids[k]] += g[k] * (w[ids[k]] * lambda));
}

/// Project one edge–edge pair: push the edges' closest points apart along the pair's direction to
/// `thickness` (the gradient taken with the closest points' parameters and the direction fixed).
pub fn project_edges(pair: &EdgePair, edges: &[[usize; 2]], p: &mut [DVec3], w: &[f64], thickness: f64) {
    let (e, f) = (edges[pair.edges[0] as usize], edges[pair.edges[1] as usize]);
    let (a0, a1, b0, b1) = (p[e[0]], p[e[1]], p[f[0]], p[f[1]]);
    let (s, t) = closest_on_segments(a0, a1, b0, b1);
    let gap = (b0 + (b1 - b0) * t) - (a0 + (a1 - a0) * s);
    let n = pair.normal;
    let c = gap.dot(n) - thickness;
    // Only where the closest points face each other across the direction (not far apart sideways).
    if c >= 0.0 || (gap - n * gap.dot(n)).length() > thickness.max(0.5 * gap.length()) {
        return;
    }
    let weights = [1.0 - s, s, 1.0 - t, t];
    let ids = [e[0], e[1], f[0], f[1]];
    let signs = [-1.0, -1.0, 1.0, 1.0];
    let denominator: f64 = (0..4).map(|k| w[ids[k]] * weights[k] * weights[k]).sum();
    if denominator == 0.0 {
        return;
    }
    let lambda = -c / denominator;
    (0..4).for_each(|k| p[ids[k]] += n * (signs[k] * weights[k] * w[ids[k]] * lambda));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_points_of_crossing_parallel_and_end_to_end_segments() {
        let (s, t) = closest_on_segments(DVec3::ZERO, DVec3::X, DVec3::new(0.3, 1.0, -1.0), DVec3::new(0.3, 1.0, 1.0));
        assert!((s - 0.3).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
        let (s, _) = closest_on_segments(DVec3::ZERO, DVec3::X, DVec3::new(2.0, 1.0, 0.0), DVec3::new(3.0, 1.0, 0.0));
        assert_eq!(s, 1.0);
    }
}
