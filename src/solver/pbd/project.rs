//! One Gauss–Seidel sweep over the cloth's own constraints — stretch per edge, bending per hinge, the
//! balloon's volume — by the rule of the method: PBD's `Δλ = −k' C / Σ w|∇C|²` or XPBD's
//! `Δλ = (−C − α̃λ)/(Σ w|∇C|² + α̃)`, then `Δp_i = w_i ∇_i C Δλ` (SPEC §5).
//!
//! Edges and hinges come in colours (no two of a colour share a particle, [`super::model`]), so the
//! constraints of a colour are independent: projecting them one after another or all at once gives
//! the same positions. The sweeps take them eight at a time where the CPU has AVX2, in single
//! precision ([`Lanes32`]), from batches packed once ([`super::batch`]): each lane's particle rows
//! (position and inverse mass, 32 bytes) are loaded whole, made relative to the lane's first particle
//! in double precision (so the lanes hold differences of the size of an edge, to a relative 6e-8),
//! narrowed and transposed into registers of x, y, z and inverse mass; the constraint functions — the
//! same source the scalar ones are ([`Real`]) — run on all lanes at once; and the moves are transposed
//! back and added to the rows in double precision, as are the multipliers. Sixteen lanes (AVX-512)
//! would need as many shuffles per lane. A CPU without AVX2 runs the same arithmetic one lane at a
//! time.

use std::marker::PhantomData;

use glam::DVec3;

use pulp::Simd;

use super::batch::{Batch, Batches, LANES, Row};
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
    /// Predicted positions and inverse masses, the positions corrected in place.
    pub rows: &'a mut [Row],
    /// One multiplier per constraint (at its batch and lane), accumulated over the substep's
    /// iterations.
    pub lambda: &'a mut [[f64; LANES]],
    /// Whether this is the substep's first sweep: the multipliers start from zero (what `lambda`
    /// holds is ignored and overwritten, so it needs no clearing).
    pub first: bool,
    /// `α/h²` (a hinge's is this times its inverse weight).
    pub compliance: f64,
    /// PBD or XPBD.
    pub rule: R,
}

/// Project every edge to its rest length.
pub fn stretch<R: Rule>(edges: &Batches<2>, sweep: Sweep<'_, R>) {
    run::<Edge, R, 2>(edges, sweep, Path::Fastest)
}

/// Project every hinge to its rest angle.
pub fn bend<R: Rule>(bends: &Batches<4>, sweep: Sweep<'_, R>) {
    run::<Bend, R, 4>(bends, sweep, Path::Fastest)
}

/// Which code runs a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Path {
    /// Eight lanes at once where the CPU has AVX2, else one at a time.
    Fastest,
    /// One lane at a time (what a CPU without AVX2 runs; the tests compare the two).
    #[cfg_attr(not(test), allow(dead_code))]
    Portable,
}

fn run<T: Lane<K>, R: Rule, const K: usize>(batches: &Batches<K>, sweep: Sweep<'_, R>, path: Path) {
    let kernel = Constraints::<T, R, K> { batches, sweep, kind: PhantomData };
    #[cfg(target_arch = "x86_64")]
    if path == Path::Fastest
        && let Some(simd) = pulp::x86::V3::try_new()
    {
        return pulp::Simd::vectorize(simd, Avx2(kernel, simd));
    }
    let _ = path;
    kernel.one_by_one()
}

/// A constraint over `K` particles, as the sweeps evaluate it.
trait Lane<const K: usize> {
    /// `C` and `∇C` at `x` (`x[0]` at the origin), for numbers or lanes, given its constants.
    fn evaluate<N: Real>(x: &[V3<N>; K], constants: [N; 2]) -> (N, [V3<N>; K]);
}

impl Lane<2> for Edge {
    #[inline(always)]
    fn evaluate<N: Real>(x: &[V3<N>; 2], constants: [N; 2]) -> (N, [V3<N>; 2]) {
        let (c, n) = constraints::stretch_of(x[0], x[1], constants[0]);
        (c, [n, real::neg(n)])
    }
}

