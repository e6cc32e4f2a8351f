//! Constraint functions `C(p)` and their exact gradients `∇C`, for position-based dynamics (Müller et al. 2007;
//! XPBD: Macklin, Müller & Chentanez 2016):
//! edge length, dihedral bending (the shell's signed atan2 hinge angle, smooth through flat, rest
//! angle wrapped), the enclosed volume of a closed mesh, and the signed distance of a point from a
//! triangle's plane (self-collision). Every gradient is checked against central finite differences.

use glam::DVec3;

use super::hinge;
use crate::linalg::real::{self, Real, V3};

/// Stretch: `C = |p₁ − p₂| − l₀`, with `∇₁C = n̂ = −∇₂C` (`n̂` the unit edge direction; zero-length
/// edges give a zero gradient).
pub fn stretch(p1: DVec3, p2: DVec3, rest: f64) -> (f64, [DVec3; 2]) {
    let (c, n) = stretch_of(p1.to_array(), p2.to_array(), rest);
    let n = DVec3::from_array(n);
    (c, [n, -n])
}

/// [`stretch`] for numbers or SIMD lanes: `C` and `∇₁C`.
#[inline(always)]
pub fn stretch_of<N: Real>(p1: V3<N>, p2: V3<N>, rest: N) -> (N, V3<N>) {
    let d = real::sub(p1, p2);
    let l = real::dot(d, d).sqrt();
    let zero = l.constant(0.0);
    let n = real::scale(d, N::select(zero.less(l), l.constant(1.0) / l, zero));
    (l - rest, n)
}

/// A rest angle `θ̄` as its cosine and sine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestAngle {
    /// `cos θ̄`.
    pub cos: f64,
    /// `sin θ̄`.
    pub sin: f64,
}

impl RestAngle {
    /// The rest angle `theta`, radians.
    pub fn new(theta: f64) -> Self {
        Self { cos: theta.cos(), sin: theta.sin() }
    }
}

/// Bending of the hinge `[a, b, c, d]` (shared edge `a → b`, wings `c`, `d`, as [`crate::mesh::Hinge`]
/// lists them): `C = θ − θ̄` wrapped to `(−π, π]`, `θ` the signed dihedral angle of [`hinge::angle`].
/// Unlike `acos(n̂₁·n̂₂)`, whose gradient is singular at 0 and π, this is smooth through flat.
pub fn bending(x: &[DVec3; 4], rest: RestAngle) -> (f64, [DVec3; 4]) {
    let (c, g) = bending_of(&x.map(|p| p.to_array()), rest.cos, rest.sin);
    (c, g.map(DVec3::from_array))
}

/// [`bending`] for numbers or SIMD lanes, the rest angle given by its cosine and sine. The difference
/// is one arctangent of the hinge's (sine, cosine) turned back by `θ̄`, which wraps it by itself.
#[inline(always)]
pub fn bending_of<N: Real>(x: &[V3<N>; 4], rest_cos: N, rest_sin: N) -> (N, [V3<N>; 4]) {
    let (s, c, g) = hinge::angle_parts(x);
    (atan2(s * rest_cos - c * rest_sin, c * rest_cos + s * rest_sin), g)
}

/// `atan2(y, x)` in `(−π, π]` to within a few units in the last place, in arithmetic a vector unit
/// does (no table, no branch but selects): the ratio of the smaller to the larger magnitude, brought
/// to `|z| ≤ tan(π/8)` within the same division (past `tan(π/8)`, `atan(lo/hi) = π/4 +
/// atan((lo − hi)/(lo + hi))`), halved [`Real::ATAN_HALVINGS`] times by `atan z = 2 atan(z / (1 +
/// √(1 + z²)))`, then the series `Σ (−1)ᵏ z²ᵏ⁺¹/(2k + 1)` to the last term the precision can see
/// ([`Real::ATAN_LAST_TERM`]: to `z²³` in double precision, `z¹⁷` in single), and the octant restored.
/// (Single precision once halved the ratio twice instead, two roots and a division more per hinge of
/// the position-based sweeps, whose slowest instructions they are.)
#[inline(always)]
pub fn atan2<N: Real>(y: N, x: N) -> N {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (zero, one) = (x.constant(0.0), x.constant(1.0));
    let steep = ax.less(ay);
    let (lo, hi) = (N::select(steep, ax, ay), N::select(steep, ay, ax));
    let past = (hi * x.constant((PI / 8.0).tan())).less(lo);
    let (num, den) = (N::select(past, lo - hi, lo), N::select(past, lo + hi, hi));
    let mut z = N::select(zero.less(den), num / den, zero);
    for _ in 0..N::ATAN_HALVINGS {
        z = z / (one + (one + z * z).sqrt());
    }
    let z2 = z * z;
    let last = N::ATAN_LAST_TERM;
    let mut series = x.constant(if last % 2 == 0 { 1.0 } else { -1.0 } / (2 * last + 1) as f64);
    for k in (0..last).rev() {
        series = series.mul_add(z2, x.constant(if k % 2 == 0 { 1.0 } else { -1.0 } / (2 * k + 1) as f64));
    }
    let r = x.constant((1 << N::ATAN_HALVINGS) as f64) * z * series;
    let r = N::select(past, x.constant(FRAC_PI_4) + r, r);
    let r = N::select(steep, x.constant(FRAC_PI_2) - r, r);
    let r = N::select(x.less(zero), x.constant(PI) - r, r);
    r.copysign(y)
}

