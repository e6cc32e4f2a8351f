//! Running a solver for a while and timing it: to rest, for a time or a number of steps, optionally
//! moving its drags before each step. Used by the automatic model choice and by `eval`.

use std::time::Instant;

use glam::DVec3;

use super::{Solver, SolverError};

/// How a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Came to rest (position change per step below the tolerance).
    Rest,
    /// Ran its whole time without coming to rest (or was not asked to).
    Ran,
    /// The solver reported divergence (its own message).
    Diverged(SolverError),
}

/// A timed run.
#[derive(Debug, Clone)]
pub struct Run {
    /// Final positions (the last finite state if it diverged).
    pub positions: Vec<DVec3>,
    /// How it ended.
    pub outcome: Outcome,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time reached, s.
    pub sim_time: f64,
    /// Wall-clock time spent inside `step`, s.
    pub wall: f64,
    /// Steps whose inner solve did not converge.
    pub unconverged_steps: u64,
}

impl Run {
    /// Wall-clock seconds per simulated second (NaN if nothing was simulated).
    pub fn cost(&self) -> f64 {
        if self.sim_time > 0.0 { self.wall / self.sim_time } else { f64::NAN }
    }

    /// The outcome as one word for tables: `rest`, `ran` or `diverged`.
    pub fn outcome_word(&self) -> &'static str {
        match self.outcome {
            Outcome::Rest => "rest",
            Outcome::Ran => "ran",
            Outcome::Diverged(_) => "diverged",
        }
    }

    /// The solver's divergence message, or empty.
    pub fn message(&self) -> String {
        match &self.outcome {
            Outcome::Diverged(e) => e.to_string(),
            _ => String::new(),
        }
    }
}

/// When to stop a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// Simulated time limit, s.
    pub max_time: f64,
    /// Step limit.
    pub max_steps: u64,
    /// Rest: stop once `‖x⁺ − x‖ ≤ rest · ‖x⁺ − X‖` for [`REST_STEPS`] steps in a row (0: never).
    pub rest: f64,
}

/// Consecutive quiet steps that make a rest.
pub const REST_STEPS: usize = 5;

/// Step until `stop` says so or the solver diverges, timing only the steps.
pub fn run(solver: &mut dyn Solver, rest: &[DVec3], stop: Stop) -> Run {
    run_driven(solver, rest, stop, &mut |_, _| Ok(()))
}

/// [`run`], calling `drive(solver, t)` before each step (at the simulated time `t` the step starts
/// from) to move drags; a drive error ends the run as a divergence would, with that error.
pub fn run_driven(
    solver: &mut dyn Solver,
    rest: &[DVec3],
    stop: Stop,
    drive: &mut dyn FnMut(&mut dyn Solver, f64) -> Result<(), SolverError>,
) -> Run {
    let mut wall = 0.0;
    let mut steps = 0;
    let mut sim_time = 0.0;
    let mut unconverged_steps = 0;
    let mut quiet = 0;
    let mut previous = solver.positions().to_vec();
    let outcome = loop {
        if sim_time >= stop.max_time * (1.0 - 1e-9) || steps >= stop.max_steps {
            break Outcome::Ran;
        }
        if let Err(e) = drive(solver, sim_time) {
            break Outcome::Diverged(e);
        }
        let start = Instant::now();
        let result = solver.step();
        wall += start.elapsed().as_secs_f64();
        match result {
            Ok(stats) => {
                steps += 1;
                sim_time = stats.sim_time;
                unconverged_steps += u64::from(!stats.converged);
            }
            Err(e) => break Outcome::Diverged(e),
        }
        let x = solver.positions();
        if stop.rest > 0.0 {
            let moved = distance(x, &previous);
            quiet = if moved <= stop.rest * distance(x, rest) { quiet + 1 } else { 0 };
            if quiet >= REST_STEPS {
                previous.copy_from_slice(x);
                break Outcome::Rest;
            }
        }
        previous.copy_from_slice(x);
    };
    Run { positions: previous, outcome, steps, sim_time, wall, unconverged_steps }
}

/// `‖a − b‖₂` over all vertices.
pub fn distance(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (*p - *q).length_squared()).sum::<f64>().sqrt()
}
