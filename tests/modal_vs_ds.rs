//! The paper's Figures 5–6: flat beam and V-beam under a sweep of gravity, 8 modes, against the
//! nonlinear static equilibrium (`ds-static`).
//!
//! What holds, and is asserted: modal warping's displacement error is below linear modal analysis's
//! at every gravity level, and its area change is a fraction of LMA's, which inflates the shell as
//! rotations grow.
//!
//! What does not hold, and is not asserted: the issue's line "MWTS's relative area change stays
//! below 1% where LMA's exceeds 10%". MWTS's area change is 1.5–2% where LMA's first passes 10%
//! (flat beam at g = 20: 1.9% against 12.6%; V-beam at g = 400: 1.8% against 14%). That is the
//! closed-form warp's own second-order term, not a defect: on a strip it changes the length by
//! `−∫w w″/2` where LMA's changes it by `+∫w′²/2`, a ratio fixed by the deflection's shape (derivation
//! in `src/solver/modal/warp.rs`). [`closed_form_area_change_matches_its_derivation`] checks the
//! prediction against the code.

use glam::DVec3;
use shellwarp::energy::ShellStiffness;
use shellwarp::scene::{self, Setup};
use shellwarp::solver::modal::compute::{ModalProblem, analyse};
use shellwarp::solver::modal::warp::{coefficients, warp};
use shellwarp::solver::{self, Solver};

fn area(x: &[DVec3], tris: &[[usize; 3]]) -> f64 {
    tris.iter().map(|t| 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).length()).sum()
}

/// Settle a method at gravity `g` (heavily damped steps; ds-static converges in its own step).
fn settle(setup: &Setup, method: &str, g: f64) -> Vec<DVec3> {
    let mut setup = setup.clone();
    setup.scene.solver.method = method.into();
    let mut s: Box<dyn Solver> = solver::build(&setup).unwrap();
    s.set_param("gravity_y", -g).unwrap();
    let steps = if method == "ds-static" { 4 } else { 400 };
    for _ in 0..steps {
        s.step().unwrap_or_else(|e| panic!("{method} at g = {g}: {e}"));
    }
    s.positions().to_vec()
}

fn sweep(scene_name: &str, gravity: &[f64]) {
    let setup = scene::load(scene_name, &["solver.rayleigh_alpha=20".into(), "solver.iterations=400".into()]).unwrap();
    assert_eq!(setup.scene.solver.modes, 8, "the paper's mode count");
    let rest = setup.mesh.positions();
    let tris = setup.mesh.triangles();
    let a0 = area(rest, tris);
    let disp = |x: &[DVec3]| x.iter().zip(rest).map(|(a, b)| *a - *b).collect::<Vec<_>>();
    let norm = |u: &[DVec3]| u.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
    let mut worst_lma_area: f64 = 0.0;
    eprintln!("{scene_name}: g, displacement error LMA / MWTS, relative area change DS / LMA / MWTS");
    for &g in gravity {
        let ds = settle(&setup, "ds-static", g);
        let u_ds = disp(&ds);
        let [lma, mwts] = ["lma", "mwts"].map(|method| {
            let x = settle(&setup, method, g);
            let u = disp(&x);
            let err = norm(&u.iter().zip(&u_ds).map(|(a, b)| *a - *b).collect::<Vec<_>>()) / norm(&u_ds);
            (err, (area(&x, tris) - a0).abs() / a0)
        });
        let ds_area = (area(&ds, tris) - a0).abs() / a0;
        eprintln!(
            "{scene_name} g = {g:>4}: error {:.4} / {:.4}; area {ds_area:.1e} / {:.2}% / {:.2}%",
            lma.0,
            mwts.0,
            100.0 * lma.1,
            100.0 * mwts.1
        );
        assert!(mwts.0 < lma.0, "{scene_name} g = {g}: MWTS error {:.4} not below LMA's {:.4}", mwts.0, lma.0);
        // The closed-form warp keeps a fixed fraction of LMA's area change (derivation in warp.rs): at most a
        // quarter wherever LMA's exceeds 1% (measured 0.19 → 0.05 flat, 0.19 → 0.08 V, falling as rotations grow).
        if lma.1 > 0.01 {
            assert!(
                mwts.1 <= 0.25 * lma.1,
                "{scene_name} g = {g}: MWTS area change {:.2e} vs LMA {:.2e}",
                mwts.1,
                lma.1
            );
        }
        // The nonlinear reference keeps its area (the membrane is 2000× stiffer than bending).
        assert!(ds_area < 0.01 * lma.1.max(0.1), "{scene_name} g = {g}: DS area change {ds_area:.2e}");
        worst_lma_area = worst_lma_area.max(lma.1);
    }
    assert!(worst_lma_area > 0.10, "{scene_name}: the sweep reaches large rotations (LMA area {worst_lma_area:.3})");
}

