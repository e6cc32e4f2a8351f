//! The simulation-thread hand-off: no torn frames, neither side slows the other down, pacing,
//! background work shown while paused, no exploded frames after a divergence, panics caught, and a
//! hanging solver seen stuck and left behind.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::DVec3;
use shellwarp::app::sim_thread::{Command, Pacing, SimHandle, SimStatus, Snapshot};
use shellwarp::solver::{DragSet, ParamValue, Progress, Solver, SolverError, StepStats};

/// A solver whose every vertex sits at (k, k, k) after step k; `delay` makes steps slow, `diverge_at`
/// makes that step fail (once) with non-finite positions, `panic_at` makes it panic (once, and once
/// more in the reset after it when `panic_on_reset`), `work` is background progress the test sets, and
/// `checkpointed` spends the delay in short sleeps between checkpoints (as Newton iterations pass them).
struct Counter {
    positions: Vec<DVec3>,
    k: u64,
    h: f64,
    delay: Duration,
    diverge_at: Option<u64>,
    panic_at: Option<u64>,
    panic_on_reset: bool,
    work: Arc<Mutex<Option<f32>>>,
    drags: DragSet,
    checkpointed: bool,
    /// How often the simulation thread said drags are to be expected.
    expected: Arc<AtomicU32>,
}

impl Counter {
    fn new(n: usize, h: f64, delay: Duration) -> Self {
        Self {
            positions: vec![DVec3::ZERO; n],
            k: 0,
            h,
            delay,
            diverge_at: None,
            panic_at: None,
            panic_on_reset: false,
            work: Arc::default(),
            drags: DragSet::new(n, true),
            checkpointed: false,
            expected: Arc::default(),
        }
    }

    fn boxed(n: usize, h: f64, delay: Duration) -> Box<dyn Solver> {
        Box::new(Self::new(n, h, delay))
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
        if self.checkpointed {
            let start = Instant::now();
            while start.elapsed() < self.delay {
                shellwarp::solver::supersede::checkpoint();
                std::thread::sleep(Duration::from_millis(1));
            }
        } else {
            std::thread::sleep(self.delay);
        }
        self.k += 1;
        if self.panic_at == Some(self.k) {
            self.panic_at = None;
            panic!("index out of bounds in the test solver at step {}", self.k);
        }
        if self.diverge_at == Some(self.k) {
            self.diverge_at = None; // once
            self.positions.iter_mut().for_each(|p| *p = DVec3::NAN);
            return Err(SolverError::Diverged { step: self.k, time: 0.0, reason: "test blow-up".into() });
        }
        let v = DVec3::splat(self.k as f64);
        self.positions.iter_mut().for_each(|p| *p = v);
        Ok(StepStats { sim_time: self.k as f64 * self.h, ..Default::default() })
    }
    fn positions(&self) -> &[DVec3] {
        &self.positions
    }
    fn reset(&mut self) {
        if std::mem::take(&mut self.panic_on_reset) {
            panic!("the test solver's reset panics once");
        }
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
    fn progress(&self) -> Option<Progress> {
        let fraction = *self.work.lock().ok()?;
        fraction.map(|fraction| Progress { label: "test work".into(), fraction })
    }
    fn expect_drags(&mut self) {
        self.expected.fetch_add(1, Ordering::Relaxed);
    }
}

/// Wait up to 10 s for a snapshot satisfying `f`.
fn wait_for(sim: &mut SimHandle, f: impl Fn(&Snapshot) -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(10) {
        if f(sim.latest()) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    false
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
    // A simulation blocked by the reader manages a few steps per read (about 0.05 s of 1 s); one that
    // ignored real time races ahead. A stall of the simulation thread past the 0.25 s backlog is
    // dropped rather than caught up, so a busy machine may leave it somewhat behind, never ahead.
    assert!(sim_time > 0.5 * wall && sim_time <= wall + 0.25 + h, "sim {sim_time:.3} s vs wall {wall:.3} s");
    assert!(
        snap.wall_time > 0.5 * wall && snap.wall_time <= wall + 0.05,
        "reported wall time {} of {wall}",
        snap.wall_time
    );
}

#[test]
fn reader_is_never_blocked_by_a_slow_sim() {
    // Steps take 100 ms. A reader that waited for the writer would manage about one read per step;
    // a wait-free one reads thousands of times while three steps are being computed, however often
    // the machine preempts it.
    let mut sim =
        SimHandle::spawn(Counter::boxed(1000, 0.01, Duration::from_millis(100)), false, Pacing::AsFastAsPossible);
    assert!(wait_for(&mut sim, |s| s.steps >= 1), "the simulation started");
    let first = sim.latest().steps;
    let mut reads = 0u64;
    let start = Instant::now();
    while sim.latest().steps < first + 3 && start.elapsed() < Duration::from_secs(10) {
        reads += 1;
    }
    assert!(sim.latest().steps >= first + 3, "the simulation kept stepping");
    assert!(reads > 1000, "only {reads} reads completed during three 100 ms steps: the reader was blocked");
}

#[test]
fn fast_then_real_time_keeps_real_time() {
    let h = 0.01;
    let mut sim = SimHandle::spawn(Counter::boxed(10, h, Duration::ZERO), false, Pacing::AsFastAsPossible);
    std::thread::sleep(Duration::from_millis(300));
    assert!(sim.latest().steps > 100, "as fast as possible ran ahead of real time");
    sim.send(Command::SetPacing(Pacing::Scaled(1.0)));
    std::thread::sleep(Duration::from_millis(50));
    let (s0, t0) = (sim.latest().steps, Instant::now());
    std::thread::sleep(Duration::from_millis(600));
    let (steps, wall) = (sim.latest().steps - s0, t0.elapsed().as_secs_f64());
    let expected = wall / h;
    // Frozen (the old bug) gives 0; still racing gives thousands. Catch-up after a preemption is
    // bounded by the 0.25 s backlog.
    assert!(steps as f64 > 0.1 * expected, "{steps} steps in {wall:.3} s of real time (expected {expected:.0})");
    assert!((steps as f64) < expected + 0.25 / h + 5.0, "{steps} steps in {wall:.3} s: not back to real time");
}

#[test]
fn background_progress_is_published_while_paused() {
    let counter = Counter::new(10, 0.01, Duration::ZERO);
    let work = counter.work.clone();
    let mut sim = SimHandle::spawn(Box::new(counter), true, Pacing::Scaled(1.0));
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Paused && s.progress.is_none()));
    *work.lock().unwrap() = Some(0.4);
    assert!(
        wait_for(&mut sim, |s| s.progress.as_ref().is_some_and(|p| p.fraction == 0.4)),
        "progress never shown while paused"
    );
    *work.lock().unwrap() = None;
    assert!(wait_for(&mut sim, |s| s.progress.is_none()), "finished work never shown while paused");
    assert_eq!(sim.latest().steps, 0, "nothing stepped");
}

