//! Exact self-intersection of a triangle mesh: the independent check of "the cloth never passes
//! through itself", written apart from the solvers' own proximity queries.
//!
//! Two triangles that share no vertex intersect when some edge of one crosses the other. A segment
//! `pq` crosses triangle `abc` when `p` and `q` lie on opposite sides of its plane (or one on it) —
//! the signs of `orient3d(a, b, c, p)` and `orient3d(a, b, c, q)` differ — and the three
//! tetrahedra `(p, q, a, b)`, `(p, q, b, c)`, `(p, q, c, a)` do not have both signs (the line passes
//! inside the triangle or on its boundary). `orient3d` is Shewchuk's adaptive-precision predicate,
//! so the answer is exact for the floating-point positions: a near miss is a miss. Candidate pairs
//! come from a sweep and prune of the triangles' bounding boxes along `x`.

use glam::DVec3;
use robust::{Coord3D, orient3d};

fn coord(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

/// The exact sign (−1, 0 or 1) of the volume of the tetrahedron `(a, b, c, d)`.
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    let v = orient3d(coord(a), coord(b), coord(c), coord(d));
    if v == 0.0 { 0.0 } else { v.signum() }
}

/// Whether the segment `pq` crosses the triangle `t` (touching counts).
fn segment_hits_triangle(p: DVec3, q: DVec3, t: [DVec3; 3]) -> bool {
    let (sp, sq) = (orient(t[0], t[1], t[2], p), orient(t[0], t[1], t[2], q));
    if sp * sq > 0.0 || (sp == 0.0 && sq == 0.0) {
        return false; // both on one side, or coplanar (not produced by a cloth that keeps a thickness)
    }
    let s = [orient(p, q, t[0], t[1]), orient(p, q, t[1], t[2]), orient(p, q, t[2], t[0])];
    !(s.iter().any(|&x| x > 0.0) && s.iter().any(|&x| x < 0.0))
}

/// Whether two triangles (sharing no vertex) intersect: some edge of one crosses the other.
fn triangles_intersect(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    (0..3).any(|k| segment_hits_triangle(a[k], a[(k + 1) % 3], b))
        || (0..3).any(|k| segment_hits_triangle(b[k], b[(k + 1) % 3], a))
}

/// The number of pairs of triangles that share no vertex and intersect, at positions `x`.
pub fn self_intersections(x: &[DVec3], triangles: &[[usize; 3]]) -> usize {
    let boxes: Vec<(DVec3, DVec3)> = triangles
        .iter()
        .map(|t| t.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| (lo.min(x[i]), hi.max(x[i]))))
        .collect();
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x));
    let mut found = 0;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if boxes[j].0.x > boxes[i].1.x {
                break;
            }
            let overlap = boxes[i].0.cmple(boxes[j].1).all() && boxes[j].0.cmple(boxes[i].1).all();
            if !overlap || triangles[i].iter().any(|v| triangles[j].contains(v)) {
                continue;
            }
            if triangles_intersect(triangles[i].map(|v| x[v]), triangles[j].map(|v| x[v])) {
                found += 1;
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_crossing_is_seen_and_a_near_miss_is_not() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Z];
        let crossing = [DVec3::new(0.2, -0.1, 0.2), DVec3::new(0.2, 0.1, 0.2), DVec3::new(0.3, 0.1, 0.25)];
        let above = crossing.map(|p| p + DVec3::Y * 0.1000001);
        assert!(triangles_intersect(t, crossing));
        assert!(!triangles_intersect(t, above));
    }

    #[test]
    fn a_flat_sheet_has_none_and_one_folded_through_itself_has_some() {
        // Two separate triangles, the second moved down through the first's plane.
        let x0 = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Z,
            DVec3::new(0.2, 0.1, 0.2),
            DVec3::new(0.4, 0.1, 0.2),
            DVec3::new(0.2, 0.1, 0.4),
        ];
        let triangles = [[0, 1, 2], [3, 4, 5]];
        assert_eq!(self_intersections(&x0, &triangles), 0);
        let mut x1 = x0.clone();
        x1[3].y = -0.1;
        assert_eq!(self_intersections(&x1, &triangles), 1);
        // Triangles sharing a vertex are never counted.
        assert_eq!(self_intersections(&x1, &[[0, 1, 2], [0, 4, 5]]), 0);
    }
}
