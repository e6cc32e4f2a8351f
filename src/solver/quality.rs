//! How good a shape is as an answer of the full discrete shell: the live readout of the viewer and
//! the figures of `sim --json`.
//!
//! - **Area change** `(A − A₀) / A₀`: a thin shell's membrane is far stiffer than its bending, so
//!   its area hardly changes; a reduced model that inflates shows it at once.
//! - **Estimated error**: the shape (with every position drag pinned at its target, as the discrete
//!   shell holds it) starts iterations of Newton's method (with line search) on the full
//!   discrete-shell equations under the scene's loads; the distance they travel, relative to the
//!   displacement they arrive at, estimates the relative displacement error `‖x − x*‖ / ‖x* − X‖`.
//!   Newton converges quadratically from a good start, so [`NEWTON_ITERATIONS`] (three) cover nearly
//!   all of the remaining distance (one alone underestimates a 9% error on the V-beam at 40 g by
//!   half). From a poor start the line search keeps the steps short: a strip pulled sideways beyond
//!   eight modes needs 20 iterations to reach its equilibrium, and three travel half the way. So the
//!   iterations go on, up to [`MAX_ITERATIONS`], while the last one still moved the shape by
//!   [`CONVERGING`] of the correction so far; a large estimate can still be a lower bound. It
//!   measures the distance to the nearest equilibrium: where the shell has several (a buckled and an
//!   unbuckled branch), a shape near another branch than the reference's is judged by that one.

use super::params::shared::{DENSITY, GRAVITY_Y, K_AREA, K_BEND, K_LENGTH};
use glam::DVec3;

use super::run::distance;
use super::{DragSet, NewtonSettings, ShellModel, SolverError};
use crate::scene::Setup;

/// Newton iterations of the full shell equations behind an estimate, at least.
pub const NEWTON_ITERATIONS: usize = 3;

/// Newton iterations behind an estimate at most.
pub const MAX_ITERATIONS: usize = 10;

/// Past [`NEWTON_ITERATIONS`], the iterations go on while the last one moved the shape by at least
/// this fraction of the whole correction so far (they are still far from converging).
pub const CONVERGING: f64 = 0.05;

/// The default relative error past which a shape is said not to be good enough (the scene's
/// `solver.accuracy` replaces it).
pub const DEFAULT_TARGET: f64 = 0.05;

/// The estimated relative displacement error of shape `x` of `setup` under `drags` (module
/// documentation).
pub fn estimate(setup: &Setup, x: &[DVec3], drags: &DragSet) -> Result<f64, SolverError> {
    estimate_reporting(setup, x, drags, &|_| {})
}

/// [`estimate`], reporting the fraction of its iterations done to `progress` before each (where
/// background work is stopped, [`super::supersede`]).
pub fn estimate_reporting(
    setup: &Setup,
    x: &[DVec3],
    drags: &DragSet,
    progress: &dyn Fn(f32),
) -> Result<f64, SolverError> {
    let mut model = ShellModel::new(setup)?;
    let mut corrected = x.to_vec();
    let mut still = vec![DVec3::ZERO; x.len()];
    model.apply_drags(drags, &mut corrected, &mut still)?;
    let one = NewtonSettings { max_iterations: 1, tolerance: 1e-10 };
    for k in 1..=MAX_ITERATIONS {
        progress((k - 1) as f32 / MAX_ITERATIONS as f32);
        let before = corrected.clone();
        if model.minimize(&mut corrected, None, one)?.converged {
            break;
        }
        if k >= NEWTON_ITERATIONS && distance(&corrected, &before) < CONVERGING * distance(&corrected, x) {
            break;
        }
    }
    let moved = distance(&corrected, setup.mesh.positions());
    Ok(if moved > 0.0 { distance(&corrected, x) / moved } else { 0.0 })
}

/// Shape `x` of `setup` after `iterations` Newton iterations of the full discrete-shell equations
/// under the scene's loads, every position drag of `drags` pinned at its target.
pub fn correct(setup: &Setup, x: &[DVec3], drags: &DragSet, iterations: usize) -> Result<Vec<DVec3>, SolverError> {
    let mut model = ShellModel::new(setup)?;
    let mut corrected = x.to_vec();
    let mut still = vec![DVec3::ZERO; x.len()];
    model.apply_drags(drags, &mut corrected, &mut still)?;
    model.minimize(&mut corrected, None, NewtonSettings { max_iterations: iterations, tolerance: 1e-10 })?;
    Ok(corrected)
}

/// Whether the full-shell estimate applies to a method: the modal methods and the discrete shells
/// (the cloths and `rigid` have another model, or none).
pub fn judged(method: &str) -> bool {
    matches!(method, "lma" | "mwts" | "mwts-rs" | "ds" | "ds-implicit" | "ds-static")
}

/// `setup` with the shell's quantities a running solver reports in `params` (stiffnesses, density,
/// vertical gravity): what a readout must judge against after the user has tuned them.
pub fn with_params(setup: &Setup, params: &[super::ParamValue]) -> Setup {
    let mut s = setup.clone();
    for p in params {
        let m = &mut s.scene.material;
        match p.spec.name {
            n if n == K_AREA.name => m.k_area = p.value,
            n if n == K_LENGTH.name => m.k_length = p.value,
            n if n == K_BEND.name => m.k_bend = p.value,
            n if n == DENSITY.name => m.density = p.value,
            n if n == GRAVITY_Y.name => s.scene.gravity[1] = p.value,
            _ => {}
        }
    }
    s
}
