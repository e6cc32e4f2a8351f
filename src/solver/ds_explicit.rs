//! `ds`: the paper's reference — the fully nonlinear discrete shell integrated with symplectic
//! (semi-implicit) Euler at a fine substep (default 1/30000 s). One [`Solver::step`] advances one
//! 1/30 s frame, i.e. `frame / substep` substeps:
//! `v ← v + h M⁻¹ (f_ext − ∇W(x) − C v)`, `x ← x + h v` on the free vertices.
//!
//! Explicit integration is only conditionally stable; raise `substep` far above its limit and the
//! state explodes, which is reported as [`SolverError::Diverged`].

use std::time::Instant;

use glam::DVec3;

use super::registry::Method;
use super::shell_model::SHELL_PARAMS;
use super::{DragSet, ParamSpec, ParamValue, ShellModel, Solver, SolverError, StepStats, check_finite};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "ds",
    summary: "discrete shell reference: symplectic Euler at a fine substep (default 1/30000 s)",
    build: |setup| Ok(Box::new(DsExplicit::new(setup)?)),
};

const FRAME: f64 = 1.0 / 30.0;

const SUBSTEP: ParamSpec = ParamSpec {
    name: "substep",
    label: "substep",
    unit: "s",
    help: "Symplectic Euler step; a 1/30 s frame takes frame/substep of them.",
    min: 1e-7,
    max: FRAME,
    log_scale: true,
    integer: false,
};

/// The explicit discrete-shell integrator.
pub struct DsExplicit {
    model: ShellModel,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    substep: f64,
    drags: DragSet,
    steps: u64,
    time: f64,
}

impl DsExplicit {
    /// Build from a scene; `solver.step` (if given) sets the substep.
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        let model = ShellModel::new(setup)?;
        let substep = SUBSTEP.check(setup.scene.solver.step.unwrap_or(1.0 / 30000.0))?;
        let x = model.rest().to_vec();
        let n = x.len();
        Ok(Self { model, v: vec![DVec3::ZERO; n], x, substep, drags: DragSet::new(n, false), steps: 0, time: 0.0 })
    }

    /// Total energy: elastic + kinetic + load potential (relative to rest), J.
    fn energy(&self) -> f64 {
        self.model.potential(&self.x) + self.model.kinetic(&self.v)
    }
}

impl Solver for DsExplicit {
    fn method(&self) -> &'static str {
        METHOD.name
    }

    fn time_step(&self) -> f64 {
        FRAME
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.model.apply_drags(&self.drags, &mut self.x, &mut self.v)?;
        let substeps = (FRAME / self.substep).round().max(1.0) as usize;
        let h = FRAME / substeps as f64;
        let n = self.model.dofs().dofs();
        let free: Vec<usize> = self.model.dofs().free_vertices().to_vec();
        let inv_mass: Vec<f64> = free.iter().map(|&i| 1.0 / self.model.masses()[i]).collect();
        let alpha = self.model.alpha;
        let mut g = vec![DVec3::ZERO; self.x.len()];
        let (mut vr, mut cv) = (vec![0.0; n], vec![0.0; n]);
        let limit = 1e6 * self.model.energy_scale();
        let mut residual = 0.0;
        for s in 0..substeps {
            self.model.potential_gradient(&self.x, &mut g);
            if self.model.beta > 0.0 {
                self.model.dofs().gather(&self.v, &mut vr);
                self.model.stiffness_damping(&vr, &mut cv);
            }
            for (f, &i) in free.iter().enumerate() {
                let damping = self.v[i] * (alpha / inv_mass[f]) + DVec3::from_slice(&cv[3 * f..3 * f + 3]);
                self.v[i] += (-g[i] - damping) * (h * inv_mass[f]);
                self.x[i] += self.v[i] * h;
            }
            // Stop early once the state is clearly blown up (checked every 256 substeps).
            if s % 256 == 255 || s + 1 == substeps {
                residual = free.iter().map(|&i| g[i].length_squared()).sum::<f64>().sqrt();
                let t = self.time + (s + 1) as f64 * h;
                check_finite(self.steps + 1, t, &self.x, self.energy(), limit)?;
            }
        }
        self.steps += 1;
        self.time += FRAME;
        Ok(StepStats {
            wall_seconds: start.elapsed().as_secs_f64(),
            sim_time: self.time,
            energy: self.energy(),
            residual,
            iterations: substeps as u32,
        })
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
        let mut p = self.model.params();
        p.push(ParamValue { spec: SUBSTEP, value: self.substep });
        p
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if name == SUBSTEP.name {
            self.substep = SUBSTEP.check(value)?;
            return Ok(());
        }
        if self.model.set_param(METHOD.name, name, value)? {
            return Ok(());
        }
        let all: Vec<ParamSpec> = SHELL_PARAMS.iter().copied().chain([SUBSTEP]).collect();
        ParamSpec::find(METHOD.name, &all, name).map(|_| ())
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
