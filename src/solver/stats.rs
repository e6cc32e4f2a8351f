//! Per-step statistics and the shared divergence check.

use std::time::Instant;

use glam::DVec3;

use super::{NewtonReport, SolverError};
use crate::linalg::filtered_pcg::PcgReport;

/// What one call of [`super::Solver::step`] did.
///
/// The default is a step without an inner solve: zeros everywhere and `converged = true`, so methods
/// that have nothing to converge can write `StepStats { wall_seconds, sim_time, ..StepStats::default() }`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepStats {
    /// Wall-clock time spent in the step, seconds.
    pub wall_seconds: f64,
    /// Simulated time after the step, seconds.
    pub sim_time: f64,
    /// Total energy (potential + kinetic) after the step, joules; `0` where a method has none.
    pub energy: f64,
    /// Final residual of the step's solve (norm of the gradient or PCG residual); `0` if none.
    pub residual: f64,
    /// Iterations of the step's solve (Newton, PCG, constraint sweeps); `0` if none.
    pub iterations: u32,
    /// `residual` relative to the solve's own scale (for Newton `|∇Φ| / max(|f_ext|, |∇Φ(y₀)|)`, the
    /// quantity its tolerance bounds); `0` if there is no solve.
    pub relative_residual: f64,
    /// Whether the step's solve met its tolerance within its iteration cap (`true` if there is none).
    /// A step that did not converge still returns `Ok` with the best iterate it reached.
    pub converged: bool,
}

impl StepStats {
    /// A step begun at `start` that reached `sim_time` with `energy`, its inner solve reporting `solve`.
    pub fn solved(start: Instant, sim_time: f64, energy: f64, solve: &impl Converged) -> Self {
        let (iterations, residual, relative_residual, converged) = solve.figures();
        let wall_seconds = start.elapsed().as_secs_f64();
        Self { wall_seconds, sim_time, energy, residual, iterations, relative_residual, converged }
    }
}

/// An inner solve's report, as the step's statistics hold it.
pub trait Converged {
    /// Its iterations, final residual, residual relative to its own scale, and whether it converged.
    fn figures(&self) -> (u32, f64, f64, bool);
}

impl Converged for NewtonReport {
    fn figures(&self) -> (u32, f64, f64, bool) {
        (self.iterations, self.residual, self.relative_residual, self.converged)
    }
}

impl Converged for PcgReport {
    fn figures(&self) -> (u32, f64, f64, bool) {
        (self.iterations, self.residual, self.relative_residual, self.converged)
    }
}

impl Default for StepStats {
    fn default() -> Self {
        Self {
            wall_seconds: 0.0,
            sim_time: 0.0,
            energy: 0.0,
            residual: 0.0,
            iterations: 0,
            relative_residual: 0.0,
            converged: true,
        }
    }
}

/// Report divergence if any position or the energy is non-finite, or the energy exceeds `energy_limit`.
pub fn check_finite(
    step: u64,
    time: f64,
    positions: &[DVec3],
    energy: f64,
    energy_limit: f64,
) -> Result<(), SolverError> {
    let diverged = |reason: String| Err(SolverError::Diverged { step, time, reason });
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return diverged(format!("vertex {i} has a non-finite position"));
    }
    if !energy.is_finite() {
        return diverged("energy is not finite".into());
    }
    if energy > energy_limit {
        return diverged(format!("energy {energy:.3e} J exceeds the limit {energy_limit:.3e} J"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_a_converged_step_without_a_solve() {
        let s = StepStats::default();
        assert!(s.converged);
        assert_eq!((s.iterations, s.residual, s.relative_residual), (0, 0.0, 0.0));
    }

    #[test]
    fn detects_nan_positions_and_exploding_energy() {
        let ok = [DVec3::ONE];
        assert!(check_finite(1, 0.1, &ok, 1.0, 10.0).is_ok());
        assert!(check_finite(1, 0.1, &[DVec3::new(f64::NAN, 0.0, 0.0)], 1.0, 10.0).is_err());
        assert!(check_finite(1, 0.1, &ok, f64::INFINITY, 10.0).is_err());
        assert!(matches!(check_finite(7, 0.1, &ok, 11.0, 10.0), Err(SolverError::Diverged { step: 7, .. })));
    }
}
