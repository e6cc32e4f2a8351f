//! A soak of the real window: for a set time the viewer is driven by a seeded random script through
//! the paths a user's hands take — drags added and moved like the mouse's (position and
//! orientation), parameters edited within and outside their ranges, methods and scenes switched,
//! drags cleared, resets (its first minute's scene switches tour every scene in order), and, for
//! the `faulty` test method, a fault that makes its next step panic or, every other time, never
//! return — and what the window lived through is recorded: frames and their times by minute,
//! resident memory once a second and at home (its first scene at rest, revisited once a minute, so
//! that a leak shows apart from the memory the scene of the moment needs), frames that would draw a
//! non-finite position, the panics and hangs the panel showed and whether each was recovered from
//! (by *Reset* or by a method switch, alternately).

use std::collections::BTreeMap;
use std::time::Instant;

use glam::DVec3;

use super::panel::UiAction;
use super::sim_thread::{Command, SimStatus, Snapshot};
use crate::solver::{Drag, DragId, DragKind};

/// What to soak and where the report goes.
#[derive(Debug, Clone, Default)]
pub struct SoakOptions {
    /// How long, seconds.
    pub seconds: f64,
    /// Where the [`SoakReport`] is written (JSON).
    pub report: std::path::PathBuf,
    /// Methods to switch among; empty: every method, and scene switches too.
    pub methods: Vec<String>,
    /// Built-in scenes to switch among (when `methods` is empty).
    pub scenes: Vec<String>,
    /// The scene it starts on, and returns to once a minute to measure memory at home.
    pub home: String,
    /// The script's seed.
    pub seed: u64,
}

/// What a soak saw.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct SoakReport {
    /// Wall-clock seconds it ran.
    pub seconds: f64,
    /// Frames drawn.
    pub frames: u64,
    /// Scripted events by kind.
    pub events: BTreeMap<String, u64>,
    /// `(seconds, MB)`: resident memory once a second.
    pub resident_mb: Vec<(f64, f64)>,
    /// `(seconds, MB)`: resident memory at home — once a minute (with scene switches) the soak goes
    /// back to its first scene at rest, drags cleared, and measures after [`HOME_SETTLE`] seconds
    /// without events: what a leak would raise, whatever scene the minute ended on.
    pub home_mb: Vec<(f64, f64)>,
    /// What ran at each home measurement — the method shown, its steps and status, and the
    /// program's own threads (the simulation's, workers still loading, analysing or judging) — to
    /// tell a leak from work still under way.
    pub home_state: Vec<String>,
    /// Frame times of each minute: `[median, 99th percentile, longest]`, milliseconds.
    pub frame_ms_by_minute: Vec<[f64; 3]>,
    /// Frames whose positions held a non-finite number.
    pub non_finite_frames: u64,
    /// The messages of the panics the panel showed.
    pub panics: Vec<String>,
    /// Solvers the panel showed stuck in a step (with the seconds it had been, when first shown).
    pub hangs: Vec<String>,
    /// Panics and hangs after which the simulation ran again.
    pub recovered: u64,
    /// Distinct error messages the simulation reported (refused parameters, drags, divergences).
    pub errors: Vec<String>,
}

/// What the soak does to the viewer this frame.
pub enum Poke {
    /// As if from the panel.
    Ui(UiAction),
    /// As if from the mouse.
    Sim(Command),
}

/// The running soak.
pub struct Soak {
    options: SoakOptions,
    rng: u64,
    start: Instant,
    next_event: f64,
    next_sample: f64,
    drags: Vec<DragId>,
    next_drag: u64,
    /// Time a panic or hang was seen and not yet recovered from.
    panicked: Option<f64>,
    /// Whether the next fault set is a hang (they alternate, a panic first).
    hang_next: bool,
    /// Scenes shown by the first minute's tour so far.
    toured: usize,
    recover_by_reset: bool,
    /// When the current visit home began, if one is under way.
    home_since: Option<f64>,
    /// When the last panic was seen (the start before any).
    last_panic: f64,
    minute_frames: Vec<f64>,
    report: SoakReport,
}

/// Seconds at home, without events, before memory is measured there.
pub const HOME_SETTLE: f64 = 8.0;

/// Seconds at the start in which scene switches tour the scenes in order.
const TOUR: f64 = 60.0;

/// Seconds `faulty` may run without a panic before the script sets its fault.
const FAULT_AFTER: f64 = 4.0;

/// Drag ids of the soak's own, far from the mouse's.
const FIRST_DRAG: u64 = 1 << 40;

impl Soak {
    /// Start a soak now.
    pub fn new(options: SoakOptions) -> Self {
        let rng = options.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        Self {
            options,
            rng,
            start: Instant::now(),
            next_event: 0.5,
            next_sample: 0.0,
            drags: Vec::new(),
            next_drag: FIRST_DRAG,
            panicked: None,
            hang_next: false,
            toured: 0,
            recover_by_reset: true,
            home_since: None,
            last_panic: 0.0,
            minute_frames: Vec::new(),
            report: SoakReport::default(),
        }
    }

