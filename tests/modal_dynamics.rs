//! MWTS dynamics: twisting a beam's tip by 90°, 180° and 360° (checked at every step), the return to
//! the exact rest shape after a large loop through modal space, background mode recomputation and
//! the projection of the state onto a new basis, drags that ask too much, and a divergence. Every solver gets a
//! fresh, private mode cache.

mod modal_common;
mod twist_common;

use glam::DVec3;
use modal_common::strip;
use shellwarp::energy::ShellStiffness;
use shellwarp::scene::{self, Setup};
use shellwarp::solver::modal::cache::Cache;
use shellwarp::solver::modal::compute::{ModalProblem, analyse};
use shellwarp::solver::modal::dynamics::{ModalDynamics, ModalParams, Shape};
use shellwarp::solver::modal::method::{ModalSolver, Variant};
use shellwarp::solver::{Drag, DragKind, DragSet, Solver, SolverError};
use twist_common::{RAMP, helicoid_area_change, twist};

/// An empty cache directory of this test's own, and the guard that removes it when dropped.
fn fresh_cache(name: &str) -> (tempfile::TempDir, Cache) {
    let dir = tempfile::Builder::new().prefix(&format!("shellwarp-modal-test-{name}-")).tempdir().unwrap();
    let cache = Cache::at(dir.path().join("cache"));
    (dir, cache)
}

#[test]
fn mwts_twists_a_beam_smoothly_by_90_180_and_360_degrees_at_every_step() {
    let segments = [40, 4];
    let setup = strip(1.0, 0.1, segments, true, &["solver.modes=12", "gravity=[0, 0, 0]", "solver.rayleigh_alpha=4"]);
    let tip = segments[0] * (segments[1] + 1) + segments[1] / 2;
    for degrees in [90.0f64, 180.0, 360.0] {
        let run = |warp: bool| {
            let (_dir, cache) = fresh_cache(&format!("twist-{degrees}-{warp}"));
            let variant = if warp { Variant::Mwts } else { Variant::Lma };
            twist(&mut ModalSolver::with_cache(&setup, variant, cache).unwrap(), &setup, tip, degrees)
        };
        let (mwts, lma) = (run(true), run(false));
        eprintln!(
            "{degrees}°: MWTS tip at {:.1}°; over all 90 steps: width within {:.2}% (LMA: {:.0}%), largest twist \
             between neighbouring rows {:.2}°, largest change of a row in one step {:.1}°; centreline length \
             within {:.2}%, area within {:.2}% (at the end {:+.2}%, a straight-axis helicoid {:+.2}%), largest fold \
             between neighbouring triangles {:.1}°",
            mwts.end.to_degrees(),
            100.0 * mwts.width,
            100.0 * lma.width,
            mwts.row_step.to_degrees(),
            mwts.time_step.to_degrees(),
            100.0 * mwts.centreline,
            100.0 * mwts.area,
            100.0 * mwts.end_area,
            100.0 * helicoid_area_change(&setup, degrees),
            mwts.fold.to_degrees()
        );
        assert!(
            (mwts.end.to_degrees() - degrees).abs() < 0.1 * degrees,
            "{degrees}°: tip twisted {:.1}°",
            mwts.end.to_degrees()
        );
        // Cross-sections keep their width within 10% (LMA's by 85% at 90° and 530% at 360°) ...
        assert!(mwts.width < 0.1, "{degrees}°: width changed by {:.1}%", 100.0 * mwts.width);
        assert!(lma.width > 0.3, "the width test can tell: LMA changes it by {:.0}%", 100.0 * lma.width);
        // ... twist smoothly along the beam: a uniform twist puts degrees/40 between rows; allow 3× that
        // for the clamp's boundary layer and the dynamics ...
        assert!(mwts.row_step.to_degrees() < 3.0 * degrees / segments[0] as f64, "{degrees}°: rows flip");
        // ... and in time: the target turns degrees/30 per step; no row moves 3× faster.
        assert!(mwts.time_step.to_degrees() < 3.0 * degrees / RAMP as f64, "{degrees}°: a row jumps in one step");
    }
}

