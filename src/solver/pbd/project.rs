//! One Gauss–Seidel sweep over the cloth's own constraints — stretch per edge, bending per hinge, the
//! balloon's volume — by the rule of the method: PBD's `Δλ = −k' C / Σ w|∇C|²` or XPBD's
//! `Δλ = (−C − α̃λ)/(Σ w|∇C|² + α̃)`, then `Δp_i = w_i ∇_i C Δλ` (SPEC §5).
//!
//! Edges and hinges come in colours (no two of a colour share a particle, [`super::model`]), so the
//! constraints of a colour are independent: projecting them one after another or all at once gives
//! the same positions. The sweeps take them eight at a time where the CPU has AVX2
//! ([`crate::linalg::isa::avx2_lanes`]; sixteen, on AVX-512, measured slower), in single precision
//! ([`Lanes32`]): gather their particles relative to each constraint's first (so the lanes hold
//! differences of the size of an edge, to a relative 6e-8), evaluate the constraint functions — the
//! same source the scalar ones are ([`Real`]) — on all lanes at once, and add the corrections to the
//! double-precision positions and multipliers.

use std::marker::PhantomData;

use glam::DVec3;

use pulp::Simd;

use super::model::{Bend, Edge};
use crate::energy::constraints;
use crate::linalg::real::{self, Lanes32, Real, V3};

/// How a constraint's multiplier changes, given `C`, `Σ w|∇C|²`, its scaled compliance `α̃` and the
/// multiplier `λ` accumulated so far.
pub trait Rule: Copy {
    /// `Δλ`.
    fn delta<N: Real>(&self, c: N, denominator: N, compliance: N, lambda: N) -> N;
}

/// PBD: a stiffness `k' ∈ [0, 1]` per iteration; no multiplier (`λ` is accumulated but unused).
#[derive(Debug, Clone, Copy)]
pub struct Stiffness(pub f64);

impl Rule for Stiffness {
    #[inline(always)]
    fn delta<N: Real>(&self, c: N, denominator: N, _: N, _: N) -> N {
        -c.constant(self.0) * c / denominator
    }
}

/// XPBD: compliance with an accumulated multiplier.
#[derive(Debug, Clone, Copy)]
pub struct Compliance;

impl Rule for Compliance {
    #[inline(always)]
    fn delta<N: Real>(&self, c: N, denominator: N, compliance: N, lambda: N) -> N {
        (-c - compliance * lambda) / (denominator + compliance)
    }
}

/// What a sweep needs besides its constraints.
pub struct Sweep<'a, R> {
    /// Predicted positions, corrected in place.
    pub p: &'a mut [DVec3],
    /// Inverse masses.
    pub w: &'a [f64],
    /// One multiplier per constraint, accumulated over the substep's iterations.
    pub lambda: &'a mut [f64],
    /// `α/h²` (a hinge's is this times its inverse weight).
    pub compliance: f64,
    /// PBD or XPBD.
    pub rule: R,
}

/// Project every edge to its rest length; `colours` are where the edges' colours begin.
pub fn stretch<R: Rule>(edges: &[Edge], colours: &[usize], sweep: Sweep<'_, R>) {
    crate::linalg::isa::avx2_lanes(Constraints::<_, _, 2> { items: edges, colours, sweep, particles: PhantomData });
}

/// Project every hinge to its rest angle; `colours` are where the hinges' colours begin.
pub fn bend<R: Rule>(bends: &[Bend], colours: &[usize], sweep: Sweep<'_, R>) {
    crate::linalg::isa::avx2_lanes(Constraints::<_, _, 4> { items: bends, colours, sweep, particles: PhantomData });
}

/// A constraint over `K` particles.
trait Lane<const K: usize>: Copy {
    /// Its particles.
    fn particles(&self) -> [usize; K];
    /// The constants of its function (a rest length, a rest angle's cosine and sine).
    fn constants(&self) -> [f64; 2];
    /// Its scaled compliance, given the sweep's.
    fn compliance(&self, sweep: f64) -> f64;
    /// `C` and `∇C` at `x`, for numbers or lanes.
    fn evaluate<N: Real>(x: &[V3<N>; K], constants: [N; 2]) -> (N, [V3<N>; K]);
}

impl Lane<2> for Edge {
    #[inline(always)]
    fn particles(&self) -> [usize; 2] {
        self.v
    }
    #[inline(always)]
    fn constants(&self) -> [f64; 2] {
        [self.rest, 0.0]
    }
    #[inline(always)]
    fn compliance(&self, sweep: f64) -> f64 {
        sweep
    }
    #[inline(always)]
    fn evaluate<N: Real>(x: &[V3<N>; 2], constants: [N; 2]) -> (N, [V3<N>; 2]) {
        let (c, n) = constraints::stretch_of(x[0], x[1], constants[0]);
        (c, [n, real::neg(n)])
    }
}

