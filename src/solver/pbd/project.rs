//! One Gauss–Seidel sweep over the cloth's own constraints — stretch per edge, bending per hinge, the
//! balloon's volume — by the rule of the method: PBD's `Δλ = −k' C / Σ w|∇C|²` or XPBD's
//! `Δλ = (−C − α̃λ)/(Σ w|∇C|² + α̃)`, then `Δp_i = w_i ∇_i C Δλ` (Müller et al. 2007;
//! Macklin, Müller & Chentanez 2016).
//!
//! With bending, the boundary edges go first, then each interior edge together with its hinge, in one
//! lane: the stretch is projected, then the bending at the stretched positions (Gauss–Seidel within
//! the lane), and the particles are read and written once for both (taking the edges on their own
//! read and wrote every particle of a hinge's edge a second time: the sweeps measured faster
//! together, `BENCHMARKS.md`, *Design measurements quoted from module docs*). Without bending every
//! edge goes on its own. Lanes come in colours (no
//! two of a colour share a particle, [`super::model`]), so the lanes of a colour are independent:
//! projecting them one after another or all at once gives the same positions. A large colour is
//! therefore cut into as many pieces as there are threads, which project at once, reading and moving
//! the shared rows ([`super::batch::Shared`]; only colours whose lanes are checked to share no
//! particle, [`Batches::separate`]), so a sweep gives the same bits on one thread and on several.
//!
//! The sweeps take them eight at a time where the CPU has AVX2, in single precision ([`Lanes32`], with
//! fused multiply-adds), from batches packed once ([`super::batch`]), moving the particles' rows —
//! positions in single precision — in and out of the lanes as [`super::avx2_lanes`] says; the constraint
//! functions — the same source the scalar ones are ([`Real`]) — run on all lanes at once. The
//! kernel is compiled with AVX-512's 32 registers where the CPU has them ([`crate::linalg::isa::eight`]),
//! indexes the rows by masked indices (no bounds checks) and writes every lane of a batch, the ones
//! past its count repeating its last. Each measured faster on the hanging sheet: rows in single
//! precision than double-precision rows narrowed lane by lane, the extra registers, the masked
//! indices, and writing every lane instead of testing each against the count. Earlier, with
//! double-precision rows: sixteen lanes (two batches joined for the arithmetic) gained a little on
//! the sheet and lost on the drape; eight lanes of double precision on AVX-512 lost (its divisions
//! and roots) (`BENCHMARKS.md`, *Design measurements quoted from module docs*). A CPU without AVX2
//! runs the same arithmetic one lane at a time.

use std::marker::PhantomData;

use glam::DVec3;

use super::batch::{Batch, Batches, Indexed, LANES, Projected, Read, Row, Rows, Shared};
use super::model::{Edge, Model, StretchBend};
use crate::energy::constraints;
use crate::linalg::real::{self, Lanes32, Real, V3};

/// How a constraint's multiplier changes, given `C`, `Σ w|∇C|²`, its scaled compliance `α̃` and the
/// multiplier `λ` accumulated so far.
pub trait Rule: Copy + Send + Sync {
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

/// XPBD: compliance with an accumulated multiplier; a constraint below its rest value (`C < 0`, an
/// edge in compression) has its compliance times `compressed` (1: the same both ways).
#[derive(Debug, Clone, Copy)]
pub struct Compliance {
    /// The compliance's factor where `C < 0`.
    pub compressed: f64,
}

impl Compliance {
    /// The same compliance both ways.
    pub const SYMMETRIC: Self = Self { compressed: 1.0 };
}

impl Rule for Compliance {
    #[inline(always)]
    fn delta<N: Real>(&self, c: N, denominator: N, compliance: N, lambda: N) -> N {
        let compliance = N::select(c.less(c.constant(0.0)), compliance * c.constant(self.compressed), compliance);
        (-c - compliance * lambda) / (denominator + compliance)
    }
}

/// What a sweep over lanes of `F` constraints needs besides the lanes.
pub struct Sweep<'a, R, const F: usize> {
    /// Predicted positions and inverse masses, the positions corrected in place.
    pub rows: Indexed<&'a mut [Row]>,
    /// One multiplier per constraint (at its batch, its place in the lane, and the lane),
    /// accumulated over the substep's iterations.
    pub lambda: &'a mut [[[f64; LANES]; F]],
    /// Whether this is the substep's first sweep: the multipliers start from zero (what `lambda`
    /// holds is ignored and overwritten, so it needs no clearing).
    pub first: bool,
    /// Whether this is the substep's last sweep: no sweep reads the multipliers after it, so they
    /// are left as they are.
    pub last: bool,
    /// `α/h²` of each of a lane's constraints (a hinge's is this times its inverse weight).
    pub compliance: [f64; F],
    /// PBD or XPBD, for each of a lane's constraints.
    pub rule: [R; F],
}

