//! The simulation thread: owns the solver, steps it at its fixed step with real-time pacing, takes
//! commands through a channel and hands finished snapshots to the renderer through a wait-free
//! triple buffer, so neither side ever blocks the other and the reader never sees a half-written frame.
//!
//! A solver that panics is caught and stopped as a diverging one is. A step whose result a reset or a
//! switch will discard is superseded when that command is sent, and stops at its next checkpoint (a
//! Newton iteration, [`crate::solver::supersede`]) instead of running on for as long as its settings
//! say. A solver that never returns from a call (and passes no checkpoint) cannot be stopped from
//! outside its thread: the thread marks when it enters the solver,
//! so the window can see it stuck ([`SimHandle::stuck_for`]), and [`SimHandle::abandon`] leaves it
//! behind for a new thread (it ends as soon as the solver returns, if ever); dropping a handle never
//! waits for such a thread for more than [`QUIT_WAIT`].

use std::panic::AssertUnwindSafe;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glam::DVec3;
use triple_buffer::{Output, triple_buffer};

use super::ghost::{Ghost, GhostView};
use super::readout::{Readout, ReadoutView};
use crate::scene::Setup;
use crate::solver::supersede::{Generation, unless_superseded};
use crate::solver::{Drag, DragId, DragKind, ParamValue, Progress, Solver, SolverError, StepStats};

/// How simulated time relates to wall-clock time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// Simulated time advances at `speed` × wall time (1 = real time, 0.25 = slow motion).
    Scaled(f64),
    /// Step as fast as possible.
    AsFastAsPossible,
}

/// What the simulation is doing.
#[derive(Debug, Clone, PartialEq)]
pub enum SimStatus {
    /// Stepping.
    Running,
    /// Waiting for play or single-step.
    Paused,
    /// Stopped by divergence; `Reset` resumes.
    Diverged(String),
    /// The solver has not returned from a call for this many seconds (set by the window, which
    /// sees it through [`SimHandle::stuck_for`]; the thread itself cannot publish while stuck).
    Stuck(f64),
}

/// Everything the UI and renderer need from one published state.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Vertex positions after the latest step.
    pub positions: Vec<DVec3>,
    /// Steps taken since the last reset.
    pub steps: u64,
    /// Statistics of the latest step.
    pub stats: StepStats,
    /// Running, paused or diverged.
    pub status: SimStatus,
    /// Active drag constraints.
    pub drags: Vec<(DragId, Drag)>,
    /// The solver's parameters and current values.
    pub params: Vec<ParamValue>,
    /// The solver's read-only figures (e.g. the active mode count), see [`Solver::info`].
    pub info: Vec<(&'static str, f64)>,
    /// The solver's method name.
    pub method: &'static str,
    /// Wall-clock seconds spent running since the last reset (for sim time vs wall time).
    pub wall_time: f64,
    /// The latest refused command, if any.
    pub last_error: Option<String>,
    /// The solver's background work, if any.
    pub progress: Option<Progress>,
    /// The reference ghost at the same time, if one runs.
    pub ghost: Option<GhostView>,
    /// The colliders' poses when the solver moves them (dynamic bodies), see [`Solver::body_poses`].
    pub bodies: Vec<(DVec3, glam::DQuat)>,
    /// The quality readout, once the scene is watched ([`Command::Watch`]).
    pub readout: Option<ReadoutView>,
}

/// A request to the simulation thread.
pub enum Command {
    /// Set a solver parameter.
    SetParam(String, f64),
    /// Add a drag constraint under a caller-chosen id.
    AddDrag(DragId, Drag),
    /// Move a drag's target.
    MoveDrag(DragId, DragKind),
    /// Remove a drag.
    RemoveDrag(DragId),
    /// Remove every drag.
    ClearDrags,
    /// Back to the initial state; clears a divergence.
    Reset,
    /// Pause or resume.
    SetPaused(bool),
    /// Take exactly one step (while paused).
    StepOnce,
    /// Change pacing.
    SetPacing(Pacing),
    /// Swap in another solver (method or scene switch); a ghost is dropped with the old solver.
    Replace(Box<dyn Solver>),
    /// Run a reference ghost beside the solver (built on the same scene), or stop it.
    SetGhost(Option<Box<dyn Solver>>),
    /// Judge the running model against the full shell of this scene (the quality readout), or stop;
    /// a [`Command::Replace`] stops it too.
    Watch(Option<Box<Setup>>),
    /// End the thread.
    Quit,
}

/// The UI side: send commands, read the latest snapshot.
pub struct SimHandle {
    commands: Sender<Command>,
    output: Output<Snapshot>,
    thread: Option<JoinHandle<()>>,
    in_solver: InSolver,
    /// Supersedes the step under way (its result is about to be discarded).
    discard: Generation,
}

