//! What a self-collision pair does: keep its vertex a thickness from its triangle, or its two edges a
//! thickness apart, on the side it keeps (the source's two constraint functions
//! `C = ±(q − p₁)·n̂ − h ≥ 0`, the sign being the side); and, once a substep's velocities are known,
//! leave touching pairs no speed apart along their normal — contact without bounce, so that a pushed
//! vertex does not fly off the cloth it was pushed out of, and a pile comes to rest.

use glam::DVec3;

use crate::collision::closest::{self, closest_on_segments, closest_on_triangle};
use crate::energy::constraints::point_triangle;

/// A vertex–triangle pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    /// The vertex.
    pub vertex: u32,
    /// The triangle.
    pub triangle: u32,
    /// +1 if the vertex keeps above the triangle's front (`(q − p₁)·n ≥ 0`), −1 below (0: not yet known).
    pub side: f64,
}

/// An edge–edge pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgePair {
    /// The two edges.
    pub edges: [u32; 2],
    /// The direction the second edge keeps from the first (unit; zero: not yet known).
    pub normal: DVec3,
}

/// Whether `q` lies over the triangle: its closest point is inside, or within a hundredth of the
/// triangle's size beside it (so neighbouring triangles overlap and no crack lets a vertex through).
pub fn over(q: DVec3, tri: [DVec3; 3]) -> bool {
    let on = closest::at(tri, closest_on_triangle(q, tri).0);
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let normal = if n.length_squared() > 0.0 { n.normalize() } else { DVec3::ZERO };
    let beside = (q - on) - normal * (q - on).dot(normal);
    let size = (tri[1] - tri[0]).length().max((tri[2] - tri[0]).length());
    beside.length() <= 0.01 * size
}

