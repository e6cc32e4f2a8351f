//! Every DS method builds from every built-in scene and takes a converged, finite step; `ds` runs
//! each at its automatic stable substep (a full 1/30 s frame, about 3000 substeps on the creature).

use shellwarp::scene;
use shellwarp::solver::ds_static::BUDGET_FACTOR;
use shellwarp::solver::{METHODS, SolverError, build};

#[test]
fn ds_methods_are_registered_and_run_every_shell_scene() {
    for name in ["ds", "ds-implicit", "ds-static"] {
        assert!(METHODS.iter().any(|m| m.name == name), "{name} is registered");
    }
    let (mut ran, mut refused, mut turned) = (Vec::new(), Vec::new(), Vec::new());
    let scenes = scene::builtin_names();
    // Scenes with tracks that turn their vertices: the discrete shells have no orientation drags.
    let turning = |setup: &scene::Setup| {
        setup.scene.tracks.iter().any(|t| t.joint.is_some() || t.keys.iter().any(|k| k.rotation.is_some()))
    };
    for scene_name in &scenes {
        for method in ["ds", "ds-implicit", "ds-static"] {
            let setup = scene::load(scene_name, &[format!("solver.method={method}")])
                .unwrap_or_else(|e| panic!("{scene_name}: {e}"));
            let mut solver = match build(&setup) {
                Ok(s) => s,
                // The one refusal allowed: a static equilibrium needs anchors.
                Err(SolverError::Unsuitable { .. }) if method == "ds-static" && setup.anchors.is_empty() => {
                    refused.push(*scene_name);
                    continue;
                }
                // And a track with rotations, named in the refusal.
                Err(SolverError::BadDrag(reason)) if turning(&setup) && reason.contains("tracks[") => {
                    turned.push((*scene_name, method));
                    continue;
                }
                Err(e) => panic!("{scene_name} / {method}: {e}"),
            };
            let stats = solver.step().unwrap_or_else(|e| panic!("{scene_name} / {method}: {e}"));
            eprintln!("{scene_name} / {method}: {stats:?}");
            for note in solver.notes() {
                eprintln!("  note: {note}");
            }
            assert!(stats.energy.is_finite() && stats.wall_seconds > 0.0);
            assert!(stats.converged, "{scene_name} / {method} did not converge: {stats:?}");
            assert!(solver.positions().iter().all(|p| p.is_finite()));
            let names: Vec<_> = solver.params().iter().map(|p| p.spec.name).collect();
            for p in ["k_area", "k_length", "k_bend", "density", "gravity_y", "rayleigh_alpha", "rayleigh_beta"] {
                assert!(names.contains(&p), "{method} lacks {p}");
            }
            assert!(solver.set_param("no_such", 1.0).is_err());
            assert!(solver.set_param("k_bend", -1.0).is_err());
            ran.push((*scene_name, method));
        }
    }
    let anchorless: Vec<&str> = scenes
        .iter()
        .copied()
        .filter(|s| scene::load(s, &[]).map(|setup| setup.anchors.is_empty()).unwrap_or(false))
        .collect();
    eprintln!(
        "ran {} scene/method pairs; ds-static refused the anchorless {refused:?}; turning tracks refused {turned:?}",
        ran.len()
    );
    assert_eq!(refused, anchorless, "exactly the scenes without anchors are refused, by ds-static only");
    assert_eq!(ran.len() + turned.len(), 3 * scenes.len() - anchorless.len(), "every other pair ran: {ran:?}");
    assert!(turned.iter().all(|(s, _)| turning(&scene::load(s, &[]).unwrap())));
}

