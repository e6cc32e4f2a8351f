//! The simulation-thread hand-off: no torn frames, and neither side slows the other down.

use std::time::{Duration, Instant};

use glam::DVec3;
use shellwarp::app::sim_thread::{Command, Pacing, SimHandle, SimStatus};
use shellwarp::solver::{DragSet, ParamValue, Solver, SolverError, StepStats};

/// A solver whose every vertex sits at (k, k, k) after step k; `delay` makes steps slow.
struct Counter {
    positions: Vec<DVec3>,
    k: u64,
    h: f64,
    delay: Duration,
    drags: DragSet,
}

impl Counter {
    fn boxed(n: usize, h: f64, delay: Duration) -> Box<dyn Solver> {
        Box::new(Self { positions: vec![DVec3::ZERO; n], k: 0, h, delay, drags: DragSet::new(n, true) })
    }
}

impl Solver for Counter {
    fn method(&self) -> &'static str {
        "counter"
    }
    fn time_step(&self) -> f64 {
        self.h
    }
    fn step(&mut self) -> Result<StepStats, SolverError> {
        std::thread::sleep(self.delay);
        self.k += 1;
        let v = DVec3::splat(self.k as f64);
        self.positions.iter_mut().for_each(|p| *p = v);
        Ok(StepStats { sim_time: self.k as f64 * self.h, ..Default::default() })
    }
    fn positions(&self) -> &[DVec3] {
        &self.positions
    }
    fn reset(&mut self) {
        self.k = 0;
        self.positions.iter_mut().for_each(|p| *p = DVec3::ZERO);
    }
    fn params(&self) -> Vec<ParamValue> {
        Vec::new()
    }
    fn set_param(&mut self, name: &str, _: f64) -> Result<(), SolverError> {
        Err(SolverError::UnknownParam { method: "counter", name: name.into(), available: String::new() })
    }
    fn drags(&self) -> &DragSet {
        &self.drags
    }
    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}

#[test]
fn reader_never_sees_a_torn_snapshot() {
    let mut sim = SimHandle::spawn(Counter::boxed(200_000, 1e-3, Duration::ZERO), false, Pacing::AsFastAsPossible);
    let start = Instant::now();
    let (mut reads, mut last) = (0, 0);
    while start.elapsed() < Duration::from_millis(1500) {
        let snap = sim.latest();
        let k = snap.steps as f64;
        assert!(snap.positions.iter().all(|p| *p == DVec3::splat(k)), "torn frame at step {k}");
        assert!(snap.steps >= last, "steps went backwards");
        last = snap.steps;
        reads += 1;
    }
    assert!(last > 10 && reads > 10, "both sides made progress: {last} steps, {reads} reads");
}

#[test]
fn sim_keeps_real_time_while_the_reader_is_slow() {
    let h = 0.01;
    let mut sim = SimHandle::spawn(Counter::boxed(1000, h, Duration::ZERO), false, Pacing::Scaled(1.0));
    let start = Instant::now();
    for _ in 0..5 {
        std::thread::sleep(Duration::from_millis(200)); // a very slow renderer
        let _ = sim.latest();
    }
    let wall = start.elapsed().as_secs_f64();
    let snap = sim.latest();
    let sim_time = snap.steps as f64 * h;
    assert!((sim_time - wall).abs() < 0.2 * wall, "sim {sim_time:.3} s vs wall {wall:.3} s");
    assert!((snap.wall_time - wall).abs() < 0.2 * wall, "reported wall time {}", snap.wall_time);
}

#[test]
fn reader_is_never_blocked_by_a_slow_sim() {
    let mut sim =
        SimHandle::spawn(Counter::boxed(1000, 0.01, Duration::from_millis(100)), false, Pacing::AsFastAsPossible);
    let start = Instant::now();
    let mut worst = Duration::ZERO;
    while start.elapsed() < Duration::from_millis(600) {
        let t = Instant::now();
        let _ = sim.latest().steps;
        worst = worst.max(t.elapsed());
    }
    assert!(worst < Duration::from_millis(20), "a read took {worst:?} while steps take 100 ms");
}

#[test]
fn commands_pause_step_reset_and_report_errors() {
    let mut sim = SimHandle::spawn(Counter::boxed(10, 0.01, Duration::ZERO), true, Pacing::AsFastAsPossible);
    let wait_for = |sim: &mut SimHandle, f: &dyn Fn(&shellwarp::app::sim_thread::Snapshot) -> bool| {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if f(sim.latest()) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        false
    };
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(sim.latest().steps, 0, "paused at start");
    sim.send(Command::StepOnce);
    assert!(wait_for(&mut sim, &|s| s.steps == 1 && s.status == SimStatus::Paused));
    sim.send(Command::SetParam("nope".into(), 1.0));
    assert!(wait_for(&mut sim, &|s| s.last_error.as_deref().is_some_and(|e| e.contains("nope"))));
    sim.send(Command::SetPaused(false));
    assert!(wait_for(&mut sim, &|s| s.steps > 50));
    sim.send(Command::Reset);
    sim.send(Command::SetPaused(true));
    assert!(wait_for(&mut sim, &|s| s.status == SimStatus::Paused && s.steps < 50));
}