/// The constraints' multipliers, at their batches and lanes (XPBD's `λ`; PBD accumulates them unused).
#[derive(Clone)]
pub struct Multipliers {
    edges: Vec<[[f64; LANES]; 1]>,
    boundary: Vec<[[f64; LANES]; 1]>,
    hinges: Vec<[[f64; LANES]; 2]>,
}

impl Multipliers {
    /// Zeroed, for the model's batches.
    pub fn new(model: &Model) -> Self {
        Self {
            edges: model.edge_batches.multipliers(),
            boundary: model.boundary_batches.multipliers(),
            hinges: model.hinge_batches.multipliers(),
        }
    }
}

/// One sweep over the cloth's own constraints in `rows`, each kind with its scaled compliance and
/// rule: with bending, the boundary edges and then the interior edges each with its hinge; without,
/// every edge. `first` and `last` say where the sweep stands in its substep ([`Sweep`]).
pub fn sweep<R: Rule>(
    model: &Model,
    rows: &mut Rows,
    lambda: &mut Multipliers,
    (first, last): (bool, bool),
    (stretch, stretch_rule): (f64, R),
    bend: Option<(f64, R)>,
) {
    let stretch_only = |batches, rows, lambda| {
        edges(batches, Sweep { rows, lambda, first, last, compliance: [stretch], rule: [stretch_rule] })
    };
    match bend {
        None => stretch_only(&model.edge_batches, rows.indexed_mut(), &mut lambda.edges),
        Some((bend, bend_rule)) => {
            stretch_only(&model.boundary_batches, rows.indexed_mut(), &mut lambda.boundary);
            hinges(
                &model.hinge_batches,
                Sweep {
                    rows: rows.indexed_mut(),
                    lambda: &mut lambda.hinges,
                    first,
                    last,
                    compliance: [stretch, bend],
                    rule: [stretch_rule, bend_rule],
                },
            );
        }
    }
}

/// Project every edge to its rest length.
fn edges<R: Rule>(edges: &Batches<2, 1>, sweep: Sweep<'_, R, 1>) {
    run::<Edge, R, 2, 1>(edges, sweep, Path::Fastest)
}

/// Project every interior edge to its rest length and then its hinge to its rest angle.
fn hinges<R: Rule>(hinges: &Batches<4, 2>, sweep: Sweep<'_, R, 2>) {
    run::<StretchBend, R, 4, 2>(hinges, sweep, Path::Fastest)
}

/// Which code runs a sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Path {
    /// Eight lanes at once where the CPU has AVX2, else one at a time.
    Fastest,
    /// One lane at a time (what a CPU without AVX2 runs; the tests compare the two).
    #[cfg_attr(not(test), allow(dead_code))]
    Portable,
}

fn run<T: Lane<K, F>, R: Rule, const K: usize, const F: usize>(
    batches: &Batches<K, F>,
    sweep: Sweep<'_, R, F>,
    path: Path,
) {
    #[cfg(target_arch = "x86_64")]
    if path == Path::Fastest && pulp::x86::V3::try_new().is_some() {
        return eight_lanes::<T, R, K, F>(batches, sweep);
    }
    let _ = path;
    Constraints::<T, R, K, F> { batches, sweep, kind: PhantomData }.one_by_one()
}