#[test]
fn position_drags_hold_vertices_and_release_them() {
    use glam::DVec3;
    use shellwarp::solver::{Drag, DragKind};
    for method in ["ds-implicit", "ds-static"] {
        let setup =
            scene::load("cantilever", &[format!("solver.method={method}"), "solver.iterations=200".into()]).unwrap();
        let mut s = build(&setup).unwrap();
        let tip = (0..setup.mesh.vertex_count())
            .max_by(|&a, &b| setup.mesh.positions()[a].x.total_cmp(&setup.mesh.positions()[b].x));
        let tip = tip.unwrap();
        let target = setup.mesh.positions()[tip] + DVec3::new(-0.1, 0.2, 0.0);
        let id = s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Position(target) }).unwrap();
        for _ in 0..5 {
            s.step().unwrap();
        }
        assert!((s.positions()[tip] - target).length() < 1e-12, "{method}: dragged vertex sits on its target");
        let lifted = s.positions()[tip - 1].y;
        assert!(lifted > 0.05, "{method}: its neighbours follow ({lifted})");
        s.drags_mut().remove(id).unwrap();
        for _ in 0..30 {
            s.step().unwrap();
        }
        assert!(s.positions()[tip].y < lifted, "{method}: released, the tip falls again");
        assert!(s.drags_mut().add(Drag { vertex: 0, kind: DragKind::Orientation(DVec3::X) }).is_err());
    }
}

#[test]
fn ds_static_refuses_a_free_shell() {
    let setup = scene::load("hanging-sheet", &["solver.method=ds-static".into(), "anchors=[]".into()]).unwrap();
    assert!(setup.anchors.is_empty());
    assert!(matches!(build(&setup), Err(SolverError::Unsuitable { .. })));
}

#[test]
fn ds_static_reports_non_convergence_and_continues_the_load_path() {
    // The cantilever made ten times softer in bending hangs almost vertically: a long load path.
    let load = |iterations: usize| {
        let overrides = [
            "solver.method=ds-static".to_string(),
            "material.k_bend=0.05".into(),
            format!("solver.iterations={iterations}"),
        ];
        build(&scene::load("cantilever", &overrides).unwrap()).unwrap()
    };
    let mut reference = load(1000);
    let full = reference.step().unwrap();
    eprintln!("1000 iterations allowed: {full:?}");
    assert!(full.converged && full.relative_residual <= 1e-8, "{full:?}");
    // A setting of 1 (a budget of BUDGET_FACTOR iterations) is not enough from rest: reported, not
    // hidden, and the state stays finite.
    let mut capped = load(1);
    let first = capped.step().unwrap();
    eprintln!("a budget of {BUDGET_FACTOR} iterations from rest: {first:?}");
    assert!(
        !first.converged && first.relative_residual > 1e-8 && first.iterations as usize <= BUDGET_FACTOR,
        "{first:?}"
    );
    assert!(capped.positions().iter().all(|p| p.is_finite()));
    // Each further step continues the load path from where the last one stopped, until it arrives.
    let steps = (2..=100).find(|_| capped.step().unwrap().converged).expect("arrives within 100 steps");
    let gap = capped.positions().iter().zip(reference.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    let sag = reference.positions().iter().map(|p| -p.y).fold(0.0, f64::max);
    eprintln!(
        "converged after {steps} capped steps; tip sag {sag:.3} m, largest distance to the uncapped solution {gap:.2e} m"
    );
    assert!(steps > 1 && gap < 1e-6 * sag, "{gap}");
}

/// The two references that stopped short at the old fixed cap of 50 iterations (relative
/// residual 0.25 and 0.75) converge with the defaults, to the answer of a huge explicit budget.
#[test]
fn ds_static_defaults_converge_where_a_fixed_cap_stopped_short() {
    for (scene_name, set) in [("v-beam", "material.k_bend=0.001"), ("cantilever", "gravity=[0, -100, 0]")] {
        let run = |extra: &[String]| {
            let mut o = vec!["solver.method=ds-static".to_string(), set.to_string()];
            o.extend_from_slice(extra);
            let mut s = build(&scene::load(scene_name, &o).unwrap()).unwrap();
            let stats = s.step().unwrap();
            (stats, s.positions().to_vec())
        };
        let (defaults, x) = run(&[]);
        let (huge, y) = run(&["solver.iterations=1000".into()]);
        eprintln!(
            "{scene_name} {set}: defaults {} iterations, relative residual {:.1e}",
            defaults.iterations, defaults.relative_residual
        );
        assert!(defaults.converged && defaults.relative_residual <= 1e-8, "{scene_name}: {defaults:?}");
        let gap = x.iter().zip(&y).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(huge.converged && gap < 1e-7, "{scene_name}: {gap:.2e} m from the answer of a huge budget");
    }
}
