//! The cloth springs of Choi & Ko 2002 ("Stable but responsive cloth"), as Noh & Jung put them on
//! triangle meshes: a scalar energy `E(r)` of the distance `r = |x₁ − x₀|` between two particles.
//!
//! - [`stretch`]: edge springs resist stretch only, `E = ½ k_s (r − L)²` for `r ≥ L`, else 0.
//! - [`Buckling`]: diagonal springs treat every shortening as buckling into a circular arc of
//!   length `L`: `E = ½ k_b L κ²` with `κ = (2/L) sinc⁻¹(r/L)`. With `u = r/L` and `s ∈ (0, π)` solving
//!   `sin s / s = u`, `E_b = (k_b/L) G(u)` with `G = 2s²`, and the force along the spring is
//!   `f_b = dE_b/dr = −(k_b/L²) F(u)`, `F(u) = 4s³/(sin s − s cos s)` (`F(1⁻) = 12`, `F(0) = 4π²`).
//!   The `1/L²` is kept (one widely copied fit drops it); `F` is tabulated once ([`BucklingCurve`]) and
//!   the chain rule `d/dr = (1/L) d/du` gives the stiffness `−(k_b/L³) F′(u) > 0`.
//!   `f_b` jumps from 0 to `−12 k_b/L²` at `r = L`, so Choi & Ko use `f_b* = max(f_b, c_b (r − L))`:
//!   in compression both are negative, the linear branch (the smaller push) acts near rest and the
//!   buckling force once the linear one would exceed it. The energy is the integral of `f_b*`.
//!
//! Both springs act along the line between the particles. With `x̂ = (x₁ − x₀)/r`, tension
//! `T = dE/dr` and stiffness `S = d²E/dr²`, the force on particle 0 is `T x̂` (on 1, `−T x̂`) and
//! `∂f₀/∂x₁ = S x̂x̂ᵀ + (T/r)(I − x̂x̂ᵀ)` ([`Spring::jacobian`]). Choi & Ko keep only the longitudinal
//! term `S x̂x̂ᵀ` for buckling springs (the transverse term `T/r < 0` would make the system indefinite);
//! [`Spring::jacobian`] returns the exact matrix so that it can be checked against finite differences.
//!
//! The per-spring evaluations are `#[inline(always)]`: the cloth runs them inside kernels compiled
//! for the CPU's best instruction set ([`crate::linalg::isa`]), which only reach inlined code.

use std::sync::OnceLock;

use glam::{DMat3, DVec3};

use super::hinge::outer;

/// A spring's scalar response at one length: energy, tension `dE/dr` and stiffness `d²E/dr²`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Spring {
    /// Stored energy, J.
    pub energy: f64,
    /// `dE/dr`, N: positive pulls the ends together, negative pushes them apart.
    pub tension: f64,
    /// `d²E/dr²`, N/m.
    pub stiffness: f64,
}

impl Spring {
    /// `(tension, stiffness)`.
    #[inline(always)]
    pub fn tension_stiffness(&self) -> (f64, f64) {
        (self.tension, self.stiffness)
    }

    /// The force on the first end, `T x̂` with `x̂ = d/|d|`, `d = x₁ − x₀` (zero if `d = 0`).
    pub fn force(&self, d: DVec3) -> DVec3 {
        let r = d.length();
        if r > 0.0 { d * (self.tension / r) } else { DVec3::ZERO }
    }

    /// The exact `∂f₀/∂x₁ = S x̂x̂ᵀ + (T/r)(I − x̂x̂ᵀ)` for `d = x₁ − x₀` (zero if `d = 0`).
    pub fn jacobian(&self, d: DVec3) -> DMat3 {
        let r = d.length();
        if r == 0.0 {
            return DMat3::ZERO;
        }
        let u = d / r;
        let t = self.tension / r;
        outer(u, u) * (self.stiffness - t) + DMat3::from_diagonal(DVec3::splat(t))
    }
}

/// The stretch-only edge spring at length `r` with rest length `rest` and stiffness `k_s` (N/m).
#[inline(always)]
pub fn stretch(r: f64, rest: f64, k_s: f64) -> Spring {
    let e = r - rest;
    if e <= 0.0 {
        return Spring::default();
    }
    Spring { energy: 0.5 * k_s * e * e, tension: k_s * e, stiffness: k_s }
}

/// `s ∈ [0, π]` with `sin s / s = u` for `u ∈ [0, 1]` (the half angle of a circular arc of length `L`
/// whose chord is `uL`).
pub fn arc_half_angle(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    // sinc is strictly decreasing on (0, π): bisection to full precision.
    bisect(|s| sinc(s) > u, 0.0, std::f64::consts::PI)
}

