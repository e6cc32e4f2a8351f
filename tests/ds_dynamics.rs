//! Dynamics of the discrete shell: the explicit reference (`ds`) against backward Euler
//! (`ds-implicit`) over an oscillation, the explicit stability limit, and implicit settling to the
//! static equilibrium.

mod common;

use common::Strip;
use glam::DVec3;
use shellwarp::solver::{DsExplicit, Solver, SolverError, build};

/// A short, coarse strip; membrane stiffness moderate so the explicit substep stays near 1/30000 s.
const SHORT: Strip = Strip { cells: 13, across: 2, dx: 0.025, width: 0.04 };
const DYN_MATERIAL: &str = "density = 1.0\nk_area = 100.0\nk_length = 100.0\nk_bend = 2e-4";
/// Stiffer in bending: released from rest under gravity the tip swings through about 30% of the
/// length and back, with a fundamental period near 0.3 s.
const SWING_MATERIAL: &str = "density = 1.0\nk_area = 100.0\nk_length = 100.0\nk_bend = 0.05";

/// Sampling interval of the trajectories, s (also the `ds` frame).
const SAMPLE: f64 = 5e-3;

/// Every vertex position at every multiple of [`SAMPLE`] up to `until` (`h` divides `SAMPLE`).
fn trajectory(s: &mut dyn Solver, h: f64, until: f64) -> Vec<Vec<DVec3>> {
    let per_sample = (SAMPLE / h).round() as usize;
    assert!((per_sample as f64 * h - SAMPLE).abs() < 1e-12, "{h} divides the sampling interval");
    let samples = (until / SAMPLE).round() as usize;
    let mut out = vec![s.positions().to_vec()];
    for _ in 0..samples {
        for _ in 0..per_sample {
            let st = s.step().unwrap();
            assert!(st.converged, "{} step did not converge: {st:?}", s.method());
        }
        out.push(s.positions().to_vec());
    }
    out
}

/// Largest vertex distance between two trajectories over all samples, m.
fn max_distance(a: &[Vec<DVec3>], b: &[Vec<DVec3>]) -> f64 {
    a.iter().zip(b).flat_map(|(p, q)| p.iter().zip(q).map(|(p, q)| (*p - *q).length())).fold(0.0, f64::max)
}

#[test]
fn explicit_and_implicit_agree_over_an_oscillation_to_first_order_in_the_step() {
    let until = 0.5;
    let setup = |method: &str, solver: String| SHORT.setup(method, SWING_MATERIAL, &solver);
    let mut ds = build(&setup("ds", format!("step = {SAMPLE}"))).unwrap();
    let reference = trajectory(ds.as_mut(), SAMPLE, until);
    let rest = &reference[0];
    let tip: Vec<f64> = reference.iter().map(|x| SHORT.row_displacement(rest, x, SHORT.cells).0).collect();
    let peak = tip.iter().copied().fold(0.0, f64::max);
    // The window holds a full swing: down to the first maximum sag, back up to the next minimum.
    let down = (1..tip.len() - 1).find(|&i| tip[i] >= tip[i - 1] && tip[i] > tip[i + 1]).expect("a turning point");
    let up = (down + 1..tip.len() - 1).find(|&i| tip[i] <= tip[i - 1] && tip[i] < tip[i + 1]).expect("a second one");
    eprintln!(
        "ds: tip sag peaks at {:.4} m (L = {:.3} m) at t = {:.3} s, swings back to {:.4} m at t = {:.3} s",
        tip[down],
        SHORT.length(),
        down as f64 * SAMPLE,
        tip[up],
        up as f64 * SAMPLE
    );
    assert!(peak > 0.2 * SHORT.length() && tip[up] < 0.2 * tip[down], "a large swing: {peak}, {}", tip[up]);
    let steps = [2.5e-3, 1.25e-3, 6.25e-4, 3.125e-4];
    let runs: Vec<Vec<Vec<DVec3>>> = steps
        .iter()
        .map(|h| {
            let mut im = build(&setup("ds-implicit", format!("step = {h}\ntolerance = 1e-10"))).unwrap();
            trajectory(im.as_mut(), *h, until)
        })
        .collect();
    let errors: Vec<f64> = runs.iter().map(|r| max_distance(r, &reference) / peak).collect();
    // Backward Euler is first order, so the error must halve with h. The Richardson extrapolation
    // 2 y(h/2) − y(h) removes the O(h) term of the smooth motion; it does not reach second order here
    // because `ds` (undamped) keeps the small high-frequency modes the load start excites, which
    // backward Euler damps away wherever ωh is not small, but it must keep falling. Were the two
    // methods' limits different, both sequences would level off at that difference instead.
    let richardson: Vec<f64> = runs
        .windows(2)
        .map(|pair| {
            let extrapolated: Vec<Vec<DVec3>> = pair[1]
                .iter()
                .zip(&pair[0])
                .map(|(fine, coarse)| fine.iter().zip(coarse).map(|(f, c)| *f * 2.0 - *c).collect())
                .collect();
            max_distance(&extrapolated, &reference) / peak
        })
        .collect();
    eprintln!(
        "max vertex error over {until} s / peak tip sag, ds-implicit vs ds: h = {steps:?} → {errors:.4?}; \
         Richardson-extrapolated pairs → {richardson:.5?}"
    );
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!((0.75..1.25).contains(&order), "first-order convergence: {errors:?}");
    }
    for w in richardson.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!(order > 0.75, "the extrapolated error keeps falling: {richardson:?}");
    }
    assert!(errors[3] < 0.03 && richardson[2] < 0.005, "{errors:?}, {richardson:?}");
}