impl Lane<4> for Bend {
    #[inline(always)]
    fn evaluate<N: Real>(x: &[V3<N>; 4], constants: [N; 2]) -> (N, [V3<N>; 4]) {
        constraints::bending_of(x, constants[0], constants[1])
    }
}

/// What a batch's lanes read: each particle relative to its constraint's first, and its inverse
/// mass; the constants, multipliers and scaled compliances.
struct Read<N, const K: usize> {
    x: [V3<N>; K],
    w: [N; K],
    constants: [N; 2],
    lambda: N,
    compliance: N,
}

/// `Δλ` of a batch's lanes, and each particle's move `w_i ∇_i C Δλ`.
type Projected<N, const K: usize> = (N, [V3<N>; K]);

/// The projection of a batch's lanes.
#[inline(always)]
fn project<T: Lane<K>, R: Rule, N: Real, const K: usize>(read: Read<N, K>, rule: R) -> Projected<N, K> {
    let (c, g) = T::evaluate(&read.x, read.constants);
    let zero = c.constant(0.0);
    // Loops, not closures, in this module's arithmetic: a closure the compiler declines to inline
    // would run without the dispatched instruction set.
    let mut denominator = zero;
    for (&w, &g) in read.w.iter().zip(&g) {
        denominator = denominator + w * real::dot(g, g);
    }
    let delta = rule.delta(c, denominator, read.compliance, read.lambda);
    // A constraint without movable particles, or degenerate, is left alone.
    let delta = N::select(zero.less(denominator), delta, zero);
    let delta = N::select(delta.abs().less(c.constant(f64::INFINITY)), delta, zero);
    let mut steps = g;
    for (step, &w) in steps.iter_mut().zip(&read.w) {
        *step = real::scale(*step, w * delta);
    }
    (delta, steps)
}

/// A sweep over batches of constraints of `K` particles, as a kernel for [`pulp`]'s dispatch.
struct Constraints<'a, T, R, const K: usize> {
    batches: &'a Batches<K>,
    sweep: Sweep<'a, R>,
    kind: PhantomData<T>,
}

impl<T: Lane<K>, R: Rule, const K: usize> Constraints<'_, T, R, K> {
    /// The sweep, one lane at a time, in the same single precision.
    #[inline(always)]
    fn one_by_one(self) {
        let Sweep { rows, lambda, first, compliance, rule } = self.sweep;
        for (batch, lambda) in self.batches.batches.iter().zip(lambda.iter_mut()) {
            if first {
                *lambda = [0.0; LANES];
            }
            for k in 0..batch.count {
                let origin = rows[batch.ids[0][k] as usize].0;
                let row = |j: usize| rows[batch.ids[j][k] as usize].0;
                let one = |v: f64| Lanes32 { simd: pulp::Scalar::new(), v: v as f32 };
                let read = Read::<_, K> {
                    x: std::array::from_fn(|j| std::array::from_fn(|a| one(row(j)[a] - origin[a]))),
                    w: std::array::from_fn(|j| one(row(j)[3])),
                    constants: batch.constants.map(|c| one(f64::from(c[k]))),
                    lambda: one(lambda[k]),
                    compliance: one(compliance * batch.factors[k]),
                };
                let (delta, steps) = project::<T, R, _, K>(read, rule);
                lambda[k] += f64::from(delta.v);
                for (j, step) in steps.iter().enumerate() {
                    let row = &mut rows[batch.ids[j][k] as usize].0;
                    (0..3).for_each(|a| row[a] += f64::from(step[a].v));
                }
            }
        }
    }
}
/// The eight-lane sweep, as a kernel for [`pulp`]'s dispatch (which compiles it for AVX2 + FMA).
#[cfg(target_arch = "x86_64")]
struct Avx2<'a, T, R, const K: usize>(Constraints<'a, T, R, K>, pulp::x86::V3);

