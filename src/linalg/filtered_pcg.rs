//! Baraff & Witkin's modified (filtered) preconditioned conjugate gradients, with Ascher & Boxerman's
//! correction of its start, for `A Δv = b` where some particles' velocity changes are prescribed.
//!
//! A constrained particle `i` has a filter `Sᵢ` (the projection onto its free directions: `I − ppᵀ`,
//! `I − ppᵀ − qqᵀ` or `0`) and a prescribed change `zᵢ` in the constrained directions. The solution has
//! `(I − S) Δv = (I − S) z` and `S (A Δv − b) = 0`:
//!
//! ```text
//! Δv = S Δv₀ + (I − S) z      (Δv₀: warm start; the original starts from z)
//! b̂ = S(b − A z),  δ₀ = b̂ᵀ P⁻¹ b̂
//! r = S(b − A Δv),  c = S(P⁻¹ r),  δ = rᵀc
//! while δ > ε² δ₀:  q = S(A c), α = δ/cᵀq, Δv += α c, r −= α q, s = P⁻¹ r, δ' = rᵀs,
//!                   c = S(s + (δ'/δ) c), δ = δ'
//! ```
//!
//! `P` is block Jacobi: the inverses of the 3 × 3 diagonal blocks of `A`, supplied by the caller.
//! Every update of `Δv` is along a filtered direction, so the constrained components stay at `z`
//! (exactly for fully constrained particles, to round-off for projections).
//!
//! An operator may split its rows into two sides ([`Operator::sides`]) whose products two threads
//! compute at once. The iteration then keeps every vector by sides: each of a [`threads::pair`]'s workers
//! updates its side's particles and sums its side's part of each dot product, and the workers meet
//! after each of an iteration's three phases (the product and `cᵀq`, the updates and `δ'`, the new
//! direction), where both add the two parts in the same order. One thread does the same sums one
//! side after the other, so the result is the same to the bit on any number of threads. Apart from
//! the product, which reads the other side's `c` along the springs across, a worker touches only
//! its own side's entries, which stay in its core's cache.

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{DMat3, DVec3};

use super::padded::{Padded, PaddedMat3, pad, unpad};
use super::shared::Shared;
use crate::threads::{self, Pair};

/// A linear operator `y = A x` on per-particle vectors (symmetric positive definite on the free
/// subspace, for [`solve`]).
pub trait Operator: Sync {
    /// Rows `first..first + y.len()` of `A x` into `y`, on padded vectors, which [`solve`] iterates
    /// with: all rows, or one of [`Self::sides`] (mark the implementation `#[inline(always)]` so that
    /// it is compiled into the solver's kernel).
    fn apply_rows(&self, x: &[Padded], first: usize, y: &mut [Padded]);

    /// Where the second of two sides begins: the rows `..h` and `h..`, whose products may be computed
    /// at once (each reading any entries of `x`). `None`: one side.
    fn sides(&self) -> Option<usize> {
        None
    }

    /// `y = A x`.
    fn apply(&self, x: &[DVec3], y: &mut [DVec3]) {
        let mut out = vec![Padded::ZERO; y.len()];
        self.apply_rows(&pad(x), 0, &mut out);
        unpad(&out, y);
    }
}

/// A closure on 3-vectors is an operator of one side (applied through copies: for tests and small
/// systems).
impl<F: Fn(&[DVec3], &mut [DVec3]) + Sync> Operator for F {
    fn apply_rows(&self, x: &[Padded], first: usize, y: &mut [Padded]) {
        let (mut x3, mut out) = (vec![DVec3::ZERO; x.len()], vec![DVec3::ZERO; x.len()]);
        unpad(x, &mut x3);
        self(&x3, &mut out);
        for (y, o) in y.iter_mut().zip(&out[first..]) {
            *y = (*o).into();
        }
    }
}

/// One constrained particle: its filter `S` and prescribed velocity change `z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constraint {
    /// Particle index.
    pub particle: usize,
    /// Projection onto the free directions.
    pub filter: DMat3,
    /// Prescribed velocity change (only its constrained components matter).
    pub z: DVec3,
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgReport {
    /// Iterations taken.
    pub iterations: u32,
    /// Final preconditioned residual norm `√δ = √(rᵀP⁻¹r)`.
    pub residual: f64,
    /// Final preconditioned residual relative to the start, `√(δ/δ₀)` (0 if `b̂ = 0`).
    pub relative_residual: f64,
    /// Whether the stopping criterion was met (rather than the iteration cap hit).
    pub converged: bool,
}

