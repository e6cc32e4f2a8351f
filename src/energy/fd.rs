//! The finite-difference check every energy's tests share (with the deterministic generator their
//! random configurations come from, [`Rng`]).
//!
//! For positions `x` (n points), the check perturbs each coordinate by `±H` and compares the central
//! differences `(E(x + H eᵢ) − E(x − H eᵢ)) / 2H` with the analytic gradient, and the central
//! differences of the gradient with the analytic Hessian (dense, `3n × 3n`, row `3w + j`, column
//! `3v + i` = `∂²E/∂x_{w,j}∂x_{v,i}`). Each error is the largest absolute difference relative to the
//! largest entry of the analytic quantity, in f64; the suite's bound is `1e-6`.

use glam::DVec3;

/// The perturbation of a coordinate.
pub const H: f64 = 1e-6;

pub use crate::linalg::random::Rng;

/// The relative errors of the central differences of `value` against `gradient` at `x`, and of
/// those of `gradient` against `hessian` (0 when there is none).
pub fn errors(
    x: &[DVec3],
    value: impl Fn(&[DVec3]) -> f64,
    gradient: impl Fn(&[DVec3]) -> Vec<DVec3>,
    hessian: Option<&[f64]>,
) -> (f64, f64) {
    let n = 3 * x.len();
    let g = gradient(x);
    let (mut ge, mut gr, mut he, mut hr) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for v in 0..x.len() {
        for i in 0..3 {
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[v][i] += H;
            xm[v][i] -= H;
            ge = ge.max(((value(&xp) - value(&xm)) / (2.0 * H) - g[v][i]).abs());
            gr = gr.max(g[v][i].abs());
            let Some(hessian) = hessian else { continue };
            let (gp, gm) = (gradient(&xp), gradient(&xm));
            for w in 0..x.len() {
                for j in 0..3 {
                    let exact = hessian[(3 * w + j) * n + 3 * v + i];
                    he = he.max(((gp[w][j] - gm[w][j]) / (2.0 * H) - exact).abs());
                    hr = hr.max(exact.abs());
                }
            }
        }
    }
    (ge / gr, if hessian.is_some() { he / hr } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wrong_derivative_is_caught_and_a_right_one_passes() {
        // E = Σ |x|⁴/4: ∇E = |x|² x, ∇²E = |x|² I + 2 x xᵀ per point.
        let value = |x: &[DVec3]| x.iter().map(|p| p.length_squared().powi(2) / 4.0).sum::<f64>();
        let gradient = |x: &[DVec3]| x.iter().map(|p| p.length_squared() * *p).collect::<Vec<_>>();
        let mut rng = Rng(5);
        let x = [rng.vec(), rng.vec()];
        let mut hessian = vec![0.0; 36];
        for (v, p) in x.iter().enumerate() {
            for (i, j) in (0..3).flat_map(|i| (0..3).map(move |j| (i, j))) {
                let delta = if i == j { p.length_squared() } else { 0.0 };
                hessian[(3 * v + j) * 6 + 3 * v + i] = delta + 2.0 * p[i] * p[j];
            }
        }
        let (g, h) = errors(&x, value, gradient, Some(&hessian));
        assert!(g < 1e-8 && h < 1e-8, "{g:e} {h:e}");
        hessian[7] += 1e-3;
        assert!(errors(&x, value, gradient, Some(&hessian)).1 > 1e-4);
        let half = |x: &[DVec3]| gradient(x).into_iter().map(|g| 0.5 * g).collect::<Vec<_>>();
        assert!(errors(&x, value, half, None).0 > 0.1);
    }
}