#[cfg(target_arch = "x86_64")]
impl<T: Lane<K>, R: Rule, const K: usize> pulp::WithSimd for Avx2<'_, T, R, K> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _: S) {
        let Avx2(kernel, simd) = self;
        let Sweep { rows, lambda, first, compliance, rule } = kernel.sweep;
        let eight = eight::Eight::new(simd, compliance, first);
        let batches = &kernel.batches.batches;
        // Two batches of a colour at a time, read before either is projected: their arithmetic is
        // independent, and the processor overlaps the two chains of long-latency roots and divisions.
        for colour in kernel.batches.colours.windows(2) {
            let mut b = colour[0];
            while b + 1 < colour[1] {
                let (first, second) =
                    (eight.read(rows, &batches[b], &lambda[b]), eight.read(rows, &batches[b + 1], &lambda[b + 1]));
                let (first, second) = (project::<T, R, _, K>(first, rule), project::<T, R, _, K>(second, rule));
                eight.write(rows, &batches[b], &mut lambda[b], first);
                eight.write(rows, &batches[b + 1], &mut lambda[b + 1], second);
                b += 2;
            }
            if b < colour[1] {
                let projected = project::<T, R, _, K>(eight.read(rows, &batches[b], &lambda[b]), rule);
                eight.write(rows, &batches[b], &mut lambda[b], projected);
            }
        }
    }
}

/// The eight-lane sweep's moves between a batch's particle rows and its lanes.
#[cfg(target_arch = "x86_64")]
mod eight {
    use std::arch::x86_64::{__m128, __m256, __m256d};

    use pulp::cast;
    use pulp::x86::V3;

    use super::{Batch, LANES, Lanes32, Projected, Read, Real, Row};

    /// What reading and writing a batch's lanes needs besides the batch: the instruction set, the
    /// sweep's compliance and the lanes' indices.
    #[derive(Clone, Copy)]
    pub struct Eight {
        simd: V3,
        compliance: __m256d,
        index: __m256,
        /// The substep's first sweep: multipliers read as zero and overwritten.
        first: bool,
    }

    impl Eight {
        /// For a sweep of this compliance, the substep's first or not.
        #[inline(always)]
        pub fn new(simd: V3, compliance: f64, first: bool) -> Self {
            let index = cast([0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
            Self { simd, compliance: simd.avx._mm256_set1_pd(compliance), index, first }
        }

        #[inline(always)]
        fn lanes(self, v: __m256) -> Lanes32<V3> {
            Lanes32 { simd: self.simd, v: cast(v) }
        }

        /// A batch's lanes as the projection reads them.
        #[inline(always)]
        pub fn read<const K: usize>(
            self,
            rows: &[Row],
            batch: &Batch<K>,
            lambda: &[f64; LANES],
        ) -> Read<Lanes32<V3>, K> {
            let (simd, avx) = (self.simd, self.simd.avx);
            // Each lane's origin: its first particle, with no inverse mass to subtract.
            let mut origins = [avx._mm256_setzero_pd(); LANES];
            for (origin, &i) in origins.iter_mut().zip(&batch.ids[0]) {
                *origin = avx._mm256_blend_pd::<0b1000>(cast(rows[i as usize].0), avx._mm256_setzero_pd());
            }
            let zero = self.lanes(avx._mm256_setzero_ps());
            let (mut x, mut w) = ([[zero; 3]; K], [zero; K]);
            for j in 0..K {
                let [px, py, pz, pw] = gather(simd, rows, &batch.ids[j], &origins);
                (x[j], w[j]) = ([self.lanes(px), self.lanes(py), self.lanes(pz)], self.lanes(pw));
            }
            let [lo, hi] = halves(&batch.factors);
            let compliance = [avx._mm256_mul_pd(lo, self.compliance), avx._mm256_mul_pd(hi, self.compliance)];
            Read {
                x,
                w,
                constants: [self.lanes(cast(batch.constants[0])), self.lanes(cast(batch.constants[1]))],
                lambda: if self.first { zero } else { self.lanes(narrow(simd, halves(lambda))) },
                compliance: self.lanes(narrow(simd, compliance)),
            }
        }

        /// A batch's projection, added to its rows and multipliers.
        #[inline(always)]
        pub fn write<const K: usize>(
            self,
            rows: &mut [Row],
            batch: &Batch<K>,
            lambda: &mut [f64; LANES],
            (delta, steps): Projected<Lanes32<V3>, K>,
        ) {
            let (simd, avx) = (self.simd, self.simd.avx);
            // Lanes past the batch's count add nothing to their multipliers.
            let real = self.lanes(self.index).less(self.lanes(avx._mm256_set1_ps(batch.count as f32)));
            let delta: __m256 = cast(Lanes32::select(real, delta, self.lanes(avx._mm256_setzero_ps())).v);
            let wide = [
                avx._mm256_cvtps_pd(avx._mm256_castps256_ps128(delta)),
                avx._mm256_cvtps_pd(avx._mm256_extractf128_ps::<1>(delta)),
            ];
            let (lo, hi): ([f64; 4], [f64; 4]) = if self.first {
                (cast(wide[0]), cast(wide[1]))
            } else {
                let [lo, hi] = halves(lambda);
                (cast(avx._mm256_add_pd(lo, wide[0])), cast(avx._mm256_add_pd(hi, wide[1])))
            };
            *lambda = [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]];
            for (ids, [sx, sy, sz]) in batch.ids.iter().zip(steps) {
                scatter(simd, rows, ids, batch.count, [cast(sx.v), cast(sy.v), cast(sz.v)]);
            }
        }
    }

