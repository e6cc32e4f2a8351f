//! Shift-invert block Lanczos with thick (Krylov–Schur) restarts for the generalized symmetric problem
//! `K φ = λ M φ` with a diagonal, positive mass `M`.
//!
//! The caller supplies the solve `Y = (K − σM)⁻¹ X` for a block of vectors at once (a sparse Cholesky
//! factorisation, typically: one pass over the factor serves the whole block, which costs little
//! more than one vector when the solve is memory bound). The operator `Op = (K − σM)⁻¹ M` is
//! self-adjoint in the `M` inner product, and its largest eigenvalues `ν = 1/(λ − σ)` are the `λ`
//! closest to the shift from above — the lowest modes when `σ` is below the spectrum (negative for a
//! free shell, whose rigid modes have `λ = 0`).
//!
//! Every new block is re-orthogonalised twice against the whole basis (block classical Gram–Schmidt,
//! twice, as dense matrix products), so the basis stays `M`-orthonormal to machine precision, the
//! projected matrix is computed rather than assumed tridiagonal, and the Ritz values are exact
//! Rayleigh quotients. A Ritz pair is accepted when `‖B s_k‖ ≤ tol · |ν|`, with `B` the coupling of
//! the basis to the next block and `s_k` the Ritz vector's last block of coordinates (the residual of
//! the transformed problem); callers should still check `‖Kφ − λMφ‖ / ‖Kφ‖` with the real `K`.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef};
use nalgebra::{DMatrix, SymmetricEigen};

/// Restarts over which the convergence rate is measured to project the restarts still needed.
const RATE_WINDOW: usize = 10;

/// Settings of [`lowest_modes`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LanczosOptions {
    /// The shift `σ`; must lie below the wanted eigenvalues (and must not be one).
    pub shift: f64,
    /// Relative tolerance on the transformed problem's Ritz residual.
    pub tolerance: f64,
    /// Target for the caller's true residual of every pair, checked once the transformed problem
    /// has converged: the iteration goes on while a pair is above it and still improving (by at
    /// least half per block solve).
    pub target: f64,
    /// Cap on restarts before giving up (earlier when the rate of the last restarts projects past twice the cap).
    pub max_restarts: usize,
    /// Vectors per block (per call of the solve).
    pub block: usize,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        Self { shift: 0.0, tolerance: 1e-12, target: 0.0, max_restarts: 200, block: 1 }
    }
}

/// Eigenpairs in ascending order of `λ`; vectors are `M`-orthonormal.
#[derive(Debug, Clone, PartialEq)]
pub struct EigenPairs {
    /// Eigenvalues `λ`.
    pub values: Vec<f64>,
    /// Eigenvectors, one `Vec` per mode, each `M`-normalised.
    pub vectors: Vec<Vec<f64>>,
    /// The caller's true residual of each pair.
    pub residuals: Vec<f64>,
    /// Number of operator applications (one per vector of every block solved).
    pub solves: usize,
    /// Number of block solves.
    pub block_solves: usize,
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

/// The basis `V` (`n × capacity`, column-major) and the projected matrix `H = Vᵀ M Op V`.
struct Krylov<'a> {
    mass: &'a [f64],
    n: usize,
    v: Vec<f64>,
    h: DMatrix<f64>,
    /// Deterministic pseudo-random state (for start vectors and for breakdowns).
    seed: u64,
}

