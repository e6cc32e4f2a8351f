//! The stable step of the explicit `ds` integrator, estimated from the linearised system at rest.
//!
//! Symplectic Euler with explicit damping on one mode `ẍ = −ω² x − c ẋ` (`c = α + β ω²` under Rayleigh
//! damping) advances `(x, v)` by a matrix with trace `2 − hc − h²ω²` and determinant `1 − hc`; both
//! eigenvalues lie in the unit disc iff `hc < 2` and `h²ω² + 2hc < 4`, i.e.
//! `h < 4 / (c + √(c² + 4ω²))` (which is `2/ω` undamped). That bound falls as `ω` grows, so the whole
//! shell is limited by its highest frequency `ω_max`, `ω²_max = λ_max(M⁻¹K₀)` over the free DOFs.
//! Fixing more vertices (drags) only lowers `λ_max` (eigenvalue interlacing), so the limit computed
//! with the scene's anchors holds under drags too.
//!
//! `λ_max` comes from Lanczos on the symmetric `M^{-1/2} K₀ M^{-1/2}` (matrix-vector products only,
//! no reorthogonalisation: a lost orthogonality only repeats Ritz values, never exceeds `λ_max`). The
//! largest Ritz value approaches `λ_max` from below, so callers keep a safety factor below the limit;
//! large deformations add geometric stiffness the rest state does not have, which that factor covers too.

use nalgebra::DMatrix;

use super::ShellModel;
use super::newton::{dot, norm};

/// Highest Lanczos steps taken.
const MAX_STEPS: usize = 120;
/// Stop when the largest Ritz value changes by less than this (relative) over [`CHECK_EVERY`] steps.
const RITZ_TOLERANCE: f64 = 1e-6;
const CHECK_EVERY: usize = 10;

/// The estimated stability limit of symplectic Euler on a shell model at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StabilityLimit {
    /// Highest angular frequency of the free, linearised system, rad/s (`0` with no free DOFs).
    pub omega_max: f64,
    /// Largest stable step at `omega_max` with the model's Rayleigh damping, s (infinite if `ω = 0`).
    pub step: f64,
}

/// Largest `h` for which symplectic Euler with explicit damping `c` is stable on `ẍ = −ω²x − cẋ`.
pub(crate) fn symplectic_euler_limit(omega: f64, c: f64) -> f64 {
    4.0 / (c + (c * c + 4.0 * omega * omega).sqrt())
}

/// Estimate `ω_max` of `model` at rest (anchors and current drags removed) and its stable step.
pub(crate) fn stability_limit(model: &mut ShellModel) -> StabilityLimit {
    let lambda = max_rest_eigenvalue(model);
    let omega_max = lambda.max(0.0).sqrt();
    let c = model.alpha + model.beta * lambda.max(0.0);
    StabilityLimit { omega_max, step: symplectic_euler_limit(omega_max, c) }
}

/// `λ_max(M⁻¹K₀)` by Lanczos on `M^{-1/2} K₀ M^{-1/2}`.
fn max_rest_eigenvalue(model: &mut ShellModel) -> f64 {
    let scale: Vec<f64> = model.reduced_masses().iter().map(|m| 1.0 / m.sqrt()).collect();
    let n = scale.len();
    if n == 0 {
        return 0.0;
    }
    // A deterministic start with components in every direction.
    let mut q: Vec<f64> = (0..n).map(|i| 1.0 + 0.5 * ((i as f64) * 0.618_034).sin()).collect();
    normalise(&mut q);
    let mut q_prev = vec![0.0; n];
    let (mut w, mut scaled, mut product) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut alphas, mut betas) = (Vec::new(), Vec::new());
    let mut beta = 0.0;
    let mut last = 0.0;
    for step in 1..=MAX_STEPS.min(n) {
        scaled.iter_mut().zip(&q).zip(&scale).for_each(|((s, q), c)| *s = q * c);
        model.rest_stiffness_product(&scaled, &mut product);
        w.iter_mut().zip(&product).zip(&scale).zip(&q_prev).for_each(|(((w, p), c), qp)| *w = p * c - beta * qp);
        let alpha = dot(&q, &w);
        w.iter_mut().zip(&q).for_each(|(w, q)| *w -= alpha * q);
        alphas.push(alpha);
        beta = dot(&w, &w).sqrt();
        let converged = if step % CHECK_EVERY == 0 {
            let ritz = largest_ritz_value(&alphas, &betas);
            let done = (ritz - last).abs() <= RITZ_TOLERANCE * ritz.abs();
            last = ritz;
            done
        } else {
            false
        };
        // An invariant subspace (exact for tiny systems) or a settled Ritz value ends the iteration.
        if converged || beta <= 1e-14 * alphas.iter().fold(0.0f64, |m, a| m.max(a.abs())) {
            break;
        }
        betas.push(beta);
        std::mem::swap(&mut q_prev, &mut q);
        q.iter_mut().zip(&w).for_each(|(q, w)| *q = w / beta);
    }
    largest_ritz_value(&alphas, &betas[..alphas.len() - 1])
}

