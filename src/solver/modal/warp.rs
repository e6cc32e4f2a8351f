//! Modal warping's closed forms: the rotation `R = exp([w]×)` and the path-independent warped
//! displacement `u = (∫₀¹ exp(s[w]×) ds) Φ q` (Choi & Ko 2005), with Taylor series near `θ = 0`.
//!
//! With `θ = |w|`: `exp([w]×) = I + a [w]× + b [w]×²` and
//! `∫₀¹ exp(s[w]×) ds = I + b [w]× + c [w]×²`, where `a = sinθ/θ`, `b = (1 − cosθ)/θ²`,
//! `c = (θ − sinθ)/θ³`. All three are smooth for every θ (no singularity at π or 2π), so a node
//! twisted past π neither flips nor explodes: rotation vectors are only ever built from `q`, never
//! extracted from a rotation matrix.
//!
//! ## What the closed form does to a bent shell's area
//!
//! The closed form is exact for locally rigid motion, and a bent shell's rotation varies in space, so
//! it does not keep lengths. To second order, for a normal deflection `w` of a flat shell (LMA:
//! `u = w n`, rotation `θ = ∇w × n`), it adds the in-plane shift `½ θ × (w n) = −½ w ∇w`, whose
//! divergence changes the area by `−½(|∇w|² + w Δw)`, on top of the `+½|∇w|²` that `w n` itself
//! costs (LMA's whole change). So MWTS changes the area by `−½ ∫ w Δw` where LMA changes it by
//! `+½ ∫ |∇w|²`: a ratio `−∫ w Δw / ∫ |∇w|²` fixed by the deflection's shape, independent of load and
//! stiffness. On a cantilever strip (`w = w(x)`, `∫ w w″ = w(L) w′(L) − ∫ w′²`) it is −1/6 for the
//! uniform-load deflection and −0.185 for the first mode's shape; the discrete cantilever scene,
//! whose strip also sags slightly across its width, measures −0.20 at small loads, falling to −0.05
//! at large rotations (`tests/modal_vs_ds.rs` checks the centreline's length change against this to
//! 1%). So MWTS's area change is about a fifth of LMA's, and the issue's "below 1% where LMA's
//! exceeds 10%" cannot hold for this closed form: the exact inextensible displacement integrates the
//! rotation along the material from the clamp (`∫₀ˣ (exp([θ(t)]×) − I) x̂ dt`), which no per-vertex
//! function of `(Φ_i q, Ψ_i q)` reproduces.

use glam::{DMat3, DVec3};

use crate::energy::hinge::cross_matrix;

/// Below this angle (`θ < π`) the coefficients are evaluated as polynomials in `θ²` (no square root,
/// no trigonometry: this is the per-vertex hot path of every MWTS step); above it in closed form.
const SERIES_BELOW: f64 = std::f64::consts::PI;

/// Terms of the series: at `θ = π` the last one is below 1e-19.
const TERMS: usize = 16;

/// `(−1)^k / (2k + offset)!` for `k < TERMS`.
const fn taylor(offset: u32) -> [f64; TERMS] {
    let mut out = [0.0; TERMS];
    let mut k = 0;
    while k < TERMS {
        let mut f = 1.0;
        let mut i = 2;
        while i <= 2 * k as u32 + offset {
            f *= i as f64;
            i += 1;
        }
        out[k] = if k % 2 == 0 { 1.0 / f } else { -1.0 / f };
        k += 1;
    }
    out
}

/// Taylor coefficients of `b = (1 − cosθ)/θ²` in `t = θ²`, lowest degree first.
pub(crate) const B_SERIES: [f64; TERMS] = taylor(2);
/// Taylor coefficients of `c = (θ − sinθ)/θ³` in `t = θ²`, lowest degree first.
pub(crate) const C_SERIES: [f64; TERMS] = taylor(3);