impl Krylov<'_> {
    fn cols(&self, range: std::ops::Range<usize>) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.v[range.start * self.n..range.end * self.n], self.n, range.len())
    }

    fn random(&mut self, out: &mut [f64]) {
        for x in out {
            self.seed = self.seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            *x = (self.seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        }
    }

    /// Remove from the columns of `w` (`n × b`) their components along basis columns `0..s`, twice;
    /// returns the accumulated coefficients `Vᵀ M w` (`s × b`).
    fn orthogonalise(&self, s: usize, w: &mut [f64], b: usize) -> DMatrix<f64> {
        let mut total = DMatrix::zeros(s, b);
        if s == 0 {
            return total;
        }
        let mut mw = vec![0.0; w.len()];
        let mut c = vec![0.0; s * b];
        for _pass in 0..2 {
            for (col, mcol) in w.chunks_exact(self.n).zip(mw.chunks_exact_mut(self.n)) {
                mcol.iter_mut().zip(col).zip(self.mass).for_each(|((o, x), m)| *o = x * m);
            }
            let basis = self.cols(0..s);
            let cm = MatMut::from_column_major_slice_mut(&mut c, s, b);
            matmul(
                cm,
                Accum::Replace,
                basis.transpose(),
                MatRef::from_column_major_slice(&mw, self.n, b),
                1.0,
                crate::threads::par(),
            );
            let wm = MatMut::from_column_major_slice_mut(w, self.n, b);
            matmul(wm, Accum::Add, basis, MatRef::from_column_major_slice(&c, s, b), -1.0, crate::threads::par());
            total += DMatrix::from_column_slice(s, b, &c);
        }
        total
    }

    /// `M`-orthonormalise the `b` columns of `w` (already orthogonal to basis columns `0..s`) in
    /// place by modified Gram–Schmidt, twice; returns `R` (`b × b`, upper triangular) with
    /// `w_in = w_out R`. A column that vanishes (an invariant subspace) is replaced by a fresh random
    /// direction orthogonal to everything, with a zero row in `R`.
    fn orthonormalise(&mut self, s: usize, w: &mut [f64], b: usize, scale: &[f64]) -> DMatrix<f64> {
        let n = self.n;
        let mut r = DMatrix::zeros(b, b);
        for c in 0..b {
            let (done, rest) = w.split_at_mut(c * n);
            let col = &mut rest[..n];
            for _pass in 0..2 {
                for (p, prev) in done.chunks_exact(n).enumerate() {
                    let d = dot_m(prev, col, self.mass);
                    col.iter_mut().zip(prev).for_each(|(x, y)| *x -= d * y);
                    r[(p, c)] += d;
                }
            }
            let norm = dot_m(col, col, self.mass).sqrt();
            if norm > 1e-13 * scale[c] && norm.is_finite() {
                col.iter_mut().for_each(|x| *x /= norm);
                r[(c, c)] = norm;
                continue;
            }
            // Breakdown: a random direction, orthogonal to the basis and to the block so far.
            let mut fresh = vec![0.0; n];
            self.random(&mut fresh);
            self.orthogonalise(s, &mut fresh, 1);
            for _pass in 0..2 {
                for prev in done.chunks_exact(n) {
                    let d = dot_m(prev, &fresh, self.mass);
                    fresh.iter_mut().zip(prev).for_each(|(x, y)| *x -= d * y);
                }
            }
            let norm = dot_m(&fresh, &fresh, self.mass).sqrt();
            col.iter_mut().zip(&fresh).for_each(|(x, y)| *x = y / norm);
            (0..b).for_each(|j| r[(c, j)] = 0.0);
        }
        r
    }

    /// `V_s Y_sel`: Ritz vectors (columns of `y` in `sel`) as one `n × |sel|` column-major array.
    fn ritz(&self, s: usize, y: &DMatrix<f64>, sel: &[usize]) -> Vec<f64> {
        let coef: Vec<f64> =
            sel.iter().flat_map(|&i| y.column(i).rows(0, s).iter().copied().collect::<Vec<_>>()).collect();
        let mut out = vec![0.0; self.n * sel.len()];
        let o = MatMut::from_column_major_slice_mut(&mut out, self.n, sel.len());
        matmul(
            o,
            Accum::Replace,
            self.cols(0..s),
            MatRef::from_column_major_slice(&coef, s, sel.len()),
            1.0,
            crate::threads::par(),
        );
        out
    }
}

fn dot_m(a: &[f64], b: &[f64], m: &[f64]) -> f64 {
    a.iter().zip(b).zip(m).map(|((x, y), w)| x * y * w).sum()
}

