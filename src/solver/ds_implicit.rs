//! `ds-implicit`: backward Euler on the discrete shell, each step solved by Newton's method with a
//! line search on the incremental potential (see [`super::newton`]), sparse Cholesky (faer) on the
//! free DOFs, exact Hessian with per-element PSD projection as the fallback. Stable at 1/30 s.

use std::time::Instant;

use glam::DVec3;

use super::newton::{Inertia, NEWTON_PARAMS, NewtonSettings, STEP};
use super::params::{self, Param, Redo};
use super::{DragSet, ParamValue, ShellModel, Solver, SolverError, StepStats, check_finite};
use super::{ENERGY_LIMIT, Footprint, Method};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "ds-implicit",
    summary: "discrete shell, backward Euler with Newton iterations (sparse Cholesky), stable at 1/30 s; no collisions",
    build: |setup| Ok(Box::new(DsImplicit::new(setup)?)),
    footprint: Footprint::FACTORED,
};

/// Its own parameters (after the shell's and the wind's, before the Newton settings).
const PARAMS: &[Param<DsImplicit>] = &[Param::new(STEP, |s| s.h, |s, v| s.h = v, Redo::Nothing)];

/// The implicit discrete-shell integrator.
pub struct DsImplicit {
    model: ShellModel,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    h: f64,
    newton: NewtonSettings,
    drags: DragSet,
    steps: u64,
    time: f64,
}

impl DsImplicit {
    /// Build from a scene (`solver.step`, default 1/30 s; `solver.iterations`; `solver.tolerance`).
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        let model = ShellModel::new(setup)?;
        let h = setup.scene.solver.step.unwrap_or(1.0 / 30.0);
        let newton = NewtonSettings::of(setup)?;
        let x = model.rest().to_vec();
        let n = x.len();
        Ok(Self { model, v: vec![DVec3::ZERO; n], x, h, newton, drags: DragSet::new(n, false), steps: 0, time: 0.0 })
    }
}

impl Solver for DsImplicit {
    fn method(&self) -> &'static str {
        METHOD.name
    }

    fn time_step(&self) -> f64 {
        self.h
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.model.apply_drags(&self.drags, &mut self.x, &mut self.v)?;
        self.model.apply_wind(self.time, &self.x, &self.v);
        let previous = self.x.clone();
        // Start Newton from the inertial prediction x + h v.
        let mut y: Vec<DVec3> = self.x.iter().zip(&self.v).map(|(x, v)| *x + *v * self.h).collect();
        let inertia = Inertia { previous: &previous, velocity: &self.v, h: self.h };
        let diverged = |reason: String, steps, time| SolverError::Diverged { step: steps, time, reason };
        let report = self
            .model
            .minimize(&mut y, Some(inertia), self.newton)
            .map_err(|e| diverged(e.to_string(), self.steps + 1, self.time + self.h))?;
        for &i in self.model.dofs().free_vertices() {
            self.v[i] = (y[i] - self.x[i]) / self.h;
        }
        self.x = y;
        self.steps += 1;
        self.time += self.h;
        let energy = self.model.potential(&self.x) + self.model.kinetic(&self.v);
        check_finite(self.steps, self.time, &self.x, energy, ENERGY_LIMIT * self.model.energy_scale())?;
        Ok(StepStats::solved(start, self.time, energy, &report))
    }

    fn positions(&self) -> &[DVec3] {
        &self.x
    }

    fn reset(&mut self) {
        self.x = self.model.rest().to_vec();
        self.v.fill(DVec3::ZERO);
        self.steps = 0;
        self.time = 0.0;
    }

    fn params(&self) -> Vec<ParamValue> {
        [self.model.params(), params::values(PARAMS, self), params::values(NEWTON_PARAMS, &self.newton)].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.model.set_param(name, value)? || params::assign(NEWTON_PARAMS, &mut self.newton, name, value)?.is_some()
        {
            return Ok(());
        }
        params::set(PARAMS, self, name, value).map(drop)
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
