//! Physics validation of the discrete-shell solvers: Euler–Bernoulli cantilever, the large-deflection
//! elastica, explicit vs implicit dynamics, and explicit instability.

use std::path::PathBuf;

use glam::DVec3;
use shellwarp::scene::{self, Origin, Setup};
use shellwarp::solver::{Solver, SolverError, build};

/// A strip along x: `cells` cells of length `dx` (so `cells + 1` vertex rows), `across` cells across a
/// width `width`, clamped by fixing the first two vertex rows. Beam length from the second row is
/// `(cells − 1) dx`.
struct Strip {
    cells: usize,
    across: usize,
    dx: f64,
    width: f64,
}

impl Strip {
    fn setup(&self, method: &str, material: &str, extra: &str) -> Setup {
        let total = self.cells as f64 * self.dx;
        let clamp = -total / 2.0 + 1.5 * self.dx;
        let text = format!(
            r#"
name = "test strip"
[mesh.grid]
size = [{total}, {width}]
segments = [{cells}, {across}]
[material]
{material}
[[anchors]]
box = {{ min = [-10.0, -1.0, -1.0], max = [{clamp}, 1.0, 1.0] }}
[solver]
method = "{method}"
{extra}
"#,
            width = self.width,
            cells = self.cells,
            across = self.across,
        );
        let origin = Origin { label: "test".into(), dir: PathBuf::from(".") };
        let setup = Setup::new(scene::parse(&text, &origin, &[]).unwrap(), origin).unwrap();
        assert_eq!(setup.anchors.len(), 2 * (self.across + 1), "exactly two rows clamped");
        setup
    }

    fn length(&self) -> f64 {
        (self.cells - 1) as f64 * self.dx
    }

    /// Mean (over the row) downward deflection and horizontal (x) shortening of vertex row `i`.
    fn row_displacement(&self, rest: &[DVec3], x: &[DVec3], i: usize) -> (f64, f64) {
        let n = self.across + 1;
        let (mut dy, mut dxs) = (0.0, 0.0);
        for j in 0..n {
            let v = i * n + j;
            dy += rest[v].y - x[v].y;
            dxs += rest[v].x - x[v].x;
        }
        (dy / n as f64, dxs / n as f64)
    }
}

/// Euler–Bernoulli cantilever under uniform load: `y(s)/y(L) = s²(6L² − 4Ls + s²)/(3L⁴)`.
fn euler_bernoulli_shape(s: f64, l: f64) -> f64 {
    s * s * (6.0 * l * l - 4.0 * l * s + s * s) / (3.0 * l.powi(4))
}

const DENSITY: f64 = 0.5;
const K_BEND: f64 = 1e-3;
const STRIP: Strip = Strip { cells: 61, across: 2, dx: 1.0 / 60.0, width: 0.04 };

fn static_strip(k_bend: f64) -> Box<dyn Solver> {
    // Nearly inextensible: membrane stiffness 10⁶ × the bending stiffness.
    let material = format!("density = {DENSITY}\nk_area = 1000.0\nk_length = 1000.0\nk_bend = {k_bend}");
    build(&STRIP.setup("ds-static", &material, "iterations = 200\ntolerance = 1e-10")).unwrap()
}

