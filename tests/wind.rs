//! Wind, one implementation for every method: a strip facing the wind is pushed along it by shells
//! (modal, discrete), cloth and position-based cloth alike, and one edge-on is not moved at all (but
//! for the rounding of the position-based sweeps' single precision); a
//! pinned flag's deflection grows with the wind speed and is nothing without wind; gusts repeat with
//! their seed.

use glam::DVec3;
use shellwarp::scene;
use shellwarp::solver;

/// The cantilever strip (in the xz plane, clamped at x = −0.5) without gravity, by `method`, in a
/// wind of `wind` m/s, after `seconds`: the mean displacement of its vertices.
fn strip(method: &str, wind: [f64; 3], seconds: f64) -> DVec3 {
    let sets = [
        format!("solver.method={method}"),
        "gravity=[0, 0, 0]".into(),
        format!("wind.velocity=[{}, {}, {}]", wind[0], wind[1], wind[2]),
        "material.k_s=500".into(),
    ];
    let setup = scene::load("cantilever", &sets).unwrap();
    let mut s = solver::build(&setup).unwrap();
    let steps = (seconds / s.time_step()).round() as usize;
    for _ in 0..steps {
        s.step().unwrap();
    }
    let rest = setup.mesh.positions();
    s.positions().iter().zip(rest).map(|(x, r)| *x - *r).sum::<DVec3>() / rest.len() as f64
}

#[test]
fn every_method_is_pushed_by_a_wind_facing_it_and_not_by_one_along_it() {
    for (method, seconds) in [
        ("lma", 1.0),
        ("mwts", 1.0),
        ("mwts-rs", 1.0),
        ("ds-implicit", 0.5),
        ("ds-static", 0.2),
        ("ds", 0.02),
        ("cloth", 0.5),
        ("pbd", 0.5),
        ("xpbd", 0.5),
    ] {
        let facing = strip(method, [0.0, 3.0, 0.0], seconds);
        let along = strip(method, [3.0, 0.0, 0.0], seconds);
        eprintln!(
            "{method}: mean displacement {:.3e} m facing the wind, {:.1e} m with the wind along the strip",
            facing.y,
            along.length()
        );
        assert!(facing.y > 1e-4, "{method}: the wind facing the strip pushes it along the wind ({facing})");
        // The position-based sweeps hold positions in single precision (relative to the first
        // particle): a strip at rest there jitters by the rounding of its rows, stiffened by XPBD's
        // small substeps (measured: at most 0.2 µm with `pbd`, 9 µm with `xpbd`, not growing over
        // 10 s), where the wind facing it moves it 0.4 m.
        let still = if method.ends_with("pbd") { 1e-5 } else { 1e-12 };
        assert!(along.length() < still, "{method}: edge-on, the strip feels nothing ({along})");
    }
}

/// The flag pinned along its top edge instead of its pole (a banner, in the xy plane: a single
/// equilibrium, where a flag on a pole may fold) in a steady wind of `speed` m/s across it, by
/// `method`: the mean deflection of its vertices across the plane, averaged over seconds 3 to 6 (its
/// swing about the equilibrium averages out).
fn flag(method: &str, speed: f64) -> f64 {
    let sets = [
        format!("solver.method={method}"),
        format!("wind.velocity=[0, 0, {speed}]"),
        "wind.gust=0".into(),
        "anchors=[{ box = { min = [-0.01, 1.99, -0.01], max = [1.21, 2.01, 0.01] } }]".into(),
    ];
    let setup = scene::load("flag", &sets).unwrap();
    let mut s = solver::build(&setup).unwrap();
    // Damped enough to settle at the balance of drag and weight instead of fluttering about it (and
    // the cloth's PCG allowed to reach its tolerance).
    match method {
        "cloth" => ["k_d", "iterations"].iter().zip([0.05, 200.0]).for_each(|(k, v)| s.set_param(k, v).unwrap()),
        _ => s.set_param("damping", 2.0).unwrap(),
    }
    let steps = (6.0 / s.time_step()).round() as usize;
    let (mut sum, mut count) = (0.0, 0);
    for k in 0..steps {
        s.step().unwrap();
        if 2 * k >= steps {
            sum += s.positions().iter().map(|p| p.z).sum::<f64>() / s.positions().len() as f64;
            count += 1;
        }
    }
    sum / count as f64
}

/// The banner as a rigid plate hinged at its top (height `L`, surface density `ρ_s`) in a wind `w`:
/// the drag on the plate tilted by θ, `½ρ C_d A (w cos θ)²` along its normal at `L/2`, balances its
/// weight's moment `m g (L/2) sin θ`, so `sin θ = k cos²θ` with `k = ρ C_d w² / (2 ρ_s g)`; its mean
/// deflection is `(L/2) sin θ`. (The scene: ρ = 1.2 kg/m³, C_d = 1, ρ_s = 0.15 kg/m², L = 0.8 m.)
fn rigid_banner(w: f64) -> f64 {
    let k = 1.2 * 1.0 * w * w / (2.0 * 0.15 * 9.81);
    let sine = if k == 0.0 { 0.0 } else { (-1.0 + (1.0 + 4.0 * k * k).sqrt()) / (2.0 * k) };
    0.4 * sine
}

#[test]
fn a_pinned_flag_deflects_more_in_a_stronger_wind_and_not_at_all_without() {
    // Beyond about 3 m/s the banner streams almost level.
    let speeds = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0];
    for method in ["xpbd", "cloth"] {
        let deflections: Vec<f64> = speeds.iter().map(|&v| flag(method, v)).collect();
        let rigid: Vec<f64> = speeds.iter().map(|&v| rigid_banner(v)).collect();
        eprintln!(
            "{method}: mean deflection {:?} m at 0, 0.5, 1, 1.5, 2, 3 m/s; a rigid plate: {:?}",
            deflections.iter().map(|d| format!("{d:.4}")).collect::<Vec<_>>(),
            rigid.iter().map(|d| format!("{d:.4}")).collect::<Vec<_>>()
        );
        assert!(deflections[0].abs() < 1e-12, "{method}: no wind, no deflection ({})", deflections[0]);
        assert!(deflections.windows(2).all(|w| w[1] > w[0]), "{method}: grows with the wind: {deflections:?}");
        // A limp banner is no rigid plate (it curves, most near its free edge), but a light one in a
        // steady wind settles close to that balance.
        for (d, r) in deflections.iter().zip(&rigid).skip(1) {
            assert!((d - r).abs() < 0.05 * r, "{method}: {d:.4} m against the rigid plate's {r:.4} m");
        }
    }
}

#[test]
fn gusts_repeat_with_their_seed_in_a_whole_run() {
    let run = |seed: u64| {
        let setup = scene::load("flag", &[format!("wind.seed={seed}")]).unwrap();
        let mut s = solver::build(&setup).unwrap();
        for _ in 0..60 {
            s.step().unwrap();
        }
        s.positions().to_vec()
    };
    assert_eq!(run(7), run(7));
    assert_ne!(run(7), run(8));
}
