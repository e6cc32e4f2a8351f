//! One Gauss–Seidel sweep over the cloth's own constraints — stretch per edge, bending per hinge, the
//! balloon's volume — by the rule of the method: PBD's `Δλ = −k' C / Σ w|∇C|²` or XPBD's
//! `Δλ = (−C − α̃λ)/(Σ w|∇C|² + α̃)`, then `Δp_i = w_i ∇_i C Δλ` (SPEC §5).
//!
//! Edges and hinges come in colours (no two of a colour share a particle, [`super::model`]), so the
//! constraints of a colour are independent: projecting them one after another or all at once gives
//! the same positions. The sweeps take them four at a time where the CPU has AVX2
//! ([`crate::linalg::isa::avx2_lanes`]; eight, on AVX-512, measured slower): gather their particles,
//! evaluate the constraint functions — the same source the scalar ones are ([`Real`]) — on all lanes
//! at once, scatter the corrections.

use std::marker::PhantomData;

use glam::DVec3;

use pulp::Simd;

use super::model::{Bend, Edge};
use crate::energy::constraints;
use crate::linalg::real::{self, Lanes, Real, V3};

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
        match S::F64_LANES {
            8 => self.lanes::<S, 8>(simd),
            4 => self.lanes::<S, 4>(simd),
            2 => self.lanes::<S, 2>(simd),
            _ => self.lanes::<S, 1>(simd),
        }
    }
}

impl<const K: usize, T: Lane<K>, R: Rule> Constraints<'_, T, R, K> {
    /// The sweep, `L` (= `S::F64_LANES`) constraints at a time.
    #[inline(always)]
    fn lanes<S: Simd, const L: usize>(self, simd: S) {
        let Sweep { p, w, lambda, compliance, rule } = self.sweep;
        let gather = |value: [f64; L]| Lanes::<S>::load(simd, &value);
        for colour in self.colours.windows(2) {
            let mut start = colour[0];
            while start < colour[1] {
                let count = (colour[1] - start).min(L);
                let group = &self.items[start..start + count];
                // Gather (lanes past the colour's end repeat its last constraint and are not
                // scattered).
                let mut ids = [[0usize; K]; L];
                let mut x = [[[0.0; L]; 3]; K];
                let (mut ws, mut constants) = ([[0.0; L]; K], [[0.0; L]; 2]);
                let (mut lambdas, mut compliances) = ([0.0; L], [0.0; L]);
                for k in 0..L {
                    let item = &group[k.min(count - 1)];
                    ids[k] = item.particles();
                    for j in 0..K {
                        let q = p[ids[k][j]];
                        (x[j][0][k], x[j][1][k], x[j][2][k]) = (q.x, q.y, q.z);
                        ws[j][k] = w[ids[k][j]];
                    }
                    [constants[0][k], constants[1][k]] = item.constants();
                    lambdas[k] = lambda[start + k.min(count - 1)];
                    compliances[k] = item.compliance(compliance);
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
                let delta = Lanes::select(c.constant(1e-300).less(denominator), delta, zero);
                let delta = Lanes::select(delta.abs().less(c.constant(f64::INFINITY)), delta, zero);
                let mut deltas = [0.0; L];
                delta.store(&mut deltas);
                let mut steps = [[[0.0; L]; 3]; K];
                for j in 0..K {
                    let step = real::scale(g[j], wl[j] * delta);
                    (0..3).for_each(|a| step[a].store(&mut steps[j][a]));
                }
                // Scatter.
                for k in 0..count {
                    lambda[start + k] += deltas[k];
                    for j in 0..K {
                        p[ids[k][j]] += DVec3::new(steps[j][0][k], steps[j][1][k], steps[j][2][k]);
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
