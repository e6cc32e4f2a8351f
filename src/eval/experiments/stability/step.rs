//! The `step` family: step size × a stiffness multiplier, every cell the same scene run with that
//! step and stiffness.
//!
//! Shells run the flat `cantilever` under gravity (all three stiffnesses scaled, × 0.01 to × 1000;
//! Rayleigh damping critical for the lowest mode) to rest, compared with `ds-static` at the same
//! stiffness. Softening by `s` is, for the static shape, gravity scaled by `1/s` (it depends on
//! `ρ g / k` alone), so the soft rows are the heavy-load rows too. The explicit `ds` runs 2,000
//! substeps per cell (an instability above the limit grows by orders of magnitude per few steps)
//! on a log grid of substeps, beside its own estimate `2/ω_max`. Cloth runs the `drape`
//! (`drape-quad` for `cloth-quad`; stretch, buckling stiffness and its linear branch scaled) for
//! 1 s, compared with the same method at h = 1 ms. `pbd` runs its `pbd-drape` (20 sweeps a step;
//! its stiffnesses are fractions per sweep, at most 1, so it has no multiplier and one row), `xpbd`
//! the drape with [`XPBD_SUBSTEPS`] substeps of [`XPBD_SWEEPS`] sweeps as in its scenes.
//!
//! References are computed once per method and stiffness and shared by the row's cells.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use glam::DVec3;

use super::super::super::measure::{self, Outcome, Run, Stop};
use super::{Probe, Row};
use crate::eval::EvalError;
use crate::solver::{STABLE_LIMIT_INFO, registry};

/// How the family is set up, for the summary.
pub const SETUP: &str = "the flat cantilever under gravity with k_A, k_L and k_B × 0.01 to × 1000 (soft is large \
    deformation, the same as heavy load), Rayleigh α critical for its lowest mode, run to rest (at most 3000 steps) and \
    compared with `ds-static` at the same stiffness; `ds` (explicit): 2000 substeps per cell on a log grid beside its \
    estimate 2/ω_max at rest; cloth: the drape with k_s, c_b and k_b × 1 to × 1000, 1 s, compared with the same method \
    at h = 1 ms (`pbd` on its `pbd-drape`, × 1 only: its stiffnesses are fractions per sweep).";

const SHELL_STIFFNESS: [f64; 6] = [0.01, 0.1, 1.0, 10.0, 100.0, 1000.0];
const CLOTH_STIFFNESS: [f64; 4] = [1.0, 10.0, 100.0, 1000.0];
const QUICK_STIFFNESS: [f64; 2] = [1.0, 1000.0];
const IMPLICIT_STEPS: [f64; 5] = [0.001, 0.003, 0.01, 1.0 / 30.0, 0.1];
const QUICK_STEPS: [f64; 3] = [0.01, 1.0 / 30.0, 0.1];
/// Substeps the explicit run takes per cell, and per frame.
const EXPLICIT_SUBSTEPS: u64 = 2000;
const EXPLICIT_FRAME: u64 = 100;

/// `xpbd`'s substeps per step and Gauss–Seidel sweeps per substep here, as in its scenes (`flag`,
/// `pile`, `push`).
pub const XPBD_SUBSTEPS: usize = 10;
/// See [`XPBD_SUBSTEPS`].
pub const XPBD_SWEEPS: usize = 2;

const SHELLS: [&str; 6] = ["lma", "mwts", "mwts-rs", "rds", "ds-implicit", "ds"];
const CLOTHS: [&str; 4] = ["cloth", "cloth-quad", "pbd", "xpbd"];

/// The explicit method's substep grid: `10^(−6 + k/per_decade)` up to 3.2e-4 s.
fn explicit_grid(quick: bool) -> Vec<f64> {
    let per_decade = if quick { 4 } else { 8 };
    (0..=(2.5 * per_decade as f64) as i32).map(|k| 10f64.powf(-6.0 + f64::from(k) / per_decade as f64)).collect()
}