#[test]
fn explicit_substep_limit_is_sharp_and_divergence_is_reported() {
    let setup = SHORT.setup("ds", DYN_MATERIAL, "");
    let limit = DsExplicit::new(&setup).unwrap().stable_limit();
    eprintln!("estimated stable substep of the short strip: {limit:.4e} s");
    let run = |substep: f64, frames: usize| {
        let mut ds = build(&setup).unwrap();
        ds.set_param("substep", substep).unwrap();
        (0..frames).try_for_each(|_| ds.step().map(|_| ())).map(|_| ds)
    };
    // Just below the estimate it is stable; just above and far above it blows up, reported, no panic.
    assert!(run(0.9 * limit, 10).is_ok());
    for factor in [1.1, 10.0] {
        match run(factor * limit, 10) {
            Err(SolverError::Diverged { reason, .. }) => {
                eprintln!("substep {factor} × limit: {reason}");
                assert!(reason.contains("estimated stable limit"), "{reason}");
            }
            Err(e) => panic!("{factor}: {e}"),
            Ok(_) => panic!("substep {factor} × the stable limit did not diverge"),
        }
    }
    // After a divergence, reset and the automatic substep run again.
    let mut ds = build(&setup).unwrap();
    ds.set_param("substep", 10.0 * limit).unwrap();
    assert!(ds.step().is_err());
    ds.reset();
    ds.set_param("substep", 0.0).unwrap();
    let st = ds.step().unwrap();
    assert!(st.energy.is_finite() && ds.positions().iter().all(|p| p.is_finite()));
}

#[test]
fn implicit_is_stable_at_a_frame_step_and_settles_to_the_static_equilibrium() {
    let mut im = build(&SHORT.setup("ds-implicit", DYN_MATERIAL, "rayleigh_alpha = 8.0")).unwrap();
    let rest = im.positions().to_vec();
    for _ in 0..150 {
        let st = im.step().unwrap();
        assert!(st.energy.is_finite() && st.converged, "{st:?}");
    }
    let mut st = build(&SHORT.setup("ds-static", DYN_MATERIAL, "iterations = 500")).unwrap();
    let stats = st.step().unwrap();
    eprintln!("ds-static from rest: {stats:?}");
    assert!(stats.converged, "{stats:?}");
    let a = SHORT.row_displacement(&rest, im.positions(), SHORT.cells).0;
    let b = SHORT.row_displacement(&rest, st.positions(), SHORT.cells).0;
    eprintln!("after 5 s of damped ds-implicit at 1/30 s the tip sag is {a:.5} m; ds-static gives {b:.5} m");
    assert!((a - b).abs() < 1e-3 * b.abs(), "{a} vs {b}");
}

/// The estimated stable substep follows the stiffness (four times stiffer: about half the step, as
/// `ω_max ∝ √k`) and ignores the load (a gravity edit keeps it exactly).
#[test]
fn the_stable_limit_follows_the_stiffness_not_the_load() {
    let setup = SHORT.setup("ds", DYN_MATERIAL, "");
    let mut ds = DsExplicit::new(&setup).unwrap();
    let limit = ds.stable_limit();
    ds.set_param("gravity_y", -30.0).unwrap();
    assert_eq!(ds.stable_limit(), limit);
    let stiffness: Vec<(&str, f64)> =
        ds.params().iter().filter(|p| p.spec.name.starts_with("k_")).map(|p| (p.spec.name, p.value)).collect();
    assert_eq!(stiffness.len(), 3, "{stiffness:?}");
    for (name, value) in stiffness {
        ds.set_param(name, 4.0 * value).unwrap();
    }
    let ratio = ds.stable_limit() / limit;
    eprintln!("stable substep {limit:.4e} s; four times stiffer: {:.4e} s (× {ratio:.4})", ds.stable_limit());
    assert!((ratio - 0.5).abs() < 0.05, "× {ratio}");
}