/// When the simulation thread entered its solver: milliseconds since `epoch` plus one, 0 while it
/// is outside.
#[derive(Clone)]
struct InSolver {
    epoch: Instant,
    since: Arc<AtomicU64>,
}

impl InSolver {
    fn new() -> Self {
        Self { epoch: Instant::now(), since: Arc::new(AtomicU64::new(0)) }
    }

    /// Run `call` marked as inside the solver.
    fn mark<T>(&self, call: impl FnOnce() -> T) -> T {
        let now = self.epoch.elapsed().as_millis() as u64 + 1;
        self.since.store(now, Ordering::Relaxed);
        let result = call();
        self.since.store(0, Ordering::Relaxed);
        result
    }

    fn elapsed(&self) -> Option<Duration> {
        let since = self.since.load(Ordering::Relaxed).checked_sub(1)?;
        Some(self.epoch.elapsed().saturating_sub(Duration::from_millis(since)))
    }
}

/// The longest a dropped handle waits for its thread to end.
pub const QUIT_WAIT: Duration = Duration::from_secs(2);

impl SimHandle {
    /// Start the thread with `solver`, running (or paused).
    pub fn spawn(solver: Box<dyn Solver>, paused: bool, pacing: Pacing) -> Self {
        let (tx, rx) = mpsc::channel();
        let in_solver = InSolver::new();
        let discard = Generation::default();
        let mut sim = SimLoop::new(solver, paused, pacing, in_solver.clone(), discard.clone());
        let (mut input, output) = triple_buffer(&sim.snapshot());
        let thread = std::thread::Builder::new()
            .name("shellwarp-sim".into())
            .spawn(move || {
                sim.run(&rx, |snap| {
                    *input.input_buffer_mut() = snap;
                    input.publish();
                });
            })
            .ok();
        Self { commands: tx, output, thread, in_solver, discard }
    }

    /// How long the solver has been inside its current call (a step, a parameter change), if it is
    /// in one: a few seconds are normal for a large implicit step, minutes mean it hangs.
    pub fn stuck_for(&self) -> Option<Duration> {
        self.in_solver.elapsed()
    }

    /// Leave the thread behind without waiting for it (its solver hangs): it is told to quit and
    /// ends when, if ever, its solver returns.
    pub fn abandon(mut self) {
        self.send(Command::Quit);
        self.thread = None;
    }

    /// Send a command (ignored if the thread has ended). A reset or a new solver first supersedes
    /// the step under way, whose result it would discard.
    pub fn send(&self, command: Command) {
        if matches!(command, Command::Reset | Command::Replace(_) | Command::Quit) {
            self.discard.cancel_all();
        }
        let _ = self.commands.send(command);
    }

    /// The latest published snapshot (never blocks; never torn).
    pub fn latest(&mut self) -> &Snapshot {
        self.output.read()
    }

    /// Whether a snapshot newer than the last one read is waiting.
    pub fn updated(&self) -> bool {
        self.output.updated()
    }
}