fn sinc(s: f64) -> f64 {
    if s.abs() < 1e-4 { 1.0 - s * s / 6.0 } else { s.sin() / s }
}

/// `(F(u), F′(u), G(u))` evaluated directly (not from the table): the buckling force curve, its
/// derivative with respect to `u`, and the arc energy `G = 2s²`.
pub fn buckling_exact(u: f64) -> (f64, f64, f64) {
    let s = arc_half_angle(u);
    if s < 2e-2 {
        // Series about s = 0 (F = 12 + 6s²/5 + …, F′(u) = −36/5 + O(s²)), from
        // D = sin s − s cos s = s³/3 − s⁵/30 + s⁷/840 and 3D − s² sin s = s⁵/15 − s⁷/210.
        let s2 = s * s;
        let d = 1.0 / 3.0 - s2 / 30.0 + s2 * s2 / 840.0; // D / s³
        let f = 4.0 / d;
        let num = 1.0 / 15.0 - s2 / 210.0; // (3D − s² sin s) / s⁵
        let df = -4.0 * num / (d * d * d);
        return (f, df, 2.0 * s2);
    }
    let (sn, cs) = s.sin_cos();
    let d = sn - s * cs;
    let f = 4.0 * s.powi(3) / d;
    // dF/ds = 4s²(3D − s² sin s)/D², du/ds = −D/s², so F′(u) = −4s⁴(3D − s² sin s)/D³.
    let df = -4.0 * s.powi(4) * (3.0 * d - s * s * sn) / (d * d * d);
    (f, df, 2.0 * s * s)
}

/// `F(u)` and `G(u)` tabulated once on `u ∈ [0, 1]` with their exact derivatives at the knots and
/// read back by cubic Hermite interpolation (so `F′` is the derivative of the interpolant of `F`).
#[derive(Debug)]
pub struct BucklingCurve {
    f: Vec<f64>,
    df: Vec<f64>,
    g: Vec<f64>,
}

const KNOTS: usize = 2048;

impl BucklingCurve {
    /// The shared table (built on first use).
    #[inline(always)]
    pub fn get() -> &'static Self {
        static CURVE: OnceLock<BucklingCurve> = OnceLock::new();
        CURVE.get_or_init(|| {
            let mut c = Self { f: Vec::new(), df: Vec::new(), g: Vec::new() };
            for k in 0..=KNOTS {
                let (f, df, g) = buckling_exact(k as f64 / KNOTS as f64);
                c.f.push(f);
                c.df.push(df);
                c.g.push(g);
            }
            c
        })
    }

    #[inline(always)]
    fn locate(u: f64) -> (usize, f64) {
        let x = u.clamp(0.0, 1.0) * KNOTS as f64;
        let k = (x.floor() as usize).min(KNOTS - 1);
        (k, x - k as f64)
    }

    /// `(F(u), F′(u))` for `u ∈ [0, 1]` (clamped).
    #[inline(always)]
    pub fn force(&self, u: f64) -> (f64, f64) {
        let (k, t) = Self::locate(u);
        let h = 1.0 / KNOTS as f64;
        hermite(t, h, self.f[k], self.df[k], self.f[k + 1], self.df[k + 1])
    }

    /// `G(u) = 2 s(u)²` for `u ∈ [0, 1]` (clamped); `G′ = −F`.
    #[inline(always)]
    pub fn energy(&self, u: f64) -> f64 {
        let (k, t) = Self::locate(u);
        let h = 1.0 / KNOTS as f64;
        hermite(t, h, self.g[k], -self.f[k], self.g[k + 1], -self.f[k + 1]).0
    }

    /// `(F(u), F′(u), G(u))`, located once: the same values as [`Self::force`] and [`Self::energy`].
    #[inline(always)]
    pub fn force_energy(&self, u: f64) -> (f64, f64, f64) {
        let (k, t) = Self::locate(u);
        let h = 1.0 / KNOTS as f64;
        let (f, df) = hermite(t, h, self.f[k], self.df[k], self.f[k + 1], self.df[k + 1]);
        (f, df, hermite(t, h, self.g[k], -self.f[k], self.g[k + 1], -self.f[k + 1]).0)
    }
}

