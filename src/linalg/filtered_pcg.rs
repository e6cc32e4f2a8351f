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

use glam::{DMat3, DVec3};

use super::padded::{Padded, PaddedMat3, pad, unpad};

/// A linear operator `y = A x` on per-particle vectors (symmetric positive definite on the free
/// subspace, for [`solve`]).
pub trait Operator {
    /// `y = A x` on padded vectors, which [`solve`] iterates with (mark the implementation
    /// `#[inline(always)]` so that it is compiled into the solver's kernel).
    fn apply_padded(&self, x: &[Padded], y: &mut [Padded]);

    /// `y = A x`.
    fn apply(&self, x: &[DVec3], y: &mut [DVec3]) {
        let mut out = vec![Padded::ZERO; y.len()];
        self.apply_padded(&pad(x), &mut out);
        unpad(&out, y);
    }
}

/// A closure on 3-vectors is an operator (applied through copies: for tests and small systems).
impl<F: Fn(&[DVec3], &mut [DVec3])> Operator for F {
    fn apply_padded(&self, x: &[Padded], y: &mut [Padded]) {
        let (mut x3, mut out) = (vec![DVec3::ZERO; x.len()], vec![DVec3::ZERO; y.len()]);
        unpad(x, &mut x3);
        self(&x3, &mut out);
        for (y, o) in y.iter_mut().zip(out) {
            *y = o.into();
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

/// The constraints' filters: particle and matrix.
type Filters = Vec<(usize, PaddedMat3)>;

#[inline(always)]
fn filter(filters: &Filters, x: &mut [Padded]) {
    for (i, s) in filters {
        x[*i] = s.times(x[*i]);
    }
}

/// `a − b`, per particle.
#[inline(always)]
fn difference(a: &[Padded], b: &[Padded]) -> Vec<Padded> {
    a.iter().zip(b).map(|(a, b)| *a - *b).collect()
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

/// Solve with the operator `a`, block-Jacobi inverse `p_inv`, the constraints, right
/// side `b` and warm start / result `dv`. `residual` receives `b − A Δv` unfiltered: on the
/// constrained directions it is minus the constraint's impulse (updated alongside the filtered
/// residual, so it costs no extra product with `A`).
///
/// The iteration is compiled for AVX2 + FMA where the CPU has them ([`super::isa`]), with the
/// operator inlined into it if its [`Operator::apply_padded`] is `#[inline(always)]`.
pub fn solve<A: Operator>(
    a: &A,
    p_inv: &[PaddedMat3],
    constraints: &[Constraint],
    b: &[DVec3],
    dv: &mut [DVec3],
    stop: Stop,
    residual: &mut [DVec3],
) -> PcgReport {
    super::isa::avx2(Iterate { a, p_inv, constraints, b, dv, stop, residual })
}

/// The arguments of [`solve`], run as a [`super::isa::Kernel`].
struct Iterate<'a, A> {
    a: &'a A,
    p_inv: &'a [PaddedMat3],
    constraints: &'a [Constraint],
    b: &'a [DVec3],
    dv: &'a mut [DVec3],
    stop: Stop,
    residual: &'a mut [DVec3],
}

impl<A: Operator> super::isa::Kernel for Iterate<'_, A> {
    type Output = PcgReport;

    #[inline(always)]
    fn run(self) -> PcgReport {
        let Self { a, p_inv, constraints, b, dv: dv_out, stop, residual: residual_out } = self;
        let n = b.len();
        let b = pad(b);
        let mut dv = pad(dv_out);
        let mut z = vec![Padded::ZERO; n];
        for c in constraints {
            z[c.particle] = c.z.into();
            let start = c.filter * DVec3::from(dv[c.particle]) + (c.z - c.filter * c.z);
            dv[c.particle] = start.into();
        }
        let filters: Filters = constraints.iter().map(|c| (c.particle, c.filter.into())).collect();
        let mut scratch = vec![Padded::ZERO; n];
        a.apply_padded(&z, &mut scratch);
        let mut b_hat = difference(&b, &scratch);
        filter(&filters, &mut b_hat);
        let mut delta0 = 0.0;
        for (r, p) in b_hat.iter().zip(p_inv) {
            delta0 += r.dot(p.times(*r));
        }
        if delta0 <= 0.0 {
            unpad(&z, dv_out);
            unpad(&difference(&b, &scratch), residual_out);
            return PcgReport::default();
        }
        a.apply_padded(&dv, &mut scratch);
        let mut residual = difference(&b, &scratch);
        let mut r = residual.clone();
        filter(&filters, &mut r);
        let mut c: Vec<Padded> = r.iter().zip(p_inv).map(|(r, p)| p.times(*r)).collect();
        filter(&filters, &mut c);
        let mut delta = dot(&r, &c);
        let mut q = scratch;
        let mut iterations = 0;
        let target = stop.tolerance * stop.tolerance * delta0.max(stop.floor);
        while delta > target && iterations < stop.max_iterations {
            a.apply_padded(&c, &mut q);
            // c = S c and S is an orthogonal projection, so cᵀ(S q) = cᵀq.
            let cq = dot(&c, &q);
            if cq <= 0.0 || !cq.is_finite() {
                break; // not positive definite on the free subspace (or broken input): stop where we are
            }
            let alpha = delta / cq;
            for (r, q) in residual.iter_mut().zip(&q) {
                *r -= *q * alpha;
            }
            filter(&filters, &mut q);
            let mut next = 0.0;
            for i in 0..n {
                dv[i] += c[i] * alpha;
                let ri = r[i] - q[i] * alpha;
                // s = P⁻¹ r, kept in q (no longer needed this iteration).
                let s = p_inv[i].times(ri);
                (r[i], q[i]) = (ri, s);
                next += ri.dot(s);
            }
            let beta = next / delta;
            for i in 0..n {
                c[i] = q[i] + c[i] * beta;
            }
            filter(&filters, &mut c);
            delta = next;
            iterations += 1;
        }
        unpad(&dv, dv_out);
        unpad(&residual, residual_out);
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
        let report = solve(&apply, &p_inv, &constraints, &b, &mut dv, stop, &mut residual);
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
        let report = solve(&apply, &p_inv, &constraints, &b, &mut dv, stop, &mut residual);
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
}