/// The cantilever scene's modes (no external force) as a bare `ModalDynamics`, with its masses.
fn cantilever_dynamics(modes: usize, overrides: &[&str]) -> (ModalDynamics, Vec<f64>, Setup) {
    let setup = scene::load("cantilever", &overrides.iter().map(|o| o.to_string()).collect::<Vec<_>>()).unwrap();
    let masses = setup.masses();
    let stiffness = ShellStiffness::from(&setup.scene.material);
    let p = ModalProblem {
        mesh: &setup.mesh,
        anchors: &setup.anchors,
        masses: &masses,
        stiffness,
        modes,
        keep_rigid: false,
    };
    let basis = analyse(&p, &|_| {}).unwrap().basis;
    let dynamics = ModalDynamics::new(basis, setup.mesh.positions().to_vec(), Vec::new(), Shape::Warp);
    (dynamics, masses, setup)
}

#[test]
fn after_a_large_loop_through_modal_space_the_shell_comes_back_to_rest() {
    // Drag the tip's orientation around a loop of rotations up to 2 rad (twist and bend together),
    // back to zero, release, and let damping take q to zero. The closed form depends on q alone, so
    // the shell returns to rest as q does — no spurious rotation left over (integrating frames step by
    // step leaves tens of degrees after such a loop).
    let (mut d, _, setup) = cantilever_dynamics(8, &[]);
    let rest = setup.mesh.positions().to_vec();
    let tip = 202;
    let params = ModalParams { step: 1.0 / 30.0, alpha: 6.0, beta: 0.0, constraint_damping: 1e-2 };
    let mut drags = DragSet::new(rest.len(), true);
    let id = drags.add(Drag { vertex: tip, kind: DragKind::Orientation(DVec3::ZERO) }).unwrap();
    let (mut farthest, mut largest_rotation) = (0.0f64, 0.0f64);
    let loop_steps = 120;
    for k in 0..=loop_steps {
        let phase = std::f64::consts::TAU * k as f64 / loop_steps as f64;
        let target = DVec3::new(2.0 * phase.sin(), 0.0, 1.0 - phase.cos());
        drags.retarget(id, DragKind::Orientation(target)).unwrap();
        d.step(&params, &drags);
        let off = d.positions().iter().zip(&rest).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        farthest = farthest.max(off);
        largest_rotation = largest_rotation.max(d.basis.rotation(tip, &d.q).length());
    }
    drags.clear();
    let mut steps = 0;
    while d.q.iter().map(|q| q.abs()).fold(0.0, f64::max) > 1e-12 {
        d.step(&params, &drags);
        steps += 1;
        assert!(steps < 20_000, "damping brings q to zero");
    }
    let q_max = d.q.iter().map(|q| q.abs()).fold(0.0, f64::max);
    let phi_max = (0..rest.len())
        .flat_map(|v| (0..d.basis.modes()).map(move |j| (v, j)))
        .map(|(v, j)| (0..3).map(|a| d.basis.phi(v, a, j).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    let off = d.positions().iter().zip(&rest).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    eprintln!(
        "loop: tip rotated up to {largest_rotation:.2} rad, shell moved up to {farthest:.3} m; after release and \
         {steps} damped steps |q| ≤ {q_max:.1e} and the shell is {off:.1e} m from rest (bound {:.1e})",
        2.0 * phi_max * q_max * d.basis.modes() as f64
    );
    assert!(largest_rotation > 1.5 && farthest > 0.2, "the loop goes far from rest");
    assert!(off <= 2.0 * phi_max * q_max * d.basis.modes() as f64, "no offset beyond what q itself explains");
    // And q = 0 exactly is the rest shape, bit for bit.
    d.reset();
    assert_eq!(d.positions(), &rest[..]);
}

#[test]
fn a_stiffness_change_projects_the_state_onto_the_new_basis() {
    // New modes for a 2000× softer membrane (shapes change, not just frequencies): the old displacement
    // is not in their span, so the carried state is its M-orthogonal projection — the residual is
    // M-orthogonal to every new mode.
    let (mut d, masses, setup) = cantilever_dynamics(8, &[]);
    let n = masses.len();
    let forces: Vec<DVec3> = masses.iter().map(|m| DVec3::new(0.1, -9.81, 0.05) * *m).collect();
    d.set_forces(forces);
    let params = ModalParams { step: 1.0 / 30.0, alpha: 2.0, beta: 0.0, constraint_damping: 1e-2 };
    // A sideways pull on a tip corner: lateral bending and torsion as well as sag, in motion.
    let mut drags = DragSet::new(n, true);
    let corner = n - 1;
    let target = setup.mesh.positions()[corner] + DVec3::new(0.0, 0.1, 0.15);
    drags.add(Drag { vertex: corner, kind: DragKind::Position(target) }).unwrap();
    for _ in 0..4 {
        d.step(&params, &drags);
    }
    let linear = |d: &ModalDynamics, c: &[f64]| (0..n).map(|v| d.basis.displacement(v, c)).collect::<Vec<_>>();
    let (u_old, v_old) = (linear(&d, &d.q), linear(&d, &d.v));
    let (softer, _, _) = cantilever_dynamics(8, &["material.k_area=0.5", "material.k_length=0.5"]);
    d.replace_basis(softer.basis, &masses);
    let (u_new, v_new) = (linear(&d, &d.q), linear(&d, &d.v));
    let m_dot = |a: &[DVec3], b: &[DVec3]| a.iter().zip(b).zip(&masses).map(|((x, y), m)| m * x.dot(*y)).sum::<f64>();
    for (what, old, new) in [("displacement", &u_old, &u_new), ("velocity", &v_old, &v_new)] {
        let residual: Vec<DVec3> = old.iter().zip(new).map(|(a, b)| *a - *b).collect();
        let lost = (m_dot(&residual, &residual) / m_dot(old, old)).sqrt();
        let worst = (0..d.basis.modes())
            .map(|j| {
                let mode: Vec<DVec3> = (0..n).map(|v| d.basis.displacement(v, &unit(d.basis.modes(), j))).collect();
                m_dot(&mode, &residual).abs() / m_dot(old, old).sqrt()
            })
            .fold(0.0, f64::max);
        eprintln!("{what}: {:.2e} of it (M-norm) is outside the new basis; residual·mode ≤ {worst:.1e}", lost);
        assert!(lost > 1e-4, "{what}: the new basis does not contain the old state");
        assert!(worst < 1e-12, "{what}: the residual is M-orthogonal to the new modes");
    }
}

/// The `j`-th unit vector of length `m`.
fn unit(m: usize, j: usize) -> Vec<f64> {
    (0..m).map(|i| if i == j { 1.0 } else { 0.0 }).collect()
}

#[test]
fn changing_the_mode_count_recomputes_in_the_background_and_carries_the_state_over() {
    let setup = scene::load("cantilever", &["solver.modes=6".into()]).unwrap();
    let (_dir, cache) = fresh_cache("mode-count");
    let mut s = ModalSolver::with_cache(&setup, Variant::Mwts, cache).unwrap();
    assert_eq!(s.analysis().basis.modes(), 6);
    for _ in 0..20 {
        s.step().unwrap();
    }
    let sag = s.positions().iter().zip(setup.mesh.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    s.set_param("modes", 10.0).unwrap();
    // Until a step polls the background job (or we wait for it), the old basis stays in use: this
    // holds whatever the timing.
    assert!(s.progress().is_some(), "a background recompute is reported");
    assert_eq!(s.analysis().basis.modes(), 6);
    let before = s.positions().to_vec();
    s.wait_for_modes().unwrap();
    assert!(s.progress().is_none());
    assert_eq!(s.analysis().basis.modes(), 10, "the new basis is in use");
    // The swap moves the shape by the projection's loss only, far less than the sag.
    let jump = before.iter().zip(s.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    eprintln!("swap: shape moved {jump:.2e} m (sag {sag:.3} m)");
    assert!(jump < 0.05 * sag, "jump {jump} at the swap, sag {sag}");
    // Through the step loop: a stiffness change swaps in when a step finds it done; every step runs.
    let softer = s.analysis().basis.eigenvalues.clone();
    s.set_param("k_bend", 1.0).unwrap();
    let start = std::time::Instant::now();
    while s.progress().is_some() {
        s.step().expect("the step loop keeps running on the old modes meanwhile");
        assert!(start.elapsed().as_secs() < 60, "the background analysis finishes");
    }
    s.step().unwrap();
    // The scene's k_bend is 0.5: doubling it doubles the first (pure bending) eigenvalue.
    let stiffer = &s.analysis().basis.eigenvalues;
    assert!(
        (stiffer[0] / softer[0] - 2.0).abs() < 0.01,
        "the stiffer modes are in use: λ₁ {} → {}",
        softer[0],
        stiffer[0]
    );
}

#[test]
fn an_unreachable_drag_stays_calm_under_the_default_damping() {
    // Pulling the tip sideways and toward the clamp asks the bending modes for what they cannot do.
    let setup = scene::load("cantilever", &[]).unwrap();
    let (_dir, cache) = fresh_cache("unreachable");
    let mut s = ModalSolver::with_cache(&setup, Variant::Mwts, cache).unwrap();
    let tip = 204;
    let target = DVec3::new(0.35, 0.2, 0.15);
    s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Position(target) }).unwrap();
    let mut energies = Vec::new();
    for _ in 0..240 {
        energies.push(s.step().unwrap().energy);
    }
    let late = &energies[120..];
    let (lo, hi) = late.iter().fold((f64::MAX, 0.0f64), |(l, h), &e| (l.min(e), h.max(e)));
    assert!(hi < 10.0 && hi - lo < 0.05 * hi, "settled, not thrashing: energy in [{lo}, {hi}] J");
    let gap = (s.positions()[tip] - target).length();
    assert!(gap < 0.1, "the tip comes as close as the modes allow: {gap} m");
}

/// A pull a kilometre away from a 1 m strip is no motion a shell makes: `lma` and `mwts` follow it
/// with an energy of 3.6e8 J, which passes the limit (a million times the loads' work across the
/// body, as for the discrete shell's methods) and is reported as a divergence; *Reset* recovers. The
/// limit was 1e12 times the largest eigenvalue (in 1/s², not J), which let such a step pass.
#[test]
fn a_pull_a_kilometre_away_is_reported_as_a_divergence_and_reset_recovers() {
    let setup = scene::load("cantilever", &[]).unwrap();
    for variant in [Variant::Lma, Variant::Mwts] {
        let (_dir, cache) = fresh_cache("kilometre");
        let mut s = ModalSolver::with_cache(&setup, variant, cache).unwrap();
        let far = setup.mesh.positions()[100] + DVec3::new(0.0, -1000.0, 0.0);
        s.drags_mut().add(Drag { vertex: 100, kind: DragKind::Position(far) }).unwrap();
        match s.step() {
            Err(SolverError::Diverged { reason, .. }) => assert!(reason.contains("exceeds the limit"), "{reason}"),
            other => panic!("{variant:?}: {other:?}"),
        }
        s.drags_mut().clear();
        s.reset();
        let energy = s.step().unwrap().energy;
        assert!(energy.is_finite() && energy < 1.0, "{variant:?} after the reset: {energy} J");
    }
}

/// Drags expected (the viewer: the factor for the drags' responses made ahead, in the background)
/// or not (made at the first drag), the steps under a drag are the same, bit for bit, before and
/// after a stiffness change swaps in new modes (whose factor is made anew).
#[test]
fn a_factor_made_ahead_for_the_drags_gives_the_same_steps() {
    let setup = scene::load("cantilever", &["solver.modes=6".into()]).unwrap();
    let tip = 204;
    let target = setup.mesh.positions()[tip] + DVec3::new(0.0, 0.1, 0.05);
    let run = |expect: bool| {
        let (_dir, cache) = fresh_cache(&format!("expect-{expect}"));
        let mut s = ModalSolver::with_cache(&setup, Variant::Mwts, cache).unwrap();
        assert!(!s.drags_prepared(), "no factor before a drag or the word that drags will come");
        if expect {
            s.expect_drags();
        }
        assert_eq!(s.drags_prepared(), expect);
        let id = s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Position(target) }).unwrap();
        let mut shapes = Vec::new();
        for _ in 0..10 {
            s.step().unwrap();
        }
        shapes.push(s.positions().to_vec());
        s.drags_mut().remove(id).unwrap();
        s.set_param("k_bend", 1.0).unwrap();
        s.wait_for_modes().unwrap();
        assert_eq!(s.drags_prepared(), expect, "the new shell's factor is made ahead again");
        s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Position(target) }).unwrap();
        for _ in 0..10 {
            s.step().unwrap();
        }
        shapes.push(s.positions().to_vec());
        shapes
    };
    let (made_at_the_drag, made_ahead) = (run(false), run(true));
    let moved = (made_ahead[1][tip] - setup.mesh.positions()[tip]).length();
    assert!(moved > 0.03, "the drag moved the tip: {moved} m");
    assert_eq!(made_ahead, made_at_the_drag);
}