/// One row per method and stiffness.
pub fn rows(quick: bool) -> Vec<Row> {
    let steps: &[f64] = if quick { &QUICK_STEPS } else { &IMPLICIT_STEPS };
    let shell: &[f64] = if quick { &QUICK_STIFFNESS } else { &SHELL_STIFFNESS };
    let cloth: &[f64] = if quick { &QUICK_STIFFNESS } else { &CLOTH_STIFFNESS };
    let available = |m: &&&str| registry::find(m).is_ok();
    let shells = SHELLS.iter().filter(available).flat_map(|&m| {
        shell.iter().map(move |&y| Row {
            method: m,
            y,
            xs: if m == "ds" { explicit_grid(quick) } else { steps.to_vec() },
        })
    });
    // `pbd`'s stiffnesses are fractions per sweep: no multiplier (module documentation).
    let cloths = CLOTHS.iter().filter(available).flat_map(|&m| {
        let ys = if m == "pbd" { &cloth[..1] } else { cloth };
        ys.iter().map(move |&y| Row { method: m, y, xs: steps.to_vec() })
    });
    shells.chain(cloths).collect()
}

/// Run one cell: `method` at step (or, for `ds`, substep) `h` and stiffness × `stiffness`.
pub fn probe(method: &str, h: f64, stiffness: f64) -> Result<Probe, EvalError> {
    match method {
        "ds" => explicit(stiffness, h),
        m if SHELLS.contains(&m) => implicit_shell(m, h, reference(m, stiffness)?.as_ref()),
        m => cloth(m, stiffness, h, reference(m, stiffness)?.as_ref()),
    }
}

/// What a cell is compared with (empty positions: no converged reference, accuracy not judged), and
/// for shells the overrides with the damping that brings runs to rest.
struct Reference {
    positions: Vec<DVec3>,
    overrides: Vec<String>,
    omega: f64,
}

impl Reference {
    /// The relative error of `x`, or NaN without a reference.
    fn error(&self, x: &[DVec3], rest: &[DVec3]) -> f64 {
        if self.positions.is_empty() { f64::NAN } else { measure::relative_error(x, &self.positions, rest) }
    }
}

/// References made so far, by the method's family and the stiffness's bits.
type Made = HashMap<(String, u64), Arc<Reference>>;

/// The reference of a method's family at a stiffness, computed once per process.
fn reference(method: &str, stiffness: f64) -> Result<Arc<Reference>, EvalError> {
    static MADE: Mutex<Option<Made>> = Mutex::new(None);
    let key = (if SHELLS.contains(&method) { "shell".into() } else { method.to_string() }, stiffness.to_bits());
    if let Some(r) = MADE.lock().ok().and_then(|m| m.as_ref()?.get(&key).cloned()) {
        return Ok(r);
    }
    let made = Arc::new(if SHELLS.contains(&method) {
        shell_reference(stiffness)?
    } else {
        cloth_reference(method, stiffness)?
    });
    if let Ok(mut m) = MADE.lock() {
        m.get_or_insert_with(HashMap::new).insert(key, made.clone());
    }
    Ok(made)
}

fn shell_overrides(stiffness: f64) -> Result<Vec<String>, EvalError> {
    let base = measure::setup("cantilever", "ds-static", &[])?;
    let m = &base.scene.material;
    Ok(vec![
        format!("material.k_area={}", m.k_area * stiffness),
        format!("material.k_length={}", m.k_length * stiffness),
        format!("material.k_bend={}", m.k_bend * stiffness),
    ])
}

fn shell_reference(stiffness: f64) -> Result<Reference, EvalError> {
    let mut overrides = shell_overrides(stiffness)?;
    let r = measure::reference("cantilever", &overrides)?;
    // An unconverged reference judges nothing: the cells are then only stable or failed.
    let positions = if r.converged { r.positions } else { Vec::new() };
    let (alpha, omega) = measure::critical_damping(&measure::setup("cantilever", "ds-static", &overrides)?)?;
    overrides.push(format!("solver.rayleigh_alpha={alpha}"));
    Ok(Reference { positions, overrides, omega })
}

