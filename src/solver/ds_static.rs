//! `ds-static`: static equilibrium of the loaded, anchored shell — Newton with line search on the
//! potential `W(x) − f_extᵀ(x − X)` (see [`super::newton`]). Each [`Solver::step`] moves the shell from
//! the equilibrium it is in to the equilibrium under the current loads; changing a load parameter and
//! stepping again continues from there.
//!
//! Adaptive load continuation: Newton from a far-away state (a soft, nearly inextensible strip under a
//! large load, starting flat) crawls, because the linearised step stretches the membrane and the line
//! search must cut it to slivers. So the step walks the load path `f(t) = f₀ + t (f₁ − f₀)` from the
//! load `f₀` of the current equilibrium to the current load `f₁`: the whole load is tried first with
//! Newton for as long as it makes progress (its stall test: three iterations in a row that neither
//! lower the potential beyond round-off nor the residual by 10%), up to a quarter of the budget below;
//! if it stalls or fails, stages that converge within [`STAGE_ITERATIONS`] are kept and the next
//! increment doubles, stages that do not are undone and the increment quartered.
//!
//! The budget is adaptive: the walk goes on while it makes progress — as long as the increment stays
//! above [`MIN_INCREMENT`] of the load change — so a solve that needs 61 or 192 iterations gets them
//! (the collapsing V-beam, a V-beam with a thousandth of the bending stiffness), bounded by
//! [`BUDGET_FACTOR`] × `iterations` in all so that a hopeless one stops in bounded time. A step that
//! stops short stays at the last equilibrium it reached, reports `converged = false` with the residual
//! under the full load, and the next step continues the path from there with the increment it had
//! reached.

use std::time::Instant;

use glam::DVec3;

use super::newton::{NEWTON_PARAMS, NewtonReport, NewtonSettings};
use super::params;
use super::{DragSet, ParamValue, ShellModel, Solver, SolverError, StepStats, check_finite};
use super::{ENERGY_LIMIT, Footprint, Method};
use crate::scene::Setup;

/// Registry entry.
pub const METHOD: Method = Method {
    name: "ds-static",
    summary: "discrete shell static equilibrium: Newton with line search on W − f_extᵀu, adaptive load \
              stepping; no collisions",
    build: |setup| Ok(Box::new(DsStatic::new(setup)?)),
    footprint: Footprint::FACTORED,
};

/// Newton iterations one stage of the load path may take before its increment is judged too large.
pub const STAGE_ITERATIONS: usize = 25;

/// The most Newton iterations one step may take, as a multiple of the `iterations` setting.
pub const BUDGET_FACTOR: usize = 40;

/// The most the direct attempt (the whole load at once) may take, as a multiple of `iterations`.
const DIRECT_FACTOR: usize = BUDGET_FACTOR / 4;

/// The smallest load increment (fraction of the step's load change) before the step gives up.
pub const MIN_INCREMENT: f64 = 1.0 / 4096.0;

/// The static equilibrium solver.
pub struct DsStatic {
    model: ShellModel,
    x: Vec<DVec3>,
    /// The external load `x` is in equilibrium with (zero at rest).
    settled: Vec<DVec3>,
    /// First load increment of the next step, as a fraction of its load change.
    increment: f64,
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
        let newton = NewtonSettings::of(setup)?;
        let x = model.rest().to_vec();
        let n = x.len();
        Ok(Self {
            model,
            x,
            settled: vec![DVec3::ZERO; n],
            increment: 1.0,
            newton,
            drags: DragSet::new(n, false),
            steps: 0,
        })
    }
}