/// Cubic Hermite on one interval of width `h` at local parameter `t ∈ [0, 1]`: value and derivative.
#[inline(always)]
fn hermite(t: f64, h: f64, y0: f64, d0: f64, y1: f64, d1: f64) -> (f64, f64) {
    let (t2, t3) = (t * t, t * t * t);
    let value = (2.0 * t3 - 3.0 * t2 + 1.0) * y0
        + (t3 - 2.0 * t2 + t) * h * d0
        + (-2.0 * t3 + 3.0 * t2) * y1
        + (t3 - t2) * h * d1;
    let slope = ((6.0 * t2 - 6.0 * t) * y0
        + (3.0 * t2 - 4.0 * t + 1.0) * h * d0
        + (-6.0 * t2 + 6.0 * t) * y1
        + (3.0 * t2 - 2.0 * t) * h * d1)
        / h;
    (value, slope)
}

/// A diagonal (buckling) spring's constants: rest length `L`, flexural rigidity `k_b` (N·m²) and the
/// linear branch's stiffness `c_b` (N/m), with the compressions at which `f_b*` changes branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Buckling {
    rest: f64,
    k_b: f64,
    c_b: f64,
    /// Compressions `t = 1 − u` bounding the interval where the buckling branch acts (empty if `lo ≥ hi`).
    buckling: (f64, f64),
    /// The energy at the start and at the end of the buckling branch, and `G(1 − t₁)`.
    branch_energy: (f64, f64, f64),
}

impl Buckling {
    /// Precompute where the branches cross. In `t = 1 − u` the linear push is `c_b L t` and the
    /// buckling push `(k_b/L²) F`; `F` is convex in `t`, so `β t − F` (`β = c_b L³/k_b`) is concave and
    /// the buckling branch (where `β t ≥ F`) is one interval `[t₁, t₂]`, possibly empty.
    pub fn new(rest: f64, k_b: f64, c_b: f64) -> Self {
        let empty = Self { rest, k_b, c_b, buckling: (1.0, 1.0), branch_energy: (0.0, 0.0, 0.0) };
        if k_b <= 0.0 {
            // No buckling resistance: max(0, c_b (r − L)) = 0 in compression, the "buckling" branch throughout.
            return Self { buckling: (0.0, 1.0), ..empty }.with_branch_energy();
        }
        if c_b <= 0.0 {
            return empty;
        }
        let curve = BucklingCurve::get();
        let beta = c_b * rest.powi(3) / k_b;
        let phi = |t: f64| beta * t - curve.force(1.0 - t).0;
        // φ′(t) = β + F′(1 − t) is decreasing; its root is φ's maximum.
        let peak = if beta + curve.force(1.0).1 <= 0.0 {
            0.0
        } else if beta + curve.force(0.0).1 >= 0.0 {
            1.0
        } else {
            bisect(|t| beta + curve.force(1.0 - t).1 > 0.0, 0.0, 1.0)
        };
        if phi(peak) < 0.0 {
            return empty;
        }
        let t1 = bisect(|t| phi(t) < 0.0, 0.0, peak);
        let t2 = if phi(1.0) >= 0.0 { 1.0 } else { bisect(|t| phi(t) >= 0.0, peak, 1.0) };
        Self { buckling: (t1, t2), ..empty }.with_branch_energy()
    }

    /// Fill in [`Self::branch_energy`] for the branches found.
    fn with_branch_energy(self) -> Self {
        let (t1, t2) = self.buckling;
        let g1 = BucklingCurve::get().energy(1.0 - t1);
        let start = 0.5 * self.c_b * self.rest * self.rest * t1 * t1;
        let end = start + self.k_b / self.rest * (BucklingCurve::get().energy(1.0 - t2) - g1);
        Self { branch_energy: (start, end, g1), ..self }
    }

    /// The response at length `r`: zero at or beyond rest length, `f_b*` in compression, with its
    /// stiffness and energy (the integral of `f_b*` from the rest length); one look-up of the curve for
    /// the three (the hot path of a cloth step, which linearises and measures every spring at once).
    #[inline(always)]
    pub fn eval(&self, r: f64) -> Spring {
        let (l, t) = (self.rest, 1.0 - r / self.rest);
        if t <= 0.0 {
            return Spring::default();
        }
        let (t1, t2) = self.buckling;
        let (start, end, g1) = self.branch_energy;
        let linear = |a: f64, b: f64| 0.5 * self.c_b * l * l * (b * b - a * a);
        if t >= t1 && t <= t2 && t1 < t2 {
            let (f, df, g) = BucklingCurve::get().force_energy(1.0 - t);
            // At t = t₁ the branches meet; the energy is taken on the linear one.
            let energy = if t <= t1 { linear(0.0, t) } else { start + self.k_b / l * (g - g1) };
            return Spring { energy, tension: -self.k_b / (l * l) * f, stiffness: -self.k_b / (l * l * l) * df };
        }
        let energy = if t1 >= t2 || t <= t1 { linear(0.0, t) } else { end + linear(t2, t) };
        Spring { energy, tension: -self.c_b * l * t, stiffness: self.c_b }
    }
}