#[test]
fn a_diverged_step_shows_the_last_finite_state() {
    let mut counter = Counter::new(50, 0.01, Duration::ZERO);
    counter.diverge_at = Some(5);
    let mut sim = SimHandle::spawn(Box::new(counter), false, Pacing::AsFastAsPossible);
    assert!(wait_for(&mut sim, |s| matches!(s.status, SimStatus::Diverged(_))), "never diverged");
    let snap = sim.latest();
    assert_eq!(snap.steps, 4);
    assert!(snap.positions.iter().all(|p| *p == DVec3::splat(4.0)), "shows step 4's positions, not the blow-up");
    match &snap.status {
        SimStatus::Diverged(reason) => assert!(reason.contains("test blow-up"), "{reason}"),
        other => panic!("{other:?}"),
    }
    sim.send(Command::Reset);
    assert!(wait_for(&mut sim, |s| s.positions.iter().all(|p| p.is_finite()) && s.status == SimStatus::Running));
}

#[test]
fn commands_pause_step_reset_and_report_errors() {
    let mut sim = SimHandle::spawn(Counter::boxed(10, 0.01, Duration::ZERO), true, Pacing::AsFastAsPossible);
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(sim.latest().steps, 0, "paused at start");
    sim.send(Command::StepOnce);
    assert!(wait_for(&mut sim, |s| s.steps == 1 && s.status == SimStatus::Paused));
    sim.send(Command::SetParam("nope".into(), 1.0));
    assert!(wait_for(&mut sim, |s| s.last_error.as_deref().is_some_and(|e| e.contains("nope"))));
    sim.send(Command::SetPaused(false));
    assert!(wait_for(&mut sim, |s| s.steps > 50));
    // Paused first: a thread running flat out between the two sends would be past 50 steps again.
    sim.send(Command::SetPaused(true));
    sim.send(Command::Reset);
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Paused && s.steps == 0));
}

/// A solver that panics inside the simulation thread is reported with its message, the thread keeps
/// answering, and Reset (after a reset that panics too) or another method recovers.
#[test]
fn a_panicking_solver_is_reported_and_reset_or_a_new_method_recovers() {
    let mut counter = Counter::new(20, 0.01, Duration::ZERO);
    counter.panic_at = Some(7);
    counter.panic_on_reset = true;
    let mut sim = SimHandle::spawn(Box::new(counter), false, Pacing::AsFastAsPossible);
    let panicked =
        |s: &Snapshot| matches!(&s.status, SimStatus::Diverged(r) if r.contains("panicked") && r.contains("step 7"));
    assert!(wait_for(&mut sim, panicked), "the panic was not reported: {:?}", sim.latest().status);
    let snap = sim.latest();
    assert_eq!(snap.steps, 6);
    assert!(snap.positions.iter().all(|p| *p == DVec3::splat(6.0)), "shows the last finished step");
    // The first reset panics too: reported, and the thread still answers the next one.
    sim.send(Command::Reset);
    assert!(wait_for(&mut sim, |s| s.last_error.as_deref().is_some_and(|e| e.contains("reset panics"))));
    sim.send(Command::Reset);
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Running && s.steps > 20), "Reset did not recover");
    // Another panic, then a method switch recovers as well.
    let mut again = Counter::new(20, 0.01, Duration::ZERO);
    again.panic_at = Some(3);
    sim.send(Command::Replace(Box::new(again)));
    assert!(wait_for(&mut sim, |s| matches!(&s.status, SimStatus::Diverged(r) if r.contains("panicked"))));
    sim.send(Command::Replace(Counter::boxed(20, 0.01, Duration::ZERO)));
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Running && s.steps > 20), "a new method did not recover");
}

