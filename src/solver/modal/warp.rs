//! Modal warping's closed forms: the rotation `R = exp([w]×)` and the path-independent warped
//! displacement `u = (∫₀¹ exp(s[w]×) ds) Φ q` (Choi & Ko 2005), with Taylor series near `θ = 0`.
//!
//! With `θ = |w|`: `exp([w]×) = I + a [w]× + b [w]×²` and
//! `∫₀¹ exp(s[w]×) ds = I + b [w]× + c [w]×²`, where `a = sinθ/θ`, `b = (1 − cosθ)/θ²`,
//! `c = (θ − sinθ)/θ³`. All three are smooth for every θ (no singularity at π or 2π), so a node
//! twisted past π neither flips nor explodes: rotation vectors are only ever built from `q`, never
//! extracted from a rotation matrix.

use glam::{DMat3, DVec3};

use super::rotation::cross_matrix;

/// Below this angle the coefficient series are used (their truncation error there is < 1e-17).
const SERIES_BELOW: f64 = 0.1;

/// `(sinθ/θ, (1 − cosθ)/θ², (θ − sinθ)/θ³)` for `θ² = theta2`.
fn coefficients(theta2: f64) -> (f64, f64, f64) {
    if theta2 < SERIES_BELOW * SERIES_BELOW { series(theta2) } else { closed(theta2) }
}

/// Taylor series of the coefficients in `t = θ²`, to `θ⁸`.
fn series(t: f64) -> (f64, f64, f64) {
    let a = 1.0 - t / 6.0 * (1.0 - t / 20.0 * (1.0 - t / 42.0 * (1.0 - t / 72.0)));
    let b = 0.5 * (1.0 - t / 12.0 * (1.0 - t / 30.0 * (1.0 - t / 56.0 * (1.0 - t / 90.0))));
    let c = (1.0 - t / 20.0 * (1.0 - t / 42.0 * (1.0 - t / 72.0 * (1.0 - t / 110.0)))) / 6.0;
    (a, b, c)
}

/// The coefficients in closed form (accurate away from `θ = 0`).
fn closed(theta2: f64) -> (f64, f64, f64) {
    let th = theta2.sqrt();
    let (s, half) = (th.sin(), (0.5 * th).sin());
    (s / th, 2.0 * half * half / theta2, (th - s) / (theta2 * th))
}

/// The rotation `exp([w]×)` (Rodrigues).
pub fn rotation(w: DVec3) -> DMat3 {
    let (a, b, _) = coefficients(w.length_squared());
    let k = cross_matrix(w);
    DMat3::IDENTITY + k * a + k * k * b
}

/// The warping operator `∫₀¹ exp(s[w]×) ds`, applied to the linear modal displacement.
pub fn warp_operator(w: DVec3) -> DMat3 {
    let (_, b, c) = coefficients(w.length_squared());
    let k = cross_matrix(w);
    DMat3::IDENTITY + k * b + k * k * c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DMat3, b: DMat3, tol: f64) -> bool {
        (0..3).all(|c| (a.col(c) - b.col(c)).length() <= tol)
    }

    #[test]
    fn rotation_is_orthonormal_and_rotates_about_its_axis() {
        for w in [DVec3::new(0.3, -0.2, 0.9), DVec3::new(0.0, 3.0, 0.0), DVec3::new(5.0, 1.0, -2.0), DVec3::splat(1e-9)]
        {
            let r = rotation(w);
            assert!(close(r.transpose() * r, DMat3::IDENTITY, 1e-14));
            assert!((r.determinant() - 1.0).abs() < 1e-14);
            assert!((r * w - w).length() < 1e-14 * w.length().max(1.0));
            let q = glam::DQuat::from_scaled_axis(w);
            assert!(close(r, DMat3::from_quat(q), 1e-13), "matches glam for {w}");
        }
    }

    #[test]
    fn series_and_closed_form_agree_at_the_switch() {
        // No jump: both branches give the same coefficients where they meet (and a bit beyond).
        for theta in [0.5 * SERIES_BELOW, SERIES_BELOW, 1.5 * SERIES_BELOW] {
            let (s, c) = (series(theta * theta), closed(theta * theta));
            assert!((s.0 - c.0).abs() < 1e-15 && (s.1 - c.1).abs() < 1e-15, "θ = {theta}: {s:?} vs {c:?}");
            // The closed form of (θ − sinθ)/θ³ loses ~6ε/θ² to cancellation: the reason for the series.
            assert!((s.2 - c.2).abs() < 1e-12 * s.2, "θ = {theta}: {s:?} vs {c:?}");
        }
    }

    #[test]
    fn warp_operator_is_the_average_rotation_along_the_path() {
        // Midpoint-rule quadrature of ∫₀¹ exp(s[w]×) ds, including past π.
        for w in [DVec3::new(0.2, 0.1, -0.05), DVec3::new(0.0, 0.0, 4.0), DVec3::new(1.0, 2.0, 6.0)] {
            let n = 4000;
            let avg =
                (0..n).fold(DMat3::ZERO, |acc, i| acc + rotation(w * ((i as f64 + 0.5) / n as f64))) * (1.0 / n as f64);
            assert!(close(warp_operator(w), avg, 1e-6 * w.length_squared().max(1.0)), "w = {w}");
        }
    }

    #[test]
    fn a_full_turn_of_a_rod_closes_a_circle() {
        // A rod along x with uniform curvature: Φq = x̂ per unit length and w(s) = s·2π ẑ.
        // Integrating the warped increments reproduces the bent rod: the tip returns to the start.
        let n = 2000;
        let mut tip = DVec3::ZERO;
        for i in 0..n {
            let s = (i as f64 + 0.5) / n as f64;
            tip += rotation(DVec3::Z * (2.0 * std::f64::consts::PI * s)) * DVec3::X / n as f64;
        }
        assert!(tip.length() < 1e-5, "closed circle: {tip}");
        // And the closed-form operator at the tip gives the chord of that arc from the base: zero.
        assert!((warp_operator(DVec3::Z * 2.0 * std::f64::consts::PI) * DVec3::X).length() < 1e-15);
    }
}
