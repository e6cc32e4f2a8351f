//! The live quality readout: how far the running model is from the full discrete shell, while the
//! user drags it.
//!
//! The area change is computed with every snapshot (one pass over the triangles). The estimated
//! error ([`crate::solver::quality::estimate`]: a few Newton iterations of the full shell equations
//! from the shape, position drags pinned) is computed on a worker thread from a copy of the state,
//! again as soon as the last one is done and the state has moved (at most every [`INTERVAL`]). Past
//! the target (the scene's `solver.accuracy`, else 5%) the readout becomes a warning, and the worker
//! looks once per method, mode count and set of dragged vertices for a remedy: the cheapest model
//! among a few steps up from the running one that meets the target under the same drags
//! ([`crate::solver::auto::remedy`]), named in the warning with its own estimate. When the readout
//! goes (a scene or method switch, or watching stops), the worker's judgement under way stops at its
//! next iteration ([`crate::solver::supersede`]) and the worker ends: a remedy search builds and
//! settles several models, and must not go on holding their memory for a scene no longer shown.

use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::time::{Duration, Instant};

use glam::DVec3;

use crate::scene::Setup;
use crate::solver::quality::{self, DEFAULT_TARGET};
use crate::solver::supersede::{Generation, unless_superseded};
use crate::solver::{DragKind, DragSet, ParamValue, Solver, auto};

/// The shortest time between two estimates.
pub const INTERVAL: Duration = Duration::from_millis(250);

/// What the panel shows.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReadoutView {
    /// Relative area change of the current shape.
    pub area_change: f64,
    /// The latest estimated relative error (None: not judged, or not computed yet).
    pub estimate: Option<f64>,
    /// The step count of the state the estimate judged.
    pub judged_step: u64,
    /// The relative error past which the readout warns.
    pub target: f64,
    /// The running method and its mode count, as judged.
    pub model: String,
    /// The remedy, once looked for (or that it is being looked for).
    pub remedy: Option<String>,
    /// Why the last estimate failed, if it did.
    pub failure: Option<String>,
}

impl ReadoutView {
    /// The warning to show, if the model is not enough: its estimated error or its area change is
    /// past the target.
    pub fn warning(&self) -> Option<String> {
        let error = self.estimate.filter(|&e| e > self.target);
        let area = (self.area_change.abs() > self.target).then_some(self.area_change);
        if error.is_none() && area.is_none() {
            return None;
        }
        let mut what = Vec::new();
        if let Some(e) = error {
            what.push(format!("estimated {:.1}% off the full shell", 100.0 * e));
        }
        if let Some(a) = area {
            what.push(format!("area {:+.1}%", 100.0 * a));
        }
        let remedy = self.remedy.as_deref().map_or(String::new(), |r| format!(" {r}"));
        Some(format!(
            "{} is not enough here: {} (target {:.0}%).{remedy}",
            self.model,
            what.join(", "),
            100.0 * self.target
        ))
    }
}

/// A state to judge.
struct Job {
    step: u64,
    positions: Vec<DVec3>,
    drags: DragSet,
    params: Vec<ParamValue>,
    method: &'static str,
    modes: Option<usize>,
    remedy: bool,
}

enum Finding {
    Estimate(u64, Result<f64, String>),
    Remedy(String),
}

