//! `ds-static`: static equilibrium of the loaded, anchored shell — Newton with line search on the
//! potential `W(x) − f_extᵀ(x − X)` (see [`super::newton`]). Each [`Solver::step`] runs Newton from
//! the current positions until converged (or the iteration cap), so after a step the positions are
//! the equilibrium; changing a load parameter and stepping again continues from there (load stepping).

use std::time::Instant;

use glam::DVec3;

use super::ds_implicit::NEWTON_PARAMS;
use super::newton::NewtonSettings;
use super::registry::Method;
use super::shell_model::SHELL_PARAMS;
use super::{DragSet, ParamSpec, ParamValue, ShellModel, Solver, SolverError, StepStats, check_finite};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "ds-static",
    summary: "discrete shell static equilibrium: Newton with line search on W − f_extᵀu",
    build: |setup| Ok(Box::new(DsStatic::new(setup)?)),
};

/// The static equilibrium solver.
pub struct DsStatic {
    model: ShellModel,
    x: Vec<DVec3>,
    newton: NewtonSettings,
    drags: DragSet,
    steps: u64,
}

impl DsStatic {
    /// Build from a scene. The scene needs anchors: a free shell under load has no equilibrium.
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        let model = ShellModel::new(setup)?;
        if !model.has_constraints() {
            return Err(SolverError::Unsuitable {
                method: METHOD.name,
                reason: "no anchored vertices: a free shell under load has no static equilibrium".into(),
            });
        }
        let s = &setup.scene.solver;
        let max_iterations = NEWTON_PARAMS[1].check(s.iterations as f64)? as usize;
        let tolerance = NEWTON_PARAMS[2].check(s.tolerance)?;
        let x = model.rest().to_vec();
        let n = x.len();
        Ok(Self {
            model,
            x,
            newton: NewtonSettings { max_iterations, tolerance },
            drags: DragSet::new(n, false),
            steps: 0,
        })
    }
}

impl Solver for DsStatic {
    fn method(&self) -> &'static str {
        METHOD.name
    }

    fn time_step(&self) -> f64 {
        1.0 / 30.0
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        let mut v = vec![DVec3::ZERO; self.x.len()];
        self.model.apply_drags(&self.drags, &mut self.x, &mut v)?;
        let time = (self.steps + 1) as f64 * self.time_step();
        let report = self.model.minimize(&mut self.x, None, self.newton).map_err(|e| SolverError::Diverged {
            step: self.steps + 1,
            time,
            reason: e.to_string(),
        })?;
        self.steps += 1;
        let energy = self.model.potential(&self.x);
        check_finite(self.steps, time, &self.x, energy, 1e6 * self.model.energy_scale())?;
        Ok(StepStats {
            wall_seconds: start.elapsed().as_secs_f64(),
            sim_time: time,
            energy,
            residual: report.residual,
            iterations: report.iterations,
        })
    }

    fn positions(&self) -> &[DVec3] {
        &self.x
    }

    fn reset(&mut self) {
        self.x = self.model.rest().to_vec();
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        let mut p = self.model.params();
        let values = [self.newton.max_iterations as f64, self.newton.tolerance];
        p.extend(NEWTON_PARAMS[1..].iter().zip(values).map(|(&spec, value)| ParamValue { spec, value }));
        p
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.model.set_param(METHOD.name, name, value)? {
            return Ok(());
        }
        let all: Vec<ParamSpec> = SHELL_PARAMS.iter().chain(&NEWTON_PARAMS[1..]).copied().collect();
        let value = ParamSpec::find(METHOD.name, &all, name)?.check(value)?;
        match name {
            "iterations" => self.newton.max_iterations = value as usize,
            _ => self.newton.tolerance = value,
        }
        Ok(())
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