    fn next(&mut self) -> u64 {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn count(&mut self, kind: &str) {
        *self.report.events.entry(kind.to_string()).or_default() += 1;
    }

    /// Where the report goes.
    pub fn report_path(&self) -> &std::path::Path {
        &self.options.report
    }

    /// Whether the time is up.
    pub fn finished(&self) -> bool {
        self.start.elapsed().as_secs_f64() >= self.options.seconds
    }

    /// Record a frame that took `frame_ms` and shows `snapshot`; what to do now.
    pub fn tick(&mut self, snapshot: &Snapshot, frame_ms: f64) -> Vec<Poke> {
        let t = self.start.elapsed().as_secs_f64();
        self.record(snapshot, t, frame_ms);
        let mut pokes = Vec::new();
        // The mouse keeps moving what it holds.
        for &id in &self.drags.clone() {
            if let Some((_, d)) = snapshot.drags.iter().find(|(i, _)| *i == id)
                && let DragKind::Position(target) = d.kind
            {
                let nudge = DVec3::new(self.uniform(-1.0, 1.0), self.uniform(-1.0, 1.0), self.uniform(-1.0, 1.0));
                pokes.push(Poke::Sim(Command::MoveDrag(id, DragKind::Position(target + 0.01 * nudge))));
            }
        }
        let homes = self.options.methods.is_empty() && !self.options.home.is_empty();
        let visits = self.report.home_mb.len() + usize::from(self.home_since.is_some());
        match (self.panicked, self.home_since) {
            (_, Some(since)) if t >= since + HOME_SETTLE => {
                self.home_since = None;
                self.report.home_mb.push((t, crate::memory::resident_bytes() as f64 / 1e6));
                let state = format!(
                    "{} at step {} ({:?}); threads: {}",
                    snapshot.method,
                    snapshot.steps,
                    snapshot.status,
                    own_threads().join(", ")
                );
                self.report.home_state.push(state);
            }
            (_, Some(_)) => {}
            _ if homes && t >= 60.0 * (visits + 1) as f64 => {
                self.home_since = Some(t);
                self.drags.clear();
                self.count("home");
                pokes.push(Poke::Ui(UiAction::SwitchScene(self.options.home.clone())));
                pokes.push(Poke::Ui(UiAction::ClearDrags));
            }
            (Some(seen), None) if t > seen + 0.5 => {
                self.panicked = Some(f64::INFINITY); // once
                self.recover_by_reset = !self.recover_by_reset;
                let poke = if self.recover_by_reset { self.switch_method() } else { UiAction::Reset };
                self.count("recovery");
                pokes.push(Poke::Ui(poke));
            }
            _ if t >= self.next_event => {
                self.next_event = t + self.uniform(0.1, 0.7);
                pokes.extend(self.event(snapshot, t));
            }
            _ => {}
        }
        pokes
    }

    fn record(&mut self, snapshot: &Snapshot, t: f64, frame_ms: f64) {
        let r = &mut self.report;
        r.frames += 1;
        r.seconds = t;
        if snapshot.positions.iter().any(|p| !p.is_finite()) {
            r.non_finite_frames += 1;
        }
        match &snapshot.status {
            SimStatus::Diverged(why) if why.contains("panicked") && self.panicked.is_none() => {
                r.panics.push(why.clone());
                self.panicked = Some(t);
                self.last_panic = t;
            }
            SimStatus::Stuck(seconds) if self.panicked.is_none() => {
                r.hangs.push(format!("`{}` stuck in a step for {seconds:.0} s", snapshot.method));
                self.panicked = Some(t);
                self.last_panic = t;
            }
            SimStatus::Running if self.panicked.is_some() => {
                r.recovered += 1;
                self.panicked = None;
            }
            _ => {}
        }
        let error = match &snapshot.status {
            SimStatus::Diverged(why) => Some(why),
            _ => snapshot.last_error.as_ref(),
        };
        if let Some(e) = error.filter(|e| !r.errors.contains(e)) {
            r.errors.push(e.clone());
        }
        if t >= self.next_sample {
            self.next_sample += 1.0;
            r.resident_mb.push((t, crate::memory::resident_bytes() as f64 / 1e6));
        }
        if (t / 60.0) as usize > r.frame_ms_by_minute.len() {
            self.close_minute();
        }
        self.minute_frames.push(frame_ms);
    }

    fn close_minute(&mut self) {
        let mut f = std::mem::take(&mut self.minute_frames);
        if f.is_empty() {
            return;
        }
        f.sort_by(f64::total_cmp);
        let at = |q: f64| f[((f.len() - 1) as f64 * q).round() as usize];
        self.report.frame_ms_by_minute.push([at(0.5), at(0.99), at(1.0)]);
    }

    fn switch_method(&mut self) -> UiAction {
        let methods: Vec<String> = if self.options.methods.is_empty() {
            crate::solver::METHODS.iter().map(|m| m.name.to_string()).collect()
        } else {
            self.options.methods.clone()
        };
        UiAction::SwitchMethod(methods[self.below(methods.len())].clone())
    }

    /// One scripted event.
    fn event(&mut self, snapshot: &Snapshot, t: f64) -> Vec<Poke> {
        let n = snapshot.positions.len().max(1);
        let faulty = snapshot.method == "faulty";
        if faulty && t > self.last_panic + FAULT_AFTER && self.panicked.is_none() {
            return vec![self.fault()];
        }
        let scenes = self.options.methods.is_empty() && !self.options.scenes.is_empty();
        let kind = self.below(12);
        let poke = match kind {
            0..=2 => {
                let vertex = self.below(n);
                let here = snapshot.positions.get(vertex).copied().unwrap_or_default();
                let offset = DVec3::new(self.uniform(-0.3, 0.3), self.uniform(-0.3, 0.3), self.uniform(-0.3, 0.3));
                let id = DragId(self.next_drag);
                self.next_drag += 1;
                self.drags.push(id);
                self.count("drag");
                Poke::Sim(Command::AddDrag(id, Drag { vertex, kind: DragKind::Position(here + offset) }))
            }
            3 => {
                let w = DVec3::new(self.uniform(-3.0, 3.0), self.uniform(-3.0, 3.0), self.uniform(-3.0, 3.0));
                let id = DragId(self.next_drag);
                self.next_drag += 1;
                self.count("twist");
                Poke::Sim(Command::AddDrag(id, Drag { vertex: self.below(n), kind: DragKind::Orientation(w) }))
            }
            4 | 5 if !snapshot.params.is_empty() => {
                let p = snapshot.params[self.below(snapshot.params.len())].spec;
                let value = if kind == 4 {
                    self.count("parameter in range");
                    let v = self.uniform(p.min, p.max.min(p.min.abs().max(1.0) * 1e3));
                    if p.integer { v.round() } else { v }
                } else {
                    self.count("parameter out of range");
                    [f64::NAN, -1.0, p.max * 10.0 + 1.0, f64::INFINITY, p.min - 1.0][self.below(5)]
                };
                // Sent as the panel's edit would be, through the same command, unchecked.
                Poke::Sim(Command::SetParam(p.name.to_string(), value))
            }
            6 | 7 if scenes && t < TOUR => {
                // The first minute tours the scenes in order, so that home is first measured once
                // each has been shown (the first showing of a scene warms caches that then stay).
                self.count("scene switch");
                let pick = self.toured % self.options.scenes.len();
                self.toured += 1;
                Poke::Ui(UiAction::SwitchScene(self.options.scenes[pick].clone()))
            }
            6 if scenes => {
                self.count("scene switch");
                let pick = self.below(self.options.scenes.len());
                Poke::Ui(UiAction::SwitchScene(self.options.scenes[pick].clone()))
            }
            6 | 7 => {
                self.count("method switch");
                Poke::Ui(self.switch_method())
            }
            8 => {
                self.count("reset");
                Poke::Ui(UiAction::Reset)
            }
            9 => {
                self.count("clear drags");
                self.drags.clear();
                Poke::Ui(UiAction::ClearDrags)
            }
            _ if faulty => self.fault(),
            _ if matches!(snapshot.status, SimStatus::Diverged(_)) => {
                self.count("reset after divergence");
                Poke::Ui(UiAction::Reset)
            }
            _ => return Vec::new(),
        };
        vec![poke]
    }

    /// Set the `faulty` method's fault: a panic and a hang in turn.
    fn fault(&mut self) -> Poke {
        self.count("fault");
        let kind = if self.hang_next { 2.0 } else { 1.0 };
        self.hang_next = !self.hang_next;
        Poke::Sim(Command::SetParam("fault".into(), kind))
    }

    /// The report so far, with the current minute's frames closed.
    pub fn report(&mut self) -> SoakReport {
        self.close_minute();
        self.report.clone()
    }
}

/// Names of this process's threads that are the program's own (`shellwarp-…`), sorted.
fn own_threads() -> Vec<String> {
    let tasks = std::fs::read_dir("/proc/self/task").into_iter().flatten().flatten();
    let mut names: Vec<String> = tasks
        .filter_map(|t| std::fs::read_to_string(t.path().join("comm")).ok())
        .map(|n| n.trim().to_string())
        .filter(|n| n.starts_with("shellwarp-"))
        .collect();
    names.sort();
    names
}