/// The boundary of `{t : inside(t)}` in `[lo, hi]`, assuming `inside(lo)` and `!inside(hi)` (to round-off).
fn bisect(inside: impl Fn(f64) -> bool, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid == lo || mid == hi {
            break;
        }
        if inside(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn buckling_curve_has_the_specified_values() {
        let c = BucklingCurve::get();
        // Choi & Ko 2002, the buckling curve: F(1⁻) = 12, F(0.9) ≈ 12.8, F(0.5) ≈ 17.5, F(0.1) ≈ 30.7; F(0) = 4π².
        for (u, want, tol) in
            [(1.0, 12.0, 1e-9), (0.9, 12.8, 0.01), (0.5, 17.5, 0.01), (0.1, 30.7, 0.01), (0.0, 39.478_417_6, 1e-8)]
        {
            let (f, _) = c.force(u);
            println!("F({u}) = {f:.6}");
            assert!(rel(f, want) < tol, "F({u}) = {f}, want {want}");
        }
        // The table reproduces the direct evaluation between knots, and G′ = −F.
        for k in 0..200 {
            let u = (k as f64 + 0.37) / 200.0;
            let (f, df, g) = buckling_exact(u);
            let (tf, tdf) = c.force(u);
            assert!(rel(tf, f) < 1e-10 && rel(tdf, df) < 1e-6 && rel(c.energy(u), g) < 1e-10, "u = {u}");
            let e = 1e-6;
            let fd = (buckling_exact(u + e).2 - buckling_exact(u - e).2) / (2.0 * e);
            assert!(rel(-fd, f) < 1e-6, "G′({u}) = {fd}, −F = {}", -f);
            let fd = (buckling_exact(u + e).0 - buckling_exact(u - e).0) / (2.0 * e);
            assert!(rel(fd, df) < 1e-6, "F′({u}) = {fd} vs {df}");
        }
    }

    #[test]
    fn arc_energy_is_half_kb_l_kappa_squared() {
        // A chord of an arc of length L with curvature κ: r = (2/κ) sin(κL/2).
        let (l, k_b) = (0.05, 3e-4);
        let spring = Buckling::new(l, k_b, 1e12); // a stiff linear branch: buckling almost at once
        for kappa in [5.0, 20.0, 60.0] {
            let r = 2.0 / kappa * (kappa * l / 2.0).sin();
            let e = spring.eval(r).energy;
            assert!(rel(e, 0.5 * k_b * l * kappa * kappa) < 1e-6, "κ = {kappa}: {e}");
        }
    }

    /// The energy is the work of the tension from the rest length, `E(r) = −∫_r^L T`, on every branch
    /// (a wrong constant where the branches meet would pass the derivative checks but not this):
    /// composite Simpson with the branch changes as nodes, so each panel is smooth.
    #[test]
    fn buckling_energy_is_the_work_of_its_tension() {
        let l = 0.04;
        for (k_b, c_b) in [(1e-6, 200.0), (1e-3, 600.0), (1e-3, 150.0), (0.0, 200.0)] {
            let spring = Buckling::new(l, k_b, c_b);
            let (t1, t2) = spring.buckling;
            let simpson = |a: f64, b: f64| {
                let n = 2000;
                let h = (b - a) / n as f64;
                let t = |k: usize| spring.eval(a + k as f64 * h).tension;
                (t(0) + t(n) + (1..n).map(|k| if k % 2 == 1 { 4.0 } else { 2.0 } * t(k)).sum::<f64>()) * h / 3.0
            };
            for r in [0.005, 0.05, 0.3, 0.6, 0.9, 0.97, 0.999].map(|u| u * l) {
                // Nodes: r, the branch changes between r and L (at r = L(1 − t)), and L.
                let mut nodes: Vec<f64> = [t2, t1].iter().map(|t| l * (1.0 - t)).filter(|n| *n > r && *n < l).collect();
                nodes.insert(0, r);
                nodes.push(l);
                let work: f64 = nodes.windows(2).map(|w| simpson(w[0], w[1])).sum();
                let e = spring.eval(r).energy;
                assert!(
                    (e + work).abs() < 1e-9 * e.abs().max(1e-12),
                    "k_b {k_b}, c_b {c_b}, r/L {}: {e} vs {}",
                    r / l,
                    -work
                );
            }
        }
    }

    /// Force and stiffness against central differences of the energy, on both branches and at `c_b`
    /// values giving no, one or two branch changes.
    #[test]
    fn scalar_springs_match_finite_differences() {
        let l = 0.04;
        type Case = (Box<dyn Fn(f64) -> Spring>, f64, f64);
        let cases: Vec<Case> = vec![
            (Box::new(move |r| stretch(r, l, 200.0)), 1.0005, 1.5),
            (Box::new(move |r| Buckling::new(l, 1e-6, 200.0).eval(r)), 0.02, 0.99999),
            (Box::new(move |r| Buckling::new(l, 1e-3, 600.0).eval(r)), 0.02, 0.99), // β = 38.4: two changes
            (Box::new(move |r| Buckling::new(l, 1e-3, 150.0).eval(r)), 0.02, 0.99), // β = 9.6: linear only
        ];
        for (i, (spring, lo, hi)) in cases.iter().enumerate() {
            for k in 0..=40 {
                let r = l * (lo + (hi - lo) * k as f64 / 40.0);
                let e = 1e-7 * l;
                let (p, m) = (spring(r + e), spring(r - e));
                let s = spring(r);
                let fd_t = (p.energy - m.energy) / (2.0 * e);
                let fd_s = (p.tension - m.tension) / (2.0 * e);
                assert!(rel(fd_t, s.tension) < 1e-6, "case {i}, r = {r}: T = {} vs fd {fd_t}", s.tension);
                assert!(rel(fd_s, s.stiffness) < 1e-6, "case {i}, r = {r}: S = {} vs fd {fd_s}", s.stiffness);
            }
        }
        // The β = 38.4 spring changes branch twice; the β = 9.6 one never.
        let two = Buckling::new(l, 1e-3, 600.0).buckling;
        assert!(two.0 > 0.0 && two.1 < 1.0 && two.0 < two.1, "{two:?}");
        let none = Buckling::new(l, 1e-3, 150.0).buckling;
        assert!(none.0 >= none.1, "{none:?}");
    }

    /// The 3D force is minus the gradient of the energy and the Jacobian is the derivative of the force.
    #[test]
    fn vector_force_and_jacobian_match_finite_differences() {
        let (x0, x1) = (DVec3::new(0.01, -0.02, 0.03), DVec3::new(0.035, 0.01, 0.02));
        let l_stretch = 0.6 * (x1 - x0).length();
        let l_buckle = 1.3 * (x1 - x0).length();
        let stretched = |d: DVec3| stretch(d.length(), l_stretch, 150.0);
        let bucking = Buckling::new(l_buckle, 2e-6, 150.0);
        let buckled = |d: DVec3| bucking.eval(d.length());
        for (name, spring) in [("stretch", &stretched as &dyn Fn(DVec3) -> Spring), ("buckling", &buckled)] {
            let d = x1 - x0;
            let s = spring(d);
            assert!(s.tension != 0.0, "{name} is active");
            let f0 = s.force(d);
            let j = s.jacobian(d);
            let e = 1e-8;
            for a in 0..3 {
                let mut step = DVec3::ZERO;
                step[a] = e;
                // f₀ = −∂E/∂x₀ = ∂E/∂d.
                let fd_f = (spring(d + step).energy - spring(d - step).energy) / (2.0 * e);
                assert!((fd_f - f0[a]).abs() < 1e-6 * f0.abs().max_element(), "{name}: f0[{a}]");
                // ∂f₀/∂x₁ = ∂f₀/∂d.
                let fd_j = (spring(d + step).force(d + step) - spring(d - step).force(d - step)) / (2.0 * e);
                let err = (fd_j - j.col(a)).abs().max_element();
                assert!(err < 1e-6 * j.abs().to_cols_array().iter().fold(0.0f64, |m, v| m.max(*v)), "{name}: col {a}");
            }
            // The kept (longitudinal) part is the full Jacobian projected on the spring's direction.
            let p = outer(d.normalize(), d.normalize());
            let longitudinal = p * j * p;
            assert!(
                (longitudinal - outer(d.normalize(), d.normalize()) * s.stiffness)
                    .abs()
                    .to_cols_array()
                    .iter()
                    .all(|v| *v < 1e-9)
            );
        }
    }
}
