//! `rigid`: the cheapest model — the mesh keeps its rest shape and translates to follow the first
//! position drag. For static props and for driving the pipeline without physics.

use std::time::Instant;

use glam::DVec3;

use super::registry::{Footprint, Method};
use super::{DragKind, DragSet, ParamSpec, ParamValue, Solver, SolverError, StepStats};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "rigid",
    summary: "no deformation: the mesh translates rigidly to follow the first position drag",
    build: |setup| Ok(Box::new(Rigid::new(setup)?)),
    footprint: Footprint::PARTICLES,
};

const PARAMS: [ParamSpec; 1] = [ParamSpec {
    name: "step",
    label: "time step",
    unit: "s",
    help: "Fixed time step of the rigid follower.",
    min: 1e-6,
    max: 1.0,
    log_scale: true,
    integer: false,
}];

/// The rigid follower.
struct Rigid {
    rest: Vec<DVec3>,
    positions: Vec<DVec3>,
    drags: DragSet,
    step: f64,
    steps: u64,
}

impl Rigid {
    fn new(setup: &Setup) -> Result<Self, SolverError> {
        let step = PARAMS[0].check(setup.scene.solver.step.unwrap_or(1.0 / 30.0))?;
        let rest = setup.mesh.positions().to_vec();
        Ok(Self { positions: rest.clone(), drags: DragSet::new(rest.len(), false), rest, step, steps: 0 })
    }
}

impl Solver for Rigid {
    fn method(&self) -> &'static str {
        METHOD.name
    }

    fn time_step(&self) -> f64 {
        self.step
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
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
        vec![ParamValue { spec: PARAMS[0], value: self.step }]
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        self.step = ParamSpec::find(METHOD.name, &PARAMS, name)?.check(value)?;
        Ok(())
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
}