impl Default for PcgReport {
    /// A solve that had nothing to do.
    fn default() -> Self {
        Self { iterations: 0, residual: 0.0, relative_residual: 0.0, converged: true }
    }
}

/// When to stop: `δ ≤ tolerance² · max(δ₀, floor)`, or after `max_iterations`.
///
/// `δ = rᵀP⁻¹r` is about `eᵀAe` for the error `e` of `Δv`, so `floor` is an error energy scale that
/// the tolerance is taken relative to when `δ₀` is smaller (a system near rest, where a purely
/// relative criterion would chase ever smaller absolute errors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// Relative tolerance on `√δ`.
    pub tolerance: f64,
    /// Lower bound of the reference `δ₀`.
    pub floor: f64,
    /// Iteration cap.
    pub max_iterations: u32,
}

/// The iteration's vectors, kept from one solve to the next (each side's entries stay in the cache of
/// the thread that works on them).
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    /// `z, Δv, b − AΔv, r, c, q`, per particle.
    vectors: [Vec<Padded>; 6],
}

/// Solve with the operator `a`, block-Jacobi inverse `p_inv`, the constraints, right
/// side `b` and warm start / result `dv`. `residual` receives `b − A Δv` unfiltered: on the
/// constrained directions it is minus the constraint's impulse (updated alongside the filtered
/// residual, so it costs no extra product with `A`). `work` holds the iteration's vectors.
///
/// The iteration is compiled for AVX2 + FMA where the CPU has them ([`super::isa`]), with the
/// operator inlined into it if its [`Operator::apply_rows`] is `#[inline(always)]`; an operator of two
/// sides has them iterated by a [`threads::pair`] of workers (call it on a pool thread kept awake:
/// [`threads::awake`]).
#[allow(clippy::too_many_arguments)]
pub fn solve<A: Operator>(
    a: &A,
    p_inv: &[PaddedMat3],
    constraints: &[Constraint],
    b: &[DVec3],
    dv: &mut [DVec3],
    stop: Stop,
    residual: &mut [DVec3],
    work: &mut Workspace,
) -> PcgReport {
    let n = b.len();
    let sides: Vec<Range<usize>> = match a.sides() {
        Some(h) if 0 < h && h < n => vec![0..h, h..n],
        _ => std::iter::once(0..n).collect(),
    };
    let held: Vec<Vec<Constraint>> =
        sides.iter().map(|rows| constraints.iter().filter(|c| rows.contains(&c.particle)).copied().collect()).collect();
    let filters: Vec<Filters> =
        held.iter().map(|side| side.iter().map(|c| (c.particle, c.filter.into())).collect()).collect();
    work.vectors.iter_mut().for_each(|v| v.resize(n, Padded::ZERO));
    let sums = Sums::default();
    let [z, dv_work, residual_work, r, c, q] = &mut work.vectors;
    // SAFETY: a worker writes only its own sides' rows of these vectors and reads other rows only of
    // `z`, `Δv` and `c` (in the products), which no worker writes in the phase that reads them: the
    // phases are separated by the pair's syncs (see `Iterate`).
    #[allow(unsafe_code)]
    let (vectors, out) = unsafe {
        (
            [z, dv_work, residual_work, r, c, q].map(|v| Shared::new(v.as_mut_slice())),
            [Shared::new(dv), Shared::new(residual)],
        )
    };
    let run = |pair: &mut Pair| {
        let (sides, held, filters, sums) = (&sides[..], &held[..], &filters[..], &sums);
        super::isa::avx2(Iterate { a, p_inv, sides, held, filters, b, vectors, out, stop, sums, pair })
    };
    if sides.len() == 2 { threads::pair(run) } else { run(&mut Pair::alone()) }
}

/// The constraints' filters: particle and matrix.
type Filters = Vec<(usize, PaddedMat3)>;

/// The sides' parts of the dot products each phase ends with, one slot per side and product.
#[derive(Default)]
struct Sums([[AtomicU64; 2]; 2]);

impl Sums {
    /// Store side `side`'s part of product `k` (`k` alternates between the phases that end in a sync).
    fn put(&self, k: usize, side: usize, value: f64) {
        self.0[k][side].store(value.to_bits(), Ordering::Relaxed);
    }