/// A colour is split into as many pieces as there are threads, each of at least this many batches
/// (eight lanes each); a smaller colour is one piece.
const SPLIT: usize = 32;

/// The sweep eight lanes at a time (the CPU has AVX2), colour after colour, each large colour whose
/// lanes share no particle in pieces on the pool's threads at once ([`crate::threads::phases`]).
/// Lanes of a colour are independent, so the rows and multipliers come out the same to the bit on one
/// thread and on several.
#[cfg(target_arch = "x86_64")]
fn eight_lanes<T: Lane<K, F>, R: Rule, const K: usize, const F: usize>(
    batches: &Batches<K, F>,
    Sweep { rows, mut lambda, first, last, compliance, rule }: Sweep<'_, R, F>,
) {
    let rows = Shared::new(rows);
    let threads = crate::threads::threads();
    let (mut pieces, mut split) = (Vec::new(), false);
    for (c, (colour, &separate)) in batches.colours.windows(2).zip(&batches.separate).enumerate() {
        let (here, rest) = std::mem::take(&mut lambda).split_at_mut(colour[1] - colour[0]);
        lambda = rest;
        let count = if separate { (here.len() / SPLIT).clamp(1, threads) } else { 1 };
        split |= count > 1;
        let mut start = colour[0];
        for piece in here.chunks_mut(here.len().div_ceil(count).max(1)) {
            let length = piece.len();
            pieces.push((c, (start, piece)));
            start += length;
        }
    }
    let project = |(start, lambda): (usize, &mut [[[f64; LANES]; F]])| {
        let batches = &batches.batches[start..start + lambda.len()];
        let kernel = Avx2::<T, R, K, F> { batches, lambda, rows, compliance, first, last, rule, kind: PhantomData };
        // The CPU has AVX2 (checked by the caller), so the kernel runs and is not handed back.
        let _ = crate::linalg::isa::eight(kernel);
    };
    // No colour in pieces: here, in order (on two threads the colours would only take turns, each
    // moving the rows to the other's core).
    if split {
        crate::threads::phases(pieces, project);
    } else {
        pieces.into_iter().for_each(|(_, piece)| project(piece));
    }
}

/// A lane's constraints over `K` particles, as the sweeps project them.
trait Lane<const K: usize, const F: usize> {
    /// The lane's projection at `read.x` (`x[0]` at the origin), for numbers or lanes.
    fn project<N: Real, R: Rule>(read: &Read<N, K, F>, rules: [R; F]) -> Projected<N, K, F>;
}

impl Lane<2, 1> for Edge {
    #[inline(always)]
    fn project<N: Real, R: Rule>(read: &Read<N, 2, 1>, rules: [R; 1]) -> Projected<N, 2, 1> {
        let (c, n) = constraints::stretch_of(read.x[0], read.x[1], read.constants[0]);
        let (delta, moves) = step(c, [n, real::neg(n)], &read.w, read.compliance[0], read.lambda[0], rules[0]);
        ([delta], moves)
    }
}

impl Lane<4, 2> for StretchBend {
    #[inline(always)]
    fn project<N: Real, R: Rule>(read: &Read<N, 4, 2>, rules: [R; 2]) -> Projected<N, 4, 2> {
        let [a, b, c, d] = read.x;
        let (stretch, n) = constraints::stretch_of(a, b, read.constants[0]);
        let w = [read.w[0], read.w[1]];
        let (stretched, [ma, mb]) = step(stretch, [n, real::neg(n)], &w, read.compliance[0], read.lambda[0], rules[0]);
        let moved = [real::add(a, ma), real::add(b, mb), c, d];
        let (bend, g) = constraints::bending_of(&moved, read.constants[1], read.constants[2]);
        let (bent, [pa, pb, pc, pd]) = step(bend, g, &read.w, read.compliance[1], read.lambda[1], rules[1]);
        ([stretched, bent], [real::add(pa, ma), real::add(pb, mb), pc, pd])
    }
}

