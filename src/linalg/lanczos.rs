//! Shift-invert Lanczos with thick (Krylov–Schur) restarts for the generalized symmetric problem
//! `K φ = λ M φ` with a diagonal, positive mass `M`.
//!
//! The caller supplies the solve `y = (K − σM)⁻¹ x` (a sparse Cholesky factorisation, typically).
//! The operator `Op = (K − σM)⁻¹ M` is self-adjoint in the `M` inner product, and its largest
//! eigenvalues `ν = 1/(λ − σ)` are the `λ` closest to the shift from above — the lowest modes when
//! `σ` is below the spectrum (negative for a free shell, whose rigid modes have `λ = 0`).
//!
//! Every basis vector is re-orthogonalised twice against the whole basis (classical Gram–Schmidt,
//! twice), so the basis stays `M`-orthonormal to machine precision and the Ritz values are exact
//! Rayleigh quotients. A Ritz pair is accepted when `β |yₖ| ≤ tol · |ν|` (the residual of the
//! transformed problem); callers should still check `‖Kφ − λMφ‖ / ‖Kφ‖` with the real `K`.

use nalgebra::{DMatrix, SymmetricEigen};

/// Settings of [`lowest_modes`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LanczosOptions {
    /// The shift `σ`; must lie below the wanted eigenvalues (and must not be one).
    pub shift: f64,
    /// Relative tolerance on the transformed problem's Ritz residual.
    pub tolerance: f64,
    /// Cap on restarts before giving up.
    pub max_restarts: usize,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        Self { shift: 0.0, tolerance: 1e-12, max_restarts: 200 }
    }
}

/// Eigenpairs in ascending order of `λ`; vectors are `M`-orthonormal.
#[derive(Debug, Clone, PartialEq)]
pub struct EigenPairs {
    /// Eigenvalues `λ`.
    pub values: Vec<f64>,
    /// Eigenvectors, one `Vec` per mode, each `M`-normalised.
    pub vectors: Vec<Vec<f64>>,
    /// Number of operator applications (linear solves) used.
    pub solves: usize,
}

/// Why the eigen solve failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LanczosError {
    /// Bad arguments (sizes, non-positive mass, more modes than DOFs).
    #[error("eigen solve: {0}")]
    Invalid(String),
    /// The wanted pairs did not converge within the restart budget.
    #[error("eigen solve did not converge: {converged} of {wanted} modes after {restarts} restarts")]
    NoConvergence {
        /// Pairs converged.
        converged: usize,
        /// Pairs wanted.
        wanted: usize,
        /// Restarts made.
        restarts: usize,
    },
    /// The linear solve reported an error or returned non-finite values.
    #[error("eigen solve: linear solve failed: {0}")]
    Solve(String),
}

fn dot_m(a: &[f64], b: &[f64], m: &[f64]) -> f64 {
    a.iter().zip(b).zip(m).map(|((x, y), w)| x * y * w).sum()
}

/// The Ritz vectors `V y_i` for the selected columns `i` of `y`.
fn ritz_vectors(basis: &[Vec<f64>], y: &DMatrix<f64>, sel: &[usize], n: usize) -> Vec<Vec<f64>> {
    sel.iter()
        .map(|&i| {
            let mut x = vec![0.0; n];
            for (k, b) in basis.iter().enumerate() {
                let c = y[(k, i)];
                x.iter_mut().zip(b).for_each(|(o, v)| *o += c * v);
            }
            x
        })
        .collect()
}