/// Six times the volume enclosed by a closed, outward-wound mesh: `Σ_t (p_{t1} × p_{t2})·p_{t3}`, and
/// its gradient per vertex (`∂/∂p₁ = p₂ × p₃` and cyclically, summed over the triangles).
pub fn six_volume(x: &[DVec3], triangles: &[[usize; 3]], gradient: &mut [DVec3]) -> f64 {
    gradient.fill(DVec3::ZERO);
    let mut v = 0.0;
    for t in triangles {
        let (a, b, c) = (x[t[0]], x[t[1]], x[t[2]]);
        v += a.cross(b).dot(c);
        gradient[t[0]] += b.cross(c);
        gradient[t[1]] += c.cross(a);
        gradient[t[2]] += a.cross(b);
    }
    v
}

/// Twice the area of the triangle `(p₁, p₂, p₃)` as seen along the unit `axis`: `C = N·â`,
/// `N = (p₂ − p₁) × (p₃ − p₁)` (negative once the triangle has turned over as seen from `â`), and its
/// gradient with respect to `[p₁, p₂, p₃]`: `∇_{p₂} C = (p₃ − p₁) × â`, `∇_{p₃} C = â × (p₂ − p₁)`,
/// `∇_{p₁} C = −∇_{p₂} C − ∇_{p₃} C` (from `a·(u × v) = u·(v × a)`).
pub fn area_along(p: [DVec3; 3], axis: DVec3) -> (f64, [DVec3; 3]) {
    let [p1, p2, p3] = p;
    let (e2, e3) = (p2 - p1, p3 - p1);
    let (g2, g3) = (e3.cross(axis), axis.cross(e2));
    (e2.cross(e3).dot(axis), [-(g2 + g3), g2, g3])
}