/// Below this fraction of `max w · Σ |∇C|²`, `Σ w |∇C|²` says the movable particles cannot change the
/// constraint (their gradient is single-precision rounding, about 1e-7 of the whole, squared 1e-14);
/// above it, a particle's move `C/|∇C|` stays within 1e4 × the constraint's own scale.
const LOCKED: f64 = 1e-8;

/// One constraint's projection: `Δλ` by the rule, and its particles' moves `w_i ∇_i C Δλ` (none for a
/// constraint without movable particles, one its movable particles cannot change, or degenerate).
#[inline(always)]
fn step<N: Real, R: Rule, const K: usize>(
    c: N,
    g: [V3<N>; K],
    w: &[N; K],
    compliance: N,
    lambda: N,
    rule: R,
) -> (N, [V3<N>; K]) {
    let zero = c.constant(0.0);
    // Loops, not closures, in this module's arithmetic: a closure the compiler declines to inline
    // would run without the dispatched instruction set.
    let (mut denominator, mut total, mut heaviest) = (zero, zero, zero);
    for (&w, &g) in w.iter().zip(&g) {
        let gg = real::dot(g, g);
        denominator = denominator + w * gg;
        total = total + gg;
        heaviest = N::select(heaviest.less(w), w, heaviest);
    }
    let delta = rule.delta(c, denominator, compliance, lambda);
    // A constraint its movable particles cannot change — their share of the gradient is rounding,
    // e.g. a hinge whose one free end turns about the line through its fixed wings — is left alone:
    // its `C / Σ w|∇C|²` is noise over noise.
    let movable = (c.constant(LOCKED) * heaviest * total).less(denominator);
    let delta = N::select(movable, delta, zero);
    let delta = N::select(delta.abs().less(c.constant(f64::INFINITY)), delta, zero);
    let mut steps = g;
    for (step, &w) in steps.iter_mut().zip(w) {
        *step = real::scale(*step, w * delta);
    }
    (delta, steps)
}

/// A sweep over batches of lanes of `F` constraints over `K` particles, as a kernel for [`pulp`]'s
/// dispatch.
struct Constraints<'a, T, R, const K: usize, const F: usize> {
    batches: &'a Batches<K, F>,
    sweep: Sweep<'a, R, F>,
    kind: PhantomData<T>,
}

impl<T: Lane<K, F>, R: Rule, const K: usize, const F: usize> Constraints<'_, T, R, K, F> {
    /// The sweep, one lane at a time, in the same single precision.
    #[inline(always)]
    fn one_by_one(self) {
        let Sweep { rows: Indexed { rows, .. }, lambda, first, last, compliance, rule } = self.sweep;
        for (batch, lambda) in self.batches.batches.iter().zip(lambda.iter_mut()) {
            if first {
                *lambda = [[0.0; LANES]; F];
            }
            for k in 0..batch.count {
                let origin = rows[batch.ids[0][k] as usize].0;
                let row = |j: usize| rows[batch.ids[j][k] as usize].0;
                let single = |v: f32| Lanes32 { simd: pulp::Scalar::new(), v };
                let one = |v: f64| single(v as f32);
                let read = Read::<_, K, F> {
                    x: std::array::from_fn(|j| std::array::from_fn(|a| single(row(j)[a] - origin[a]))),
                    w: std::array::from_fn(|j| single(row(j)[3])),
                    constants: batch.constants.map(|c| one(f64::from(c[k]))),
                    lambda: std::array::from_fn(|f| one(lambda[f][k])),
                    compliance: std::array::from_fn(|f| one(compliance[f]) * one(f64::from(batch.factors[f][k]))),
                };
                let (deltas, steps) = T::project(&read, rule);
                if !last {
                    for (lambda, delta) in lambda.iter_mut().zip(deltas) {
                        lambda[k] += f64::from(delta.v);
                        // Lanes past the count, repeating the last, keep its multipliers.
                        if k + 1 == batch.count {
                            let kept = lambda[k];
                            lambda[k..].fill(kept);
                        }
                    }
                }
                for (j, step) in steps.iter().enumerate() {
                    let row = &mut rows[batch.ids[j][k] as usize].0;
                    (0..3).for_each(|a| row[a] += step[a].v);
                }
            }
        }
    }
}
/// The eight-lane sweep over some batches of one colour and their multipliers, as a kernel for
/// [`crate::linalg::isa::eight`].
#[cfg(target_arch = "x86_64")]
struct Avx2<'a, T, R, const K: usize, const F: usize> {
    batches: &'a [Batch<K, F>],
    lambda: &'a mut [[[f64; LANES]; F]],
    rows: Shared<'a>,
    compliance: [f64; F],
    first: bool,
    last: bool,
    rule: [R; F],
    kind: PhantomData<fn() -> T>,
}