/// Which model and which dragged vertices a remedy was looked for.
type RemedyKey = (&'static str, Option<usize>, Vec<usize>);

/// The readout of one scene, owned by the simulation thread.
pub struct Readout {
    setup: Setup,
    jobs: Sender<Job>,
    findings: Receiver<Finding>,
    busy: bool,
    last: Option<Instant>,
    /// The state (steps, drag revision) the last job was sent for.
    sent_for: Option<(u64, u64)>,
    remedy_for: Option<RemedyKey>,
    view: ReadoutView,
    /// The worker's ticket is current until the readout goes.
    generation: Generation,
}

impl Readout {
    /// A readout for the scene `setup`, with its worker thread.
    pub fn new(setup: Setup) -> Self {
        let (jobs, inbox) = mpsc::channel::<Job>();
        let (outbox, findings) = mpsc::channel();
        let worker_setup = setup.clone();
        let generation = Generation::default();
        let ticket = generation.next();
        let spawned = std::thread::Builder::new().name("shellwarp-readout".into()).spawn(move || {
            let quiet = |_: f32| {};
            for job in inbox {
                let Some(estimate) = unless_superseded(&ticket, &quiet, |p| judge(&worker_setup, &job, p)) else {
                    return;
                };
                if outbox.send(Finding::Estimate(job.step, estimate)).is_err() {
                    return;
                }
                if job.remedy {
                    let Some(r) = unless_superseded(&ticket, &quiet, |p| remedy(&worker_setup, &job, p)) else {
                        return;
                    };
                    if outbox.send(Finding::Remedy(r)).is_err() {
                        return;
                    }
                }
            }
        });
        let target = setup.scene.solver.accuracy.unwrap_or(DEFAULT_TARGET);
        let failure = spawned.err().map(|e| format!("no readout worker: {e}"));
        Self {
            setup,
            jobs,
            findings,
            busy: false,
            last: None,
            sent_for: None,
            remedy_for: None,
            view: ReadoutView { target, failure, ..ReadoutView::default() },
            generation,
        }
    }

    /// Take in the worker's findings and, if it is idle, hand it the current state of `solver`
    /// (after `steps` steps) when that has changed. Returns whether a finding came in.
    pub fn poll(&mut self, solver: &dyn Solver, steps: u64) -> bool {
        let mut found = false;
        loop {
            let finding = self.findings.try_recv();
            found |= finding.is_ok();
            match finding {
                Ok(Finding::Estimate(step, Ok(e))) => {
                    (self.view.estimate, self.view.judged_step, self.view.failure) = (Some(e), step, None);
                    self.busy = false;
                }
                Ok(Finding::Estimate(_, Err(e))) => (self.view.failure, self.busy) = (Some(e), false),
                Ok(Finding::Remedy(r)) => self.view.remedy = Some(r),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    self.busy = true; // never send again
                    break;
                }
            }
        }
        let method = solver.method();
        let modes = modes(&solver.params());
        self.view.model = match modes {
            Some(m) => format!("{method}, {m} modes"),
            None => method.to_string(),
        };
        let state = (steps, solver.drags().revision());
        let due = self.last.is_none_or(|t| t.elapsed() >= INTERVAL);
        if !quality::judged(method) || self.busy || !due || self.sent_for == Some(state) {
            if !quality::judged(method) {
                self.view.estimate = None;
            }
            return found;
        }
        let key: RemedyKey = (method, modes, dragged(solver.drags()));
        let over = self.view.estimate.is_some_and(|e| e > self.view.target);
        let remedy = over && self.remedy_for.as_ref() != Some(&key);
        if remedy {
            self.remedy_for = Some(key);
            self.view.remedy = Some(format!("Looking for a model that meets {:.0}%…", 100.0 * self.view.target));
        } else if self.remedy_for.as_ref().is_some_and(|k| *k != key) {
            (self.remedy_for, self.view.remedy) = (None, None);
        }
        let job = Job {
            step: steps,
            positions: solver.positions().to_vec(),
            drags: solver.drags().clone(),
            params: solver.params(),
            method,
            modes,
            remedy,
        };
        if self.jobs.send(job).is_ok() {
            (self.busy, self.last, self.sent_for) = (true, Some(Instant::now()), Some(state));
        }
        found
    }

    /// The readout for `positions` (the shape now shown).
    pub fn view(&self, positions: &[DVec3]) -> ReadoutView {
        ReadoutView { area_change: self.setup.mesh.area_change(positions), ..self.view.clone() }
    }
}

impl Drop for Readout {
    fn drop(&mut self) {
        self.generation.cancel_all();
    }
}

/// The mode count among a solver's parameters, if it has one.
fn modes(params: &[ParamValue]) -> Option<usize> {
    params.iter().find(|p| p.spec.name == "modes").map(|p| p.value as usize)
}

/// The vertices held by position drags, sorted.
fn dragged(drags: &DragSet) -> Vec<usize> {
    let mut v: Vec<usize> =
        drags.iter().filter(|(_, d)| matches!(d.kind, DragKind::Position(_))).map(|(_, d)| d.vertex).collect();
    v.sort_unstable();
    v.dedup();
    v
}

fn judge(setup: &Setup, job: &Job, progress: &dyn Fn(f32)) -> Result<f64, String> {
    let setup = quality::with_params(setup, &job.params);
    quality::estimate_reporting(&setup, &job.positions, &job.drags, progress).map_err(|e| e.to_string())
}

fn remedy(setup: &Setup, job: &Job, progress: &dyn Fn(f32)) -> String {
    let setup = quality::with_params(setup, &job.params);
    let target = setup.scene.solver.accuracy.unwrap_or(DEFAULT_TARGET);
    match auto::remedy(&setup, target, &job.drags, (job.method, job.modes.unwrap_or(4)), progress) {
        Ok(choice) => {
            let w = choice.winner();
            if w.estimate <= target {
                format!("{} meets it (estimated {:.1}%).", w.label(), 100.0 * w.estimate)
            } else {
                format!("No model tried meets it; the closest is {} ({:.1}%).", w.label(), 100.0 * w.estimate)
            }
        }
        Err(e) => format!("No remedy found: {e}."),
    }
}
