//! Static physics of the discrete shell (`ds-static`) on a clamped strip: the Euler–Bernoulli
//! cantilever under a small load, and the large-deflection elastica under a tip point load (against
//! Bisshopp & Drucker's published table) and under self-weight.

mod common;

use common::Strip;
use glam::DVec3;
use shellwarp::solver::{Solver, StepStats, build};

/// Euler–Bernoulli cantilever under uniform load: `y(s)/y(L) = s²(6L² − 4Ls + s²)/(3L⁴)`.
fn euler_bernoulli_shape(s: f64, l: f64) -> f64 {
    s * s * (6.0 * l * l - 4.0 * l * s + s * s) / (3.0 * l.powi(4))
}

const DENSITY: f64 = 0.5;
const K_BEND: f64 = 1e-3;
const STRIP: Strip = Strip { cells: 61, across: 2, dx: 1.0 / 60.0, width: 0.04 };

/// Nearly inextensible: membrane stiffness 10⁶ × the bending stiffness.
fn material(k_bend: f64) -> String {
    format!("density = {DENSITY}\nk_area = 1000.0\nk_length = 1000.0\nk_bend = {k_bend}")
}

const NEWTON: &str = "iterations = 1000\ntolerance = 1e-10";

fn static_strip(k_bend: f64) -> Box<dyn Solver> {
    build(&STRIP.setup("ds-static", &material(k_bend), NEWTON)).unwrap()
}

/// One `ds-static` step that must have converged (to the tolerance or the round-off floor).
fn converged_step(s: &mut dyn Solver) -> StepStats {
    let stats = s.step().unwrap();
    assert!(stats.converged, "Newton did not converge: {stats:?}");
    stats
}

/// Solve the static cantilever at gravity `g` (m/s², downward), ramping the load in `ramp` stages.
fn equilibrium(s: &mut dyn Solver, g: f64, ramp: usize) -> Vec<DVec3> {
    for k in 1..=ramp {
        s.set_param("gravity_y", -g * k as f64 / ramp as f64).unwrap();
        converged_step(s);
    }
    s.positions().to_vec()
}

/// Small-load run: returns (tip deflection, EI calibrated from it, the run's positions).
fn small_load(k_bend: f64, g: f64) -> (f64, f64, Vec<DVec3>) {
    let mut s = static_strip(k_bend);
    let rest = s.positions().to_vec();
    let x = equilibrium(s.as_mut(), g, 1);
    let tip = STRIP.row_displacement(&rest, &x, STRIP.cells).0;
    let w = DENSITY * STRIP.width * g; // load per unit length (lumped masses carry it exactly)
    let l = STRIP.length();
    (tip, w * l.powi(4) / (8.0 * tip), x)
}

#[test]
fn cantilever_small_load_matches_euler_bernoulli() {
    let g = 5e-4;
    let (tip, ei, x) = small_load(K_BEND, g);
    let l = STRIP.length();
    let rest = static_strip(K_BEND).positions().to_vec();
    assert!(tip > 0.0 && tip / l < 2e-2, "small load keeps the strip linear: tip/L = {}", tip / l);
    // Shape along the whole strip, normalised by the tip.
    let mut worst: f64 = 0.0;
    for i in 1..=STRIP.cells {
        let s = (i - 1) as f64 * STRIP.dx;
        let y = STRIP.row_displacement(&rest, &x, i).0 / tip;
        worst = worst.max((y - euler_bernoulli_shape(s, l)).abs());
    }
    let mid = STRIP.row_displacement(&rest, &x, 1 + (STRIP.cells - 1) / 2).0 / tip;
    let ratio_error = (mid - 17.0 / 48.0).abs() / (17.0 / 48.0);
    eprintln!(
        "cantilever: tip/L = {:.3e}, EI_eff = {ei:.4e} N·m², y(L/2)/y(L) = {mid:.5} (17/48 = {:.5}, rel. error {ratio_error:.2e}), max shape error {worst:.2e}",
        tip / l,
        17.0 / 48.0
    );
    assert!(ratio_error < 0.02, "mid/tip ratio {mid} vs 17/48");
    assert!(worst < 0.01, "shape deviates from Euler–Bernoulli by {worst} of the tip deflection");
    // Tip deflection ∝ 1/k_B.
    let (tip4, _, _) = small_load(4.0 * K_BEND, g);
    let r = tip / tip4;
    eprintln!("cantilever: tip(k_B)/tip(4 k_B) = {r:.5}");
    assert!((r - 4.0).abs() < 0.01, "tip ratio {r} should be 4");
    // EI_eff ∝ k_B: a different load gives the same calibration.
    let (_, ei2, _) = small_load(K_BEND, 2.0 * g);
    assert!((ei2 / ei - 1.0).abs() < 1e-3);
}

