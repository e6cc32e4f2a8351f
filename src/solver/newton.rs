//! Newton's method with a backtracking line search on the free DOFs of a [`ShellModel`], minimising
//!
//! `Φ(y) = W(y) − f_extᵀ(y − X) [+ ½(y − x̃)ᵀ M (y − x̃)/h² + (1/2h)(y − x)ᵀ C (y − x)]`,
//!
//! the static potential (for `ds-static`) or, with the bracketed inertia and damping terms
//! (`x̃ = x + h v`, `C = αM + βK₀`), the backward-Euler incremental potential whose stationary point is
//! the implicit step `M(v⁺ − v)/h = f_ext − ∇W(x⁺) − C v⁺`, `x⁺ = x + h v⁺` (for `ds-implicit`).
//!
//! Indefiniteness: each iteration first tries the exact Hessian; if its Cholesky factorisation fails or
//! the step is not a descent direction, the per-element PSD-projected Hessian is used instead
//! ([`HessianMode::Projected`]); if that is singular too (a free shell in statics), `μ I` is added with
//! `μ` growing tenfold until it factorises. Near a stable equilibrium the exact Hessian is positive
//! definite, so convergence ends quadratically.

use glam::DVec3;

use super::ShellModel;
use super::params::{self, Param, Redo};
use super::{ParamSpec, SolverError};
use crate::energy::HessianMode;
use crate::linalg::SparseCholesky;
use crate::scene::Setup;

/// Backward Euler's step, a parameter of the dynamic Newton method.
pub(crate) const STEP: ParamSpec =
    ParamSpec::linear("step", "time step", "s", "Backward Euler step.", 1e-6, 1.0).in_scene("solver.step");

/// The Newton iteration cap's spec, shared by every method that iterates Newton's method in a step.
pub(crate) const ITERATIONS_SPEC: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear(
        "iterations",
        "Newton iterations",
        "",
        "Cap on Newton iterations per solve (`rds` solves a step again, once, if it stops short).",
        1.0,
        1000.0,
    )
    .in_scene("solver.iterations")
};

/// The Newton iteration cap.
const ITERATIONS: Param<NewtonSettings> =
    Param::new(ITERATIONS_SPEC, |n| n.max_iterations as f64, |n, v| n.max_iterations = v as usize, Redo::Nothing);

/// The Newton tolerance.
const TOLERANCE: Param<NewtonSettings> = Param::new(
    ParamSpec::linear("tolerance", "Newton tolerance", "", "Relative residual at which Newton stops.", 1e-14, 1.0)
        .in_scene("solver.tolerance"),
    |n| n.tolerance,
    |n, v| n.tolerance = v,
    Redo::Nothing,
);

/// The Newton settings' parameters, the same in every Newton method.
pub(crate) const NEWTON_PARAMS: &[Param<NewtonSettings>] = &[ITERATIONS, TOLERANCE];

/// Iteration cap and relative tolerance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Maximum Newton iterations.
    pub max_iterations: usize,
    /// Converged when `|∇Φ| ≤ tolerance × max(|f_ext|, |∇Φ(y₀)|)` (2-norms over free DOFs).
    pub tolerance: f64,
}

impl NewtonSettings {
    /// The scene's `solver.iterations` and `solver.tolerance`, checked against [`NEWTON_PARAMS`].
    pub(crate) fn of(setup: &Setup) -> Result<Self, SolverError> {
        params::check_scene(params::specs(NEWTON_PARAMS), setup)?;
        let s = &setup.scene.solver;
        Ok(Self { max_iterations: s.iterations, tolerance: s.tolerance })
    }
}

/// The inertia and damping terms of one backward-Euler step.
#[derive(Debug, Clone, Copy)]
pub struct Inertia<'a> {
    /// Positions at the start of the step, `x`.
    pub previous: &'a [DVec3],
    /// Velocities at the start of the step, `v`.
    pub velocity: &'a [DVec3],
    /// Step, s.
    pub h: f64,
}

/// What a minimisation did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NewtonReport {
    /// Newton iterations taken.
    pub iterations: u32,
    /// Final `|∇Φ|` over the free DOFs, N.
    pub residual: f64,
    /// `residual / max(|f_ext|, |∇Φ(y₀)|)`, the quantity [`NewtonSettings::tolerance`] bounds.
    pub relative_residual: f64,
    /// Whether the tolerance was met, or the iteration stopped (stalled or capped) with the residual
    /// inside its round-off floor (see `ShellModel::roundoff_floor`): no f64 iteration can do better.
    /// `false` otherwise; `y` then holds the best iterate and `relative_residual` says how far it got.
    pub converged: bool,
    /// Times the exact Hessian was replaced by the projected one.
    pub projected: u32,
}

