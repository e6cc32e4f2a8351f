//! Self-collision: every vertex keeps a thickness from every nearby triangle on the side it started
//! the substep on (the source's two constraint functions, `C = ±(q − p₁)·n̂ − h ≥ 0`, with the sign
//! of the side), the triangle's own vertices excluded.
//!
//! Candidates come from a spatial hash with cells of about the mean edge length, rebuilt each substep
//! from the triangles' bounding boxes over the substep (start and predicted positions) grown by the
//! thickness; a vertex whose swept box meets a triangle's box becomes a pair, with the side taken from
//! the start positions. A constraint acts only where the vertex lies over the triangle's interior (its
//! edges and corners are its neighbours' business). Pairs are found in vertex order, candidates in
//! triangle order: the same scene gives the same pairs, bit for bit.

use glam::DVec3;

use crate::collision::SpatialHash;
use crate::energy::constraints::point_triangle;

use super::contact::closest_on_triangle;

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

/// The self-collision pairs of the cloth, found anew each substep.
#[derive(Debug, Clone, Default)]
pub struct SelfCollision {
    hash: SpatialHash,
    candidates: Vec<u32>,
    merged: Vec<u32>,
    /// This substep's pairs.
    pub pairs: Vec<Pair>,
}

impl SelfCollision {
    /// Cells of side `cell` (about the mean edge length).
    pub fn new(cell: f64) -> Self {
        Self { hash: SpatialHash::new(cell), ..Self::default() }
    }

    /// Find the pairs of a substep from `x` (start) to `p` (predicted).
    pub fn find(&mut self, x: &[DVec3], p: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        let grow = DVec3::splat(thickness);
        self.hash.rebuild(triangles.iter().map(|t| {
            let (lo, hi) = t.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
                (lo.min(x[i]).min(p[i]), hi.max(x[i]).max(p[i]))
            });
            (lo - grow, hi + grow)
        }));
        self.pairs.clear();
        for v in 0..x.len() {
            // The vertex's swept segment, at both ends (the hash reports the boxes containing a point).
            self.merged.clear();
            for end in [x[v], p[v]] {
                self.hash.query(end, &mut self.candidates);
                self.merged.extend_from_slice(&self.candidates);
            }
            self.merged.sort_unstable();
            self.merged.dedup();
            for &t in &self.merged {
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
    }
}

/// Project one pair: move the vertex and the triangle's vertices apart to `thickness` on the pair's
/// side (inverse masses `w`), if the vertex is over the triangle's interior and too close.
pub fn project(pair: &Pair, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
    let (v, t) = (pair.vertex as usize, triangles[pair.triangle as usize]);
    let tri = t.map(|i| p[i]);
    let b = closest_on_triangle(p[v], tri[0], tri[1], tri[2]);
    if b.iter().any(|&x| x <= 0.0) {
        return;
    }
    let (c, g) = point_triangle(p[v], tri, thickness, pair.side);
    if c >= 0.0 || !c.is_finite() {
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
