//! What the experiments measure, shared by all of them: building a solver for a scene with
//! overrides, running it to rest or for a time while timing its steps, the static reference, and the
//! error measures (relative displacement-field error, relative area change).

use std::time::Instant;

use glam::DVec3;

pub use crate::solver::run::{Outcome, REST_STEPS, Run, Stop, distance, run, run_driven};

use super::EvalError;
use crate::scene::{self, Key, Selection, Setup, Track};
use crate::solver::modal::cache::Cache;
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

/// Give `setup` a track on `vertices` with `keys` (as a scene's `[[tracks]]` entry would).
pub fn add_track(setup: &mut Setup, vertices: Vec<usize>, keys: Vec<Key>) {
    let select = Selection { aabb: None, indices: Some(vertices.clone()) };
    setup.scene.tracks.push(Track { select, pivot: None, keys, joint: None, looping: false });
    setup.tracks.push(vertices);
}

/// The steps of 1/30 s in which `ds-static` walks a motion that moves a vertex by `length` metres
/// and turns by `degrees`: at most 1 cm and 6° a step.
pub fn walk_steps(length: f64, degrees: f64) -> usize {
    (length / 0.01).max(degrees / 6.0).ceil().max(1.0) as usize
}

/// The vertices at the largest rest `x`: the tip row of a strip clamped at its smallest `x`.
pub fn tip_row(rest: &[DVec3]) -> Vec<usize> {
    let end = rest.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    (0..rest.len()).filter(|&i| rest[i].x > end - 1e-9).collect()
}

/// Give `setup` one track turning its tip row by `degrees` about the strip's axis (x) over
/// `seconds`, the row's place held (positions and rotation keys: every method follows it).
pub fn twist_tip(setup: &mut Setup, degrees: f64, seconds: f64) {
    let tip = tip_row(setup.mesh.positions());
    let key =
        |time: f64, angle: f64| Key { time, position: Some([0.0; 3]), rotation: Some([angle.to_radians(), 0.0, 0.0]) };
    add_track(setup, tip, vec![key(0.0, 0.0), key(seconds, degrees)]);
}

/// `ds-static` walked through the motion of `setup`'s tracks in `steps` steps of 1/30 s (the tracks'
/// keys must reach their last at `steps / 30` s), then held for three more: the reference of a
/// dragged or twisted shell, and whether its last step converged. Cached in the modal cache's folder
/// (`references/`), keyed by the scene as realised and this program's version, so that the cases
/// of one motion share it; written atomically.
pub fn walked_reference(setup: &Setup, steps: usize) -> Result<(Vec<DVec3>, bool), EvalError> {
    let mut s = setup.clone();
    s.scene.solver.method = "ds-static".into();
    let text = format!("{}|{:?}|{steps}", env!("CARGO_PKG_VERSION"), s.scene);
    let hash = text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3));
    let file = Cache::from_env().dir().map(|d| d.join("references").join(format!("{}-{hash:016x}.json", s.scene.name)));
    let cached = file.as_ref().and_then(|f| std::fs::read_to_string(f).ok());
    if let Some(Ok((x, converged))) = cached.map(|c| serde_json::from_str::<(Vec<[f64; 3]>, bool)>(&c)) {
        return Ok((x.into_iter().map(DVec3::from).collect(), converged));
    }
    let mut solver = build(&s)?;
    let mut converged = false;
    for _ in 0..steps + 3 {
        converged = solver
            .step()
            .map_err(EvalError::solver(format!("ds-static through the motion on {}", s.scene.name)))?
            .converged;
    }
    let x = solver.positions().to_vec();
    if let Some(file) = file {
        let text =
            serde_json::to_string(&(x.iter().map(|p| p.to_array()).collect::<Vec<_>>(), converged)).unwrap_or_default();
        // Best effort: a reference that cannot be kept is computed again next time.
        let _ = file
            .parent()
            .map(std::fs::create_dir_all)
            .transpose()
            .and_then(|_| crate::atomic::write(&file, text.as_bytes()));
    }
    Ok((x, converged))
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
