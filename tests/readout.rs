//! The live quality readout, through the simulation thread and the egui panel: it warns, naming a
//! remedy it measured, when the model cannot follow a drag, stays quiet when it can, and its
//! estimate is within a factor of two of the error against the discrete shell walked to the same
//! drag.

use std::time::{Duration, Instant};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::DVec3;
use shellwarp::app::panel::{self, PanelState};
use shellwarp::app::readout::ReadoutView;
use shellwarp::app::sim_thread::{Command, Pacing, SimHandle, Snapshot};
use shellwarp::scene::{self, Setup};
use shellwarp::solver::{self, Drag, DragId, DragKind, quality};

/// The cantilever's free-end corner.
const TIP: usize = 204;

fn cantilever(method: &str, modes: usize) -> Setup {
    scene::load("cantilever", &[format!("solver.method={method}"), format!("solver.modes={modes}")]).unwrap()
}

/// Run `setup` in the simulation thread with the tip dragged to `target` and the readout watching,
/// until `done` holds for the readout of a state past ten seconds (failing after two minutes); that
/// snapshot.
fn watched(setup: &Setup, target: DVec3, done: impl Fn(&ReadoutView) -> bool) -> Snapshot {
    // Paused until the drag and the watch are in, so that every step counted is taken under the drag
    // (a test thread descheduled between sends must not let the shell run free for hundreds of steps).
    let mut sim = SimHandle::spawn(solver::build(setup).unwrap(), true, Pacing::AsFastAsPossible);
    sim.send(Command::Watch(Some(Box::new(setup.clone()))));
    sim.send(Command::AddDrag(DragId(1), Drag { vertex: TIP, kind: DragKind::Position(target) }));
    sim.send(Command::SetPaused(false));
    let start = Instant::now();
    loop {
        let snap = sim.latest().clone();
        // Judge a settled state: ten seconds of simulated time at least (300 steps).
        let settled = |r: &ReadoutView| r.judged_step >= 300 && done(r);
        if snap.readout.as_ref().is_some_and(settled) {
            return snap;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "never settled as asked: {:?}", snap.readout);
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The panel drawn for `snap`, and whether it shows text containing `needle`.
fn panel_shows(snap: &Snapshot, needle: &str) -> bool {
    struct Ui {
        panel: PanelState,
        snapshot: Snapshot,
    }
    let ui =
        Ui { panel: PanelState::new(vec!["cantilever".into()], vec![], "cantilever".into()), snapshot: snap.clone() };
    let mut h = Harness::builder().with_size(egui::vec2(panel::DEFAULT_WIDTH, 1400.0)).build_ui_state(
        |ui, s: &mut Ui| {
            panel::show(ui, &mut s.panel, &s.snapshot);
        },
        ui,
    );
    h.run();
    h.query_by_label_contains(needle).is_some()
}

#[test]
fn the_readout_warns_with_a_remedy_when_the_modes_cannot_follow_a_drag() {
    // Two modes of the strip bend it up and down; a pull sideways is beyond them.
    let setup = cantilever("mwts", 2);
    let sideways = setup.mesh.positions()[TIP] + DVec3::new(-0.2, 0.0, 0.3);
    let snap = watched(&setup, sideways, |r| r.remedy.as_ref().is_some_and(|m| !m.starts_with("Looking")));
    let r = snap.readout.clone().expect("watched");
    eprintln!("mwts, 2 modes: area {:+.2}%, estimate {:?}: {:?}", 100.0 * r.area_change, r.estimate, r.warning());
    let warning = r.warning().expect("a warning");
    assert!(warning.contains("mwts, 2 modes is not enough"), "{warning}");
    assert!(warning.contains("meets it"), "a remedy that meets the target is named: {warning}");
    assert!(panel_shows(&snap, "is not enough here"), "the panel shows the warning");
}

#[test]
fn the_readout_is_quiet_when_the_model_follows_the_drag() {
    // The tip pulled down and in, along the way the strip bends: within eight modes of mwts-rs.
    let setup = cantilever("mwts-rs", 8);
    let lift = setup.mesh.positions()[TIP] + DVec3::new(-0.1, -0.3, 0.0);
    let snap = watched(&setup, lift, |r| r.estimate.is_some());
    let r = snap.readout.clone().expect("watched");
    eprintln!("mwts-rs, 8 modes: area {:+.3}%, estimate {:?}", 100.0 * r.area_change, r.estimate);
    assert!(r.estimate.is_some_and(|e| e < r.target) && r.warning().is_none(), "{r:?}");
    assert!(panel_shows(&snap, "estimated error"), "the panel shows the estimate");
    assert!(!panel_shows(&snap, "is not enough here"), "and no warning");
}

/// `ds-static` walked to the tip drag in `steps` equal steps: the reference shape.
fn walked(target: DVec3, steps: usize) -> Vec<DVec3> {
    let setup = cantilever("ds-static", 8);
    let mut s = solver::build(&setup).unwrap();
    let start = setup.mesh.positions()[TIP];
    let id = s.drags_mut().add(Drag { vertex: TIP, kind: DragKind::Position(start) }).unwrap();
    for k in 1..=steps {
        s.drags_mut().retarget(id, DragKind::Position(start.lerp(target, k as f64 / steps as f64))).unwrap();
        s.step().unwrap();
    }
    s.positions().to_vec()
}

#[test]
fn the_estimate_is_within_a_factor_two_of_the_error_against_the_walked_shell() {
    let rest = cantilever("mwts", 8).mesh.positions().to_vec();
    // A pull sideways and one down along the bend (where the walked shell and the models end on the
    // same branch of equilibria: the estimate judges the nearest one).
    let models = [("mwts", 2), ("mwts", 8), ("lma", 8), ("mwts-rs", 4), ("mwts-rs", 8)];
    for pull in [DVec3::new(-0.2, 0.0, 0.3), DVec3::new(-0.1, -0.3, 0.0)] {
        let target = rest[TIP] + pull;
        let reference = walked(target, 20);
        for (method, modes) in models {
            let setup = cantilever(method, modes);
            let mut s = solver::build(&setup).unwrap();
            s.drags_mut().add(Drag { vertex: TIP, kind: DragKind::Position(target) }).unwrap();
            for _ in 0..300 {
                s.step().unwrap();
            }
            let error = shellwarp::eval::measure::relative_error(s.positions(), &reference, &rest);
            let estimate = quality::estimate(&setup, s.positions(), s.drags()).unwrap();
            eprintln!("pull {pull}: {method}, {modes} modes: error {error:.4}, estimate {estimate:.4}");
            if error > quality::DEFAULT_TARGET {
                assert!(estimate > 0.5 * error && estimate < 2.0 * error, "{method} {modes}: {estimate} vs {error}");
            } else {
                assert!(estimate < 2.0 * quality::DEFAULT_TARGET, "{method} {modes}: {estimate} vs {error}");
            }
        }
    }
}