/// Signed distance of `q` from the plane of the triangle `(p₁, p₂, p₃)` minus a thickness:
/// `C = (q − p₁)·n̂ − h`, `n̂ = N/|N|`, `N = (p₂ − p₁) × (p₃ − p₁)`, and its exact gradient with
/// respect to `[q, p₁, p₂, p₃]`. With `u = (I − n̂n̂ᵀ)(q − p₁)/|N|` (how moving `N` turns `n̂` towards
/// `q`): `∇_q C = n̂`, `∇_{p₁} C = −n̂ + u × (p₃ − p₂)`, `∇_{p₂} C = u × (p₁ − p₃)`,
/// `∇_{p₃} C = u × (p₂ − p₁)` — from `∂N/∂p₁ = [p₃ − p₂]×` etc. and `[a]×ᵀu = u × a`.
/// A side `sign` of −1 keeps `q` below the triangle instead (`C = −(q − p₁)·n̂ − h`).
pub fn point_triangle(q: DVec3, p: [DVec3; 3], thickness: f64, sign: f64) -> (f64, [DVec3; 4]) {
    let [p1, p2, p3] = p;
    let big_n = (p2 - p1).cross(p3 - p1);
    let len = big_n.length();
    if len == 0.0 {
        return (f64::INFINITY, [DVec3::ZERO; 4]);
    }
    let n = big_n / len;
    let r = q - p1;
    let u = (r - n * n.dot(r)) / len;
    let c = sign * r.dot(n) - thickness;
    let g = [n, -n + u.cross(p3 - p2), u.cross(p1 - p3), u.cross(p2 - p1)];
    (c, g.map(|g| g * sign))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::fd::{self, Rng};

    #[test]
    fn stretch_gradient_matches_finite_differences() {
        let mut rng = Rng(1);
        for _ in 0..20 {
            let x = [rng.vec(), rng.vec()];
            let (_, g) = stretch(x[0], x[1], 0.3);
            let e = fd::errors(&x, |y| stretch(y[0], y[1], 0.3).0, |_| g.to_vec(), None).0;
            assert!(e < 1e-6, "{e}");
        }
    }

    #[test]
    fn bending_gradient_matches_finite_differences_near_flat_near_pi_and_with_a_curved_rest() {
        let mut rng = Rng(2);
        // A hinge folded to angle `phi` about the x axis, slightly perturbed.
        let folded = |phi: f64, rng: &mut Rng| {
            let (a, b) = (DVec3::ZERO, DVec3::X);
            let c = DVec3::new(0.4, 1.0, 0.0);
            let d = DVec3::new(0.6, -phi.cos(), phi.sin());
            [a, b, c, d].map(|p| p + rng.vec() * 1e-3)
        };
        for (phi, rest) in [(1e-4, 0.0), (0.0, 0.0), (0.7, 0.5), (3.1, 3.0), (3.13, -3.1), (-2.0, 1.0)] {
            let x = folded(phi, &mut rng);
            let rest = RestAngle::new(rest);
            let (c, g) = bending(&x, rest);
            assert!(c.abs() <= std::f64::consts::PI + 1e-12);
            let theta = hinge::angle(&x);
            let wrapped = hinge::wrapped_difference(theta, rest.sin.atan2(rest.cos));
            assert!((c - wrapped).abs() < 1e-14, "{c} against θ − θ̄ = {wrapped}");
            let e = fd::errors(&x, |y| bending(&[y[0], y[1], y[2], y[3]], rest).0, |_| g.to_vec(), None).0;
            assert!(e < 1e-6, "angle {phi}, rest {rest:?}: {e}");
        }
    }

    #[test]
    fn the_vector_friendly_arctangent_agrees_with_the_library_one() {
        let mut rng = Rng(7);
        let mut worst: f64 = 0.0;
        for k in 0..200_000 {
            let scale = 10f64.powi(k % 9 - 4);
            let (y, x) = (rng.uniform() * scale, rng.uniform() * scale);
            worst = worst.max((atan2(y, x) - y.atan2(x)).abs());
        }
        for (y, x) in
            [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (1.0, 1.0), (-2.0, -2.0), (0.0, 0.0), (1e-300, -1.0)]
        {
            worst = worst.max((atan2(y, x) - y.atan2(x)).abs());
        }
        assert!(worst < 4.0 * f64::EPSILON, "{worst:e}");
        // In single precision (as the sweeps take it): within two units in the last place of the
        // angle, over every octant and on both sides of tan(π/8).
        let single = |v: f64| crate::linalg::real::Lanes32 { simd: pulp::Scalar::new(), v: v as f32 };
        let mut worst: f64 = 0.0;
        for k in 0..200_000 {
            let (y, x) =
                (f64::from(single(rng.uniform()).v), f64::from(single(rng.uniform() * 10f64.powi(k % 5 - 2)).v));
            let got = f64::from(atan2(single(y), single(x)).v);
            worst = worst.max((got - y.atan2(x)).abs() / (f64::from(f32::EPSILON) * y.atan2(x).abs().max(1e-30)));
        }
        assert!(worst < 2.0, "{worst} units in the last place");
    }

    #[test]
    fn volume_of_a_cube_and_its_gradient() {
        // A unit cube as 12 outward triangles.
        let v: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64)).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let tris: Vec<[usize; 3]> = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let mut g = vec![DVec3::ZERO; 8];
        assert!((six_volume(&v, &tris, &mut g) - 6.0).abs() < 1e-12, "six times the unit volume");
        let mut rng = Rng(3);
        let x: Vec<DVec3> = v.iter().map(|p| *p + rng.vec() * 0.1).collect();
        six_volume(&x, &tris, &mut g);
        let e = fd::errors(&x, |y| six_volume(y, &tris, &mut [DVec3::ZERO; 8]), |_| g.to_vec(), None).0;
        assert!(e < 1e-6, "{e}");
    }

    #[test]
    fn area_along_gradient_matches_finite_differences_and_turns_negative_when_the_triangle_turns_over() {
        let mut rng = Rng(5);
        for _ in 0..20 {
            let x = [rng.vec(), rng.vec(), rng.vec()];
            let axis = rng.vec().normalize();
            let (_, g) = area_along(x, axis);
            let e = fd::errors(&x, |y| area_along([y[0], y[1], y[2]], axis).0, |_| g.to_vec(), None).0;
            assert!(e < 1e-6, "{e}");
        }
        // The unit right triangle in the xz plane, seen from +y: twice its area is 1, turned over −1.
        let t = [DVec3::ZERO, DVec3::Z, DVec3::X];
        assert!((area_along(t, DVec3::Y).0 - 1.0).abs() < 1e-15);
        assert!((area_along([t[0], t[2], t[1]], DVec3::Y).0 + 1.0).abs() < 1e-15);
    }

    #[test]
    fn point_triangle_gradient_matches_finite_differences_on_both_sides() {
        let mut rng = Rng(4);
        for sign in [1.0, -1.0] {
            for _ in 0..20 {
                let x = [rng.vec(), rng.vec(), rng.vec(), rng.vec()];
                let (_, g) = point_triangle(x[0], [x[1], x[2], x[3]], 0.01, sign);
                let e =
                    fd::errors(&x, |y| point_triangle(y[0], [y[1], y[2], y[3]], 0.01, sign).0, |_| g.to_vec(), None).0;
                assert!(e < 1e-6, "{e}");
            }
        }
        // Above a horizontal triangle by 0.5 with thickness 0.1: C = 0.4.
        let (c, _) = point_triangle(DVec3::new(0.2, 0.5, 0.2), [DVec3::ZERO, DVec3::Z, DVec3::X], 0.1, 1.0);
        assert!((c - 0.4).abs() < 1e-12, "{c}");
    }
}