/// The `count` eigenpairs of `K φ = λ M φ` nearest above `options.shift`, for an `n`-dimensional
/// problem with diagonal mass `mass`, given `solve(x, b)` overwriting the `b` vectors in `x`
/// (column-major, `n × b`) with `(K − σM)⁻¹ x`, and `true_residual(λ, φ)` measuring a pair the way
/// the caller judges it (typically `‖Kφ − λMφ‖ / ‖Kφ‖`; see [`LanczosOptions::target`]).
pub fn lowest_modes(
    mass: &[f64],
    count: usize,
    mut solve: impl FnMut(&mut [f64], usize) -> Result<(), String>,
    mut true_residual: impl FnMut(f64, &[f64]) -> f64,
    options: LanczosOptions,
) -> Result<EigenPairs, LanczosError> {
    let n = mass.len();
    if count == 0 || count > n {
        return Err(LanczosError::Invalid(format!("asked for {count} modes of a {n}-DOF system")));
    }
    if mass.iter().any(|&m| !(m.is_finite() && m > 0.0)) {
        return Err(LanczosError::Invalid("mass must be finite and positive".into()));
    }
    let b = options.block.clamp(1, n);
    // Basis capacity: whole blocks, twice the wanted pairs plus slack that grows with the block (a
    // block Krylov space needs more vectors than a single-vector one), at most n.
    let kmax = (2 * count + 20 + 6 * (b - 1)).div_ceil(b) * b;
    let kmax = if kmax >= n { n } else { kmax };
    // Ritz vectors kept at a restart: about half the basis, so that whole blocks fill the rest.
    let keep = kmax.saturating_sub(((kmax - count) / 2 / b).max(1) * b);
    let mut k = Krylov { mass, n, v: vec![0.0; n * kmax], h: DMatrix::zeros(kmax, kmax), seed: 0x2545_f491_4f6c_dd1d };
    let first = b.min(kmax);
    let mut start = vec![0.0; n * first];
    k.random(&mut start);
    let scale: Vec<f64> = start.chunks_exact(n).map(|c| dot_m(c, c, mass).sqrt()).collect();
    k.orthonormalise(0, &mut start, first, &scale);
    k.v[..n * first].copy_from_slice(&start);

    let (mut solves, mut block_solves) = (0, 0);
    // True residuals at the previous check (infinite: none yet).
    let mut previous = vec![f64::INFINITY; count];
    // Columns `0..filled` hold the basis; the last block `filled - width..filled` still needs `Op`.
    let (mut filled, mut width) = (first, first);
    // The worst relative Ritz residual of the wanted pairs at each restart.
    let mut worst_at = Vec::new();
    for restart in 0..=options.max_restarts {
        loop {
            let j0 = filled - width;
            let mut w: Vec<f64> = k.v[j0 * n..filled * n].to_vec();
            for col in w.chunks_exact_mut(n) {
                col.iter_mut().zip(mass).for_each(|(x, m)| *x *= m);
            }
            solve(&mut w, width).map_err(LanczosError::Solve)?;
            solves += width;
            block_solves += 1;
            if w.iter().any(|x| !x.is_finite()) {
                return Err(LanczosError::Solve("non-finite result".into()));
            }
            let scale: Vec<f64> = w.chunks_exact(n).map(|c| dot_m(c, c, mass).sqrt()).collect();
            let c = k.orthogonalise(filled, &mut w, width);
            for i in 0..filled {
                for j in 0..width {
                    k.h[(i, j0 + j)] = c[(i, j)];
                    k.h[(j0 + j, i)] = c[(i, j)];
                }
            }
            // The new block's own projection is symmetric up to round-off: average it.
            for a in 0..width {
                for bb in 0..a {
                    let avg = 0.5 * (c[(j0 + a, bb)] + c[(j0 + bb, a)]);
                    k.h[(j0 + a, j0 + bb)] = avg;
                    k.h[(j0 + bb, j0 + a)] = avg;
                }
            }
            // `Op V_blk` = (its projection) + `Q R`: `Q` is the next block, `R` the coupling.
            let coupling = k.orthonormalise(filled, &mut w, width, &scale);
            let next = width.min(kmax - filled);
            k.v[filled * n..(filled + next) * n].copy_from_slice(&w[..next * n]);
            // Rayleigh–Ritz on the `filled` columns whose images are known.
            let eig = SymmetricEigen::new(k.h.view((0, 0), (filled, filled)).into_owned());
            let mut order: Vec<usize> = (0..filled).collect();
            order.sort_by(|&x, &y| eig.eigenvalues[y].total_cmp(&eig.eigenvalues[x]));
            let residual = |i: usize| {
                let last = eig.eigenvectors.column(i).rows(j0, width).into_owned();
                (&coupling * last).norm()
            };
            let wanted = count.min(filled);
            let converged = order[..wanted]
                .iter()
                .take_while(|&&i| residual(i) <= options.tolerance * eig.eigenvalues[i].abs())
                .count();
            if converged == count || filled == n {
                let sel = &order[..count];
                let values: Vec<f64> = sel.iter().map(|&i| options.shift + 1.0 / eig.eigenvalues[i]).collect();
                let vectors: Vec<Vec<f64>> =
                    k.ritz(filled, &eig.eigenvectors, sel).chunks_exact(n).map(<[f64]>::to_vec).collect();
                let residuals: Vec<f64> = values.iter().zip(&vectors).map(|(&l, v)| true_residual(l, v)).collect();
                // Done when every pair meets the target, or has stopped improving (round-off).
                let done =
                    filled == n || residuals.iter().zip(&previous).all(|(&r, &p)| r <= options.target || r > 0.5 * p);
                if done {
                    return Ok(EigenPairs { values, vectors, residuals, solves, block_solves });
                }
                previous = residuals;
            }
            if next == 0 {
                // The worst wanted residual falls about geometrically between restarts: where the rate
                // of the last `RATE_WINDOW` restarts projects the tolerance past twice the cap (a
                // stiffness ratio of 1e10 makes it crawl), give up now rather than at the cap.
                let worst = order[..wanted].iter().map(|&i| residual(i) / eig.eigenvalues[i].abs()).fold(0.0, f64::max);
                worst_at.push(worst);
                let hopeless = restart >= RATE_WINDOW && worst > 0.0 && {
                    let rate = (worst / worst_at[restart - RATE_WINDOW]).powf(1.0 / RATE_WINDOW as f64);
                    let needed = (options.tolerance / worst).ln() / rate.ln();
                    !(rate < 1.0 && restart as f64 + needed <= 2.0 * options.max_restarts as f64)
                };
                if restart == options.max_restarts || hopeless {
                    return Err(LanczosError::NoConvergence { converged, wanted: count, restarts: restart });
                }
                // Thick restart: the best `keep` Ritz vectors, then the residual block. Their mutual
                // projection is diagonal; the coupling to the residual block is recomputed explicitly
                // when that block is expanded.
                let sel = &order[..keep];
                let kept = k.ritz(filled, &eig.eigenvectors, sel);
                k.v[..keep * n].copy_from_slice(&kept);
                k.v[keep * n..(keep + width) * n].copy_from_slice(&w);
                k.h.fill(0.0);
                for (a, &i) in sel.iter().enumerate() {
                    k.h[(a, a)] = eig.eigenvalues[i];
                }
                filled = keep + width;
                break;
            }
            filled += next;
            width = next;
        }
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

    /// `‖Kφ − λMφ‖ / ‖Kφ‖`.
    fn relative_residual(k: &DMatrix<f64>, m: &[f64], lambda: f64, phi: &[f64]) -> f64 {
        let kv = k * nalgebra::DVector::from_column_slice(phi);
        let r: f64 = (0..m.len()).map(|i| (kv[i] - lambda * m[i] * phi[i]).powi(2)).sum::<f64>().sqrt();
        r / kv.norm()
    }

    fn run(k: &DMatrix<f64>, m: &[f64], count: usize, shift: f64, block: usize) -> EigenPairs {
        let n = m.len();
        let shifted = k - DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(m)) * shift;
        let chol = shifted.clone().lu();
        lowest_modes(
            m,
            count,
            |x, b| {
                for col in x.chunks_exact_mut(n).take(b) {
                    let r = chol.solve(&nalgebra::DVector::from_column_slice(col)).ok_or("singular")?;
                    col.copy_from_slice(r.as_slice());
                }
                Ok(())
            },
            |l, v| relative_residual(k, m, l, v),
            // As in the modal analysis: aim a decade below 1e-8 on the true residual.
            LanczosOptions { shift, block, target: 1e-9, ..Default::default() },
        )
        .inspect(|p| assert_eq!(p.vectors[0].len(), n))
        .unwrap()
    }

    #[test]
    fn matches_dense_generalized_eigenvalues_for_every_block_size() {
        let (k, m) = chain(300);
        let reference = dense_reference(&k, &m);
        for block in [1, 3, 8] {
            for count in [1, 4, 12] {
                let pairs = run(&k, &m, count, 0.0, block);
                for (i, (&got, &want)) in pairs.values.iter().zip(&reference).enumerate() {
                    assert!((got - want).abs() <= 1e-9 * want, "block {block}, mode {i}: {got} vs {want}");
                }
                // M-orthonormal, and true residuals small.
                for (a, va) in pairs.vectors.iter().enumerate() {
                    for (b, vb) in pairs.vectors.iter().enumerate() {
                        let d = dot_m(va, vb, &m);
                        assert!((d - if a == b { 1.0 } else { 0.0 }).abs() < 1e-10, "<{a},{b}>_M = {d}");
                    }
                    let r = relative_residual(&k, &m, pairs.values[a], va);
                    assert!(r <= 1e-8, "block {block}, mode {a} relative residual {r}");
                    assert_eq!(r, pairs.residuals[a], "the reported residual is the true one");
                }
                assert_eq!(pairs.solves % block, 0, "whole blocks");
            }
        }
    }

    #[test]
    fn thick_restarts_converge_on_a_poorly_separated_spectrum() {
        // A shift far below the spectrum squeezes ν = 1/(λ − σ) together: many restarts are needed.
        let (k, m) = chain(300);
        let reference = dense_reference(&k, &m);
        for block in [1, 4] {
            let pairs = run(&k, &m, 6, -1.0, block);
            assert!(pairs.solves > 2 * (2 * 6 + 20), "block {block} restarted: {} solves", pairs.solves);
            for (got, want) in pairs.values.iter().zip(&reference) {
                assert!((got - want).abs() <= 1e-9 * want, "block {block}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn negative_shift_finds_zero_modes_of_a_free_system() {
        // Free-free chain: one zero (rigid) mode.
        let (mut k, m) = chain(60);
        k[(0, 0)] = 1.0;
        let pairs = run(&k, &m, 3, -0.01, 2);
        let reference = dense_reference(&k, &m);
        assert!(pairs.values[0].abs() < 1e-10, "rigid mode λ = {}", pairs.values[0]);
        assert!((pairs.values[2] - reference[2]).abs() < 1e-9 * reference[2]);
    }

    #[test]
    fn refuses_bad_requests() {
        let m = vec![1.0; 4];
        let ok = |_: &mut [f64], _: usize| Ok(());
        let (d, r) = (LanczosOptions::default(), |_: f64, _: &[f64]| 0.0);
        assert!(matches!(lowest_modes(&m, 5, ok, r, d), Err(LanczosError::Invalid(_))));
        assert!(matches!(lowest_modes(&[1.0, -1.0], 1, ok, r, d), Err(LanczosError::Invalid(_))));
        let fail = |_: &mut [f64], _: usize| Err("boom".to_string());
        assert!(matches!(lowest_modes(&m, 1, fail, r, d), Err(LanczosError::Solve(_))));
    }
}
