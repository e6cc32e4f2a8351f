//! `ds`: the paper's reference — the fully nonlinear discrete shell integrated with symplectic
//! (semi-implicit) Euler at a fine substep. One [`Solver::step`] advances one frame (`solver.step`,
//! default 1/30 s) in equal substeps `h`:
//! `v ← v + h M⁻¹ (f_ext − ∇W(x) − C v)`, `x ← x + h v` on the free vertices.
//!
//! The substep is `solver.substep` (or the `substep` parameter) when one is given, used as given.
//! Otherwise it is automatic: the paper's 1/30000 s, or [`SAFETY`] × the estimated stable limit of
//! [`super::stability`] when that is smaller — a mesh with small stiff triangles (the creature) needs a
//! much finer step than the paper's. [`Solver::notes`] says which substep was chosen and why.
//!
//! Explicit integration is only conditionally stable: a substep far above the limit makes the state
//! explode, which is reported as [`SolverError::Diverged`] naming the substep and the limit.

use std::time::Instant;

use glam::DVec3;

use super::params::shared::GRAVITY_Y;
use super::params::{self, Param, Redo};
use super::stability::{StabilityLimit, stability_limit};
use super::{DragSet, ParamSpec, ParamValue, ShellModel, Solver, SolverError, StepStats, check_finite};
use super::{ENERGY_LIMIT, Footprint, Method};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "ds",
    summary: "discrete shell reference: symplectic Euler at 1/30000 s or finer (automatic stable substep); \
              no collisions",
    build: |setup| Ok(Box::new(DsExplicit::new(setup)?)),
    footprint: Footprint::FACTORED,
};

/// The paper's substep, s.
const PAPER_SUBSTEP: f64 = 1.0 / 30000.0;

/// Fraction of the estimated stable limit an automatic substep may use.
pub const SAFETY: f64 = 0.8;

const FRAME: ParamSpec = ParamSpec {
    name: "step",
    label: "frame",
    unit: "s",
    help: "Time one step advances, in substeps.",
    min: 1e-6,
    max: 1.0,
    integer: false,
    key: "solver.step",
};

const SUBSTEP: ParamSpec = ParamSpec {
    name: "substep",
    label: "substep",
    unit: "s",
    help: "Symplectic Euler step, used as given; 0 = automatic (1/30000 s, or 0.8 × the stable limit if smaller).",
    min: 0.0,
    max: 1.0,
    integer: false,
    key: "solver.substep",
};

/// Its own parameters, after the shell's and the wind's.
const PARAMS: &[Param<DsExplicit>] = &[
    Param::new(FRAME, |s| s.frame, |s, v| s.frame = v, Redo::Nothing),
    Param::new(SUBSTEP, DsExplicit::substep, |s, v| s.requested = Some(v).filter(|&h| h > 0.0), Redo::Nothing),
];

/// The [`Solver::info`] label of the estimated stable limit of the substep, `2/ω_max` at rest (s).
pub const STABLE_LIMIT_INFO: &str = "stable limit 2/ω_max (s)";

/// The explicit discrete-shell integrator.
pub struct DsExplicit {
    model: ShellModel,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    frame: f64,
    /// The substep asked for; `None` = automatic.
    requested: Option<f64>,
    /// Estimated stability limit for the current parameters.
    limit: StabilityLimit,
    drags: DragSet,
    steps: u64,
    time: f64,
}

impl DsExplicit {
    /// Build from a scene: `solver.step` sets the frame (default 1/30 s), `solver.substep` the substep
    /// (automatic if absent).
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        let mut model = ShellModel::new(setup)?;
        let s = &setup.scene.solver;
        let frame = s.step.unwrap_or(1.0 / 30.0);
        let requested = s.substep.filter(|&h| h > 0.0);
        let limit = stability_limit(&mut model);
        let x = model.rest().to_vec();
        let n = x.len();
        Ok(Self {
            model,
            v: vec![DVec3::ZERO; n],
            x,
            frame,
            requested,
            limit,
            drags: DragSet::new(n, false),
            steps: 0,
            time: 0.0,
        })
    }

    /// The substep in use: the requested one, else the automatic choice.
    pub fn substep(&self) -> f64 {
        self.requested.unwrap_or(PAPER_SUBSTEP.min(SAFETY * self.limit.step))
    }

    /// The estimated stable limit of the substep (at rest, with the current parameters), s.
    pub fn stable_limit(&self) -> f64 {
        self.limit.step
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
        self.frame
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.model.apply_drags(&self.drags, &mut self.x, &mut self.v)?;
        // The fewest equal substeps not longer than the substep (a ratio that is whole up to round-off stays whole).
        let substeps = (self.frame / self.substep() * (1.0 - 1e-12)).ceil().max(1.0) as usize;
        let h = self.frame / substeps as f64;
        let n = self.model.dofs().dofs();
        let free: Vec<usize> = self.model.dofs().free_vertices().to_vec();
        let inv_mass: Vec<f64> = free.iter().map(|&i| 1.0 / self.model.masses()[i]).collect();
        let alpha = self.model.alpha;
        let mut g = vec![DVec3::ZERO; self.x.len()];
        let (mut vr, mut cv) = (vec![0.0; n], vec![0.0; n]);
        let limit = ENERGY_LIMIT * self.model.energy_scale();
        let mut residual = 0.0;
        for s in 0..substeps {
            super::supersede::checkpoint();
            self.model.apply_wind(self.time + s as f64 * h, &self.x, &self.v);
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
                check_finite(self.steps + 1, t, &self.x, self.energy(), limit).map_err(|e| match e {
                    SolverError::Diverged { step, time, reason } => SolverError::Diverged {
                        step,
                        time,
                        reason: format!(
                            "{reason} (substep {h:.3e} s; estimated stable limit {:.3e} s)",
                            self.limit.step
                        ),
                    },
                    other => other,
                })?;
            }
        }
        self.steps += 1;
        self.time += self.frame;
        Ok(StepStats {
            wall_seconds: start.elapsed().as_secs_f64(),
            sim_time: self.time,
            energy: self.energy(),
            residual,
            iterations: substeps as u32,
            ..StepStats::default()
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
        [self.model.params(), params::values(PARAMS, self)].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.model.set_param(name, value)? {
            // The limit depends on stiffness, masses and damping, not on the load.
            if name != GRAVITY_Y.name {
                self.limit = stability_limit(&mut self.model);
            }
            return Ok(());
        }
        params::set(PARAMS, self, name, value).map(drop)
    }

    fn info(&self) -> Vec<(&'static str, f64)> {
        vec![("substep (s)", self.substep()), (STABLE_LIMIT_INFO, self.limit.step)]
    }

    fn notes(&self) -> Vec<String> {
        let (h, limit) = (self.substep(), self.limit.step);
        let source = match self.requested {
            Some(_) if h > limit => "as requested, ABOVE the estimated stable limit: expect divergence",
            Some(_) => "as requested",
            None if h < PAPER_SUBSTEP => "automatic: safety × the stable limit, below the paper's 1/30000 s",
            None => "automatic: the paper's 1/30000 s, within safety × the stable limit",
        };
        vec![format!(
            "substep {h:.3e} s ({source}); estimated stable limit {limit:.3e} s (ω_max = {:.3e} rad/s at rest, \
             safety {SAFETY})",
            self.limit.omega_max
        )]
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