/// Solve the static cantilever at gravity `g` (m/s², downward), ramping the load in `ramp` stages.
fn equilibrium(s: &mut dyn Solver, g: f64, ramp: usize) -> Vec<DVec3> {
    for k in 1..=ramp {
        s.set_param("gravity_y", -g * k as f64 / ramp as f64).unwrap();
        let stats = s.step().unwrap();
        assert!(stats.iterations < 200, "Newton did not converge: {stats:?}");
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

/// Large-deflection cantilever under a uniformly distributed dead load (self-weight), nondimensional:
/// `θ'' = −α (1 − σ) cos θ`, `θ(0) = 0`, `θ'(1) = 0` with `α = wL³/EI`, σ = s/L and θ the slope angle
/// (positive downwards). Solved by shooting on `θ'(0)` (bisection) with RK4; returns the tip deflection
/// `δ/L = ∫ sin θ dσ` and horizontal tip position `x/L = ∫ cos θ dσ`.
///
/// This is the classical elastica of a cantilever under self-weight (Rohde, Q. Appl. Math. 11, 1953;
/// tabulated by Lee, Int. J. Non-Linear Mech. 37, 2002). The reference is computed here rather than
/// copied from those tables, and its discretisation error is checked by halving the step.
fn elastica(alpha: f64, steps: usize) -> (f64, f64) {
    let integrate = |k0: f64| {
        let h = 1.0 / steps as f64;
        // State: θ, θ', x, y.
        let f = |s: f64, u: [f64; 4]| [u[1], -alpha * (1.0 - s) * u[0].cos(), u[0].cos(), u[0].sin()];
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
    let (mut lo, mut hi) = (0.0, alpha / 2.0 * 1.001);
    assert!(integrate(lo)[1] < 0.0 && integrate(hi)[1] > 0.0, "bracket");
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if integrate(mid)[1] > 0.0 { hi = mid } else { lo = mid }
    }
    let u = integrate(0.5 * (lo + hi));
    (u[3], u[2])
}

#[test]
fn elastica_reference_converges_and_has_the_linear_limit() {
    for alpha in [0.01, 3.0, 12.0] {
        let (d1, x1) = elastica(alpha, 2000);
        let (d2, x2) = elastica(alpha, 4000);
        assert!((d1 - d2).abs() < 1e-10 && (x1 - x2).abs() < 1e-10, "α = {alpha}: {d1} vs {d2}");
    }
    // Small α: Euler–Bernoulli δ/L = α/8.
    let (d, _) = elastica(0.01, 2000);
    assert!((d / (0.01 / 8.0) - 1.0).abs() < 1e-4, "{d}");
}

#[test]
fn cantilever_large_load_matches_the_elastica() {
    let l = STRIP.length();
    let (_, ei, _) = small_load(K_BEND, 5e-4);
    let mut s = static_strip(K_BEND);
    let rest = s.positions().to_vec();
    let mut g_prev = 0.0;
    for alpha in [2.0, 5.0, 10.0, 20.0] {
        let (d_ref, x_ref) = elastica(alpha, 4000);
        // Load per unit length w = ρ b g with α = wL³/EI.
        let g = alpha * ei / (DENSITY * STRIP.width * l.powi(3));
        // Continue from the previous equilibrium, ramping the extra load in a few stages.
        for k in 1..=4 {
            s.set_param("gravity_y", -(g_prev + (g - g_prev) * k as f64 / 4.0)).unwrap();
            let st = s.step().unwrap();
            assert!(st.iterations < 200, "{st:?}");
        }
        g_prev = g;
        let (dy, dx) = STRIP.row_displacement(&rest, s.positions(), STRIP.cells);
        // The clamp row is at arc length 0: x/L of the tip = 1 − shortening/L.
        let (d_sim, x_sim) = (dy / l, 1.0 - dx / l);
        let (ed, ex) = ((d_sim - d_ref).abs() / d_ref, (x_sim - x_ref).abs() / x_ref);
        eprintln!(
            "elastica α = {alpha}: δ/L sim {d_sim:.4} ref {d_ref:.4} (err {:.2}%), x/L sim {x_sim:.4} ref {x_ref:.4} (err {:.2}%), linear theory δ/L = {:.3}",
            100.0 * ed,
            100.0 * ex,
            alpha / 8.0
        );
        assert!(ed < 0.03 && ex < 0.03, "α = {alpha}: deflection error {ed}, horizontal error {ex}");
    }
}

/// A short, coarse strip for dynamics (membrane stiffness kept moderate so 1/30000 s is stable).
const SHORT: Strip = Strip { cells: 13, across: 2, dx: 0.025, width: 0.04 };
const DYN_MATERIAL: &str = "density = 1.0\nk_area = 100.0\nk_length = 100.0\nk_bend = 2e-4";

fn tip_trajectory(s: &mut dyn Solver, until: f64) -> Vec<(f64, f64)> {
    let rest = s.positions().to_vec();
    let mut out = Vec::new();
    let mut t = 0.0;
    while t < until - 1e-9 {
        t = s.step().unwrap().sim_time;
        out.push((t, SHORT.row_displacement(&rest, s.positions(), SHORT.cells).0));
    }
    out
}

#[test]
fn explicit_and_implicit_agree_on_a_short_dynamic_run() {
    let until = 0.2;
    let mut ds = build(&SHORT.setup("ds", DYN_MATERIAL, "")).unwrap();
    let reference = tip_trajectory(ds.as_mut(), until);
    let (t_end, tip_end) = *reference.last().unwrap();
    let peak = reference.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
    let mut errors = Vec::new();
    for h in [2e-3, 1e-3, 5e-4] {
        let mut im =
            build(&SHORT.setup("ds-implicit", DYN_MATERIAL, &format!("step = {h}\ntolerance = 1e-10"))).unwrap();
        let traj = tip_trajectory(im.as_mut(), until);
        let (t, tip) = *traj.last().unwrap();
        assert!((t - t_end).abs() < 1e-9);
        errors.push((tip - tip_end).abs() / peak);
    }
    eprintln!(
        "ds tip at t = {t_end:.3}: {tip_end:.5} m (peak {peak:.5}); ds-implicit relative errors for h = 2e-3, 1e-3, 5e-4: {errors:?}"
    );
    assert!(peak > 1e-3, "the strip moves visibly");
    // Backward Euler is first order: halving h roughly halves the error, and at 5e-4 s it is small.
    assert!(errors[1] < 0.7 * errors[0] && errors[2] < 0.7 * errors[1], "{errors:?}");
    assert!(errors[2] < 0.03, "{errors:?}");
}

#[test]
fn explicit_blows_up_above_its_stable_step_and_reports_divergence() {
    let mut ds = build(&SHORT.setup("ds", DYN_MATERIAL, "")).unwrap();
    ds.set_param("substep", 1.0 / 300.0).unwrap();
    let mut outcome = None;
    for _ in 0..60 {
        if let Err(e) = ds.step() {
            outcome = Some(e);
            break;
        }
    }
    assert!(matches!(outcome, Some(SolverError::Diverged { .. })), "{outcome:?}");
    // After reset and a stable step it runs again.
    ds.reset();
    ds.set_param("substep", 1.0 / 30000.0).unwrap();
    assert!(ds.step().is_ok());
}

#[test]
fn implicit_is_stable_at_a_frame_step_and_settles_to_the_static_equilibrium() {
    let mut im = build(&SHORT.setup("ds-implicit", DYN_MATERIAL, "rayleigh_alpha = 8.0")).unwrap();
    let rest = im.positions().to_vec();
    for _ in 0..150 {
        let st = im.step().unwrap();
        assert!(st.energy.is_finite() && st.iterations < 50, "{st:?}");
    }
    let mut st = build(&SHORT.setup("ds-static", DYN_MATERIAL, "")).unwrap();
    let first = st.step().unwrap();
    let second = st.step().unwrap();
    eprintln!("ds-static from rest: {first:?}; continued: {second:?}");
    let a = SHORT.row_displacement(&rest, im.positions(), SHORT.cells).0;
    let b = SHORT.row_displacement(&rest, st.positions(), SHORT.cells).0;
    eprintln!("after 5 s of damped ds-implicit at 1/30 s the tip sag is {a:.5} m; ds-static gives {b:.5} m");
    assert!((a - b).abs() < 1e-3 * b.abs(), "{a} vs {b}");
}