/// How the elastica is loaded.
#[derive(Clone, Copy, Debug)]
enum Loading {
    /// A vertical point load `P` at the free end, `α = PL²/EI`.
    Tip,
    /// A uniformly distributed dead load `w` (self-weight), `α = wL³/EI`.
    SelfWeight,
}

/// The inextensible elastica of a cantilever, nondimensional: `θ'' = −α m(σ) cos θ`, `θ(0) = 0`,
/// `θ'(1) = 0`, with σ = s/L, θ the slope angle (positive downwards) and `m = 1` (tip load) or `1 − σ`
/// (self-weight). Solved by shooting on `θ'(0)` (bisection) with RK4 in `steps` steps; returns the tip
/// deflection `δ/L = ∫ sin θ dσ` and the horizontal tip shortening `1 − x/L = 1 − ∫ cos θ dσ`.
fn elastica(loading: Loading, alpha: f64, steps: usize) -> (f64, f64) {
    let integrate = |k0: f64| {
        let h = 1.0 / steps as f64;
        let m = |s: f64| match loading {
            Loading::Tip => 1.0,
            Loading::SelfWeight => 1.0 - s,
        };
        // State: θ, θ', x, y.
        let f = |s: f64, u: [f64; 4]| [u[1], -alpha * m(s) * u[0].cos(), u[0].cos(), u[0].sin()];
        let mut u = [0.0, k0, 0.0, 0.0];
        for i in 0..steps {
            let s = i as f64 * h;
            let add =
                |u: [f64; 4], k: [f64; 4], c: f64| [u[0] + c * k[0], u[1] + c * k[1], u[2] + c * k[2], u[3] + c * k[3]];
            let k1 = f(s, u);
            let k2 = f(s + h / 2.0, add(u, k1, h / 2.0));
            let k3 = f(s + h / 2.0, add(u, k2, h / 2.0));
            let k4 = f(s + h, add(u, k3, h));
            for j in 0..4 {
                u[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
        u
    };
    // θ'(0) is the clamp moment / EI, between 0 and the linear value α (tip) or α/2 (self-weight).
    let (mut lo, mut hi) = (0.0, alpha * 1.001);
    assert!(integrate(lo)[1] < 0.0 && integrate(hi)[1] > 0.0, "bracket");
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if integrate(mid)[1] > 0.0 { hi = mid } else { lo = mid }
    }
    let u = integrate(0.5 * (lo + hi));
    (u[3], 1.0 - u[2])
}

/// Bisshopp & Drucker, "Large deflection of cantilever beams", Q. Appl. Math. 3(3):272–275 (1945):
/// cantilever with a vertical tip load, `(PL²/EI, δ/L, (L − x)/L)` — tip deflection and horizontal tip
/// shortening from their elliptic-integral solution, to the four digits widely reproduced.
const BISSHOPP_DRUCKER: [(f64, f64, f64); 4] =
    [(1.0, 0.3017, 0.0564), (2.0, 0.4935, 0.1606), (3.0, 0.6033, 0.2544), (5.0, 0.7138, 0.3876)];

#[test]
fn elastica_reference_reproduces_the_published_table_and_the_linear_limit() {
    for (alpha, d_pub, s_pub) in BISSHOPP_DRUCKER {
        let (d, s) = elastica(Loading::Tip, alpha, 2000);
        eprintln!(
            "tip-load elastica α = {alpha}: δ/L {d:.5} (published {d_pub}), shortening {s:.5} (published {s_pub})"
        );
        assert!((d - d_pub).abs() <= 6e-5 && (s - s_pub).abs() <= 6e-5, "α = {alpha}: {d}, {s}");
    }
    for loading in [Loading::Tip, Loading::SelfWeight] {
        for alpha in [0.01, 3.0, 12.0] {
            let (d1, s1) = elastica(loading, alpha, 2000);
            let (d2, s2) = elastica(loading, alpha, 4000);
            assert!((d1 - d2).abs() < 1e-10 && (s1 - s2).abs() < 1e-10, "{loading:?} α = {alpha}: {d1} vs {d2}");
        }
    }
    // Small α: Euler–Bernoulli δ/L = α/3 (tip load) and α/8 (self-weight).
    let (d, _) = elastica(Loading::Tip, 0.01, 2000);
    assert!((d / (0.01 / 3.0) - 1.0).abs() < 1e-4, "{d}");
    let (d, _) = elastica(Loading::SelfWeight, 0.01, 2000);
    assert!((d / (0.01 / 8.0) - 1.0).abs() < 1e-4, "{d}");
}

/// A `[[loads]]` table putting `total` newtons (downward, −y) on the tip row of `strip`, shared equally.
fn tip_load(strip: &Strip, total: f64) -> String {
    let x = strip.cells as f64 * strip.dx / 2.0 - 0.5 * strip.dx;
    let each = total / (strip.across + 1) as f64;
    format!(
        "[[loads]]\nselect = {{ box = {{ min = [{x}, -1.0, -1.0], max = [10.0, 1.0, 1.0] }} }}\nforce = [0.0, {}, 0.0]\n",
        -each
    )
}

/// A `ds-static` strip with a downward tip load `p` (N) and no gravity, solved from rest.
fn tip_loaded(p: f64) -> (Box<dyn Solver>, Vec<DVec3>, StepStats) {
    let setup = STRIP.setup_with("ds-static", &material(K_BEND), &tip_load(&STRIP, p), NEWTON);
    let mut s = build(&setup).unwrap();
    s.set_param("gravity_y", 0.0).unwrap();
    let rest = s.positions().to_vec();
    let stats = converged_step(s.as_mut());
    (s, rest, stats)
}

#[test]
fn cantilever_tip_load_matches_bisshopp_and_drucker() {
    let l = STRIP.length();
    // Calibrate EI from a small tip load: δ = PL³/(3EI).
    let p0 = 1e-6;
    let (s, rest, _) = tip_loaded(p0);
    let (tip0, _) = STRIP.row_displacement(&rest, s.positions(), STRIP.cells);
    assert!(tip0 > 0.0 && tip0 / l < 2e-2, "small load keeps the strip linear: δ/L = {}", tip0 / l);
    let ei = p0 * l.powi(3) / (3.0 * tip0);
    for (alpha, d_pub, s_pub) in BISSHOPP_DRUCKER {
        let (s, rest, stats) = tip_loaded(alpha * ei / (l * l));
        let (dy, dx) = STRIP.row_displacement(&rest, s.positions(), STRIP.cells);
        let (d, short) = (dy / l, dx / l);
        let (ed, es) = ((d - d_pub).abs() / d_pub, (short - s_pub).abs() / s_pub);
        eprintln!(
            "tip load PL²/EI = {alpha}: δ/L {d:.4} vs {d_pub} ({:.2}%), (L − x)/L {short:.4} vs {s_pub} ({:.2}%), \
             linear theory δ/L = {:.3}; {} Newton iterations",
            100.0 * ed,
            100.0 * es,
            alpha / 3.0,
            stats.iterations
        );
        assert!(ed < 0.03 && es < 0.03, "PL²/EI = {alpha}: deflection error {ed}, shortening error {es}");
    }
}

/// Self-weight: the reference is the shooting solution above (validated against the published
/// tip-load table and the linear limit), not a published table.
#[test]
fn cantilever_under_large_self_weight_matches_the_elastica() {
    let l = STRIP.length();
    let (_, ei, _) = small_load(K_BEND, 5e-4);
    let mut s = static_strip(K_BEND);
    let rest = s.positions().to_vec();
    let mut g_prev = 0.0;
    for alpha in [2.0, 5.0, 10.0, 20.0] {
        let (d_ref, s_ref) = elastica(Loading::SelfWeight, alpha, 4000);
        // Load per unit length w = ρ b g with α = wL³/EI.
        let g = alpha * ei / (DENSITY * STRIP.width * l.powi(3));
        // Continue from the previous equilibrium, ramping the extra load in a few stages.
        for k in 1..=4 {
            s.set_param("gravity_y", -(g_prev + (g - g_prev) * k as f64 / 4.0)).unwrap();
            converged_step(s.as_mut());
        }
        g_prev = g;
        let (dy, dx) = STRIP.row_displacement(&rest, s.positions(), STRIP.cells);
        let (d, short) = (dy / l, dx / l);
        let (ed, es) = ((d - d_ref).abs() / d_ref, (short - s_ref).abs() / s_ref);
        eprintln!(
            "self-weight wL³/EI = {alpha}: δ/L {d:.4} vs {d_ref:.4} ({:.2}%), (L − x)/L {short:.4} vs {s_ref:.4} ({:.2}%), \
             linear theory δ/L = {:.3}",
            100.0 * ed,
            100.0 * es,
            alpha / 8.0
        );
        assert!(ed < 0.03 && es < 0.03, "α = {alpha}: deflection error {ed}, shortening error {es}");
    }
}