impl DsStatic {
    /// Walk the load path from `settled` to the current loads (see the module doc). Leaves the model's
    /// forces at the current loads; the report's iterations are the total over all stages.
    fn continuation(&mut self) -> Result<NewtonReport, SolverError> {
        // The wind on the shell as it stands (at rest: no velocity of its own), held over the step;
        // successive steps carry it to the equilibrium of the load that follows the shape.
        let still = vec![DVec3::ZERO; self.x.len()];
        let target = self.model.loads(self.steps as f64 * self.time_step(), &self.x, &still);
        let from = self.settled.clone();
        let load = |t: f64| -> Vec<DVec3> { from.iter().zip(&target).map(|(a, b)| *a + (*b - *a) * t).collect() };
        let (mut t, mut increment) = (0.0, self.increment);
        let mut iterations = 0u32;
        // The last equilibrium on the path, and the one before it (for the secant predictor).
        let mut saved = self.x.clone();
        let mut previous: Option<(f64, Vec<DVec3>)> = None;
        let mut last = None;
        let mut result = Ok(());
        while t < 1.0 {
            let remaining = (BUDGET_FACTOR * self.newton.max_iterations).saturating_sub(iterations as usize);
            if remaining == 0 || increment < MIN_INCREMENT {
                break;
            }
            let next = (t + increment).min(1.0);
            // Secant predictor: extrapolate the path through the last two equilibria.
            if let Some((t_prev, x_prev)) = &previous {
                let r = (next - t) / (t - t_prev);
                self.x.iter_mut().zip(&saved).zip(x_prev).for_each(|((x, s), p)| *x = *s + (*s - *p) * r);
            }
            self.model.set_external_forces(load(next));
            // The direct attempt (the whole load change at once) may go on while Newton makes progress
            // (its stall test stops it otherwise), up to a quarter of the budget; the stages of a
            // continuation get `STAGE_ITERATIONS` each.
            let cap = if t == 0.0 && increment == 1.0 {
                DIRECT_FACTOR * self.newton.max_iterations
            } else {
                STAGE_ITERATIONS
            };
            let stage = NewtonSettings { max_iterations: remaining.min(cap), ..self.newton };
            let outcome = self.model.minimize(&mut self.x, None, stage);
            iterations += outcome.as_ref().map_or(0, |r| r.iterations);
            match outcome {
                Ok(r) if r.converged => {
                    previous = Some((t, std::mem::replace(&mut saved, self.x.clone())));
                    t = next;
                    increment *= 2.0;
                    last = Some(r);
                }
                // A non-finite stage is a too-large increment too, unless it was already the smallest.
                Err(e) if increment <= MIN_INCREMENT => {
                    result = Err(e);
                    break;
                }
                _ => {
                    self.x.copy_from_slice(&saved);
                    increment /= 4.0;
                }
            }
        }
        self.settled = load(t);
        // Continue next time with this increment, rescaled to the load change that is left.
        self.increment = if t >= 1.0 { 1.0 } else { (increment / (1.0 - t)).clamp(MIN_INCREMENT, 1.0) };
        self.model.set_external_forces(target);
        result?;
        let mut report = match last {
            Some(r) if t >= 1.0 => r,
            // Stopped short: report the residual under the full load (a zero-iteration solve measures it).
            _ => NewtonReport {
                converged: false,
                ..self.model.minimize(&mut self.x, None, NewtonSettings { max_iterations: 0, ..self.newton })?
            },
        };
        report.iterations = iterations;
        Ok(report)
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
        let report = self.continuation().map_err(|e| SolverError::Diverged {
            step: self.steps + 1,
            time,
            reason: e.to_string(),
        })?;
        self.steps += 1;
        let energy = self.model.potential(&self.x);
        check_finite(self.steps, time, &self.x, energy, ENERGY_LIMIT * self.model.energy_scale())?;
        Ok(StepStats::solved(start, time, energy, &report))
    }

    fn positions(&self) -> &[DVec3] {
        &self.x
    }

    fn reset(&mut self) {
        self.x = self.model.rest().to_vec();
        self.settled.fill(DVec3::ZERO);
        self.increment = 1.0;
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        [self.model.params(), params::values(NEWTON_PARAMS, &self.newton)].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.model.set_param(name, value)? || params::assign(NEWTON_PARAMS, &mut self.newton, name, value)?.is_some()
        {
            return Ok(());
        }
        Err(params::unknown(METHOD.name, name, self.params().iter().map(|p| p.spec.name)))
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