impl Lane<4> for Bend {
    #[inline(always)]
    fn particles(&self) -> [usize; 4] {
        self.v
    }
    #[inline(always)]
    fn constants(&self) -> [f64; 2] {
        [self.rest.cos, self.rest.sin]
    }
    #[inline(always)]
    fn compliance(&self, sweep: f64) -> f64 {
        sweep * self.inverse_weight
    }
    #[inline(always)]
    fn evaluate<N: Real>(x: &[V3<N>; 4], constants: [N; 2]) -> (N, [V3<N>; 4]) {
        constraints::bending_of(x, constants[0], constants[1])
    }
}

/// A sweep over coloured constraints of `K` particles each, as a kernel for [`pulp`]'s dispatch.
struct Constraints<'a, T, R, const K: usize> {
    items: &'a [T],
    colours: &'a [usize],
    sweep: Sweep<'a, R>,
    particles: PhantomData<[(); K]>,
}

impl<const K: usize, T: Lane<K>, R: Rule> pulp::WithSimd for Constraints<'_, T, R, K> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        // The lane count as a constant, so the gathers build vectors in registers.
        match S::F32_LANES {
            16 => self.lanes::<S, 16>(simd),
            8 => self.lanes::<S, 8>(simd),
            4 => self.lanes::<S, 4>(simd),
            _ => self.lanes::<S, 1>(simd),
        }
    }
}

impl<const K: usize, T: Lane<K>, R: Rule> Constraints<'_, T, R, K> {
    /// The sweep, `L` (= `S::F32_LANES`) constraints at a time.
    #[inline(always)]
    fn lanes<S: Simd, const L: usize>(self, simd: S) {
        let Sweep { p, w, lambda, compliance, rule } = self.sweep;
        let gather = |value: [f32; L]| Lanes32::<S>::load(simd, &value);
        for colour in self.colours.windows(2) {
            let mut start = colour[0];
            while start < colour[1] {
                let count = (colour[1] - start).min(L);
                let group = &self.items[start..start + count];
                // Gather (lanes past the colour's end repeat its last constraint and are not
                // scattered).
                let mut ids = [[0usize; K]; L];
                let mut x = [[[0.0f32; L]; 3]; K];
                let (mut ws, mut constants) = ([[0.0f32; L]; K], [[0.0f32; L]; 2]);
                let (mut lambdas, mut compliances) = ([0.0f32; L], [0.0f32; L]);
                for k in 0..L {
                    let item = &group[k.min(count - 1)];
                    ids[k] = item.particles();
                    let origin = p[ids[k][0]];
                    for j in 0..K {
                        let q = p[ids[k][j]] - origin;
                        (x[j][0][k], x[j][1][k], x[j][2][k]) = (q.x as f32, q.y as f32, q.z as f32);
                        ws[j][k] = w[ids[k][j]] as f32;
                    }
                    let [a, b] = item.constants();
                    (constants[0][k], constants[1][k]) = (a as f32, b as f32);
                    lambdas[k] = lambda[start + k.min(count - 1)] as f32;
                    compliances[k] = item.compliance(compliance) as f32;
                }
                let mut xs = [[gather([0.0; L]); 3]; K];
                let mut wl = [gather([0.0; L]); K];
                for j in 0..K {
                    for a in 0..3 {
                        xs[j][a] = gather(x[j][a]);
                    }
                    wl[j] = gather(ws[j]);
                }
                let constants = [gather(constants[0]), gather(constants[1])];
                let (lambdas, compliances) = (gather(lambdas), gather(compliances));
                // Evaluate all lanes at once.
                let (c, g) = T::evaluate(&xs, constants);
                let zero = c.constant(0.0);
                let denominator = (0..K).fold(zero, |sum, j| sum + wl[j] * real::dot(g[j], g[j]));
                let delta = rule.delta(c, denominator, compliances, lambdas);
                // A constraint without movable particles, or degenerate, is left alone.
                let delta = Lanes32::select(zero.less(denominator), delta, zero);
                let delta = Lanes32::select(delta.abs().less(c.constant(f64::INFINITY)), delta, zero);
                let mut deltas = [0.0f32; L];
                delta.store(&mut deltas);
                let mut steps = [[[0.0f32; L]; 3]; K];
                for j in 0..K {
                    let step = real::scale(g[j], wl[j] * delta);
                    (0..3).for_each(|a| step[a].store(&mut steps[j][a]));
                }
                // Scatter.
                for k in 0..count {
                    lambda[start + k] += f64::from(deltas[k]);
                    for j in 0..K {
                        let [sx, sy, sz] = [0, 1, 2].map(|a| f64::from(steps[j][a][k]));
                        p[ids[k][j]] += DVec3::new(sx, sy, sz);
                    }
                }
                start += count;
            }
        }
    }
}