impl Drop for SimHandle {
    fn drop(&mut self) {
        self.send(Command::Quit);
        if let Some(t) = self.thread.take() {
            // A thread stuck in its solver is left behind rather than hanging the window's exit.
            let start = Instant::now();
            while !t.is_finished() && start.elapsed() < QUIT_WAIT {
                std::thread::sleep(Duration::from_millis(5));
            }
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

fn status(paused: bool) -> SimStatus {
    if paused { SimStatus::Paused } else { SimStatus::Running }
}

struct SimLoop {
    solver: Box<dyn Solver>,
    paused: bool,
    pacing: Pacing,
    /// Simulated seconds due but not yet stepped (real-time pacing only; never negative).
    owed: f64,
    steps: u64,
    stats: StepStats,
    diverged: Option<String>,
    last_error: Option<String>,
    running_wall: f64,
    /// Positions after the latest finite step: what is shown once a step diverges.
    last_good: Vec<DVec3>,
    /// The background progress in the latest published snapshot.
    shown_progress: Option<Progress>,
    /// The reference ghost, if any.
    ghost: Option<Ghost>,
    /// Simulated time of the main solver.
    time: f64,
    /// The quality readout, if watched.
    readout: Option<Readout>,
    /// Marks calls into the solver, for [`SimHandle::stuck_for`].
    in_solver: InSolver,
    /// Each step runs on a ticket of this; [`SimHandle::send`] supersedes it.
    discard: Generation,
}

/// When more than this much simulated time is owed, the backlog is dropped instead of caught up.
const MAX_BACKLOG: f64 = 0.25;

/// How long an idle (paused or diverged) loop waits for a command before looking at background work.
const IDLE_WAIT: Duration = Duration::from_millis(20);

impl SimLoop {
    fn new(
        mut solver: Box<dyn Solver>,
        paused: bool,
        pacing: Pacing,
        in_solver: InSolver,
        discard: Generation,
    ) -> Self {
        // The user drags: what a first drag needs is made ahead, in the background.
        solver.expect_drags();
        Self {
            last_good: solver.positions().to_vec(),
            solver,
            paused,
            pacing,
            owed: 0.0,
            steps: 0,
            stats: StepStats::default(),
            diverged: None,
            last_error: None,
            running_wall: 0.0,
            shown_progress: None,
            ghost: None,
            time: 0.0,
            readout: None,
            in_solver,
            discard,
        }
    }

    fn status(&self) -> SimStatus {
        match &self.diverged {
            Some(reason) => SimStatus::Diverged(reason.clone()),
            None => status(self.paused),
        }
    }

    fn snapshot(&self) -> Snapshot {
        let solver = self.solver.as_ref();
        // A diverged step leaves non-finite or exploded positions in the solver: show the last good ones.
        let positions = if self.diverged.is_some() { self.last_good.clone() } else { solver.positions().to_vec() };
        Snapshot {
            readout: self.readout.as_ref().map(|r| r.view(&positions)),
            positions,
            steps: self.steps,
            stats: self.stats,
            status: self.status(),
            drags: solver.drags().iter().copied().collect(),
            params: solver.params(),
            info: solver.info(),
            method: solver.method(),
            wall_time: self.running_wall,
            last_error: self.last_error.clone(),
            progress: solver.progress(),
            ghost: self.ghost.as_ref().map(Ghost::view),
            bodies: solver.body_poses(),
        }
    }

    fn publish(&mut self, out: &mut impl FnMut(Snapshot)) {
        let snapshot = self.snapshot();
        self.shown_progress.clone_from(&snapshot.progress);
        out(snapshot);
    }

    /// Back to time zero with a (possibly new) solver state.
    fn restart(&mut self) {
        self.steps = 0;
        self.stats = StepStats::default();
        self.diverged = None;
        self.running_wall = 0.0;
        self.owed = 0.0;
        self.time = 0.0;
        self.remember_positions();
    }

    fn remember_positions(&mut self) {
        self.last_good.clear();
        self.last_good.extend_from_slice(self.solver.positions());
    }

    /// Let the solver finish background work; true when the published progress is out of date.
    fn poll_background(&mut self) -> bool {
        if let Err(e) = self.solver.poll() {
            self.last_error = Some(e.to_string());
        }
        self.solver.progress() != self.shown_progress
    }

    /// Apply one command; returns false on Quit. A solver that panics while applying it is stopped
    /// as a divergence would be, with the panic's message.
    fn apply(&mut self, command: Command) -> bool {
        if matches!(command, Command::Quit) {
            return false;
        }
        let in_solver = self.in_solver.clone();
        match in_solver.mark(|| std::panic::catch_unwind(AssertUnwindSafe(|| self.apply_one(command)))) {
            Ok(result) => self.last_error = result.err().map(|e| e.to_string()),
            Err(payload) => {
                let message = panicked(payload.as_ref());
                self.last_error = Some(message.clone());
                self.diverged = Some(message);
            }
        }
        true
    }

    fn apply_one(&mut self, command: Command) -> Result<(), SolverError> {
        let ghost = self.ghost.as_mut();
        match command {
            Command::SetParam(name, value) => self.solver.set_param(&name, value),
            Command::AddDrag(id, drag) => {
                if let Some(g) = ghost {
                    g.add_drag(id, drag);
                }
                self.solver.drags_mut().insert(id, drag)
            }
            Command::MoveDrag(id, kind) => {
                if let Some(g) = ghost {
                    g.move_drag(id, kind);
                }
                self.solver.drags_mut().retarget(id, kind)
            }
            Command::RemoveDrag(id) => {
                if let Some(g) = ghost {
                    g.remove_drag(id);
                }
                self.solver.drags_mut().remove(id).map(|_| ())
            }
            Command::ClearDrags => {
                if let Some(g) = ghost {
                    g.clear_drags();
                }
                self.solver.drags_mut().clear();
                Ok(())
            }
            Command::Reset => {
                if let Some(g) = ghost {
                    g.reset();
                }
                self.solver.reset();
                self.restart();
                Ok(())
            }
            Command::SetGhost(solver) => {
                self.ghost = solver.map(|s| {
                    let mut g = Ghost::new(s);
                    // The ghost takes the main solver's drags and catches up with its time.
                    self.solver.drags().iter().for_each(|&(id, d)| g.add_drag(id, d));
                    g.follow(self.time, self.solver.positions());
                    g
                });
                Ok(())
            }
            Command::SetPaused(p) => {
                self.paused = p;
                Ok(())
            }
            Command::StepOnce => {
                self.paused = true;
                self.step();
                Ok(())
            }
            Command::SetPacing(p) => {
                self.pacing = p;
                self.owed = 0.0;
                Ok(())
            }
            Command::Watch(setup) => {
                self.readout = setup.map(|s| Readout::new(*s));
                Ok(())
            }
            Command::Replace(solver) => {
                self.solver = solver;
                self.solver.expect_drags();
                self.ghost = None;
                self.readout = None;
                // What the old solver, its loads and analyses freed goes back to the system.
                crate::memory::release_freed();
                self.restart();
                Ok(())
            }
            Command::Quit => Ok(()),
        }
    }

    fn step(&mut self) {
        if self.diverged.is_some() {
            return;
        }
        // A panicking solver stops as a diverging one does; the thread, and the window, go on.
        let (in_solver, ticket) = (&self.in_solver, self.discard.next());
        let solver = &mut self.solver;
        let step = || unless_superseded(&ticket, &|_| {}, |_| solver.step());
        let stepped = in_solver.mark(|| std::panic::catch_unwind(AssertUnwindSafe(step)));
        let outcome = match stepped {
            // A superseded step: the reset or switch that discards it is the next command.
            Ok(None) => return,
            Ok(Some(result)) => Ok(result),
            Err(payload) => Err(panicked(payload.as_ref())),
        };
        match outcome {
            Ok(Ok(stats)) => {
                self.stats = stats;
                self.steps += 1;
                self.time = stats.sim_time;
                self.remember_positions();
                if let Some(g) = &mut self.ghost {
                    g.follow(self.time, self.solver.positions());
                }
            }
            Ok(Err(e)) => self.diverged = Some(e.to_string()),
            Err(message) => self.diverged = Some(message),
        }
    }

    fn run(&mut self, rx: &Receiver<Command>, mut out: impl FnMut(Snapshot)) {
        let mut clock = Instant::now();
        loop {
            // Commands first; block briefly when there is nothing to step.
            let idle = self.paused || self.diverged.is_some();
            let first = if idle {
                match rx.recv_timeout(IDLE_WAIT) {
                    Ok(c) => Some(c),
                    Err(RecvTimeoutError::Timeout) => None,
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            } else {
                rx.try_recv().ok()
            };
            let mut changed = false;
            for command in first.into_iter().chain(std::iter::from_fn(|| rx.try_recv().ok())) {
                if !self.apply(command) {
                    return;
                }
                changed = true;
            }
            // Background work finishes, and its progress is shown, even while nothing steps.
            changed |= self.poll_background();
            if let Some(r) = &mut self.readout
                && self.diverged.is_none()
            {
                changed |= r.poll(self.solver.as_ref(), self.steps);
            }
            let now = Instant::now();
            let elapsed = now.duration_since(clock).as_secs_f64();
            clock = now;
            if self.paused || self.diverged.is_some() {
                self.owed = 0.0;
                if changed {
                    self.publish(&mut out);
                }
                continue;
            }
            self.running_wall += elapsed;
            let h = self.solver.time_step();
            let due = match self.pacing {
                Pacing::AsFastAsPossible => true,
                Pacing::Scaled(speed) => {
                    // Bounded catch-up: a backlog beyond MAX_BACKLOG is dropped, not stepped.
                    self.owed = (self.owed + elapsed * speed).min(MAX_BACKLOG.max(h));
                    if self.owed >= h {
                        self.owed -= h;
                        true
                    } else {
                        false
                    }
                }
            };
            if due {
                self.step();
                self.publish(&mut out);
            } else {
                if changed {
                    self.publish(&mut out);
                }
                if let Pacing::Scaled(speed) = self.pacing {
                    let wait = ((h - self.owed) / speed.max(1e-6)).clamp(0.0, 0.005);
                    std::thread::sleep(Duration::from_secs_f64(wait));
                }
            }
        }
    }
}

/// What a solver's panic said, for the panel: its message (a string payload) or that it had none.
fn panicked(payload: &(dyn std::any::Any + Send)) -> String {
    let what =
        payload.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| payload.downcast_ref::<String>().cloned());
    format!("the solver panicked: {}; Reset or another method recovers", what.as_deref().unwrap_or("(no message)"))
}