/// Terms of the series that `t = θ² ≤ top` needs for the first omitted one to be below 1e-19
/// relative: 7 below θ = 1/4, 10 below θ = 1, 16 below π. (At or above π: [`closed`] instead.)
pub(crate) fn series_terms(top: f64) -> usize {
    if top < 0.0625 {
        7
    } else if top < 1.0 {
        10
    } else {
        TERMS
    }
}

/// Whether `t = θ²` is past the series (`θ ≥ π`), where [`closed`] takes over.
pub(crate) fn past_series(t: f64) -> bool {
    t >= SERIES_BELOW * SERIES_BELOW
}

/// `[sinθ/θ, (1 − cosθ)/θ², (θ − sinθ)/θ³]` for `θ² = theta2`: the series below π, else the
/// closed form. Only two series are summed: `sinθ/θ` is `1 − θ² · (θ − sinθ)/θ³` (exact; `θ²·c ≤ 1`
/// below `π`, so its absolute error stays at round-off).
pub fn coefficients(theta2: f64) -> [f64; 3] {
    if past_series(theta2) {
        return closed(theta2);
    }
    let n = series_terms(theta2);
    let horner = |series: &[f64]| series.iter().rev().fold(0.0, |acc, &ck| acc * theta2 + ck);
    let (b, c) = (horner(&B_SERIES[..n]), horner(&C_SERIES[..n]));
    [1.0 - theta2 * c, b, c]
}

/// `[db/dt, dc/dt]` for `t = θ² = theta2`, the derivatives of the coefficients `b` and `c` of
/// [`coefficients`] (the series below π, else the closed forms
/// `db/dt = (θ sinθ − 2(1 − cosθ)) / 2θ⁴`, `dc/dt = (θ(1 − cosθ) − 3(θ − sinθ)) / 2θ⁵`).
pub fn derivatives(theta2: f64) -> [f64; 2] {
    if past_series(theta2) {
        let th = theta2.sqrt();
        let (s, c) = th.sin_cos();
        let t2 = theta2 * theta2;
        return [(th * s - 2.0 * (1.0 - c)) / (2.0 * t2), (th * (1.0 - c) - 3.0 * (th - s)) / (2.0 * t2 * th)];
    }
    let derivative = |series: &[f64]| (1..series.len()).rev().fold(0.0, |acc, k| acc * theta2 + k as f64 * series[k]);
    [derivative(&B_SERIES), derivative(&C_SERIES)]
}

/// `∂/∂w [(∫₀¹ exp(s[w]×) ds) v]` at fixed `v`: how the warped displacement of a vertex moves with
/// its rotation vector (`mwts`'s position drags need it beside `∂/∂v`, which is the warp operator).
/// With `u = v + b (w × v) + c (w × (w × v))`, `t = |w|²`:
/// `∂u/∂w = 2b′ (w × v) wᵀ − b [v]× + 2c′ (w × (w × v)) wᵀ − c ([w × v]× + [w]× [v]×)`.
pub fn warp_jacobian(w: DVec3, v: DVec3) -> DMat3 {
    let t = w.length_squared();
    let [_, b, c] = coefficients(t);
    let [db, dc] = derivatives(t);
    let (wv, wwv) = (w.cross(v), w.cross(w.cross(v)));
    let outer = |a: DVec3| DMat3::from_cols(a * w.x, a * w.y, a * w.z);
    outer(wv) * (2.0 * db) - cross_matrix(v) * b + outer(wwv) * (2.0 * dc)
        - (cross_matrix(wv) + cross_matrix(w) * cross_matrix(v)) * c
}

/// The coefficients in closed form (accurate away from `θ = 0`).
pub(crate) fn closed(theta2: f64) -> [f64; 3] {
    let th = theta2.sqrt();
    let (s, half) = (th.sin(), (0.5 * th).sin());
    [s / th, 2.0 * half * half / theta2, (th - s) / (theta2 * th)]
}

/// `(∫₀¹ exp(s[w]×) ds) v` given `coefficients(|w|²)`: `v + b (w × v) + c (w × (w × v))`.
pub fn warp(w: DVec3, [_, b, c]: [f64; 3], v: DVec3) -> DVec3 {
    let wv = w.cross(v);
    v + wv * b + w.cross(wv) * c
}

