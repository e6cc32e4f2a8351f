//! The signed dihedral angle of a hinge and its first and second derivatives.
//!
//! A hinge is four points `[a, b, c, d]`: the shared edge `a → b`, the wing `c` of the first
//! triangle `(a, b, c)` and the wing `d` of the second triangle `(b, a, d)` — both in mesh winding, as
//! [`crate::mesh::Hinge`] lists them. With the (unnormalised) normals `N₁ = (b − a) × (c − a)`,
//! `N₂ = (a − b) × (d − b)` and `ê = (b − a)/|b − a|`,
//!
//! `θ = atan2((N₁ × N₂)·ê, N₁·N₂)`,
//!
//! which is zero when flat, smooth through flat, positive when the wings fold towards `−N` (a
//! "mountain" seen from the normal side) and defined on `(−π, π]`. The atan2 form is scale invariant,
//! so the unnormalised normals can be used directly.
//!
//! Gradient (Bridson et al. 2003; Tamstorf & Grinspun 2013), with `hᵢ` the wing heights over the edge:
//! `∇_c θ = −n̂₁/h₁ = −|e| N₁/|N₁|²`, `∇_d θ = −|e| N₂/|N₂|²`,
//! `∇_b θ = −(s₁ ∇_c θ + s₂ ∇_d θ)`, `∇_a θ = −(∇_b θ + ∇_c θ + ∇_d θ)`,
//! where `s₁ = (c − a)·e/|e|²` and `s₂ = (d − a)·e/|e|²` locate the wings' feet along the edge.
//!
//! Hessian: the exact derivative of that gradient, derived here rather than copied (so the block form
//! differs from Tamstorf & Grinspun's presentation but is the same matrix), using
//! `∂N/∂p = [r − q]×`, `∂N/∂q = [p − r]×`, `∂N/∂r = [q − p]×` for a triangle `(p, q, r)`:
//! `∂(∇_c θ)/∂x_k = −(1/|N₁|²) (N₁ ⊗ ∂|e|/∂x_k + |e| (I − 2 n̂₁n̂₁ᵀ) ∂N₁/∂x_k)` and likewise for `d`;
//! `∂(∇_b θ)/∂x_k = −(∇_c θ ⊗ ∂s₁/∂x_k + s₁ ∂(∇_c θ)/∂x_k + (same for d))`; the `a` rows follow from
//! translation invariance. Only the lower blocks are computed (`angle_hessian_lower`); the upper ones
//! are their transposes, so the matrix is exactly symmetric. It is verified against central finite
//! differences for random configurations, near flat, and for |θ| up to 3.

use glam::{DMat3, DVec3};

use crate::linalg::real::{Real, V3, add, cross, dot, neg, scale, sub};