#[cfg(target_arch = "x86_64")]
impl<T: Lane<K, F>, R: Rule, const K: usize, const F: usize> crate::linalg::isa::Eight for Avx2<'_, T, R, K, F> {
    type Output = ();

    #[inline(always)]
    fn run(self, simd: pulp::x86::V3) {
        let Avx2 { batches, lambda, rows, compliance, first, last, rule, .. } = self;
        let eight = super::avx2_lanes::Eight::new(simd, compliance, (first, last));
        // Two batches at a time, read before either is projected: their arithmetic is independent,
        // and the processor overlaps the two chains of long-latency roots and divisions.
        let mut b = 0;
        while b + 1 < batches.len() {
            let ((first, first_raw), (second, second_raw)) =
                (eight.read(rows, &batches[b], &lambda[b]), eight.read(rows, &batches[b + 1], &lambda[b + 1]));
            let (first, second) = (T::project(&first, rule), T::project(&second, rule));
            eight.write(rows, &batches[b], &mut lambda[b], first_raw, first);
            eight.write(rows, &batches[b + 1], &mut lambda[b + 1], second_raw, second);
            b += 2;
        }
        if b < batches.len() {
            let (read, raw) = eight.read(rows, &batches[b], &lambda[b]);
            let projected = T::project(&read, rule);
            eight.write(rows, &batches[b], &mut lambda[b], raw, projected);
        }
    }
}

