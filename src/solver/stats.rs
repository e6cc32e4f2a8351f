//! Per-step statistics and the shared divergence check.

use glam::DVec3;

use super::SolverError;

/// What one call of [`super::Solver::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
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
    fn detects_nan_positions_and_exploding_energy() {
        let ok = [DVec3::ONE];
        assert!(check_finite(1, 0.1, &ok, 1.0, 10.0).is_ok());
        assert!(check_finite(1, 0.1, &[DVec3::new(f64::NAN, 0.0, 0.0)], 1.0, 10.0).is_err());
        assert!(check_finite(1, 0.1, &ok, f64::INFINITY, 10.0).is_err());
        assert!(matches!(check_finite(7, 0.1, &ok, 11.0, 10.0), Err(SolverError::Diverged { step: 7, .. })));
    }
}