/// Project the enclosed volume to `target` (six times the volume), a hard constraint; `gradient` is
/// scratch of the particles' length.
pub fn volume(triangles: &[[usize; 3]], p: &mut [DVec3], w: &[f64], target: f64, gradient: &mut [DVec3]) {
    let c = constraints::six_volume(p, triangles, gradient) - target;
    let denominator: f64 = gradient.iter().zip(w).map(|(g, w)| w * g.length_squared()).sum();
    if denominator > 0.0 {
        let dl = -c / denominator;
        p.iter_mut().zip(gradient.iter()).zip(w).for_each(|((p, g), w)| *p += *g * (w * dl));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::constraints::RestAngle;

    /// `n` disjoint groups of four particles (a hinge each), bent and stretched off their rest state,
    /// 100 m from the origin (where an `f32` position would be good to only 4 µm), and their inverse
    /// masses (some zero).
    fn scattered(n: usize) -> (Vec<DVec3>, Vec<f64>) {
        let offset = DVec3::new(100.0, -50.0, 75.0);
        let base = [
            DVec3::ZERO,
            DVec3::new(0.01, 0.0, 0.0),
            DVec3::new(0.004, 0.009, 0.001),
            DVec3::new(0.006, -0.008, 0.002),
        ];
        let p = (0..n * 4)
            .map(|i| {
                let k = (i / 4) as f64;
                offset + base[i % 4] * (1.0 + 0.1 * (0.7 * k).sin()) + DVec3::new(0.02 * k, 0.0, 0.0)
            })
            .collect();
        let w = (0..n * 4).map(|i| if i % 7 == 3 { 0.0 } else { 1.0e5 * (1.0 + 0.3 * (i as f64).cos()) }).collect();
        (p, w)
    }

    /// One XPBD projection of each constraint in double precision: `Δλ` and the particles' moves.
    fn expected(c: f64, g: &[DVec3], ids: &[usize], w: &[f64], compliance: f64, lambda: f64) -> (f64, Vec<DVec3>) {
        let denominator: f64 = g.iter().zip(ids).map(|(g, &i)| w[i] * g.length_squared()).sum();
        let delta = (-c - compliance * lambda) / (denominator + compliance);
        (delta, g.iter().zip(ids).map(|(g, &i)| *g * (w[i] * delta)).collect())
    }

    /// The single-precision sweep moves each particle as the double-precision formula does, to a
    /// relative 1e-5 of the move, far from the origin too.
    #[test]
    fn the_single_precision_sweep_agrees_with_double_precision() {
        let n = 37;
        let (start, w) = scattered(n);
        let bends: Vec<Bend> = (0..n)
            .map(|k| Bend {
                v: [4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3],
                rest: RestAngle::new(0.3),
                inverse_weight: 0.8,
            })
            .collect();
        let edges: Vec<Edge> = (0..n).map(|k| Edge { v: [4 * k, 4 * k + 2], rest: 0.009 }).collect();
        let compliance = 2.0e3;
        for case in ["bend", "stretch"] {
            let mut p = start.clone();
            let mut lambda: Vec<f64> = (0..n).map(|k| 1e-6 * k as f64).collect();
            let before = lambda.clone();
            let colours = [0, n];
            let sweep = Sweep { p: &mut p, w: &w, lambda: &mut lambda, compliance, rule: Compliance };
            if case == "bend" {
                bend(&bends, &colours, sweep)
            } else {
                stretch(&edges, &colours, sweep)
            }
            for k in 0..n {
                let (ids, (c, g), alpha) = if case == "bend" {
                    let b = bends[k];
                    let (c, g) = constraints::bending(&b.v.map(|i| start[i]), b.rest);
                    (b.v.to_vec(), (c, g.to_vec()), compliance * b.inverse_weight)
                } else {
                    let e = edges[k];
                    let (c, g) = constraints::stretch(start[e.v[0]], start[e.v[1]], e.rest);
                    (e.v.to_vec(), (c, g.to_vec()), compliance)
                };
                let (delta, moves) = expected(c, &g, &ids, &w, alpha, before[k]);
                let scale = moves.iter().map(|m| m.length()).fold(0.0, f64::max);
                assert!(scale > 1e-5, "{case} {k}: the test should move particles ({scale})");
                for (&i, m) in ids.iter().zip(&moves) {
                    let error = (p[i] - start[i] - *m).length();
                    assert!(error <= 1e-5 * scale, "{case} {k}: particle {i} off by {error:e} of {scale:e}");
                }
                assert!((lambda[k] - before[k] - delta).abs() <= 1e-5 * delta.abs(), "{case} {k}: Δλ");
            }
        }
    }
}
