//! The reference ghost, headless: the simulation thread runs `mwts` with a `ds-implicit` ghost on the
//! same scene and drags; the error it reports equals the one computed from separate runs of both
//! methods to the same time. A ghost too slow for real time is refused, saying why.

use std::time::{Duration, Instant};

use glam::DVec3;
use shellwarp::app::ghost::{MAX_GHOST_COST, check_pace, relative_error};
use shellwarp::app::sim_thread::{Command, Pacing, SimHandle, Snapshot};
use shellwarp::scene;
use shellwarp::solver::{self, Drag, DragId, DragKind, Solver};

fn built(method: &str) -> Box<dyn Solver> {
    solver::build(&scene::load("cantilever", &[format!("solver.method={method}")]).unwrap()).unwrap()
}

fn wait(sim: &mut SimHandle, done: impl Fn(&Snapshot) -> bool) -> Snapshot {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) {
        let snap = sim.latest().clone();
        if done(&snap) {
            return snap;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("the simulation thread never got there");
}

#[test]
fn the_ghost_error_is_what_separate_runs_of_both_methods_give() {
    let tip = 204;
    let target = DVec3::new(0.4, 0.15, 0.05);
    let drag = Drag { vertex: tip, kind: DragKind::Position(target) };
    let mut sim = SimHandle::spawn(built("mwts"), true, Pacing::AsFastAsPossible);
    sim.send(Command::SetGhost(Some(built("ds-implicit"))));
    sim.send(Command::AddDrag(DragId(7), drag));
    for _ in 0..20 {
        sim.send(Command::StepOnce);
    }
    let snap = wait(&mut sim, |s| s.steps == 20);
    let ghost = snap.ghost.clone().expect("a ghost runs");
    assert_eq!(ghost.method, "ds-implicit");
    assert!(ghost.message.is_none(), "{:?}", ghost.message);
    // The same, separately: both methods with the same drag, to the same time.
    let (mut main, mut reference) = (built("mwts"), built("ds-implicit"));
    let rest = main.positions().to_vec();
    for s in [&mut main, &mut reference] {
        s.drags_mut().insert(DragId(7), drag).unwrap();
        for _ in 0..20 {
            s.step().unwrap();
        }
    }
    let expected = relative_error(main.positions(), reference.positions(), &rest);
    eprintln!(
        "mwts against a ds-implicit ghost after 20 steps: {:.3}% (separately {:.3}%)",
        100.0 * ghost.error,
        100.0 * expected
    );
    assert!(expected > 1e-3, "the two methods differ ({expected:.2e})");
    assert!((ghost.error - expected).abs() <= 1e-12 * expected.max(1.0), "{} vs {expected}", ghost.error);
    assert!(ghost.positions.iter().zip(reference.positions()).all(|(a, b)| (*a - *b).length() < 1e-12));
    // Reset takes the ghost back too; stopping it removes it.
    sim.send(Command::Reset);
    let snap = wait(&mut sim, |s| s.steps == 0);
    assert_eq!(snap.ghost.map(|g| g.error), Some(0.0));
    sim.send(Command::SetGhost(None));
    assert!(wait(&mut sim, |s| s.ghost.is_none()).ghost.is_none());
}

#[test]
fn a_ghost_too_slow_for_real_time_is_refused_with_its_cost() {
    // The explicit shell at 1e-6 s substeps: tens of seconds of computing per simulated second.
    let setup = scene::load("cantilever", &["solver.method=ds".into(), "solver.substep=1e-6".into()]).unwrap();
    let mut slow = solver::build(&setup).unwrap();
    let err = check_pace(slow.as_mut()).expect_err("far slower than real time");
    assert!(err.contains("refused") && err.contains("per simulated second"), "{err}");
    assert!(slow.positions().iter().zip(setup.mesh.positions()).all(|(a, b)| a == b), "reset after the trial step");
    let cost = check_pace(built("lma").as_mut()).expect("a modal ghost keeps real time");
    assert!(cost < MAX_GHOST_COST);
}