/// Largest eigenvalue of the symmetric tridiagonal matrix with diagonal `a` and off-diagonal `b`.
fn largest_ritz_value(a: &[f64], b: &[f64]) -> f64 {
    let k = a.len();
    let t = DMatrix::from_fn(k, k, |i, j| match i.abs_diff(j) {
        0 => a[i],
        1 => b[i.min(j)],
        _ => 0.0,
    });
    t.symmetric_eigenvalues().iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

fn normalise(v: &mut [f64]) {
    let n = norm(v);
    v.iter_mut().for_each(|x| *x /= n);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{self, Origin, Setup};
    use std::path::PathBuf;

    fn model(mesh: &str, solver: &str) -> ShellModel {
        let text = format!(
            "name = \"t\"\n{mesh}\n[material]\ndensity = 0.3\nk_area = 50.0\nk_length = 200.0\nk_bend = 0.01\n\
             [[anchors]]\nindices = [0, 1]\n[solver]\nmethod = \"ds\"\n{solver}\n"
        );
        let origin = Origin { label: "test".into(), dir: PathBuf::from(".") };
        let setup = Setup::new(scene::parse(&text, &origin, &[]).expect("scene"), origin).expect("setup");
        ShellModel::new(&setup).expect("model")
    }

    /// `λ_max(M⁻¹K₀)` from the dense generalised eigenproblem.
    fn dense_max(m: &mut ShellModel) -> f64 {
        let n = m.dofs().dofs();
        let mass = m.reduced_masses();
        let mut k = DMatrix::zeros(n, n);
        let mut e = vec![0.0; n];
        let mut col = vec![0.0; n];
        for j in 0..n {
            e.fill(0.0);
            e[j] = 1.0;
            m.rest_stiffness_product(&e, &mut col);
            for i in 0..n {
                k[(i, j)] = col[i] / (mass[i] * mass[j]).sqrt();
            }
        }
        let k = (&k + k.transpose()) * 0.5;
        k.symmetric_eigenvalues().iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    #[test]
    fn lanczos_finds_the_highest_frequency_of_regular_and_irregular_meshes() {
        for mesh in [
            "[mesh.grid]\nsize = [0.3, 0.1]\nsegments = [12, 4]",
            "[mesh.delaunay-sheet]\nsize = [0.3, 0.3]\nedge = 0.04",
        ] {
            let mut m = model(mesh, "");
            let exact = dense_max(&mut m);
            let estimate = max_rest_eigenvalue(&mut m);
            eprintln!("λ_max: Lanczos {estimate:.6e}, dense {exact:.6e}");
            assert!(estimate <= exact * (1.0 + 1e-9), "a Ritz value never exceeds λ_max");
            assert!(estimate >= 0.99 * exact, "{estimate} vs {exact}");
        }
    }

    #[test]
    fn damped_limit_is_the_boundary_of_the_amplification_matrix() {
        // Spectral radius of [[1 − h²ω², h(1 − hc)], [−hω², 1 − hc]] (state x, v).
        let radius = |h: f64, w: f64, c: f64| {
            let (tr, det) = (2.0 - h * c - h * h * w * w, 1.0 - h * c);
            let disc = tr * tr / 4.0 - det;
            if disc >= 0.0 { (tr / 2.0).abs() + disc.sqrt() } else { det.abs().sqrt() }
        };
        for (w, c) in [(10.0, 0.0), (10.0, 3.0), (1e4, 50.0), (2.0, 30.0)] {
            let h = symplectic_euler_limit(w, c);
            assert!(radius(0.999 * h, w, c) <= 1.0 + 1e-12, "ω {w}, c {c}: stable below");
            assert!(radius(1.001 * h, w, c) > 1.0, "ω {w}, c {c}: unstable above");
        }
        assert!((symplectic_euler_limit(10.0, 0.0) - 0.2).abs() < 1e-15, "2/ω undamped");
    }

    #[test]
    fn limit_includes_rayleigh_damping() {
        let plain = stability_limit(&mut model("[mesh.grid]\nsize = [0.3, 0.1]\nsegments = [12, 4]", ""));
        let damped = stability_limit(&mut model(
            "[mesh.grid]\nsize = [0.3, 0.1]\nsegments = [12, 4]",
            "rayleigh_alpha = 5.0\nrayleigh_beta = 1e-4",
        ));
        assert_eq!(plain.omega_max, damped.omega_max);
        let c = 5.0 + 1e-4 * plain.omega_max.powi(2);
        assert!((damped.step - symplectic_euler_limit(plain.omega_max, c)).abs() < 1e-15);
        assert!(damped.step < plain.step && (plain.step - 2.0 / plain.omega_max).abs() < 1e-15);
    }
}