fn implicit_shell(method: &str, h: f64, reference: &Reference) -> Result<Probe, EvalError> {
    let mut over = reference.overrides.clone();
    over.push(format!("solver.step={h}"));
    let s = measure::setup("cantilever", method, &over)?;
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: 40.0 / reference.omega, max_steps: 3000, rest: 1e-7 };
    let run = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
    let error = reference.error(&run.positions, &rest);
    let area = measure::area_change(&run.positions, &s);
    Ok(Probe::new(run, error, area, true, None))
}

fn explicit(stiffness: f64, substep: f64) -> Result<Probe, EvalError> {
    let mut over = shell_overrides(stiffness)?;
    over.extend([format!("solver.substep={substep}"), format!("solver.step={}", substep * EXPLICIT_FRAME as f64)]);
    let s = measure::setup("cantilever", "ds", &over)?;
    let mut solver = measure::build(&s)?;
    let limit = solver.info().iter().find(|(k, _)| *k == STABLE_LIMIT_INFO).map_or(f64::NAN, |(_, v)| *v);
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: f64::INFINITY, max_steps: EXPLICIT_SUBSTEPS / EXPLICIT_FRAME, rest: 0.0 };
    let run = measure::run(solver.as_mut(), &rest, stop);
    let area = measure::area_change(&run.positions, &s);
    // Neither accuracy nor area is judged here: 2000 substeps are milliseconds of motion, far from
    // any rest, and a diverging run is caught by the solver.
    Ok(Probe::new(run, f64::NAN, area, false, None).with_limit(limit))
}

/// The cloth scene a method runs: the drape, on Choi & Ko's grid for `cloth-quad`, `pbd`'s own.
pub fn cloth_scene(method: &str) -> &'static str {
    match method {
        "cloth-quad" => "drape-quad",
        "pbd" => "pbd-drape",
        _ => "drape",
    }
}

/// The scaled stiffnesses, and `xpbd`'s inner settings (module documentation).
fn cloth_overrides(method: &str, stiffness: f64) -> Result<Vec<String>, EvalError> {
    let base = measure::setup(cloth_scene(method), "cloth", &[])?;
    let m = &base.scene.material;
    let mut over = vec![
        format!("material.k_s={}", m.k_s * stiffness),
        format!("material.c_b={}", m.c_b * stiffness),
        format!("material.k_b={}", m.k_b * stiffness),
    ];
    if method == "xpbd" {
        over.extend([format!("solver.substeps={XPBD_SUBSTEPS}"), format!("solver.sweeps={XPBD_SWEEPS}")]);
    }
    Ok(over)
}

const CLOTH_TIME: f64 = 1.0;
const CLOTH_REFERENCE_STEP: f64 = 0.001;

fn cloth_run(method: &str, stiffness: f64, h: f64) -> Result<(Run, Vec<DVec3>), EvalError> {
    let mut over = cloth_overrides(method, stiffness)?;
    over.push(format!("solver.step={h}"));
    let s = measure::setup(cloth_scene(method), method, &over)?;
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: CLOTH_TIME, max_steps: u64::MAX, rest: 0.0 };
    Ok((measure::run(measure::build(&s)?.as_mut(), &rest, stop), rest))
}

fn cloth_reference(method: &str, stiffness: f64) -> Result<Reference, EvalError> {
    let (run, _) = cloth_run(method, stiffness, CLOTH_REFERENCE_STEP)?;
    let positions = if matches!(run.outcome, Outcome::Diverged(_)) { Vec::new() } else { run.positions };
    Ok(Reference { positions, overrides: Vec::new(), omega: f64::NAN })
}

fn cloth(method: &str, stiffness: f64, h: f64, reference: &Reference) -> Result<Probe, EvalError> {
    let (run, rest) = cloth_run(method, stiffness, h)?;
    let error = reference.error(&run.positions, &rest);
    let area = measure::area_change(&run.positions, &measure::setup(cloth_scene(method), method, &[])?);
    // Cloth's springs resist stretch only: its area is not a measure of accuracy here.
    Ok(Probe::new(run, error, area, false, None))
}
