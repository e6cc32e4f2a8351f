//! Self-collision: every vertex keeps a thickness from every nearby triangle on the side it started
//! the substep on (the source's two constraint functions, `C = ±(q − p₁)·n̂ − h ≥ 0`, the sign being
//! that side), the triangle's own vertices excluded; and every edge keeps the thickness from every
//! nearby edge it shares no vertex with, on the side it started on, so that two triangles cannot pass
//! through each other edge first while no vertex crosses a face.
//!
//! Finding the pairs: spatial hashes of the vertices and of the edges' midpoints (cells of about the
//! longest edge), queried with the triangles' and edges' boxes, give every vertex–triangle and
//! edge–edge pair closer than the thickness plus a margin `m`; each substep then takes its pairs, with
//! their sides, from that list. The list holds as long as no two vertices have moved, relative to each
//! other, by `m` since the search: every displacement `d_i` is within `m/2` of their mean `T`, checked
//! at the start and the predicted end of each substep (a shared translation, as in a fall, does not
//! count). When one has, the hashes are rebuilt and the search made again from the substep's start,
//! with a margin of at least three times the substep's own relative travel. So no pair a search in
//! every substep would find is missed, and a search is made only when the cloth has moved enough to
//! need one. A vertex–triangle constraint acts where the vertex lies over the triangle (or within a
//! twentieth of its size beside it, overlapping its neighbours); an edge–edge one between the edges'
//! closest points along the direction they started apart. The same scene gives the same pairs in the
//! same order, bit for bit.

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
    /// +1 if the vertex keeps above the triangle's front (`(q − p₁)·n ≥ 0`), −1 below (0: not yet known).
    pub side: f64,
}

/// An edge–edge pair of one substep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgePair {
    /// The two edges.
    pub edges: [u32; 2],
    /// The direction the second edge keeps from the first (unit; zero: not yet known).
    pub normal: DVec3,
}

/// The self-collision pairs of the cloth.
#[derive(Debug, Clone, Default)]
pub struct SelfCollision {
    vertex_hash: SpatialHash,
    centroid_hash: SpatialHash,
    midpoint_hash: SpatialHash,
    /// The mesh's edges.
    pub edges: Vec<[usize; 2]>,
    /// Each vertex's margin at the last search, m.
    margins: Vec<f64>,
    /// The smallest margin of a search, m.
    least_margin: f64,
    /// Positions at the last search.
    reference: Vec<DVec3>,
    /// Scratch: the keys of the pairs a search finds.
    near_vertices: Vec<[u32; 2]>,
    near_edges: Vec<[u32; 2]>,
    /// The vertex–triangle pairs within the thickness plus the margins at the last search, sorted.
    pub pairs: Vec<Pair>,
    /// The edge–edge pairs likewise.
    pub edge_pairs: Vec<EdgePair>,
    /// Searches made so far.
    pub searches: u64,
}

/// The bounding box of some points, grown by `grow`.
fn bounds(points: impl IntoIterator<Item = DVec3>, grow: f64) -> (DVec3, DVec3) {
    let (lo, hi) =
        points.into_iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
    (lo - DVec3::splat(grow), hi + DVec3::splat(grow))
}

