//! `rigid`: the cheapest model — the mesh keeps its rest shape and translates to follow the first
//! position drag. For static props and for driving the pipeline without physics.
//!
//! `faulty` is the same follower with a `fault` parameter: set to 1, its next step panics (as an
//! index out of bounds in a real solver would); set to 2, its next step never returns (as an endless
//! loop would). It exists to test that a panicking or hanging solver is caught, reported and recovered
//! from by the simulation thread and the window, and is offered only when `SHELLWARP_TEST_METHODS` is
//! set ([`super::registry::TEST_METHODS`]).

use std::time::Instant;

use glam::DVec3;

use super::params::{self, Param, Redo};
use super::{DragKind, DragSet, ParamSpec, ParamValue, Solver, SolverError, StepStats};
use super::{Footprint, Method};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "rigid",
    summary: "no deformation: the mesh translates rigidly to follow the first position drag",
    build: |setup| Ok(Box::new(Rigid::new(setup, false)?)),
    footprint: Footprint::PARTICLES,
};

/// Registry entry of the test method that panics on command.
pub const FAULTY: Method = Method {
    name: "faulty",
    summary: "test method: the rigid follower, whose next step panics (`fault` = 1) or hangs (2) on command",
    build: |setup| Ok(Box::new(Rigid::new(setup, true)?)),
    footprint: Footprint::PARTICLES,
};

/// The rigid follower's parameter.
const PARAMS: &[Param<Rigid>] = &[Param::new(
    ParamSpec::linear("step", "time step", "s", "Fixed time step of the rigid follower.", 1e-6, 1.0)
        .in_scene("solver.step"),
    |r| r.step,
    |r, v| r.step = v,
    Redo::Nothing,
)];

/// The faulty follower's parameters: the rigid one's and the fault.
const FAULTY_PARAMS: &[Param<Rigid>] = &[
    PARAMS[0],
    Param::new(
        ParamSpec {
            integer: true,
            ..ParamSpec::linear(
                "fault",
                "fault",
                "",
                "1: the next step panics; 2: the next step never returns (tests of the window's recovery).",
                0.0,
                2.0,
            )
        },
        |r| r.fault.map_or(0.0, f64::from),
        |r, v| r.fault = Some(v as u8),
        Redo::Nothing,
    ),
];

/// The rigid follower.
struct Rigid {
    rest: Vec<DVec3>,
    positions: Vec<DVec3>,
    drags: DragSet,
    step: f64,
    steps: u64,
    /// `Some(armed)` for `faulty`: 0, or the fault the next step has (1 panic, 2 hang).
    fault: Option<u8>,
}

impl Rigid {
    /// Its parameter table: the faulty follower's has the fault too.
    fn table(&self) -> &'static [Param<Rigid>] {
        if self.fault.is_some() { FAULTY_PARAMS } else { PARAMS }
    }

    fn new(setup: &Setup, faulty: bool) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        let step = setup.scene.solver.step.unwrap_or(1.0 / 30.0);
        let rest = setup.mesh.positions().to_vec();
        let fault = faulty.then_some(0);
        Ok(Self { positions: rest.clone(), drags: DragSet::new(rest.len(), false), rest, step, steps: 0, fault })
    }
}

impl Solver for Rigid {
    fn method(&self) -> &'static str {
        if self.fault.is_some() { FAULTY.name } else { METHOD.name }
    }

    fn time_step(&self) -> f64 {
        self.step
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        // A fault fires once.
        match self.fault.as_mut().map(std::mem::take) {
            Some(1) => panic!("index out of bounds: the faulty test method's fault was set (step {})", self.steps + 1),
            Some(2) => loop {
                std::thread::sleep(std::time::Duration::from_secs(1));
            },
            _ => {}
        }
        let offset = self
            .drags
            .iter()
            .find_map(|(_, d)| match d.kind {
                DragKind::Position(target) => Some(target - self.rest[d.vertex]),
                DragKind::Orientation(_) => None,
            })
            .unwrap_or(DVec3::ZERO);
        for (p, r) in self.positions.iter_mut().zip(&self.rest) {
            *p = *r + offset;
        }
        self.steps += 1;
        let sim_time = self.steps as f64 * self.step;
        super::check_finite(self.steps, sim_time, &self.positions, 0.0, f64::INFINITY)?;
        Ok(StepStats { wall_seconds: start.elapsed().as_secs_f64(), sim_time, ..StepStats::default() })
    }

    fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    fn reset(&mut self) {
        self.positions.clone_from(&self.rest);
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        params::values(self.table(), self)
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        params::set(self.table(), self, name, value).map(drop)
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::{Drag, build};

    #[test]
    fn follows_the_first_position_drag_and_resets() {
        let setup = crate::scene::load("cantilever", &["solver.method=rigid".to_string()]).unwrap();
        let mut s = build(&setup).unwrap();
        let v = 5;
        let target = setup.mesh.positions()[v] + DVec3::new(0.0, 0.3, 0.0);
        s.drags_mut().add(Drag { vertex: v, kind: DragKind::Position(target) }).unwrap();
        let stats = s.step().unwrap();
        assert!((stats.sim_time - 1.0 / 30.0).abs() < 1e-15);
        assert!((s.positions()[v] - target).length() < 1e-12);
        assert!((s.positions()[0] - setup.mesh.positions()[0] - DVec3::new(0.0, 0.3, 0.0)).length() < 1e-12);
        s.reset();
        assert_eq!(s.positions(), setup.mesh.positions());
        assert!(s.set_param("step", -1.0).is_err());
        assert!(s.set_param("nope", 1.0).is_err());
        s.set_param("step", 0.01).unwrap();
        assert_eq!(s.time_step(), 0.01);
    }

    #[test]
    fn the_faulty_method_panics_once_on_command() {
        let setup = crate::scene::load("cantilever", &[]).unwrap();
        let mut s = (FAULTY.build)(&setup).unwrap();
        s.step().unwrap();
        assert!(s.set_param("fault", 3.0).is_err());
        s.set_param("fault", 1.0).unwrap();
        let panic = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| s.step())).unwrap_err();
        assert!(panic.downcast_ref::<String>().is_some_and(|m| m.contains("fault was set (step 2)")));
        s.step().unwrap(); // once
        assert!((METHOD.build)(&setup).unwrap().set_param("fault", 1.0).is_err(), "rigid has no fault");
    }
}