/// The `count` eigenpairs of `K φ = λ M φ` nearest above `options.shift`, for an `n`-dimensional
/// problem with diagonal mass `mass`, given `solve(x, y)` computing `y = (K − σM)⁻¹ x`.
pub fn lowest_modes(
    mass: &[f64],
    count: usize,
    mut solve: impl FnMut(&[f64], &mut [f64]) -> Result<(), String>,
    options: LanczosOptions,
) -> Result<EigenPairs, LanczosError> {
    let n = mass.len();
    if count == 0 || count > n {
        return Err(LanczosError::Invalid(format!("asked for {count} modes of a {n}-DOF system")));
    }
    if mass.iter().any(|&m| !(m.is_finite() && m > 0.0)) {
        return Err(LanczosError::Invalid("mass must be finite and positive".into()));
    }
    let kmax = (2 * count + 20).min(n);
    let keep = (count + (kmax - count) / 2).min(kmax - 1).max(count.min(kmax - 1));
    // Deterministic pseudo-random start (a fixed linear congruential sequence).
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut start: Vec<f64> = (0..n)
        .map(|_| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let norm = dot_m(&start, &start, mass).sqrt();
    start.iter_mut().for_each(|x| *x /= norm);

    let mut basis: Vec<Vec<f64>> = vec![start];
    let mut h = DMatrix::<f64>::zeros(kmax, kmax);
    let mut kept = 0; // columns of `h` already filled (after a restart: the kept Ritz values + arrow)
    let mut solves = 0;
    let mut mx = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut residual_beta = 0.0;
    for restart in 0..=options.max_restarts {
        // Expand the basis to kmax vectors.
        for j in kept..kmax {
            let v = &basis[j];
            mx.iter_mut().zip(v).zip(mass).for_each(|((o, x), m)| *o = x * m);
            solve(&mx, &mut w).map_err(LanczosError::Solve)?;
            solves += 1;
            if w.iter().any(|x| !x.is_finite()) {
                return Err(LanczosError::Solve("non-finite result".into()));
            }
            let mut coef = vec![0.0; j + 1];
            for _pass in 0..2 {
                let c: Vec<f64> = basis.iter().map(|b| dot_m(b, &w, mass)).collect();
                for (b, &ci) in basis.iter().zip(&c) {
                    w.iter_mut().zip(b).for_each(|(x, y)| *x -= ci * y);
                }
                coef.iter_mut().zip(&c).for_each(|(a, b)| *a += b);
            }
            for (i, &ci) in coef.iter().enumerate() {
                h[(i, j)] = ci;
                h[(j, i)] = ci;
            }
            let beta = dot_m(&w, &w, mass).sqrt();
            if j + 1 < kmax {
                h[(j + 1, j)] = beta;
                h[(j, j + 1)] = beta;
            }
            if beta <= 1e-14 * coef[j].abs().max(f64::MIN_POSITIVE) {
                // Invariant subspace: continue with a fresh direction orthogonal to the basis.
                w.iter_mut().enumerate().for_each(|(i, x)| *x = ((i * 7919 + j * 104729) % 1000) as f64 / 1000.0 - 0.5);
                for _pass in 0..2 {
                    let c: Vec<f64> = basis.iter().map(|b| dot_m(b, &w, mass)).collect();
                    for (b, &ci) in basis.iter().zip(&c) {
                        w.iter_mut().zip(b).for_each(|(x, y)| *x -= ci * y);
                    }
                }
                let nb = dot_m(&w, &w, mass).sqrt();
                w.iter_mut().for_each(|x| *x /= nb);
                if j + 1 < kmax {
                    h[(j + 1, j)] = 0.0;
                    h[(j, j + 1)] = 0.0;
                }
            } else {
                w.iter_mut().for_each(|x| *x /= beta);
            }
            // Early exit: once the basis is a few vectors past `count`, check convergence every other
            // step (a Ritz check costs a small dense eigen solve; a solve costs far more).
            let size = j + 1;
            if size < kmax && size >= count + 4 && (size - kept) % 2 == 0 {
                let eig = SymmetricEigen::new(h.view((0, 0), (size, size)).into_owned());
                let mut order: Vec<usize> = (0..size).collect();
                order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
                let done = order[..count].iter().all(|&i| {
                    beta * eig.eigenvectors[(size - 1, i)].abs() <= options.tolerance * eig.eigenvalues[i].abs()
                });
                if done {
                    let sel = &order[..count];
                    let values = sel.iter().map(|&i| options.shift + 1.0 / eig.eigenvalues[i]).collect();
                    return Ok(EigenPairs { values, vectors: ritz_vectors(&basis, &eig.eigenvectors, sel, n), solves });
                }
            }
            if j + 1 < kmax {
                basis.push(w.clone());
            } else {
                // Residual direction of the full basis, for the restart.
                residual_beta = if beta <= 1e-14 * coef[j].abs().max(f64::MIN_POSITIVE) { 0.0 } else { beta };
            }
        }
        let eig = SymmetricEigen::new(h.clone());
        let mut order: Vec<usize> = (0..kmax).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let converged = order
            .iter()
            .take(count)
            .take_while(|&&i| {
                residual_beta * eig.eigenvectors[(kmax - 1, i)].abs() <= options.tolerance * eig.eigenvalues[i].abs()
            })
            .count();
        let ritz = |sel: &[usize]| ritz_vectors(&basis, &eig.eigenvectors, sel, n);
        if converged == count || kmax == n {
            let sel: Vec<usize> = order[..count].to_vec();
            let values = sel.iter().map(|&i| options.shift + 1.0 / eig.eigenvalues[i]).collect();
            return Ok(EigenPairs { values, vectors: ritz(&sel), solves });
        }
        if restart == options.max_restarts {
            return Err(LanczosError::NoConvergence { converged, wanted: count, restarts: restart });
        }
        // Thick restart: keep the best `keep` Ritz vectors, then the residual direction.
        let sel: Vec<usize> = order[..keep].to_vec();
        let mut new_basis = ritz(&sel);
        h.fill(0.0);
        for (a, &i) in sel.iter().enumerate() {
            h[(a, a)] = eig.eigenvalues[i];
            let arrow = residual_beta * eig.eigenvectors[(kmax - 1, i)];
            h[(keep, a)] = arrow;
            h[(a, keep)] = arrow;
        }
        new_basis.push(w.clone());
        basis = new_basis;
        kept = keep;
    }
    Err(LanczosError::NoConvergence { converged: 0, wanted: count, restarts: options.max_restarts })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixed-free chain of `n` springs (stiffness k) and lumped masses: a discrete string.
    fn chain(n: usize) -> (DMatrix<f64>, Vec<f64>) {
        let mut k = DMatrix::zeros(n, n);
        for i in 0..n {
            k[(i, i)] = if i + 1 < n { 2.0 } else { 1.0 };
            if i + 1 < n {
                k[(i, i + 1)] = -1.0;
                k[(i + 1, i)] = -1.0;
            }
        }
        let m = (0..n).map(|i| 1.0 + 0.5 * ((i * 37) % 11) as f64 / 11.0).collect();
        (k, m)
    }

    fn dense_reference(k: &DMatrix<f64>, m: &[f64]) -> Vec<f64> {
        let n = m.len();
        let s = DMatrix::from_fn(n, n, |i, j| k[(i, j)] / (m[i] * m[j]).sqrt());
        let mut v: Vec<f64> = SymmetricEigen::new(s).eigenvalues.iter().copied().collect();
        v.sort_by(f64::total_cmp);
        v
    }

    fn run(k: &DMatrix<f64>, m: &[f64], count: usize, shift: f64) -> EigenPairs {
        let n = m.len();
        let shifted = k - DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(m)) * shift;
        let chol = shifted.clone().lu();
        lowest_modes(
            m,
            count,
            |x, y| {
                let r = chol.solve(&nalgebra::DVector::from_column_slice(x)).ok_or("singular")?;
                y.copy_from_slice(r.as_slice());
                Ok(())
            },
            LanczosOptions { shift, ..Default::default() },
        )
        .inspect(|p| assert_eq!(p.vectors[0].len(), n))
        .unwrap()
    }

    #[test]
    fn matches_dense_generalized_eigenvalues_with_restarts() {
        let (k, m) = chain(300);
        let reference = dense_reference(&k, &m);
        for count in [1, 4, 12] {
            let pairs = run(&k, &m, count, 0.0);
            for (i, (&got, &want)) in pairs.values.iter().zip(&reference).enumerate() {
                assert!((got - want).abs() <= 1e-9 * want, "mode {i}: {got} vs {want}");
            }
            // M-orthonormal, and true residuals small.
            for (a, va) in pairs.vectors.iter().enumerate() {
                for (b, vb) in pairs.vectors.iter().enumerate() {
                    let d = dot_m(va, vb, &m);
                    assert!((d - if a == b { 1.0 } else { 0.0 }).abs() < 1e-10, "<{a},{b}>_M = {d}");
                }
                let kv = &k * nalgebra::DVector::from_column_slice(va);
                let r: f64 = (0..m.len()).map(|i| (kv[i] - pairs.values[a] * m[i] * va[i]).powi(2)).sum::<f64>().sqrt();
                assert!(r <= 1e-8 * kv.norm(), "mode {a} relative residual {}", r / kv.norm());
            }
        }
    }

    #[test]
    fn thick_restarts_converge_on_a_poorly_separated_spectrum() {
        // A shift far below the spectrum squeezes ν = 1/(λ − σ) together: many restarts are needed.
        let (k, m) = chain(300);
        let reference = dense_reference(&k, &m);
        let pairs = run(&k, &m, 6, -1.0);
        assert!(pairs.solves > 2 * (2 * 6 + 20), "restarted: {} solves", pairs.solves);
        for (got, want) in pairs.values.iter().zip(&reference) {
            assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        }
    }

    #[test]
    fn negative_shift_finds_zero_modes_of_a_free_system() {
        // Free-free chain: one zero (rigid) mode.
        let (mut k, m) = chain(60);
        k[(0, 0)] = 1.0;
        let pairs = run(&k, &m, 3, -0.01);
        let reference = dense_reference(&k, &m);
        assert!(pairs.values[0].abs() < 1e-10, "rigid mode λ = {}", pairs.values[0]);
        assert!((pairs.values[2] - reference[2]).abs() < 1e-9 * reference[2]);
    }

    #[test]
    fn refuses_bad_requests() {
        let m = vec![1.0; 4];
        let ok = |_: &[f64], _: &mut [f64]| Ok(());
        assert!(matches!(lowest_modes(&m, 5, ok, LanczosOptions::default()), Err(LanczosError::Invalid(_))));
        assert!(matches!(lowest_modes(&[1.0, -1.0], 1, ok, LanczosOptions::default()), Err(LanczosError::Invalid(_))));
        let fail = |_: &[f64], _: &mut [f64]| Err("boom".to_string());
        assert!(matches!(lowest_modes(&m, 1, fail, LanczosOptions::default()), Err(LanczosError::Solve(_))));
    }
}