    /// The two sides' parts of product `k`, added in side order (after a sync; one side: its part).
    fn total(&self, k: usize, sides: usize) -> f64 {
        let part = |s: usize| f64::from_bits(self.0[k][s].load(Ordering::Relaxed));
        if sides == 2 { part(0) + part(1) } else { part(0) }
    }
}

#[inline(always)]
fn filter(filters: &Filters, first: usize, x: &mut [Padded]) {
    for (i, s) in filters {
        x[i - first] = s.times(x[i - first]);
    }
}

#[inline(always)]
fn dot(a: &[Padded], b: &[Padded]) -> f64 {
    // A plain loop: an iterator's `sum` is a separate function, not inlined into the kernel.
    let mut sum = 0.0;
    for (a, b) in a.iter().zip(b) {
        sum += a.dot(*b);
    }
    sum
}

/// One worker's iteration: its sides of every vector ([`solve`]).
///
/// The vectors `z, Δv, b − AΔv, r, c, q` and the results are shared by the workers. A worker writes
/// only its own sides' rows, and reads the other side's rows only of `z`, `Δv` and `c`, in the
/// products; `z` is written only before the sync that precedes its product, `Δv` not between the
/// syncs around its product, and `c` only in the last phase of an iteration, after the sync that ends
/// the product's phase and before the one that begins the next.
struct Iterate<'a, 'p, A> {
    a: &'a A,
    p_inv: &'a [PaddedMat3],
    sides: &'a [Range<usize>],
    held: &'a [Vec<Constraint>],
    filters: &'a [Filters],
    b: &'a [DVec3],
    vectors: [Shared<'a, Padded>; 6],
    out: [Shared<'a, DVec3>; 2],
    stop: Stop,
    sums: &'a Sums,
    pair: &'a mut Pair<'p>,
}

impl<'a, A: Operator> super::isa::Kernel for Iterate<'a, '_, A> {
    type Output = PcgReport;

    #[allow(unsafe_code)]
    #[inline(always)]
    fn run(self) -> PcgReport {
        let Self { a, p_inv, sides, held, filters, b, vectors, out: [dv_out, residual_out], stop, sums, pair } = self;
        let [z, dv, residual, r, c, q] = vectors;
        let count = sides.len();
        let mine: &[usize] = if count == 1 { &[0] } else { pair.halves() };
        // SAFETY (every `rows` and `whole` below): see the type's documentation.
        let part = |v: Shared<'a, Padded>, s: usize| unsafe { v.rows(sides[s].clone()) };
        // Δv = S Δv₀ + (I − S) z.
        for &s in mine {
            let rows = sides[s].clone();
            let (z, dv, dv_out) = (part(z, s), part(dv, s), unsafe { dv_out.rows(rows.clone()) });
            z.fill(Padded::ZERO);
            for (dv, d) in dv.iter_mut().zip(dv_out.iter()) {
                *dv = (*d).into();
            }
            for c in &held[s] {
                let k = c.particle - rows.start;
                z[k] = c.z.into();
                dv[k] = (c.filter * DVec3::from(dv[k]) + (c.z - c.filter * c.z)).into();
            }
        }
        // Results written to the caller's vectors, each side's rows by its worker.
        let finish = |s: usize| {
            let rows = sides[s].clone();
            let (dv_out, residual_out) = unsafe { (dv_out.rows(rows.clone()), residual_out.rows(rows.clone())) };
            unpad(part(dv, s), dv_out);
            unpad(part(residual, s), residual_out);
        };
        pair.sync();
        let z = unsafe { z.whole() };
        // b̂ = S(b − A z), δ₀ = b̂ᵀP⁻¹b̂; the product kept in q, b̂ in r.
        for &s in mine {
            let rows = sides[s].clone();
            let (q, r) = (part(q, s), part(r, s));
            a.apply_rows(z, rows.start, q);
            let mut delta0 = 0.0;
            for (k, i) in rows.clone().enumerate() {
                r[k] = Padded::from(b[i]) - q[k];
            }
            filter(&filters[s], rows.start, r);
            for (k, i) in rows.enumerate() {
                delta0 += r[k].dot(p_inv[i].times(r[k]));
            }
            sums.put(0, s, delta0);
        }
        pair.sync();
        let delta0 = sums.total(0, count);
        if delta0 <= 0.0 {
            for &s in mine {
                let rows = sides[s].clone();
                let (dv, residual, q) = (part(dv, s), part(residual, s), part(q, s));
                for (k, i) in rows.enumerate() {
                    (dv[k], residual[k]) = (z[i], Padded::from(b[i]) - q[k]);
                }
                finish(s);
            }
            return PcgReport::default();
        }
        // r = S(b − A Δv), c = S P⁻¹ r, δ = rᵀc.
        for &s in mine {
            let rows = sides[s].clone();
            let (residual, r, c) = (part(residual, s), part(r, s), part(c, s));
            a.apply_rows(unsafe { dv.whole() }, rows.start, residual);
            for (k, i) in rows.clone().enumerate() {
                residual[k] = Padded::from(b[i]) - residual[k];
                r[k] = residual[k];
            }
            filter(&filters[s], rows.start, r);
            for (k, i) in rows.clone().enumerate() {
                c[k] = p_inv[i].times(r[k]);
            }
            filter(&filters[s], rows.start, c);
            sums.put(1, s, dot(r, c));
        }
        pair.sync();
        let mut delta = sums.total(1, count);
        let mut iterations = 0;
        let target = stop.tolerance * stop.tolerance * delta0.max(stop.floor);
        while delta > target && iterations < stop.max_iterations {
            for &s in mine {
                let rows = sides[s].clone();
                let q = part(q, s);
                a.apply_rows(unsafe { c.whole() }, rows.start, q);
                // c = S c and S is an orthogonal projection, so cᵀ(S q) = cᵀq.
                sums.put(0, s, dot(&unsafe { c.whole() }[rows], q));
            }
            pair.sync();
            let cq = sums.total(0, count);
            if cq <= 0.0 || !cq.is_finite() {
                break; // not positive definite on the free subspace (or broken input): stop where we are
            }
            let alpha = delta / cq;
            for &s in mine {
                let rows = sides[s].clone();
                let (dv, residual, r, c, q) = (part(dv, s), part(residual, s), part(r, s), part(c, s), part(q, s));
                for (r, q) in residual.iter_mut().zip(q.iter()) {
                    *r -= *q * alpha;
                }
                filter(&filters[s], rows.start, q);
                let mut next = 0.0;
                for (k, i) in rows.enumerate() {
                    dv[k] += c[k] * alpha;
                    let ri = r[k] - q[k] * alpha;
                    // s = P⁻¹ r, kept in q (no longer needed this iteration).
                    let si = p_inv[i].times(ri);
                    (r[k], q[k]) = (ri, si);
                    next += ri.dot(si);
                }
                sums.put(1, s, next);
            }
            pair.sync();
            let next = sums.total(1, count);
            let beta = next / delta;
            for &s in mine {
                let rows = sides[s].clone();
                let (c, q) = (part(c, s), part(q, s));
                for (c, q) in c.iter_mut().zip(q.iter()) {
                    *c = *q + *c * beta;
                }
                filter(&filters[s], rows.start, c);
            }
            pair.sync();
            delta = next;
            iterations += 1;
        }
        mine.iter().for_each(|&s| finish(s));
        let delta = delta.max(0.0);
        PcgReport {
            iterations,
            residual: delta.sqrt(),
            relative_residual: (delta / delta0).sqrt(),
            converged: delta <= target,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::energy::hinge::outer;

    /// A right side that the prescribed changes already satisfy (`b = A z`): nothing to iterate, whatever
    /// the warm start; `Δv = z` and the residual is `b − A z = 0`.
    #[test]
    fn a_system_its_constraints_solve_returns_them() {
        let n = 5;
        // Coupled neighbours: y_i = 3 x_i − (x_{i−1} + x_{i+1}) / 2.
        let apply = |x: &[DVec3], y: &mut [DVec3]| {
            for i in 0..x.len() {
                let left = if i > 0 { x[i - 1] } else { DVec3::ZERO };
                let right = x.get(i + 1).copied().unwrap_or_default();
                y[i] = x[i] * 3.0 - (left + right) * 0.5;
            }
        };
        let p = DVec3::new(0.0, 0.6, 0.8);
        let constraints = [
            Constraint { particle: 1, filter: DMat3::ZERO, z: DVec3::new(0.3, -0.2, 0.1) },
            Constraint { particle: 3, filter: DMat3::IDENTITY - outer(p, p), z: p * 0.7 },
        ];
        let mut z = vec![DVec3::ZERO; n];
        for c in &constraints {
            z[c.particle] = c.z;
        }
        let mut b = vec![DVec3::ZERO; n];
        apply(&z, &mut b);
        let p_inv = vec![PaddedMat3::from(DMat3::IDENTITY / 3.0); n];
        let mut dv: Vec<DVec3> = (0..n).map(|i| DVec3::splat(0.1 * i as f64 + 0.05)).collect();
        let mut residual = vec![DVec3::ONE; n];
        let stop = Stop { tolerance: 1e-10, floor: 0.0, max_iterations: 50 };
        let report = solve(&apply, &p_inv, &constraints, &b, &mut dv, stop, &mut residual, &mut Workspace::default());
        assert_eq!(report, PcgReport::default());
        assert_eq!(dv, z);
        assert!(residual.iter().all(|r| *r == DVec3::ZERO), "{residual:?}");
    }

    /// A random SPD block matrix, a few constraints of each kind; the filtered solution is checked
    /// against a dense solve of the reduced system `Tᵀ A T y = Tᵀ (b − A z)`, `Δv = z + T y`.
    #[test]
    fn matches_a_dense_solve_of_the_filtered_system() {
        let n = 12;
        let mut seed = 3u64;
        let mut rand = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let g = DMatrix::from_fn(3 * n, 3 * n, |_, _| rand());
        let a = &g * g.transpose() + DMatrix::identity(3 * n, 3 * n) * 0.5;
        let b: Vec<DVec3> = (0..n).map(|_| DVec3::new(rand(), rand(), rand())).collect();
        let p = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let q = DVec3::new(2.0, -2.0, 1.0) / 3.0;
        let constraints = [
            Constraint { particle: 1, filter: DMat3::ZERO, z: DVec3::new(0.3, -0.2, 0.1) },
            Constraint { particle: 4, filter: DMat3::IDENTITY - outer(p, p), z: p * 0.7 },
            Constraint { particle: 7, filter: DMat3::IDENTITY - outer(p, p) - outer(q, q), z: p * -0.2 + q * 0.4 },
        ];
        let p_inv: Vec<PaddedMat3> = (0..n)
            .map(|i| {
                let block = DMat3::from_cols_array(&std::array::from_fn(|k| a[(3 * i + k % 3, 3 * i + k / 3)]));
                block.inverse().into()
            })
            .collect();
        let apply = |x: &[DVec3], y: &mut [DVec3]| {
            let xv = DVector::from_iterator(3 * n, x.iter().flat_map(|v| v.to_array()));
            let yv = &a * xv;
            for (i, y) in y.iter_mut().enumerate() {
                *y = DVec3::new(yv[3 * i], yv[3 * i + 1], yv[3 * i + 2]);
            }
        };
        let mut dv: Vec<DVec3> = (0..n).map(|i| DVec3::splat(0.1 * i as f64)).collect(); // a warm start
        let stop = Stop { tolerance: 1e-14, floor: 0.0, max_iterations: 500 };
        let mut residual = vec![DVec3::ZERO; n];
        let report = solve(&apply, &p_inv, &constraints, &b, &mut dv, stop, &mut residual, &mut Workspace::default());
        assert!(report.relative_residual <= 1e-14, "{report:?}");
        // Reduced basis T: identity columns for free particles, the filter's range for constrained ones.
        let mut columns: Vec<DVector<f64>> = Vec::new();
        let mut z = DVector::zeros(3 * n);
        for i in 0..n {
            let c = constraints.iter().find(|c| c.particle == i);
            let free: Vec<DVec3> = match c {
                None => vec![DVec3::X, DVec3::Y, DVec3::Z],
                Some(c) if c.filter == DMat3::ZERO => vec![],
                Some(c) if c.particle == 4 => vec![q, p.cross(q)],
                Some(_) => vec![p.cross(q)],
            };
            if let Some(c) = c {
                z.rows_mut(3 * i, 3).copy_from(&DVector::from_row_slice(&c.z.to_array()));
            }
            for d in free {
                let mut col = DVector::zeros(3 * n);
                col.rows_mut(3 * i, 3).copy_from(&DVector::from_row_slice(&d.to_array()));
                columns.push(col);
            }
        }
        let t = DMatrix::from_columns(&columns);
        let bv = DVector::from_iterator(3 * n, b.iter().flat_map(|v| v.to_array()));
        let reduced = t.transpose() * &a * &t;
        let rhs = t.transpose() * (&bv - &a * &z);
        let y = reduced.cholesky().expect("SPD").solve(&rhs);
        let want = &z + &t * y;
        for i in 0..n {
            let got = dv[i];
            let err = (got - DVec3::new(want[3 * i], want[3 * i + 1], want[3 * i + 2])).length();
            assert!(err < 1e-8 * want.amax(), "particle {i}: {got} vs {:?}", want.rows(3 * i, 3));
        }
        // The tracked residual is b − A Δv.
        let mut a_dv = vec![DVec3::ZERO; n];
        apply(&dv, &mut a_dv);
        for i in 0..n {
            assert!((residual[i] - (b[i] - a_dv[i])).length() < 1e-10, "residual of particle {i}");
        }
        // Constrained components equal z: exactly for the fixed particle, to round-off for projections.
        assert_eq!(dv[1], constraints[0].z);
        assert!((dv[4].dot(p) - 0.7).abs() < 1e-14);
        assert!((dv[7].dot(p) + 0.2).abs() < 1e-14 && (dv[7].dot(q) - 0.4).abs() < 1e-14);
    }

    /// A chain of particles coupled to their neighbours, its rows in two sides (`..h`, `h..`).
    struct Chain {
        n: usize,
        half: Option<usize>,
    }

    impl Operator for Chain {
        fn apply_rows(&self, x: &[Padded], first: usize, y: &mut [Padded]) {
            for (k, y) in y.iter_mut().enumerate() {
                let i = first + k;
                let left = if i > 0 { x[i - 1] } else { Padded::ZERO };
                let right = if i + 1 < self.n { x[i + 1] } else { Padded::ZERO };
                *y = x[i] * (3.0 + (i % 3) as f64) - (left + right) * 0.9;
            }
        }

        fn sides(&self) -> Option<usize> {
            self.half
        }
    }

    /// Split into two sides, the system is solved as in one (a pair of workers on two threads, one
    /// worker in turn on one): the same iterations, the solution and the residual the same to
    /// round-off, and the constraints held.
    #[test]
    fn two_sides_solve_as_one() {
        let n = 301;
        let b: Vec<DVec3> = (0..n).map(|i| DVec3::new((i as f64 * 0.3).sin(), 1.0, (i as f64 * 0.11).cos())).collect();
        let p = DVec3::new(0.0, 0.6, 0.8);
        // Constraints on either side and on the particles at the split.
        let constraints: Vec<Constraint> = [3, 149, 150, 151, 290]
            .iter()
            .enumerate()
            .map(|(k, &i)| Constraint {
                particle: i,
                filter: if k % 2 == 0 { DMat3::ZERO } else { DMat3::IDENTITY - outer(p, p) },
                z: DVec3::new(0.1, -0.2, 0.3) * k as f64,
            })
            .collect();
        let p_inv: Vec<PaddedMat3> =
            (0..n).map(|i| DMat3::from_diagonal(DVec3::splat(1.0 / (3.0 + (i % 3) as f64))).into()).collect();
        let stop = Stop { tolerance: 1e-10, floor: 0.0, max_iterations: 1000 };
        let solve_with = |half| {
            let (mut dv, mut residual) = (vec![DVec3::splat(0.01); n], vec![DVec3::ZERO; n]);
            let chain = Chain { n, half };
            let report = crate::threads::awake(true, || {
                solve(&chain, &p_inv, &constraints, &b, &mut dv, stop, &mut residual, &mut Workspace::default())
            });
            (report, dv, residual)
        };
        let (one, dv_one, residual_one) = solve_with(None);
        let (two, dv_two, residual_two) = solve_with(Some(150));
        assert!(one.converged && one.iterations > 5, "{one:?}");
        assert_eq!(one.iterations, two.iterations);
        for i in 0..n {
            assert!((dv_one[i] - dv_two[i]).length() < 1e-12, "particle {i}: {} vs {}", dv_one[i], dv_two[i]);
            assert!((residual_one[i] - residual_two[i]).length() < 1e-12, "residual of particle {i}");
        }
        assert_eq!(dv_two[3], constraints[0].z);
        assert_eq!(dv_two[150], constraints[2].z);
        assert!((dv_two[149].dot(p) - constraints[1].z.dot(p)).abs() < 1e-14);
    }
}