/// Project a vertex–triangle pair: move the vertex and the triangle's vertices apart to `thickness`
/// on the pair's side (inverse masses `w`), if the vertex is over the triangle and too close.
pub fn project_vertex(pair: &Pair, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
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

/// The closest points' parameters of an edge pair, the gap between them and its part along the pair's
/// normal, if the closest points face each other across the normal (not far apart sideways).
fn facing(pair: &EdgePair, edges: &[[usize; 2]], x: &[DVec3], thickness: f64) -> Option<([usize; 4], [f64; 4], f64)> {
    let (e, f) = (edges[pair.edges[0] as usize], edges[pair.edges[1] as usize]);
    let (a, b) = (e.map(|i| x[i]), f.map(|i| x[i]));
    let (s, t) = closest_on_segments(a, b);
    let gap = (b[0] + (b[1] - b[0]) * t) - (a[0] + (a[1] - a[0]) * s);
    let n = pair.normal;
    let along = gap.dot(n);
    if n == DVec3::ZERO || (gap - n * along).length() > thickness.max(0.5 * gap.length()) {
        return None;
    }
    Some(([e[0], e[1], f[0], f[1]], [-(1.0 - s), -s, 1.0 - t, t], along))
}

/// Project an edge–edge pair: push the edges' closest points apart along the pair's normal to
/// `thickness` (the gradient taken with the closest points' parameters and the normal fixed).
pub fn project_edges(pair: &EdgePair, edges: &[[usize; 2]], p: &mut [DVec3], w: &[f64], thickness: f64) {
    let Some((ids, weights, along)) = facing(pair, edges, p, thickness) else { return };
    let c = along - thickness;
    let denominator: f64 = (0..4).map(|k| w[ids[k]] * weights[k] * weights[k]).sum();
    if c >= 0.0 || denominator == 0.0 {
        return;
    }
    let lambda = -c / denominator;
    (0..4).for_each(|k| p[ids[k]] += pair.normal * (weights[k] * w[ids[k]] * lambda));
}

/// Take away the separating normal speed of particles `ids` (signed weights `weights`, so that
/// `Σ weights_k v_k · n` is the pair's relative normal speed).
fn stop(ids: [usize; 4], weights: [f64; 4], n: DVec3, v: &mut [DVec3], w: &[f64]) {
    let speed: f64 = (0..4).map(|k| weights[k] * v[ids[k]].dot(n)).sum();
    let denominator: f64 = (0..4).map(|k| w[ids[k]] * weights[k] * weights[k]).sum();
    if speed > 0.0 && denominator > 0.0 {
        let impulse = speed / denominator;
        (0..4).for_each(|k| v[ids[k]] -= n * (weights[k] * w[ids[k]] * impulse));
    }
}

/// A touching vertex–triangle pair (over the triangle, within the thickness) at `x` keeps no
/// separating speed along the triangle's normal.
pub fn settle_vertex(pair: &Pair, x: &[DVec3], v: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
    let (q, t) = (pair.vertex as usize, triangles[pair.triangle as usize]);
    let tri = t.map(|i| x[i]);
    let (c, g) = point_triangle(x[q], tri, 0.0, pair.side);
    let touching = c < 1.01 * thickness; // false for a degenerate triangle's NaN too
    if pair.side == 0.0 || !touching || !over(x[q], tri) {
        return;
    }
    let (b, _) = closest_on_triangle(x[q], tri);
    stop([q, t[0], t[1], t[2]], [1.0, -b[0], -b[1], -b[2]], g[0], v, w);
}

/// A touching edge–edge pair at `x` keeps no separating speed along its normal.
pub fn settle_edges(pair: &EdgePair, edges: &[[usize; 2]], x: &[DVec3], v: &mut [DVec3], w: &[f64], thickness: f64) {
    if let Some((ids, weights, along)) = facing(pair, edges, x, thickness)
        && along < 1.01 * thickness
    {
        stop(ids, weights, pair.normal, v, w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_touching_pair_loses_its_separating_speed_and_keeps_its_momentum() {
        // A vertex just above a horizontal triangle, flying up from it; the triangle at rest.
        let triangles = [[1, 2, 3]];
        let x = [DVec3::new(0.2, 0.005, 0.2), DVec3::ZERO, DVec3::Z, DVec3::X];
        let w = [1.0, 2.0, 2.0, 2.0];
        let pair = Pair { vertex: 0, triangle: 0, side: 1.0 };
        let side = point_triangle(x[0], triangles[0].map(|i| x[i]), 0.0, 1.0).0;
        assert!(side > 0.0, "the vertex is on the front");
        let mut v = [DVec3::new(0.3, 2.0, 0.0), DVec3::ZERO, DVec3::ZERO, DVec3::ZERO];
        let momentum = |v: &[DVec3]| v.iter().zip(&w).map(|(v, w)| *v / *w).sum::<DVec3>();
        let before = momentum(&v);
        settle_vertex(&pair, &x, &mut v, &w, &triangles, 0.01);
        let b = closest_on_triangle(x[0], triangles[0].map(|i| x[i])).0;
        let relative = v[0] - (v[1] * b[0] + v[2] * b[1] + v[3] * b[2]);
        assert!(relative.y.abs() < 1e-12, "no separating speed left: {relative}");
        assert!((relative.x - 0.3).abs() < 1e-12, "sliding is kept");
        assert!((momentum(&v) - before).length() < 1e-12, "momentum kept");
        // Approaching, or out of reach: untouched.
        let mut v2 = [DVec3::new(0.0, -1.0, 0.0), DVec3::ZERO, DVec3::ZERO, DVec3::ZERO];
        settle_vertex(&pair, &x, &mut v2, &w, &triangles, 0.01);
        assert_eq!(v2[0].y, -1.0);
        let mut v3 = [DVec3::new(0.0, 2.0, 0.0), DVec3::ZERO, DVec3::ZERO, DVec3::ZERO];
        settle_vertex(&pair, &x, &mut v3, &w, &triangles, 0.001);
        assert_eq!(v3[0].y, 2.0);
    }
}