/// The rotation `exp([w]×)` (Rodrigues).
pub fn rotation(w: DVec3) -> DMat3 {
    let [a, b, _] = coefficients(w.length_squared());
    let k = cross_matrix(w);
    DMat3::IDENTITY + k * a + k * k * b
}

/// The warping operator `∫₀¹ exp(s[w]×) ds`, applied to the linear modal displacement.
pub fn warp_operator(w: DVec3) -> DMat3 {
    let [_, b, c] = coefficients(w.length_squared());
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
        // No jump: on either side of each switch in the number of terms (θ = 1/4, 1) and of the switch
        // to the closed form (θ = π) the series agrees with the closed form.
        for theta in [0.249, 0.251, 0.3, 0.999, 1.001, 0.5 * SERIES_BELOW, 0.999 * SERIES_BELOW, SERIES_BELOW] {
            let (s, c) = (coefficients(theta * theta), closed(theta * theta));
            for k in 0..3 {
                assert!((s[k] - c[k]).abs() < 1e-15, "θ = {theta}, coefficient {k}: {s:?} vs {c:?}");
            }
        }
        // And 16 terms are still accurate a bit beyond π (the switch is not at the series' edge).
        let t = (1.1 * SERIES_BELOW).powi(2);
        let sixteen = |series: &[f64]| series.iter().rev().fold(0.0, |acc, &ck| acc * t + ck);
        assert!((sixteen(&B_SERIES) - closed(t)[1]).abs() < 1e-15 && (sixteen(&C_SERIES) - closed(t)[2]).abs() < 1e-15);
        // Near zero the closed form of (θ − sinθ)/θ³ loses ~6ε/θ² to cancellation; the series does not.
        let tiny = 1e-4;
        assert!((coefficients(tiny * tiny)[2] - (1.0 / 6.0 - tiny * tiny / 120.0)).abs() < 1e-17);
        assert_eq!(coefficients(0.0), [1.0, 0.5, 1.0 / 6.0]);
    }

    #[test]
    fn the_warps_jacobian_matches_central_differences() {
        // Small, moderate, past π and past 2π, with the series/closed switch crossed by the differences.
        let v = DVec3::new(0.2, 0.9, -0.4);
        for w in [
            DVec3::new(1e-3, -2e-3, 5e-4),
            DVec3::new(0.7, -2.1, 1.3),
            DVec3::new(0.0, 0.0, 0.999 * SERIES_BELOW),
            DVec3::new(4.0, 1.0, -5.0),
        ] {
            let analytic = warp_jacobian(w, v);
            for a in 0..3 {
                let mut e = DVec3::ZERO;
                e[a] = 1e-6 * w.length().max(1.0);
                let fd = (warp_operator(w + e) * v - warp_operator(w - e) * v) / (2.0 * e[a]);
                let err = (fd - analytic.col(a)).length() / analytic.col(a).length().max(1e-3);
                assert!(err < 1e-6, "w = {w}, column {a}: {} vs {fd} (relative {err:.1e})", analytic.col(a));
            }
        }
        // The series' derivatives agree with the closed forms where both are accurate.
        for theta in [0.5, 1.5, 0.999 * SERIES_BELOW] {
            let t = theta * theta;
            let (th, (s, c)) = (theta, theta.sin_cos());
            let closed =
                [(th * s - 2.0 * (1.0 - c)) / (2.0 * t * t), (th * (1.0 - c) - 3.0 * (th - s)) / (2.0 * t * t * th)];
            let series = derivatives(t);
            assert!((series[0] - closed[0]).abs() < 1e-13 && (series[1] - closed[1]).abs() < 1e-13, "{theta}");
        }
    }

    #[test]
    fn vector_form_matches_the_matrix() {
        let (w, f) = (DVec3::new(0.7, -2.1, 1.3), DVec3::new(0.2, 0.9, -0.4));
        let k = coefficients(w.length_squared());
        assert!((warp(w, k, f) - warp_operator(w) * f).length() < 1e-14);
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