    /// Eight doubles as two registers.
    #[inline(always)]
    fn halves(v: &[f64; LANES]) -> [__m256d; 2] {
        [cast([v[0], v[1], v[2], v[3]]), cast([v[4], v[5], v[6], v[7]])]
    }

    /// `[lo, hi]` (four doubles each) as eight singles.
    #[inline(always)]
    fn narrow(simd: V3, [lo, hi]: [__m256d; 2]) -> __m256 {
        let avx = simd.avx;
        avx._mm256_insertf128_ps::<1>(avx._mm256_castps128_ps256(avx._mm256_cvtpd_ps(lo)), avx._mm256_cvtpd_ps(hi))
    }

    /// The four-by-four transposes of `a` (each register two blocks of four lanes).
    #[inline(always)]
    fn transpose(simd: V3, a: [__m256; 4]) -> [__m256; 4] {
        let avx = simd.avx;
        let t: [__m256d; 4] = [
            cast(avx._mm256_unpacklo_ps(a[0], a[1])),
            cast(avx._mm256_unpackhi_ps(a[0], a[1])),
            cast(avx._mm256_unpacklo_ps(a[2], a[3])),
            cast(avx._mm256_unpackhi_ps(a[2], a[3])),
        ];
        [
            cast(avx._mm256_unpacklo_pd(t[0], t[2])),
            cast(avx._mm256_unpackhi_pd(t[0], t[2])),
            cast(avx._mm256_unpacklo_pd(t[1], t[3])),
            cast(avx._mm256_unpackhi_pd(t[1], t[3])),
        ]
    }

    /// The rows `ids` relative to each lane's origin, in single precision, as registers of x, y, z
    /// and inverse mass.
    #[inline(always)]
    fn gather(simd: V3, rows: &[Row], ids: &[u32; LANES], origins: &[__m256d; LANES]) -> [__m256; 4] {
        let avx = simd.avx;
        let mut r: [__m128; LANES] = [cast([0.0f32; 4]); LANES];
        for k in 0..LANES {
            r[k] = avx._mm256_cvtpd_ps(avx._mm256_sub_pd(cast(rows[ids[k] as usize].0), origins[k]));
        }
        // Lanes k and k + 4 side by side: x y z w | x y z w.
        let mut a = [avx._mm256_setzero_ps(); 4];
        for k in 0..4 {
            a[k] = avx._mm256_insertf128_ps::<1>(avx._mm256_castps128_ps256(r[k]), r[k + 4]);
        }
        transpose(simd, a)
    }