/// Keep each triangle's area, seen along its unit normal at the substep's start `x`, at least `near_least_area`
/// times its rest area (`double_areas`: twice each rest area): the hard inequality
/// `N·n̂₀ − least·2A₀ ≥ 0` ([`constraints::area_along`]). Edges alone let a triangle squeezed in its
/// plane collapse and turn over, laying its neighbours over each other (the hanging sheet's clips do
/// that at 8–12 substeps of one sweep). Only triangles that start the substep within twice the least
/// area are looked at (they are among `listed`, [`super::near_least_area::Areas::under`], which may list a few
/// more): another would have to lose half its area within the substep to end it under the least, and
/// would then be looked at from the next substep's start, before it could turn over. (Beside the
/// hanging sheet's clips at 8 × 1 some triangles do lose half their area within a substep: a list made
/// for two substeps at once let that sheet cross itself, `BENCHMARKS.md`.)
pub fn least_area(
    triangles: &[[usize; 3]],
    listed: &[u32],
    x: &[DVec3],
    p: &mut [DVec3],
    w: &[f64],
    double_areas: &[f64],
    least: f64,
) {
    for &t in listed {
        let (t, a0) = (triangles[t as usize], double_areas[t as usize]);
        let start = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
        if start.length_squared() >= (2.0 * least * a0).powi(2) {
            continue;
        }
        let axis = start.normalize_or_zero();
        let (c, g) = constraints::area_along(t.map(|i| p[i]), axis);
        let c = c - least * a0;
        let denominator: f64 = (0..3).map(|k| w[t[k]] * g[k].length_squared()).sum();
        if c >= 0.0 || denominator == 0.0 {
            continue;
        }
        let lambda = -c / denominator;
        (0..3).for_each(|k| p[t[k]] += g[k] * (w[t[k]] * lambda));
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
    use crate::solver::pbd::batch::Packable;
    use crate::solver::pbd::model::Bend;

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

    /// One XPBD projection in double precision of a constraint with value `c` and gradient `g` over
    /// particles of inverse masses `w`: `Δλ` and the particles' moves.
    fn expected(c: f64, g: &[DVec3], w: &[f64], compliance: f64, lambda: f64) -> (f64, Vec<DVec3>) {
        let denominator: f64 = g.iter().zip(w).map(|(g, w)| w * g.length_squared()).sum();
        let delta = (-c - compliance * lambda) / (denominator + compliance);
        (delta, g.iter().zip(w).map(|(g, w)| *g * (w * delta)).collect())
    }

    /// The sweep's base compliance (each constraint's is this times its factor).
    const COMPLIANCE: f64 = 2.0e3;

    /// The single-precision sweep over `items` (37 lanes in two colours, 100 m from the origin)
    /// moves each particle as `expect` does in double precision (given the lane's item, positions,
    /// inverse masses and multipliers: each `Δλ` and each particle's move), to a relative 1e-5 of the
    /// lane's largest move and the rounding of the particle's row (a unit in the last place of its
    /// distance from the first particle, whatever the distance from the origin); the eight-lane path
    /// (where the CPU has AVX2) and the one-lane path give the same bits; a substep's first sweep,
    /// whatever its multipliers hold, gives the bits of a sweep from cleared multipliers; and its last
    /// leaves them as they are.
    fn agrees<T: Lane<K, F> + Packable<K, F>, const K: usize, const F: usize>(
        case: &str,
        make: impl Fn(usize) -> T,
        expect: impl Fn(&T, [DVec3; K], [f64; K], [f64; F]) -> ([f64; F], [DVec3; K]),
    ) {
        #[cfg(target_arch = "x86_64")]
        if pulp::x86::V3::try_new().is_none() {
            eprintln!("no AVX2 here: both paths below are the one-lane one");
        }
        let n = 37;
        let (start, w) = scattered(n);
        let items: Vec<T> = (0..n).map(make).collect();
        // Two colours, so that each ends in a part-filled batch.
        let colours = [0, 20, n];
        let batches = Batches::new(&items, &colours);
        // Each lane's batch and place.
        let lane = |k: usize| if k < 20 { (k / LANES, k % LANES) } else { (3 + (k - 20) / LANES, (k - 20) % LANES) };
        let sweep = |path: Path, lambda: &mut [[[f64; LANES]; F]], first: bool, last: bool| {
            let mut rows = Rows::default();
            rows.fill(&start, &w);
            let compliance = [COMPLIANCE; F];
            run::<T, _, K, F>(
                &batches,
                Sweep { rows: rows.indexed_mut(), lambda, first, last, compliance, rule: [Compliance::SYMMETRIC; F] },
                path,
            );
            rows
        };
        for path in [Path::Fastest, Path::Portable] {
            let (mut cleared, mut held) = (batches.multipliers(), vec![[[7.0; LANES]; F]; 6]);
            let (from_zero, first) = (sweep(path, &mut cleared, false, false), sweep(path, &mut held, true, false));
            assert!(
                from_zero.particles() == first.particles() && cleared == held,
                "{case} {path:?}: the first sweep reads its multipliers"
            );
            let (mut some, mut kept) = (vec![[[7.0; LANES]; F]; 6], vec![[[7.0; LANES]; F]; 6]);
            let (other, last) = (sweep(path, &mut some, false, false), sweep(path, &mut kept, false, true));
            assert!(
                other.particles() == last.particles(),
                "{case} {path:?}: the last sweep moves the particles as any other"
            );
            assert!(kept == vec![[[7.0; LANES]; F]; 6] && some != kept, "{case} {path:?}: and leaves the multipliers");
        }
        let mut results = Vec::new();
        for path in [Path::Fastest, Path::Portable] {
            let mut lambda = batches.multipliers();
            for k in 0..n {
                let (b, l) = lane(k);
                // The lanes past a batch's count keep its last lane's multipliers.
                let lanes = if l + 1 == batches.batches[b].count { l..LANES } else { l..l + 1 };
                (0..F).for_each(|f| lambda[b][f][lanes.clone()].fill(1e-6 * (k + 40 * f) as f64));
            }
            let before = lambda.clone();
            let rows = sweep(path, &mut lambda, false, false);
            let mut p = start.clone();
            rows.read(&mut p);
            for (k, item) in items.iter().enumerate() {
                let ids = item.particles();
                let (b, l) = lane(k);
                let (deltas, moves) =
                    expect(item, ids.map(|i| start[i]), ids.map(|i| w[i]), std::array::from_fn(|f| before[b][f][l]));
                let scale = moves.iter().map(|m| m.length()).fold(0.0, f64::max);
                assert!(scale > 1e-5, "{case} {k}: the test should move particles ({scale})");
                for (&i, m) in ids.iter().zip(&moves) {
                    let error = (p[i] - start[i] - *m).length();
                    let rounding = f64::from(f32::EPSILON) * (start[i] + *m - start[0]).abs().max_element();
                    let within = 1e-5 * scale + rounding;
                    assert!(error <= within, "{case} {k} {path:?}: particle {i} off by {error:e} of {scale:e}");
                }
                for (f, delta) in deltas.iter().enumerate() {
                    let got = lambda[b][f][l] - before[b][f][l];
                    assert!((got - delta).abs() <= 1e-5 * delta.abs(), "{case} {k}: Δλ {f}: {got} against {delta}");
                }
            }
            // The lanes past a batch's count still keep its last lane's multipliers.
            for (b, l, last) in [(2, 4, 3), (2, 7, 3), (5, 1, 0), (5, 7, 0)] {
                assert_eq!(lambda[b][0][l], lambda[b][0][last], "{case} {path:?}: lane {b}/{l} past the count");
            }
            results.push((p, lambda));
        }
        assert!(results[0] == results[1], "{case}: the two paths differ");
    }

    #[test]
    fn the_single_precision_stretch_agrees_with_double_precision() {
        agrees(
            "stretch",
            |k| Edge { v: [4 * k, 4 * k + 2], rest: 0.009 },
            |e: &Edge, x: [DVec3; 2], w, [lambda]| {
                let (c, g) = constraints::stretch(x[0], x[1], e.rest);
                let (delta, moves) = expected(c, &g, &w, COMPLIANCE, lambda);
                ([delta], [moves[0], moves[1]])
            },
        );
    }

    /// An interior edge's stretch and then its hinge's bending, at the stretched positions.
    #[test]
    fn the_single_precision_stretch_and_bending_agree_with_double_precision() {
        agrees(
            "stretch and bend",
            |k| StretchBend {
                rest: 0.009,
                bend: Bend {
                    v: [4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3],
                    rest: RestAngle::new(0.3),
                    inverse_weight: 0.8,
                },
            },
            |h: &StretchBend, x: [DVec3; 4], w, [stretch, bend]| {
                let (c, g) = constraints::stretch(x[0], x[1], h.rest);
                let (stretched, m) = expected(c, &g, &w[..2], COMPLIANCE, stretch);
                let moved = [x[0] + m[0], x[1] + m[1], x[2], x[3]];
                let (c, g) = constraints::bending(&moved, h.bend.rest);
                let (bent, moves) = expected(c, &g, &w, COMPLIANCE * h.bend.inverse_weight, bend);
                ([stretched, bent], [moves[0] + m[0], moves[1] + m[1], moves[2], moves[3]])
            },
        );
    }

    #[test]
    fn a_triangle_squeezed_over_in_its_plane_keeps_the_least_area_and_a_roomy_one_is_left_alone() {
        // Twice the rest area 1; at the start a tenth of it; predicted turned over (its apex pushed
        // through its base, in the plane): the guard brings it back to a fifth, seen along the start
        // normal (one projection of a constraint quadratic in the positions: within 5%), moving the
        // centre of mass not at all (equal masses).
        let triangles = [[0, 1, 2], [3, 4, 5]];
        let double_areas = [1.0, 1.0];
        let x = [DVec3::ZERO, DVec3::X, DVec3::new(0.5, 0.0, 0.1), DVec3::Z, DVec3::Z + DVec3::X, DVec3::Z + DVec3::Y];
        let mut p = [DVec3::ZERO, DVec3::X, DVec3::new(0.4, 0.0, -0.05), x[3], x[4], x[5]];
        let w = [1.0; 6];
        let predicted: Vec<DVec3> = p.to_vec();
        least_area(&triangles, &[0, 1], &x, &mut p, &w, &double_areas, 0.2);
        let axis = (x[1] - x[0]).cross(x[2] - x[0]).normalize();
        let (c, _) = constraints::area_along([p[0], p[1], p[2]], axis);
        let before = constraints::area_along([predicted[0], predicted[1], predicted[2]], axis).0;
        assert!(before < 0.0 && (c - 0.2).abs() < 0.01, "twice the area along the start normal {before} → {c}");
        let centre = |q: &[DVec3]| (q[0] + q[1] + q[2]) / 3.0;
        assert!((centre(&p) - centre(&predicted)).length() < 1e-15);
        // The second triangle starts with its whole area: not looked at, even when predicted flat.
        let mut flat = p;
        flat[5] = DVec3::Z + DVec3::X * 0.5;
        let before = flat;
        least_area(&triangles, &[0, 1], &x, &mut flat, &w, &double_areas, 0.2);
        assert_eq!(flat[3..], before[3..]);
    }

    /// A hinge whose only free end turns about the line through its fixed wings (its gradient there is
    /// rounding) is left alone; the same hinge with a free wing is projected. Before, the first one's
    /// `C / Σ w|∇C|²` moved the free end kilometres in a step (a sheet clamped along an edge by `pbd`).
    #[test]
    fn a_constraint_its_free_particles_cannot_change_is_left_alone() {
        let g = [[1e-9, 2e-9, 0.0], [0.0, 24.0, 0.0], [0.0, -12.0, 0.0], [0.0, -12.0, 0.0]];
        let (delta, moves) = step(1e-9, g, &[2160.0, 0.0, 0.0, 0.0], 0.0, 0.0, Stiffness(0.05));
        assert_eq!(delta, 0.0);
        assert!(moves.iter().all(|m| m.iter().all(|&v| v == 0.0)), "{moves:?}");
        let (delta, moves) = step(1e-3, g, &[2160.0, 2160.0, 0.0, 0.0], 0.0, 0.0, Stiffness(0.05));
        let want = -0.05 * 1e-3 / (2160.0 * (24.0f64 * 24.0 + 5e-18));
        assert!((delta - want).abs() <= 1e-12 * want.abs() && moves[1][1] < 0.0, "{delta} against {want}");
    }

    #[test]
    fn a_compressed_constraint_has_its_compliance_times_the_compression_factor() {
        let (d, a, lambda) = (2.0, 0.5, 0.1);
        let soft = Compliance { compressed: 100.0 };
        // Stretched: as the symmetric rule.
        assert_eq!(soft.delta(0.2, d, a, lambda), Compliance::SYMMETRIC.delta(0.2, d, a, lambda));
        // Compressed: the compliance is a hundred times the stretched one.
        let want = (0.2 - 100.0 * a * lambda) / (d + 100.0 * a);
        assert!((soft.delta(-0.2, d, a, lambda) - want).abs() < 1e-15);
        let ratio = soft.delta(-0.2, d, a, 0.0) / Compliance::SYMMETRIC.delta(-0.2, d, a, 0.0);
        assert!((ratio - (d + a) / (d + 100.0 * a)).abs() < 1e-12, "a softer push back: {ratio}");
    }
}
