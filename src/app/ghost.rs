//! The reference "ghost": a second solver on the same scene, stepped in the simulation thread to the
//! main solver's time with the same drags, drawn as a wireframe over the main one, with the live
//! relative displacement error `‖x_main − x_ghost‖ / ‖x_ghost − X‖` (the ghost is the reference).
//! So a user sees what a cheaper method gives up (`--method mwts --ghost ds-implicit`).
//!
//! A ghost must not stall the loop: before it is accepted, one step of it is timed, and a ghost that
//! needs more than [`MAX_GHOST_COST`] wall-clock seconds per simulated second is refused, saying so.

use std::time::Instant;

use glam::DVec3;

use crate::solver::{Drag, DragId, DragKind, Solver, SolverError};

/// The most wall-clock seconds per simulated second a ghost may cost: half of real time, leaving the
/// other half to the main solver.
pub const MAX_GHOST_COST: f64 = 0.5;

/// Time one step of `solver` (then reset it): its wall-clock seconds per simulated second, or why it
/// is refused (too slow for real time, or it failed).
pub fn check_pace(solver: &mut dyn Solver) -> Result<f64, String> {
    let start = Instant::now();
    let stats = solver.step().map_err(|e| format!("ghost {}: its first step failed: {e}", solver.method()))?;
    let cost = start.elapsed().as_secs_f64() / stats.sim_time.max(f64::MIN_POSITIVE);
    solver.reset();
    if cost > MAX_GHOST_COST {
        return Err(format!(
            "ghost {} refused: it needs {cost:.2} s of computing per simulated second (measured on its first step), \
             more than the {MAX_GHOST_COST} s that keeps the view in real time",
            solver.method()
        ));
    }
    Ok(cost)
}

/// A ghost in the simulation thread.
pub struct Ghost {
    solver: Box<dyn Solver>,
    rest: Vec<DVec3>,
    time: f64,
    error: f64,
    /// Why the ghost stopped or what it refused (it keeps its last state).
    message: Option<String>,
    stopped: bool,
}

/// What the snapshot shows of a ghost.
#[derive(Debug, Clone, PartialEq)]
pub struct GhostView {
    /// The ghost's method.
    pub method: &'static str,
    /// Its positions at the main solver's time.
    pub positions: Vec<DVec3>,
    /// `‖x_main − x_ghost‖ / ‖x_ghost − X‖` (0 while the ghost is at rest).
    pub error: f64,
    /// A refused drag or a divergence of the ghost, if any.
    pub message: Option<String>,
}

/// `‖x − reference‖ / ‖reference − rest‖`, or 0 when the reference has not moved.
pub fn relative_error(x: &[DVec3], reference: &[DVec3], rest: &[DVec3]) -> f64 {
    let d = |a: &[DVec3], b: &[DVec3]| a.iter().zip(b).map(|(p, q)| (*p - *q).length_squared()).sum::<f64>().sqrt();
    let scale = d(reference, rest);
    if scale > 0.0 { d(x, reference) / scale } else { 0.0 }
}

impl Ghost {
    /// A ghost from a solver built on the same scene as the main one.
    pub fn new(solver: Box<dyn Solver>) -> Self {
        let rest = solver.positions().to_vec();
        Self { solver, rest, time: 0.0, error: 0.0, message: None, stopped: false }
    }

    /// Step to the main solver's time `t` (to within half the ghost's step) and compare with `main`.
    pub fn follow(&mut self, t: f64, main: &[DVec3]) {
        while !self.stopped && self.time < t - 0.5 * self.solver.time_step() {
            match self.solver.step() {
                Ok(stats) => self.time = stats.sim_time,
                Err(e) => {
                    self.message = Some(format!("ghost {} stopped: {e}", self.solver.method()));
                    self.stopped = true;
                }
            }
        }
        self.error = relative_error(main, self.solver.positions(), &self.rest);
    }

    /// Mirror a drag command; a drag the ghost cannot take is noted, not fatal.
    pub fn add_drag(&mut self, id: DragId, drag: Drag) {
        let result = self.solver.drags_mut().insert(id, drag);
        self.note(result);
    }

    /// Mirror a drag move.
    pub fn move_drag(&mut self, id: DragId, kind: DragKind) {
        // A drag the ghost refused has no id here: nothing to move.
        let _ = self.solver.drags_mut().retarget(id, kind);
    }

    /// Mirror a drag removal.
    pub fn remove_drag(&mut self, id: DragId) {
        let _ = self.solver.drags_mut().remove(id);
    }

    /// Mirror clearing every drag.
    pub fn clear_drags(&mut self) {
        self.solver.drags_mut().clear();
    }

    /// Back to time zero with the main solver.
    pub fn reset(&mut self) {
        self.solver.reset();
        self.time = 0.0;
        self.error = 0.0;
        self.stopped = false;
        self.message = None;
    }

    fn note(&mut self, result: Result<(), SolverError>) {
        if let Err(e) = result {
            self.message = Some(format!("ghost {}: {e}", self.solver.method()));
        }
    }

    /// What to show.
    pub fn view(&self) -> GhostView {
        GhostView {
            method: self.solver.method(),
            positions: self.solver.positions().to_vec(),
            error: self.error,
            message: self.message.clone(),
        }
    }
}