struct Objective<'a> {
    inertia: Option<Inertia<'a>>,
    mass: Vec<f64>,
}

impl ShellModel {
    /// `Φ(y)` and its reduced gradient (into `g`).
    fn objective(&mut self, o: &Objective, y: &[DVec3], g: &mut [f64], scratch: &mut [DVec3]) -> f64 {
        let mut phi = self.potential_gradient(y, scratch);
        self.dofs().gather(scratch, g);
        if let Some(it) = o.inertia {
            let n = self.dofs().dofs();
            let (mut dy, mut dtilde) = (vec![0.0; n], vec![0.0; n]);
            for (f, &v) in self.dofs().free_vertices().iter().enumerate() {
                let d = y[v] - it.previous[v];
                let t = d - it.velocity[v] * it.h;
                dy[3 * f..3 * f + 3].copy_from_slice(&d.to_array());
                dtilde[3 * f..3 * f + 3].copy_from_slice(&t.to_array());
            }
            let mut cd = vec![0.0; n];
            self.stiffness_damping(&dy, &mut cd);
            let (a, h) = (self.alpha, it.h);
            for i in 0..n {
                let m = o.mass[i];
                phi += 0.5 * m * dtilde[i] * dtilde[i] / (h * h) + 0.5 * (a * m * dy[i] * dy[i] + dy[i] * cd[i]) / h;
                g[i] += m * dtilde[i] / (h * h) + (a * m * dy[i] + cd[i]) / h;
            }
        }
        phi
    }

    /// Assemble `∇²Φ` in `mode` (plus `shift` on the diagonal) and factorise it.
    fn factor(&mut self, o: &Objective, y: &[DVec3], mode: HessianMode, shift: f64) -> Result<(), SolverError> {
        let k0 = match o.inertia {
            Some(_) if self.beta > 0.0 => Some(self.rest_stiffness().to_vec()),
            _ => None,
        };
        self.assemble(y, mode);
        let mut diag = vec![shift; self.dofs().dofs()];
        if let Some(it) = o.inertia {
            let c = 1.0 / (it.h * it.h) + self.alpha / it.h;
            diag.iter_mut().zip(&o.mass).for_each(|(d, m)| *d += c * m);
            if let Some(k0) = &k0 {
                self.asm.add_scaled(k0, self.beta / it.h);
            }
        }
        self.asm.add_diagonal(&diag);
        if self.chol.is_none() {
            self.chol =
                Some(SparseCholesky::new(self.asm.matrix()).map_err(|e| SolverError::Numerical(e.to_string()))?);
        }
        let Some(chol) = self.chol.as_mut() else { unreachable!("just created") };
        chol.factor(self.asm.matrix()).map_err(|e| SolverError::Numerical(e.to_string()))
    }