    /// Add the moves `[x, y, z]` of the first `count` lanes to the rows `ids`, in double precision.
    #[inline(always)]
    fn scatter(simd: V3, rows: &mut [Row], ids: &[u32; LANES], count: usize, [x, y, z]: [__m256; 3]) {
        let avx = simd.avx;
        // Lanes k and k + 4 of a[k]: x y z 0 | x y z 0.
        let a = transpose(simd, [x, y, z, avx._mm256_setzero_ps()]);
        for (k, &i) in ids.iter().enumerate().take(count) {
            let half = if k < 4 { avx._mm256_castps256_ps128(a[k]) } else { avx._mm256_extractf128_ps::<1>(a[k - 4]) };
            let row = &mut rows[i as usize];
            row.0 = cast(avx._mm256_add_pd(cast(row.0), avx._mm256_cvtps_pd(half)));
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
    use crate::solver::pbd::batch;

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
    /// relative 1e-5 of the move, far from the origin too; the eight-lane path (where the CPU has
    /// AVX2) and the one-lane path give the same bits; and a substep's first sweep, whatever its
    /// multipliers hold, gives the bits of a sweep from cleared multipliers.
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
        // Two colours, so that each ends in a part-filled batch.
        let colours = [0, 20, n];
        let (bent, stretched) = (Batches::new(&bends, &colours), Batches::new(&edges, &colours));
        let compliance = 2.0e3;
        // Each constraint's batch and lane.
        let lane = |k: usize| if k < 20 { (k / LANES, k % LANES) } else { (3 + (k - 20) / LANES, (k - 20) % LANES) };
        #[cfg(target_arch = "x86_64")]
        if pulp::x86::V3::try_new().is_none() {
            eprintln!("no AVX2 here: both paths below are the one-lane one");
        }
        for case in ["bend", "stretch"] {
            let sweep = |path: Path, lambda: &mut [[f64; LANES]], first: bool| {
                let mut rows = Vec::new();
                batch::fill_rows(&start, &w, &mut rows);
                let sweep = Sweep { rows: &mut rows, lambda, first, compliance, rule: Compliance };
                if case == "bend" {
                    run::<Bend, _, 4>(&bent, sweep, path)
                } else {
                    run::<Edge, _, 2>(&stretched, sweep, path)
                }
                rows
            };
            for path in [Path::Fastest, Path::Portable] {
                let (mut cleared, mut held) = (vec![[0.0; LANES]; 6], vec![[7.0; LANES]; 6]);
                let (from_zero, first) = (sweep(path, &mut cleared, false), sweep(path, &mut held, true));
                assert!(
                    from_zero == first && cleared == held,
                    "{case} {path:?}: the first sweep reads its multipliers"
                );
            }
            let mut results = Vec::new();
            for path in [Path::Fastest, Path::Portable] {
                let mut lambda = vec![[0.0; LANES]; 6];
                (0..n).for_each(|k| lambda[lane(k).0][lane(k).1] = 1e-6 * k as f64);
                let before = lambda.clone();
                let rows = sweep(path, &mut lambda, false);
                let mut p = start.clone();
                batch::read_rows(&rows, &mut p);
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
                    let (b, l) = lane(k);
                    let (delta, moves) = expected(c, &g, &ids, &w, alpha, before[b][l]);
                    let scale = moves.iter().map(|m| m.length()).fold(0.0, f64::max);
                    assert!(scale > 1e-5, "{case} {k}: the test should move particles ({scale})");
                    for (&i, m) in ids.iter().zip(&moves) {
                        let error = (p[i] - start[i] - *m).length();
                        assert!(
                            error <= 1e-5 * scale,
                            "{case} {k} {path:?}: particle {i} off by {error:e} of {scale:e}"
                        );
                    }
                    assert!((lambda[b][l] - before[b][l] - delta).abs() <= 1e-5 * delta.abs(), "{case} {k}: Δλ");
                }
                // The lanes past a batch's count keep their multipliers.
                for (b, l) in [(2, 4), (2, 7), (5, 1), (5, 7)] {
                    assert_eq!(lambda[b][l], 0.0, "{case} {path:?}: unused lane {b}/{l}");
                }
                results.push((p, lambda));
            }
            assert!(results[0] == results[1], "{case}: the two paths differ");
        }
    }
}
