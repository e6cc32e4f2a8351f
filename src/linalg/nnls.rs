//! Non-negative least squares, `min |A w − b|²` subject to `w ≥ 0`, by Lawson & Hanson's active-set
//! method (1974, *Solving Least Squares Problems*, ch. 23), written on the normal equations
//! `G = AᵀA`, `d = Aᵀb`: its cost depends on the column count alone, so a caller that grows `A` a
//! column at a time (a greedy cubature) keeps `G` and `d` and never touches the rows again.
//!
//! The method keeps a *passive* set `P` (the positive weights). Each outer iteration moves the
//! column whose negative gradient `d − G w` is largest into `P`; the inner loop solves the
//! unconstrained problem on `P` (`G_PP z = d_P`) and, while some `z_i ≤ 0`, steps from `w` towards
//! `z` as far as feasibility allows and drops the weights that reach zero. It stops when no column
//! outside `P` has a positive gradient (the Karush–Kuhn–Tucker conditions). A start `w` (from a
//! smaller problem) is taken as it is, so growing problems are solved warm.

use nalgebra::{DMatrix, DVector};

/// The weights `w ≥ 0` minimising `½ wᵀ G w − dᵀ w` (the normal-equation form of
/// `|A w − b|²`), from `start` (zero where not given, clamped to `w ≥ 0`).
///
/// # Panics
/// If `gram` is not square of `d`'s size, or `start` is of another size.
pub fn solve(gram: &DMatrix<f64>, d: &DVector<f64>, start: Option<&DVector<f64>>) -> DVector<f64> {
    let n = d.len();
    assert!(gram.nrows() == n && gram.ncols() == n, "the Gram matrix must be {n} × {n}");
    let mut w = start.map_or_else(|| DVector::zeros(n), |s| s.map(|x| x.max(0.0)));
    let mut passive: Vec<bool> = w.iter().map(|&x| x > 0.0).collect();
    let scale = gram.diagonal().max().max(f64::MIN_POSITIVE);
    let tolerance = 1e-12 * scale * (1.0 + w.amax()) + 1e-14 * d.amax();
    let ridge = 1e-13 * scale;
    for _ in 0..3 * n + 1 {
        // Inner loop: the least-squares weights on the passive set, kept feasible.
        for _ in 0..=n {
            let set: Vec<usize> = (0..n).filter(|&i| passive[i]).collect();
            if set.is_empty() {
                break;
            }
            let z = restricted(gram, d, &set, ridge);
            if z.iter().all(|&x| x > 0.0) {
                w.fill(0.0);
                set.iter().zip(z.iter()).for_each(|(&i, &x)| w[i] = x);
                break;
            }
            let alpha = set
                .iter()
                .zip(z.iter())
                .filter(|&(_, &x)| x <= 0.0)
                .map(|(&i, &x)| w[i] / (w[i] - x))
                .fold(f64::INFINITY, f64::min);
            let floor = 1e-14 * w.amax();
            for (&i, &x) in set.iter().zip(z.iter()) {
                w[i] += alpha * (x - w[i]);
                if w[i] <= floor {
                    w[i] = 0.0;
                    passive[i] = false;
                }
            }
        }
        let gradient = d - gram * &w;
        let best = (0..n).filter(|&i| !passive[i]).max_by(|&a, &b| gradient[a].total_cmp(&gradient[b]));
        match best {
            Some(j) if gradient[j] > tolerance => passive[j] = true,
            _ => break,
        }
    }
    w
}

/// `G_PP⁻¹ d_P` for the index set `set` (a ridge keeps repeated columns solvable).
fn restricted(gram: &DMatrix<f64>, d: &DVector<f64>, set: &[usize], ridge: f64) -> DVector<f64> {
    let k = set.len();
    let g = DMatrix::from_fn(k, k, |a, b| gram[(set[a], set[b])] + if a == b { ridge } else { 0.0 });
    let rhs = DVector::from_fn(k, |a, _| d[set[a]]);
    match g.clone().cholesky() {
        Some(c) => c.solve(&rhs),
        None => g.lu().solve(&rhs).unwrap_or_else(|| DVector::zeros(k)),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::solve;
    use crate::linalg::random::Rng;

    /// The best of the unconstrained least-squares solutions on every support that are feasible.
    fn brute_force(a: &DMatrix<f64>, b: &DVector<f64>) -> (DVector<f64>, f64) {
        let n = a.ncols();
        let mut best = (DVector::zeros(n), b.norm_squared());
        for mask in 1u32..(1 << n) {
            let set: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
            let sub = DMatrix::from_fn(a.nrows(), set.len(), |r, c| a[(r, set[c])]);
            let Some(z) = (sub.transpose() * &sub).cholesky().map(|c| c.solve(&(sub.transpose() * b))) else {
                continue;
            };
            if z.iter().all(|&x| x >= 0.0) {
                let r = (&sub * &z - b).norm_squared();
                if r < best.1 {
                    let mut w = DVector::zeros(n);
                    set.iter().zip(z.iter()).for_each(|(&i, &x)| w[i] = x);
                    best = (w, r);
                }
            }
        }
        best
    }

    #[test]
    fn matches_the_exhaustive_search_on_small_problems() {
        let mut rng = Rng(11);
        for trial in 0..20 {
            let (m, n) = (9, 7);
            let a = DMatrix::from_fn(m, n, |_, _| rng.uniform());
            let b = DVector::from_fn(m, |_, _| rng.uniform());
            let w = solve(&(a.transpose() * &a), &(a.transpose() * &b), None);
            let (expected, residual) = brute_force(&a, &b);
            assert!(w.iter().all(|&x| x >= 0.0), "trial {trial}: {w}");
            let r = (&a * &w - &b).norm_squared();
            assert!((r - residual).abs() <= 1e-10 * (1.0 + residual), "trial {trial}: {r} vs {residual}");
            assert!((&w - &expected).amax() < 1e-8, "trial {trial}: {w} vs {expected}");
            assert!(w.iter().any(|&x| x == 0.0) || expected.iter().all(|&x| x > 0.0));
        }
    }

    #[test]
    fn a_warm_start_reaches_the_same_optimum_and_satisfies_the_kkt_conditions() {
        let mut rng = Rng(5);
        let (m, n) = (60, 40);
        let a = DMatrix::from_fn(m, n, |_, _| rng.uniform() + 0.2);
        let b = DVector::from_fn(m, |_, _| rng.uniform() + 1.0);
        let (g, d) = (a.transpose() * &a, a.transpose() * &b);
        let cold = solve(&g, &d, None);
        let start = DVector::from_fn(n, |i, _| if i % 3 == 0 { 0.5 } else { 0.0 });
        let warm = solve(&g, &d, Some(&start));
        let value = |w: &DVector<f64>| (&a * w - &b).norm_squared();
        assert!((value(&cold) - value(&warm)).abs() <= 1e-9 * value(&cold), "{} {}", value(&cold), value(&warm));
        let gradient = &d - &g * &cold;
        for i in 0..n {
            if cold[i] > 0.0 {
                assert!(gradient[i].abs() < 1e-8 * d.amax(), "stationary on the support: {}", gradient[i]);
            } else {
                assert!(gradient[i] < 1e-8 * d.amax(), "no descent off the support: {}", gradient[i]);
            }
        }
        assert!(cold.iter().any(|&x| x == 0.0), "some weights are held at zero: {cold}");
    }
}