#[test]
fn a_hanging_solver_is_seen_stuck_and_is_left_behind_without_waiting() {
    // A step of an hour stands for one that never returns.
    let start = Instant::now();
    let mut sim =
        SimHandle::spawn(Counter::boxed(20, 0.01, Duration::from_secs(3600)), false, Pacing::AsFastAsPossible);
    while sim.stuck_for().is_none_or(|d| d < Duration::from_millis(300)) {
        assert!(start.elapsed() < Duration::from_secs(10), "never seen inside its step");
        std::thread::sleep(Duration::from_millis(5));
    }
    // (Marked in whole milliseconds.)
    assert!(sim.stuck_for().unwrap() <= start.elapsed() + Duration::from_millis(1), "stuck no longer than it ran");
    // Abandoned for a new thread: returns at once, and the new thread runs.
    let old = std::mem::replace(
        &mut sim,
        SimHandle::spawn(Counter::boxed(20, 0.01, Duration::ZERO), false, Pacing::AsFastAsPossible),
    );
    let abandoned = Instant::now();
    old.abandon();
    // A wait would last QUIT_WAIT (2 s) or for ever; a busy machine may delay the return a little.
    assert!(abandoned.elapsed() < Duration::from_secs(1), "abandoning waited {:?}", abandoned.elapsed());
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Running && s.steps > 20), "the new thread did not run");
    assert!(sim.stuck_for().is_none_or(|d| d < Duration::from_secs(1)));
    // Dropping a handle whose thread is stuck waits at most QUIT_WAIT.
    let stuck = SimHandle::spawn(Counter::boxed(20, 0.01, Duration::from_secs(3600)), false, Pacing::AsFastAsPossible);
    std::thread::sleep(Duration::from_millis(50));
    let dropped = Instant::now();
    drop(stuck);
    let waited = dropped.elapsed();
    assert!(waited < shellwarp::app::sim_thread::QUIT_WAIT + Duration::from_millis(500), "waited {waited:?}");
}

#[test]
fn a_long_step_that_a_reset_or_a_switch_would_discard_stops_at_its_next_checkpoint() {
    let long = || {
        let mut c = Counter::new(20, 0.01, Duration::from_secs(3600));
        c.checkpointed = true;
        Box::new(c)
    };
    let mut sim = SimHandle::spawn(long(), false, Pacing::AsFastAsPossible);
    let inside = |sim: &SimHandle| sim.stuck_for().is_some_and(|d| d > Duration::from_millis(200));
    let start = Instant::now();
    while !inside(&sim) {
        assert!(start.elapsed() < Duration::from_secs(10), "never inside its step");
        std::thread::sleep(Duration::from_millis(5));
    }
    // Reset: the step stops, the solver is reset and steps again (into another hour-long step).
    // The old step has been running for `before`; a new one is seen by a shorter time inside.
    let before = sim.stuck_for().unwrap();
    let reset = Instant::now();
    sim.send(Command::Reset);
    while sim.stuck_for().is_none_or(|d| d >= before) {
        assert!(reset.elapsed() < Duration::from_secs(2), "the step was not stopped");
        std::thread::sleep(Duration::from_millis(1));
    }
    // A switch: the step stops and the new solver runs on the same thread.
    while !inside(&sim) {
        std::thread::sleep(Duration::from_millis(5));
    }
    sim.send(Command::Replace(Counter::boxed(20, 0.01, Duration::ZERO)));
    assert!(wait_for(&mut sim, |s| s.status == SimStatus::Running && s.steps > 20), "the new solver did not run");
    assert!(reset.elapsed() < Duration::from_secs(5));
}

/// The simulation thread tells every solver it is given, at the start and on a switch, that drags
/// are to be expected (so the modal methods make their drags' factor ahead, in the background).
#[test]
fn every_solver_the_thread_is_given_is_told_to_expect_drags() {
    let (first, second) = (Counter::new(10, 0.01, Duration::ZERO), Counter::new(10, 0.01, Duration::ZERO));
    let (told_first, told_second) = (first.expected.clone(), second.expected.clone());
    let mut sim = SimHandle::spawn(Box::new(first), true, Pacing::AsFastAsPossible);
    sim.send(Command::Replace(Box::new(second)));
    sim.send(Command::StepOnce);
    assert!(wait_for(&mut sim, |s| s.steps >= 1), "the second solver steps");
    assert_eq!((told_first.load(Ordering::Relaxed), told_second.load(Ordering::Relaxed)), (1, 1));
}
