//! The `drag` family: the creature's head (vertex 100) dragged down and sideways by a distance, its
//! target moved there over a ramp time (0: a jump, the mouse's grab), then held; every reduced shell
//! method at 8 modes. The creature (12,962 vertices) is where a user meets the reduced methods'
//! failures under a drag; its discrete-shell reference walked through one drag takes minutes, so
//! here a run is judged by its area (inflated past 10%, inaccurate past 1%) and the solver's
//! own divergence — the `drag` experiment judges the shape against `ds-static`.

use glam::DVec3;

use super::super::super::measure::{self, Stop};
use super::{Probe, Row};
use crate::eval::EvalError;
use crate::scene::Key;

/// How the family is set up, for the summary.
pub const SETUP: &str = "the creature's vertex 100 dragged down and sideways (direction (0.26, −0.46, 0.01)) by \
    0.05–0.53 m, reached by a jump or over a ramp of 0.1 s (up to 5.3 m/s) or 1 s, then held 2 s; `lma`, `mwts`, \
    `mwts-rs`, `rds` at 8 modes, judged by their area change.";

const VERTEX: usize = 100;
const DIRECTION: [f64; 3] = [0.2585, -0.4637, 0.0082];
const MODES: usize = 8;
const HOLD: f64 = 2.0;
const DISTANCES: [f64; 4] = [0.05, 0.1, 0.25, 0.53];
const QUICK_DISTANCES: [f64; 2] = [0.05, 0.53];
const RAMPS: [f64; 3] = [0.0, 0.1, 1.0];
const METHODS: [&str; 4] = ["lma", "mwts", "mwts-rs", "rds"];

/// One row per method and ramp (quick: `mwts` with a jump).
pub fn rows(quick: bool) -> Vec<Row> {
    let (methods, ramps, xs): (&[&'static str], &[f64], &[f64]) =
        if quick { (&["mwts"], &RAMPS[..1], &QUICK_DISTANCES) } else { (&METHODS, &RAMPS, &DISTANCES) };
    methods.iter().flat_map(|&method| ramps.iter().map(move |&y| Row { method, y, xs: xs.to_vec() })).collect()
}

/// Run one cell: `method` with the head dragged `distance` metres over `ramp` seconds.
pub fn probe(method: &str, distance: f64, ramp: f64) -> Result<Probe, EvalError> {
    let mut s = measure::setup("creature", method, &[format!("solver.modes={MODES}")])?;
    let offset = DVec3::from(DIRECTION).normalize() * distance;
    let key = |time: f64, at: DVec3| Key { time, position: Some(at.to_array()), rotation: None };
    let keys = if ramp > 0.0 { vec![key(0.0, DVec3::ZERO), key(ramp, offset)] } else { vec![key(0.0, offset)] };
    measure::add_track(&mut s, vec![VERTEX], keys);
    let rest = s.mesh.positions().to_vec();
    let run = measure::run(
        measure::build(&s)?.as_mut(),
        &rest,
        Stop { max_time: ramp + HOLD, max_steps: u64::MAX, rest: 0.0 },
    );
    let area = measure::area_change(&run.positions, &s);
    Ok(Probe::new(run, f64::NAN, area, true, None))
}