/// The mean of the displacements `y − from`.
fn mean_displacement(y: &[DVec3], from: &[DVec3]) -> DVec3 {
    y.iter().zip(from).map(|(a, b)| *a - *b).sum::<DVec3>() / y.len().max(1) as f64
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

/// The vector from the closest point of segment `a` to that of segment `b`.
fn segment_gap(a: [DVec3; 2], b: [DVec3; 2]) -> DVec3 {
    let (s, t) = closest_on_segments(a[0], a[1], b[0], b[1]);
    (b[0] + (b[1] - b[0]) * t) - (a[0] + (a[1] - a[0]) * s)
}

impl SelfCollision {
    /// For a mesh with these edges, of mean length `mean_edge` (which sets the least margin).
    pub fn new(mean_edge: f64, edges: Vec<[usize; 2]>) -> Self {
        Self { edges, least_margin: 0.25 * mean_edge, ..Self::default() }
    }

    /// This substep's pairs, for the substep from `x` (start) to `p` (predicted).
    pub fn find(&mut self, x: &[DVec3], p: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        let stale = self.reference.len() != x.len() || {
            let (tx, tp) = (mean_displacement(x, &self.reference), mean_displacement(p, &self.reference));
            (0..x.len()).any(|i| {
                let drift = (x[i] - self.reference[i] - tx).length().max((p[i] - self.reference[i] - tp).length());
                2.0 * drift >= self.margins[i]
            })
        };
        if stale {
            let t0 = std::time::Instant::now();
            let t = mean_displacement(p, x);
            self.margins.clear();
            self.margins.extend(p.iter().zip(x).map(|(a, b)| self.least_margin + 3.0 * (*a - *b - t).length()));
            self.search(x, triangles, thickness);
            if std::env::var("SCDEBUG").is_ok() {
                eprintln!(
                    "search {} margin {:.4} vt {} ee {} in {:.2} ms",
                    self.searches,
                    self.margins.iter().fold(0.0f64, |a, b| a.max(*b)),
                    self.near_vertices.len(),
                    self.near_edges.len(),
                    t0.elapsed().as_secs_f64() * 1e3
                );
            }
        }
        for pair in &mut self.pairs {
            let (v, tri) = (x[pair.vertex as usize], triangles[pair.triangle as usize].map(|i| x[i]));
            let (d, _) = point_triangle(v, tri, 0.0, 1.0);
            // A vertex over the triangle and closer than the thickness keeps the side it had: if it was
            // pushed through in the last substep, this brings it back.
            let kept = pair.side != 0.0 && d.abs() < thickness && over(v, tri);
            if !kept && d.is_finite() {
                pair.side = if d >= 0.0 { 1.0 } else { -1.0 };
            }
        }
        for pair in &mut self.edge_pairs {
            let [i, j] = pair.edges;
            let (e, f) = (self.edges[i as usize].map(|k| x[k]), self.edges[j as usize].map(|k| x[k]));
            let gap = segment_gap(e, f);
            let cross = (e[1] - e[0]).cross(f[1] - f[0]);
            let parallel =
                cross.length_squared() <= 1e-12 * (e[1] - e[0]).length_squared() * (f[1] - f[0]).length_squared();
            // Edges closer than the thickness keep the side they had (as vertices do).
            let towards = if pair.normal != DVec3::ZERO && gap.length() < thickness { pair.normal } else { gap };
            if !parallel {
                let n = cross.normalize();
                pair.normal = if n.dot(towards) >= 0.0 { n } else { -n };
            } else if pair.normal == DVec3::ZERO && gap.length_squared() > 0.0 {
                pair.normal = gap.normalize();
            }
        }
    }

    /// Rebuild the hashes at `x` and list every pair closer than the thickness plus half the sum of
    /// its two sides' margins (a side's margin: the largest of its vertices'). Each pair is found from
    /// the side with the larger margin, whose query box reaches that far: a fast vertex near slow
    /// cloth does not grow every query.
    fn search(&mut self, x: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        self.searches += 1;
        self.reference.clear();
        self.reference.extend_from_slice(x);
        let margins = &self.margins;
        let longest = self.edges.iter().map(|e| (x[e[0]] - x[e[1]]).length()).fold(0.0, f64::max);
        let cell = longest.max(1e-9);
        let side = |ids: &[usize]| ids.iter().map(|&i| margins[i]).fold(0.0, f64::max);
        // Vertex–triangle pairs whose triangle has the larger margin: the vertices in its grown box.
        let mut near_vertices = std::mem::take(&mut self.near_vertices);
        near_vertices.clear();
        self.vertex_hash.set_cell(cell);
        self.vertex_hash.rebuild(x.iter().copied());
        for (t, tri) in triangles.iter().enumerate() {
            let corners = tri.map(|i| x[i]);
            let margin = side(tri);
            let (lo, hi) = bounds(corners, thickness + margin);
            let near = &mut near_vertices;
            self.vertex_hash.query(lo, hi, |v, q| {
                let mv = margins[v as usize];
                if mv <= margin && !tri.contains(&(v as usize)) && within(q, corners, thickness + 0.5 * (margin + mv)) {
                    near.push([v, t as u32]);
                }
            });
        }
        // Those whose vertex has the larger margin: the triangles whose centroids are within the
        // largest centroid-to-corner distance of its grown box.
        let centroids = || triangles.iter().map(|t| (x[t[0]] + x[t[1]] + x[t[2]]) / 3.0);
        let radius = centroids()
            .zip(triangles)
            .map(|(c, t)| t.iter().map(|&i| (x[i] - c).length()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        self.centroid_hash.set_cell(cell);
        self.centroid_hash.rebuild(centroids());
        for (v, &mv) in margins.iter().enumerate() {
            if mv <= self.least_margin {
                continue; // no triangle's margin is smaller
            }
            let (lo, hi) = bounds([x[v]], thickness + mv + radius);
            let near = &mut near_vertices;
            self.centroid_hash.query(lo, hi, |t, _| {
                let tri = triangles[t as usize];
                let margin = side(&tri);
                if margin < mv && !tri.contains(&v) && within(x[v], tri.map(|i| x[i]), thickness + 0.5 * (margin + mv))
                {
                    near.push([v as u32, t]);
                }
            });
        }
        // Edge–edge pairs, from the edge with the larger (margin, index): the edges whose midpoints
        // are within half the longest edge of its grown box.
        let mut near_edges = std::mem::take(&mut self.near_edges);
        near_edges.clear();
        self.midpoint_hash.set_cell(cell);
        self.midpoint_hash.rebuild(self.edges.iter().map(|e| 0.5 * (x[e[0]] + x[e[1]])));
        for (i, e) in self.edges.iter().enumerate() {
            let ends = e.map(|k| x[k]);
            let margin = side(e);
            let (lo, hi) = bounds(ends, thickness + margin + 0.5 * longest);
            let (edges, near) = (&self.edges, &mut near_edges);
            self.midpoint_hash.query(lo, hi, |j, _| {
                let f = edges[j as usize];
                let mf = side(&f);
                if (mf, j as usize) >= (margin, i) || f.contains(&e[0]) || f.contains(&e[1]) {
                    return;
                }
                let reach = thickness + 0.5 * (margin + mf);
                if segment_gap(ends, f.map(|k| x[k])).length_squared() <= reach * reach {
                    near.push([i.min(j as usize) as u32, i.max(j as usize) as u32]);
                }
            });
        }
        // The pairs found again keep their sides.
        near_vertices.sort_unstable();
        near_edges.sort_unstable();
        self.pairs = carry(
            &near_vertices,
            &self.pairs,
            |p| [p.vertex, p.triangle],
            |[vertex, triangle]| Pair { vertex, triangle, side: 0.0 },
        );
        self.edge_pairs =
            carry(&near_edges, &self.edge_pairs, |p| p.edges, |edges| EdgePair { edges, normal: DVec3::ZERO });
        (self.near_vertices, self.near_edges) = (near_vertices, near_edges);
    }
}

/// The pairs with these (sorted) keys: those in `old` (sorted by key) as they were, new ones made.
fn carry<P: Copy>(keys: &[[u32; 2]], old: &[P], key: impl Fn(&P) -> [u32; 2], new: impl Fn([u32; 2]) -> P) -> Vec<P> {
    let mut k = 0;
    keys.iter()
        .map(|&wanted| {
            while k < old.len() && key(&old[k]) < wanted {
                k += 1;
            }
            if k < old.len() && key(&old[k]) == wanted { old[k] } else { new(wanted) }
        })
        .collect()
}

/// Whether `q` lies over the triangle: its closest point is inside, or within a twentieth of the
/// triangle's size beside it (so neighbouring triangles overlap and no crack lets a vertex through).
fn over(q: DVec3, tri: [DVec3; 3]) -> bool {
    let b = closest_on_triangle(q, tri[0], tri[1], tri[2]);
    let on = tri[0] * b[0] + tri[1] * b[1] + tri[2] * b[2];
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let normal = if n.length_squared() > 0.0 { n.normalize() } else { DVec3::ZERO };
    let beside = (q - on) - normal * (q - on).dot(normal);
    let size = (tri[1] - tri[0]).length().max((tri[2] - tri[0]).length());
    beside.length() <= 0.05 * size
}

/// Whether point `q` is within `reach` of the triangle `corners`.
fn within(q: DVec3, corners: [DVec3; 3], reach: f64) -> bool {
    let b = closest_on_triangle(q, corners[0], corners[1], corners[2]);
    (q - (corners[0] * b[0] + corners[1] * b[1] + corners[2] * b[2])).length_squared() <= reach * reach
}

impl SelfCollision {
    /// Project every pair once (vertex–triangle, then edge–edge).
    pub fn project(&self, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
        for pair in &self.pairs {
            project(pair, p, w, triangles, thickness);
        }
        for pair in &self.edge_pairs {
            project_edges(pair, &self.edges, p, w, thickness);
        }
    }
}

/// Project one vertex–triangle pair: move the vertex and the triangle's vertices apart to `thickness`
/// on the pair's side (inverse masses `w`), if the vertex is over the triangle and too close.
fn project(pair: &Pair, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
    let (v, t) = (pair.vertex as usize, triangles[pair.triangle as usize]);
    let tri = t.map(|i| p[i]);
    let (c, g) = point_triangle(p[v], tri, thickness, pair.side);
    if c >= 0.0 || !c.is_finite() || pair.side == 0.0 || !over(p[v], tri) {
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
fn project_edges(pair: &EdgePair, edges: &[[usize; 2]], p: &mut [DVec3], w: &[f64], thickness: f64) {
    let (e, f) = (edges[pair.edges[0] as usize], edges[pair.edges[1] as usize]);
    let (a0, a1, b0, b1) = (p[e[0]], p[e[1]], p[f[0]], p[f[1]]);
    let (s, t) = closest_on_segments(a0, a1, b0, b1);
    let gap = (b0 + (b1 - b0) * t) - (a0 + (a1 - a0) * s);
    let n = pair.normal;
    let c = gap.dot(n) - thickness;
    if n == DVec3::ZERO {
        return;
    }
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