#[test]
fn flat_beam_gravity_sweep() {
    sweep("cantilever", &[5.0, 10.0, 20.0, 40.0, 100.0]);
}

#[test]
fn v_beam_gravity_sweep() {
    sweep("v-beam", &[40.0, 100.0, 200.0, 400.0, 800.0]);
}

/// The derivation in `warp.rs`, checked on the flat cantilever at a small load. To second order the
/// warped node `i` sits at `X_i + w_i n − ½ w_i (θ_i × n)` (normal deflection `w`, rotation
/// `θ = Ψ_i q`): along the centreline, `(x_i − w_i θ_i / 2, w_i)`, so its length changes by
/// `Σ (Δw)²/(2Δx) − w_tip θ_tip / 2` where LMA's changes by `Σ (Δw)²/(2Δx)`. The same term across the
/// width (the discrete strip sags 0.6% more at its edges, rotating them by ±8e-4 about x) narrows it.
/// Together MWTS shrinks the strip by a fifth of what LMA stretches it.
#[test]
fn closed_form_area_change_matches_its_derivation() {
    let setup = scene::load("cantilever", &[]).unwrap();
    let masses = setup.masses();
    let m = &setup.scene.material;
    let p = ModalProblem {
        mesh: &setup.mesh,
        anchors: &setup.anchors,
        masses: &masses,
        stiffness: ShellStiffness::from(m),
        modes: 8,
        keep_rigid: false,
    };
    let a = analyse(&p, &|_| {}).unwrap();
    let b = &a.basis;
    let (rest, tris) = (setup.mesh.positions(), setup.mesh.triangles());
    let n = rest.len();
    // LMA's static solution under a small gravity: q_j = φ_jᵀ f / λ_j.
    let g = 2.0;
    let q: Vec<f64> = (0..b.modes())
        .map(|j| (0..n).map(|v| -g * masses[v] * b.phi(v, 1, j)).sum::<f64>() / b.eigenvalues[j])
        .collect();
    let lma: Vec<DVec3> = (0..n).map(|v| rest[v] + b.displacement(v, &q)).collect();
    let mwts: Vec<DVec3> = (0..n)
        .map(|v| {
            let w = b.rotation(v, &q);
            rest[v] + warp(w, coefficients(w.length_squared()), b.displacement(v, &q))
        })
        .collect();
    // Centreline: the middle vertex of each row of 5, from the clamp's second (fixed) row to the tip.
    let per_row = 5;
    let line: Vec<usize> = (1..n / per_row).map(|i| i * per_row + 2).collect();
    let length = |x: &[DVec3]| line.windows(2).map(|s| (x[s[1]] - x[s[0]]).length()).sum::<f64>();
    let l0 = length(rest);
    let w = |v: usize| lma[v].y - rest[v].y;
    let dx = rest[line[1]].x - rest[line[0]].x;
    let stretch: f64 = line.windows(2).map(|s| (w(s[1]) - w(s[0])).powi(2) / (2.0 * dx)).sum();
    let tip = *line.last().unwrap();
    let predicted = [stretch, stretch - 0.5 * w(tip) * b.rotation(tip, &q).z].map(|d| d / l0);
    let measured = [length(&lma) / l0 - 1.0, length(&mwts) / l0 - 1.0];
    let a0 = area(rest, tris);
    let areas = [(area(&lma, tris) - a0) / a0, (area(&mwts, tris) - a0) / a0];
    eprintln!(
        "centreline length change LMA {:.4e} (predicted {:.4e}), MWTS {:.4e} (predicted {:.4e}); \
         area change LMA {:.3e}, MWTS {:.3e}: ratio {:.3}",
        measured[0],
        predicted[0],
        measured[1],
        predicted[1],
        areas[0],
        areas[1],
        areas[1] / areas[0]
    );
    for (got, want) in measured.iter().zip(predicted) {
        assert!((got - want).abs() < 0.01 * want.abs(), "{got:.4e} vs {want:.4e}");
    }
    assert!(predicted[1] < 0.0 && areas[0] > 0.0 && areas[1] < 0.0, "LMA stretches, the warp shrinks");
    assert!((-0.25..-0.15).contains(&(areas[1] / areas[0])), "a fifth of LMA's, opposite sign");
}