/// `u vᵀ`.
pub(crate) fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// The cross-product matrix `[v]×`, so that `[v]× w = v × w`.
pub(crate) fn cross_matrix(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

/// The signed dihedral angle θ of the hinge `[a, b, c, d]` (see the module docs), radians.
pub fn angle(x: &[DVec3; 4]) -> f64 {
    let [a, b, c, d] = *x;
    let e = b - a;
    let n1 = e.cross(c - a);
    let n2 = (a - b).cross(d - b);
    n1.cross(n2).dot(e / e.length()).atan2(n1.dot(n2))
}

/// The angle as its (scaled) sine and cosine, `(N₁ × N₂)·ê` and `N₁·N₂` (`θ = atan2` of them), and
/// its gradient: what a caller that takes the arctangent its own way needs. Written once for numbers
/// and SIMD lanes ([`Real`]).
#[inline(always)]
pub fn angle_parts<N: Real>(x: &[V3<N>; 4]) -> (N, N, [V3<N>; 4]) {
    let [a, b, c, d] = *x;
    let e = sub(b, a);
    let l2 = dot(e, e);
    let l = l2.sqrt();
    // One division for the three that share `|e|²` (they are the hot loop's slowest instructions).
    let inverse_l2 = l2.constant(1.0) / l2;
    let (ca, da) = (sub(c, a), sub(d, a));
    let n1 = cross(e, ca);
    let n2 = cross(sub(a, b), sub(d, b));
    let gc = scale(n1, -l / dot(n1, n1));
    let gd = scale(n2, -l / dot(n2, n2));
    let s1 = dot(ca, e) * inverse_l2;
    let s2 = dot(da, e) * inverse_l2;
    let gb = neg(add(scale(gc, s1), scale(gd, s2)));
    let ga = neg(add(add(gb, gc), gd));
    (dot(cross(n1, n2), e) * (l * inverse_l2), dot(n1, n2), [ga, gb, gc, gd])
}

/// The angle and its gradient.
pub fn angle_gradient(x: &[DVec3; 4]) -> (f64, [DVec3; 4]) {
    let (sine, cosine, g) = angle_parts(&x.map(|p| p.to_array()));
    (sine.atan2(cosine), g.map(DVec3::from_array))
}

/// Position of block `(p, q)`, `p ≥ q`, in the row-wise packed lower triangle of a 4 × 4 block matrix.
pub(crate) const fn lower_index(p: usize, q: usize) -> usize {
    p * (p + 1) / 2 + q
}

/// The angle, its gradient and the ten lower blocks `∂²θ/∂x_p∂x_q` (`p ≥ q`, packed by
/// [`lower_index`]), computing only what they need: rows `c` and `d` are the base blocks (`c` does not
/// move `N₂` nor `d` move `N₁`, so `(d, c)` is zero), row `b` follows from them for columns `a, b`,
/// and row `a` only for column `a`.
pub(crate) fn angle_hessian_lower(x: &[DVec3; 4]) -> (f64, [DVec3; 4], [DMat3; 10]) {
    let (theta, [ga, gb, gc, gd]) = angle_gradient(x);
    let [a, b, c, d] = *x;
    let e = b - a;
    let l2 = e.length_squared();
    let l = l2.sqrt();
    let eh = e / l;
    let n1 = e.cross(c - a);
    let n2 = (a - b).cross(d - b);
    let q1 = n1.length_squared();
    let q2 = n2.length_squared();
    let s1 = (c - a).dot(e) / l2;
    let s2 = (d - a).dot(e) / l2;

    // ∂s/∂x_k for a wing point w, s = (w − a)·e/|e|²: for k = a, b (and ∂s/∂w = e/|e|², unused here).
    let ds = |w: DVec3, s: f64| {
        let db = ((w - a) - e * (2.0 * s)) / l2;
        [-(db + e / l2), db]
    };
    let ds1 = ds(c, s1);
    let ds2 = ds(d, s2);
    let (u1, u2) = (n1 / q1.sqrt(), n2 / q2.sqrt());
    let (m1, m2) = (n1 / q1, n2 / q2);
    // (I − 2ûûᵀ)[v]× = [v]× − 2û(û × v)ᵀ.
    let reflect_cross = |u: DVec3, v: DVec3| cross_matrix(v) - outer(u * 2.0, u.cross(v));
    let (r1, r2) = (l / q1, l / q2);
    // ∂(∇_c θ)/∂x_k = −(N₁/|N₁|² ⊗ ∂|e|/∂x_k + |e|/|N₁|² (I − 2n̂₁n̂₁ᵀ) ∂N₁/∂x_k), with ∂|e|/∂x_a = −ê,
    // ∂|e|/∂x_b = ê, ∂N₁/∂x_{a,b,c} = [c − b]×, [a − c]×, [e]×; likewise for d with N₂.
    let hc = [
        -(outer(m1, -eh) + reflect_cross(u1, c - b) * r1),
        -(outer(m1, eh) + reflect_cross(u1, a - c) * r1),
        -(reflect_cross(u1, e) * r1),
    ];
    let hd = [
        -(outer(m2, -eh) + reflect_cross(u2, b - d) * r2),
        -(outer(m2, eh) + reflect_cross(u2, d - a) * r2),
        -(reflect_cross(u2, -e) * r2),
    ];
    let hb = |k: usize| -(outer(gc, ds1[k]) + hc[k] * s1 + outer(gd, ds2[k]) + hd[k] * s2);
    let (hba, hbb) = (hb(0), hb(1));
    let haa = -(hba + hc[0] + hd[0]);
    let lower = [haa, hba, hbb, hc[0], hc[1], hc[2], hd[0], hd[1], DMat3::ZERO, hd[2]];
    (theta, [ga, gb, gc, gd], lower)
}

/// `θ − θ̄` wrapped to `[−π, π)`, so a rest angle near ±π does not jump by 2π.
pub fn wrapped_difference(theta: f64, rest: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let d = theta - rest;
    // Both angles lie in [−π, π], so one turn at most brings the difference back (and this is exact,
    // where `rem_euclid` would round).
    if d >= PI {
        d - TAU
    } else if d < -PI {
        d + TAU
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::fd::Rng;

    /// The dihedral angle with its gradient and Hessian.
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct AngleDerivatives {
        /// The signed angle θ, radians, in (−π, π].
        theta: f64,
        /// `∂θ/∂x_p` for the four hinge points `[a, b, c, d]`.
        grad: [DVec3; 4],
        /// `hess[p][q] = ∂²θ/∂x_p∂x_q` (row block p, column block q).
        hess: [[DMat3; 4]; 4],
    }

    /// The angle, its gradient and its Hessian (exactly symmetric: the upper blocks are the transposes
    /// of `angle_hessian_lower`'s).
    fn angle_hessian(x: &[DVec3; 4]) -> AngleDerivatives {
        let (theta, grad, lower) = angle_hessian_lower(x);
        let mut hess = [[DMat3::ZERO; 4]; 4];
        for p in 0..4 {
            for q in 0..=p {
                hess[p][q] = lower[lower_index(p, q)];
                hess[q][p] = lower[lower_index(p, q)].transpose();
            }
        }
        AngleDerivatives { theta, grad, hess }
    }

    #[test]
    fn cross_matrix_is_the_cross_product() {
        let (a, b) = (DVec3::new(0.3, -1.2, 2.0), DVec3::new(-0.7, 0.4, 1.1));
        assert!((cross_matrix(a) * b - a.cross(b)).length() < 1e-15);
    }

    /// A hinge along x with wings at fold angles chosen so that θ ≈ `theta`, then jittered.
    fn hinge_at(theta: f64, rng: &mut Rng, jitter: f64) -> [DVec3; 4] {
        let a = DVec3::new(-0.4, 0.0, 0.0);
        let b = DVec3::new(0.6, 0.0, 0.0);
        // First wing in the y=0 plane on the −z... choose so the flat hinge is consistently oriented:
        // N₁ = e × (c − a) must equal N₂ = (a − b) × (d − b) when flat.
        let c = DVec3::new(0.1, 0.0, -0.8);
        let r = 0.9;
        let d0 = DVec3::new(0.2, 0.0, r);
        // Rotate d about the edge (x axis) by theta (sign fixed by checking below).
        let (s, co) = theta.sin_cos();
        let d = DVec3::new(d0.x, -d0.z * s, d0.z * co);
        let mut x = [a, b, c, d];
        for p in &mut x {
            *p += rng.vec() * jitter;
        }
        x
    }

    fn max_abs(v: &[f64]) -> f64 {
        v.iter().fold(0.0, |m, x| m.max(x.abs()))
    }

    fn check_fd(x: [DVec3; 4]) -> (f64, f64, f64) {
        let h = 1e-6;
        let an = angle_hessian(&x);
        let (t2, g2) = angle_gradient(&x);
        assert_eq!(t2, an.theta);
        assert_eq!(g2, an.grad);
        assert!((angle(&x) - an.theta).abs() < 1e-15);
        let mut g_err = Vec::new();
        let mut g_ref = Vec::new();
        let mut h_err = Vec::new();
        let mut h_ref = Vec::new();
        for p in 0..4 {
            for i in 0..3 {
                let mut xp = x;
                let mut xm = x;
                xp[p][i] += h;
                xm[p][i] -= h;
                let fd = (angle(&xp) - angle(&xm)) / (2.0 * h);
                g_err.push(fd - an.grad[p][i]);
                g_ref.push(an.grad[p][i]);
                let (_, gp) = angle_gradient(&xp);
                let (_, gm) = angle_gradient(&xm);
                for q in 0..4 {
                    for j in 0..3 {
                        let fd = (gp[q][j] - gm[q][j]) / (2.0 * h);
                        // Column i of block (q, p) is ∂(∇_q θ)/∂x_{p,i}.
                        let an_v = an.hess[q][p].col(i)[j];
                        h_err.push(fd - an_v);
                        h_ref.push(an_v);
                    }
                }
            }
        }
        let mut asym: f64 = 0.0;
        for p in 0..4 {
            for q in 0..4 {
                asym = asym.max(max_abs(&(an.hess[p][q] - an.hess[q][p].transpose()).to_cols_array()));
            }
        }
        (max_abs(&g_err) / max_abs(&g_ref), max_abs(&h_err) / max_abs(&h_ref), asym / max_abs(&h_ref))
    }

    #[test]
    fn angle_sign_and_value_of_a_constructed_fold() {
        let mut rng = Rng(1);
        for &t in &[-3.0, -1.0, -0.2, 0.0, 0.3, 1.2, 2.5, 3.0] {
            let x = hinge_at(t, &mut rng, 0.0);
            assert!((angle(&x) - t).abs() < 1e-12, "θ = {} for a fold of {t}", angle(&x));
        }
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let mut rng = Rng(0x9e3779b97f4a7c15);
        let mut worst = (0.0f64, 0.0f64, 0.0f64);
        // Near flat, moderate and large folds up to |θ| ≈ 3, each jittered.
        for &t in &[0.0, 1e-7, -1e-4, 0.05, -0.5, 1.0, -1.7, 2.2, -2.6, 3.0, -3.0] {
            for _ in 0..4 {
                let x = hinge_at(t, &mut rng, 0.15);
                let (g, h, s) = check_fd(x);
                worst = (worst.0.max(g), worst.1.max(h), worst.2.max(s));
            }
        }
        // Fully random, non-degenerate configurations.
        for _ in 0..40 {
            let x = [rng.vec(), rng.vec(), rng.vec(), rng.vec()];
            let e = (x[1] - x[0]).length();
            let h1 = (x[1] - x[0]).cross(x[2] - x[0]).length() / e;
            let h2 = (x[1] - x[0]).cross(x[3] - x[0]).length() / e;
            if e < 0.2 || h1 < 0.2 || h2 < 0.2 || angle(&x).abs() > 3.0 {
                continue;
            }
            let (g, h, s) = check_fd(x);
            worst = (worst.0.max(g), worst.1.max(h), worst.2.max(s));
        }
        eprintln!(
            "hinge angle FD relative errors: gradient {:.2e}, Hessian {:.2e}, asymmetry {:.2e}",
            worst.0, worst.1, worst.2
        );
        assert!(worst.0 < 1e-6, "gradient relative error {:e}", worst.0);
        assert!(worst.1 < 1e-6, "Hessian relative error {:e}", worst.1);
        assert!(worst.2 < 1e-12, "Hessian asymmetry {:e}", worst.2);
    }

    #[test]
    fn invariant_under_rigid_motion_and_wraps() {
        let mut rng = Rng(5);
        let x = hinge_at(1.3, &mut rng, 0.1);
        let q = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 2.1);
        let y = x.map(|p| q * p + DVec3::new(3.0, -1.0, 0.5));
        assert!((angle(&x) - angle(&y)).abs() < 1e-13);
        assert!((wrapped_difference(3.1, -3.1) - (6.2 - std::f64::consts::TAU)).abs() < 1e-15);
        assert!((wrapped_difference(-3.1, 3.1) - (std::f64::consts::TAU - 6.2)).abs() < 1e-15);
        assert!((wrapped_difference(0.5, 0.2) - 0.3).abs() < 1e-15);
    }
}