    /// Minimise `Φ` over the free DOFs of `y` (prescribed entries are left as they are).
    pub fn minimize(
        &mut self,
        y: &mut [DVec3],
        inertia: Option<Inertia<'_>>,
        settings: NewtonSettings,
    ) -> Result<NewtonReport, SolverError> {
        let n = self.dofs().dofs();
        let mut report = NewtonReport::default();
        if n == 0 {
            report.converged = true;
            return Ok(report);
        }
        let o = Objective { inertia, mass: self.reduced_masses() };
        let mut scratch = vec![DVec3::ZERO; y.len()];
        let mut g = vec![0.0; n];
        let mut phi = self.objective(&o, y, &mut g, &mut scratch);
        let mut f = vec![0.0; n];
        self.dofs().gather(self.external_forces(), &mut f);
        let reference = norm(&f).max(norm(&g)).max(f64::MIN_POSITIVE);
        let mut trial = y.to_vec();
        let mut g_trial = vec![0.0; n];
        let mut mean_diag = None;
        let mut stalls = 0;
        loop {
            report.residual = norm(&g);
            report.relative_residual = report.residual / reference;
            if !report.residual.is_finite() || !phi.is_finite() {
                return Err(SolverError::Numerical("non-finite residual in Newton's method".into()));
            }
            if report.residual <= settings.tolerance * reference {
                report.converged = true;
                return Ok(report);
            }
            if report.iterations as usize >= settings.max_iterations {
                report.converged = report.residual <= self.roundoff_floor(y);
                return Ok(report);
            }
            report.iterations += 1;
            // Where a step that will be discarded (a reset, a switch) stops ([`super::supersede`]).
            super::supersede::checkpoint();
            let d = self.direction(&o, y, &g, &mut mean_diag, &mut report.projected)?;
            // Backtracking (Armijo) line search. Near convergence Φ differences drown in round-off, so a
            // step that does not raise Φ beyond that and reduces |∇Φ| is accepted too.
            let slope = dot(&d, &g);
            let mut step = 1.0;
            let mut accepted = false;
            let mut significant = false;
            for _ in 0..40 {
                trial.copy_from_slice(y);
                self.dofs().scatter_add(&d, step, &mut trial);
                let phi_t = self.objective(&o, &trial, &mut g_trial, &mut scratch);
                let roundoff = 1e-12 * phi.abs().max(phi_t.abs()).max(1e-300);
                if phi_t <= phi + 1e-4 * step * slope || (phi_t <= phi + roundoff && norm(&g_trial) < report.residual) {
                    accepted = true;
                    significant = phi_t < phi - roundoff;
                    phi = phi_t;
                    break;
                }
                step *= 0.5;
            }
            // Stalled: Φ no longer changes beyond round-off and the residual stops falling (three steps
            // in a row without a 10% gain). Converged if that is the round-off floor, else stuck.
            stalls = if significant || (accepted && norm(&g_trial) < 0.9 * report.residual) { 0 } else { stalls + 1 };
            if !accepted || stalls >= 3 {
                if accepted {
                    y.copy_from_slice(&trial);
                    report.residual = norm(&g_trial);
                    report.relative_residual = report.residual / reference;
                }
                report.converged =
                    report.residual <= settings.tolerance * reference || report.residual <= self.roundoff_floor(y);
                return Ok(report);
            }
            y.copy_from_slice(&trial);
            std::mem::swap(&mut g, &mut g_trial);
        }
    }
}

impl ShellModel {
    /// The Newton direction `d = −H⁻¹ g`: exact Hessian, else the projected one (counted in
    /// `projected`), else projected + `μ I` with `μ` growing tenfold from 1e-8 of the mean
    /// diagonal entry (`mean_diag` caches that scale between calls).
    fn direction(
        &mut self,
        o: &Objective,
        y: &[DVec3],
        g: &[f64],
        mean_diag: &mut Option<f64>,
        projected: &mut u32,
    ) -> Result<Vec<f64>, SolverError> {
        let mut d = vec![0.0; g.len()];
        for attempt in 0..12 {
            let (mode, shift) = match attempt {
                0 => (HessianMode::Exact, 0.0),
                1 => (HessianMode::Projected, 0.0),
                k => {
                    let scale = *mean_diag.get_or_insert_with(|| {
                        self.asm.values().iter().map(|v: &f64| v.abs()).sum::<f64>() / self.asm.nnz() as f64
                    });
                    (HessianMode::Projected, scale * 10f64.powi(k - 10))
                }
            };
            if attempt == 1 {
                *projected += 1;
            }
            if self.factor(o, y, mode, shift).is_err() {
                continue;
            }
            d.iter_mut().zip(g).for_each(|(d, g)| *d = -g);
            if let Some(chol) = &self.chol {
                chol.solve(&mut d).map_err(|e| SolverError::Numerical(e.to_string()))?;
            }
            if dot(&d, g) < 0.0 && d.iter().all(|x| x.is_finite()) {
                return Ok(d);
            }
        }
        Err(SolverError::Numerical("no descent direction: Hessian could not be regularised".into()))
    }

    /// The smallest `|∇Φ|` f64 can resolve at `y`: a position is known to `ε|y|`, which moves the
    /// gradient by the Hessian times that, bounded per DOF by `H_dd ε |y_d|` (the last assembled
    /// system's diagonal). An iteration that stalls below this has converged as far as f64 allows.
    fn roundoff_floor(&self, y: &[DVec3]) -> f64 {
        let mut abs_y = vec![0.0; self.dofs().dofs()];
        self.dofs().gather(y, &mut abs_y);
        let diagonal = self.asm.diagonal();
        f64::EPSILON * diagonal.iter().zip(&abs_y).map(|(h, y)| (h * y).powi(2)).sum::<f64>().sqrt()
    }
}

/// `aᵀb`.
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `|a|`.
pub(super) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}
