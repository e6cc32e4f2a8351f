//! What the experiments measure, shared by all of them: building a solver for a scene with
//! overrides, running it to rest or for a time while timing its steps, the static reference, and the
//! error measures (relative displacement-field error, relative area change).

use std::time::Instant;

use glam::DVec3;

pub use crate::solver::run::{Outcome, REST_STEPS, Run, Stop, distance, run, run_driven};

use super::EvalError;
use crate::scene::{self, Setup};
use crate::solver::modal::compute::{ModalAnalysis, analyse_scene};
use crate::solver::{self, Solver};

/// A scene with a method and overrides, realised.
pub fn setup(scene_name: &str, method: &str, overrides: &[String]) -> Result<Setup, EvalError> {
    let mut all = overrides.to_vec();
    all.push(format!("solver.method={method}"));
    Ok(scene::load(scene_name, &all)?)
}

/// Build the setup's solver.
pub fn build(setup: &Setup) -> Result<Box<dyn Solver>, EvalError> {
    let method = setup.scene.solver.method.clone();
    solver::build(setup).map_err(EvalError::solver(format!("building {method} for {}", setup.scene.name)))
}

/// Relative displacement-field error `‖u − u_ref‖ / ‖u_ref‖` (`u = x − X`).
pub fn relative_error(x: &[DVec3], reference: &[DVec3], rest: &[DVec3]) -> f64 {
    distance(x, reference) / distance(reference, rest)
}

/// Total area of a triangle mesh at positions `x`, m².
pub fn area(x: &[DVec3], triangles: &[[usize; 3]]) -> f64 {
    triangles.iter().map(|t| 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).length()).sum()
}

/// Relative area change `(A − A₀) / A₀` (signed).
pub fn area_change(x: &[DVec3], setup: &Setup) -> f64 {
    setup.mesh.area_change(x)
}

/// The static reference: `ds-static` with its default settings, one step from rest.
#[derive(Debug, Clone)]
pub struct Reference {
    /// Equilibrium positions.
    pub positions: Vec<DVec3>,
    /// Relative residual it reached.
    pub relative_residual: f64,
    /// Whether it converged: the solver met its tolerance (relative residual ≤ 1e-8 at the defaults), or
    /// stopped at the round-off floor of f64 (then the relative residual may be larger: see
    /// `relative_residual`).
    pub converged: bool,
    /// Newton iterations.
    pub iterations: u32,
    /// Wall-clock time of the solve, s.
    pub wall: f64,
}

/// Solve the static equilibrium of `scene_name` with `overrides` by `ds-static` at its defaults.
pub fn reference(scene_name: &str, overrides: &[String]) -> Result<Reference, EvalError> {
    let s = setup(scene_name, "ds-static", overrides)?;
    let mut solver = build(&s)?;
    let start = Instant::now();
    let stats = solver.step().map_err(EvalError::solver(format!("ds-static on {scene_name}")))?;
    Ok(Reference {
        positions: solver.positions().to_vec(),
        relative_residual: stats.relative_residual,
        converged: stats.converged,
        iterations: stats.iterations,
        wall: start.elapsed().as_secs_f64(),
    })
}

/// The modal analysis of a shell scene with `modes` modes, computed afresh (never from the cache).
pub fn modal_analysis(setup: &Setup, modes: usize) -> Result<ModalAnalysis, EvalError> {
    analyse_scene(setup, modes).map_err(EvalError::solver(format!("modal analysis of {}", setup.scene.name)))
}

/// Rayleigh mass damping `α = 2ω₁` that critically damps the lowest mode of a shell scene, so every
/// mode decays at least like `e^{−ω₁t}` and a run comes to rest in a few `1/ω₁`. Returns `(α, ω₁)`.
pub fn critical_damping(setup: &Setup) -> Result<(f64, f64), EvalError> {
    let omega = modal_analysis(setup, 1)?.basis.eigenvalues[0].sqrt();
    Ok((2.0 * omega, omega))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_and_area_measures() {
        let rest = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let x = [DVec3::ZERO, DVec3::X * 2.0, DVec3::Y];
        let r = [DVec3::ZERO, DVec3::X * 3.0, DVec3::Y];
        assert!((relative_error(&x, &r, &rest) - 0.5).abs() < 1e-15);
        assert!((area(&rest, &[[0, 1, 2]]) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn a_damped_shell_comes_to_rest_and_the_run_is_timed() {
        let s = setup("cantilever", "lma", &["solver.rayleigh_alpha=16".into()]).unwrap();
        let mut solver = build(&s).unwrap();
        let r = run(solver.as_mut(), s.mesh.positions(), Stop { max_time: 20.0, max_steps: u64::MAX, rest: 1e-7 });
        assert_eq!(r.outcome, Outcome::Rest, "after {} s", r.sim_time);
        assert!(r.sim_time < 5.0 && r.wall > 0.0 && r.cost() > 0.0);
        // At rest under gravity: another second changes nothing to the tolerance's order.
        let more = run(solver.as_mut(), s.mesh.positions(), Stop { max_time: 1.0, max_steps: u64::MAX, rest: 0.0 });
        let moved = relative_error(&r.positions, &more.positions, s.mesh.positions());
        assert!(moved < 1e-4, "still moving: {moved:.2e}");
    }
}
