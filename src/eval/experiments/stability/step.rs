//! `stability`: where each method fails. For every method, a map over its step size × a stiffness
//! multiplier (× 1 to × 1000): stable, inaccurate (error or area change above the stated thresholds),
//! or diverged (when, and the solver's own message). The failures are found by the sweep, nothing is
//! staged: every cell is the same scene run with that step and stiffness.
//!
//! Shells run the flat `cantilever` under gravity (all three stiffnesses scaled, Rayleigh damping
//! critical for the lowest mode) to rest, compared with `ds-static` at the same stiffness. The
//! explicit `ds` runs 2,000 substeps per cell (an instability above the limit grows by orders of
//! magnitude per few steps), on a log grid of substeps; the boundary between the largest stable and
//! the smallest diverged substep is then narrowed by bisection and compared with the method's own
//! estimate `2/ω_max`. Cloth runs the `drape` (`drape-quad` for `cloth-quad`; stretch, buckling
//! stiffness and its linear branch scaled) for 1 s, compared with the same method at h = 1 ms. The
//! position-based methods run with their own inner settings, not the cloth's PCG cap of 200 as
//! Gauss–Seidel sweeps (which made one `xpbd` reference 2·10⁶ sweeps): `pbd` its `pbd-drape` (20
//! sweeps a step; its stiffnesses are fractions per sweep, at most 1, so it has no multiplier and one
//! row of cells), `xpbd` the drape with [`XPBD_SUBSTEPS`] substeps of [`XPBD_SWEEPS`] sweeps as in its
//! scenes (compliances `1/k_s` and the hinge's from `k_b`, scaled).

use std::path::Path;

use super::super::chart::{Cell, MapPanel, Maps};
use super::super::measure::{self, Outcome, Run, Stop};
use super::super::report::{Section, bold};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{EvalError, Experiment};
use super::{chart_ref, key_value};
use crate::solver::{STABLE_LIMIT_INFO, registry};

/// The experiment.
pub struct Stability;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("method", ""),
    computed("stiffness", "×"),
    computed("step", "s"),
    computed("probe", ""),
    computed("outcome", ""),
    computed("rel_error", ""),
    computed("area_change", ""),
    computed("fail_time", "s"),
    computed("message", ""),
    computed("estimated_limit", "s"),
    computed("boundary_vs_estimate", ""),
    timed("cost", "s/s"),
];

/// Relative displacement error above which a run that did not diverge is *inaccurate*.
pub const ERROR_THRESHOLD: f64 = 0.1;
/// Relative area change above which a shell run is *inaccurate*.
pub const AREA_THRESHOLD: f64 = 0.01;

const STIFFNESS: [f64; 4] = [1.0, 10.0, 100.0, 1000.0];
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

/// Which methods, on which scene family.
fn methods() -> Vec<(&'static str, bool)> {
    let shells = ["lma", "mwts", "mwts-rs", "ds-implicit", "ds"].map(|m| (m, true));
    let cloth = ["cloth", "cloth-quad", "pbd", "xpbd"].map(|m| (m, false));
    shells.into_iter().chain(cloth).filter(|(m, _)| registry::find(m).is_ok()).collect()
}

/// The explicit method's substep grid: `10^(−6 + k/per_decade)` up to 3.2e-4 s.
fn explicit_grid(quick: bool) -> Vec<f64> {
    let per_decade = if quick { 4 } else { 8 };
    (0..=(2.5 * per_decade as f64) as i32).map(|k| 10f64.powf(-6.0 + f64::from(k) / per_decade as f64)).collect()
}

impl Experiment for Stability {
    fn name(&self) -> &'static str {
        "stability"
    }

    fn title(&self) -> &'static str {
        "Stability maps: step size × stiffness"
    }

    fn columns(&self) -> &'static [Column] {
        COLUMNS
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        let stiffness: &[f64] = if quick { &[1.0, 1000.0] } else { &STIFFNESS };
        // `pbd`'s stiffnesses are fractions per sweep: no multiplier (module documentation).
        let rows = |m: &str| if m == "pbd" { &stiffness[..1] } else { stiffness };
        methods().iter().flat_map(|(m, _)| rows(m).iter().map(move |s| format!("{m}/stiffness={s}"))).collect()
    }

    fn run(&self, case: &str, quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let (method, s) = case.split_once('/').ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let stiffness = key_value(s, "stiffness")?;
        let &(method, shell) =
            methods().iter().find(|m| m.0 == method).ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let mut table = Table::new(COLUMNS);
        let mut push = |step: f64, probe: &str, cell: &CellRun| {
            table.push(vec![
                ("case", case.into()),
                ("method", method.into()),
                ("stiffness", stiffness.into()),
                ("step", step.into()),
                ("probe", probe.into()),
                ("outcome", cell.outcome.into()),
                ("rel_error", cell.error.into()),
                ("area_change", cell.area.into()),
                ("fail_time", cell.fail_time.into()),
                ("message", cell.run.message().into()),
                ("estimated_limit", cell.limit.into()),
                ("cost", cell.run.cost().into()),
            ])
        };
        if method == "ds" {
            let grid = explicit_grid(quick);
            let mut stable = None;
            let mut diverged = None;
            let mut limit = f64::NAN;
            for (i, &h) in grid.iter().enumerate() {
                let cell = explicit(stiffness, h)?;
                limit = cell.limit;
                if cell.outcome == "diverged" {
                    diverged = diverged.or(Some(h));
                } else if diverged.is_none() {
                    stable = Some(h);
                }
                push(h, "grid", &cell)?;
                progress((i + 1) as f32 / grid.len() as f32);
            }
            // Narrow the boundary (in log h) between the largest stable and the smallest diverged substep.
            if let (Some(mut lo), Some(mut hi)) = (stable, diverged) {
                for _ in 0..(if quick { 5 } else { 8 }) {
                    let mid = (lo * hi).sqrt();
                    let cell = explicit(stiffness, mid)?;
                    push(mid, "bisection", &cell)?;
                    if cell.outcome == "diverged" { hi = mid } else { lo = mid }
                }
                let boundary = (lo * hi).sqrt();
                table.push(vec![
                    ("case", case.into()),
                    ("method", method.into()),
                    ("stiffness", stiffness.into()),
                    ("step", boundary.into()),
                    ("probe", "boundary".into()),
                    ("estimated_limit", limit.into()),
                    ("boundary_vs_estimate", (boundary / limit).into()),
                ])?;
            }
            return Ok(table);
        }
        let steps: &[f64] = if quick { &QUICK_STEPS } else { &IMPLICIT_STEPS };
        let reference = if shell { shell_reference(stiffness)? } else { cloth_reference(method, stiffness)? };
        for (i, &h) in steps.iter().enumerate() {
            let cell =
                if shell { implicit_shell(method, h, &reference)? } else { cloth(method, stiffness, h, &reference)? };
            push(h, "grid", &cell)?;
            progress((i + 1) as f32 / steps.len() as f32);
        }
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section {
            experiment: self.name().into(),
            title: self.title().into(),
            setup: format!(
                "Each cell is one run. Shells: the flat cantilever under gravity with k_A, k_L and k_B × 1 to × 1000, \
                 Rayleigh α critical for its lowest mode, run to rest (at most 3000 steps) and compared with `ds-static` \
                 at the same stiffness. `ds` (explicit): 2000 substeps per cell on a log grid, the boundary then \
                 narrowed by bisection, beside the method's own estimate 2/ω_max at rest. Cloth: the drape (on \
                 Choi & Ko's grid for `cloth-quad`) with k_s, c_b and k_b × 1 to × 1000, 1 s, compared with the same method at h = 1 ms; \
                 `pbd` on its own `pbd-drape` (20 sweeps a step; its stiffnesses are fractions per sweep, so × 1 only), \
                 `xpbd` with {XPBD_SUBSTEPS} substeps of {XPBD_SWEEPS} sweeps (as its scenes). Diverged: \
                 the solver reported divergence (non-finite state or exploding energy); inaccurate: error above \
                 {ERROR_THRESHOLD} or (shells) area change above {AREA_THRESHOLD}. Conditionally stable methods: \
                 `ds` (symplectic Euler); the others integrate implicitly (`ds-implicit`: backward Euler with \
                 Newton; `lma`, `mwts`: per-mode implicit Euler; `mwts-rs`: linearly implicit Euler with the load \
                 stiffness; `cloth`: linearised backward Euler) or project positions (`pbd`, `xpbd`)."
            ),
            ..Section::default()
        };
        let (mi, si, hi, pi, oi, ti, gi, li, bi) = (
            table.index("method")?,
            table.index("stiffness")?,
            table.index("step")?,
            table.index("probe")?,
            table.index("outcome")?,
            table.index("fail_time")?,
            table.index("message")?,
            table.index("estimated_limit")?,
            table.index("boundary_vs_estimate")?,
        );
        let categories = ["stable", "inaccurate", "diverged"];
        let legend = vec![
            ("stable".to_string(), plotters::style::RGBColor(110, 190, 110)),
            (
                format!("inaccurate (error > {ERROR_THRESHOLD} or area > {AREA_THRESHOLD})"),
                plotters::style::RGBColor(240, 200, 80),
            ),
            ("diverged".to_string(), plotters::style::RGBColor(215, 70, 60)),
        ];
        let mut panels = Vec::new();
        let mut names: Vec<String> = table.rows.iter().map(|r| r[mi].text()).collect();
        names.dedup();
        for name in &names {
            let grid: Vec<&Vec<Value>> =
                table.rows.iter().filter(|r| r[mi].text() == *name && r[pi].text() == "grid").collect();
            let mut steps: Vec<f64> = grid.iter().map(|r| r[hi].num()).collect();
            steps.sort_by(f64::total_cmp);
            steps.dedup();
            let mut stiff: Vec<f64> = grid.iter().map(|r| r[si].num()).collect();
            stiff.sort_by(f64::total_cmp);
            stiff.dedup();
            let cells = grid
                .iter()
                .map(|r| Cell {
                    column: steps.iter().position(|&h| h == r[hi].num()).unwrap_or(0),
                    row: stiff.iter().position(|&s| s == r[si].num()).unwrap_or(0),
                    category: categories.iter().position(|c| *c == r[oi].text()).unwrap_or(2),
                })
                .collect();
            // The estimated limit at stiffness × 1, at its place on the (log) step axis.
            let marker = grid.iter().find(|r| r[si].num() == 1.0 && r[li].num().is_finite()).and_then(|r| {
                let (first, last) = (*steps.first()?, *steps.last()?);
                let ratio = (last / first).ln() / (steps.len() - 1).max(1) as f64;
                let at = (r[li].num() / first).ln() / ratio + 0.5;
                Some((at, "2/ω_max at × 1".to_string()))
            });
            panels.push(MapPanel {
                title: name.clone(),
                columns: steps.iter().map(|h| super::super::report::number(*h)).collect(),
                rows: stiff.iter().map(|s| format!("×{s}")).collect(),
                cells,
                marker,
            });
            // One sentence per method: its first failure, with the solver's own words.
            let first = grid
                .iter()
                .filter(|r| r[oi].text() == "diverged")
                .min_by(|a, b| (a[hi].num() * a[si].num().sqrt()).total_cmp(&(b[hi].num() * b[si].num().sqrt())));
            match first {
                Some(r) => section.findings.push(format!(
                    "`{name}` diverged at step {} s, stiffness × {}, after {} s: \"{}\" ({} of {} cells diverged).",
                    bold(r[hi].num()),
                    bold(r[si].num()),
                    bold(r[ti].num()),
                    r[gi].text(),
                    grid.iter().filter(|r| r[oi].text() == "diverged").count(),
                    grid.len()
                )),
                None => section.findings.push(format!(
                    "`{name}` never diverged ({} cells; {} inaccurate).",
                    grid.len(),
                    grid.iter().filter(|r| r[oi].text() == "inaccurate").count()
                )),
            }
        }
        for r in table.rows.iter().filter(|r| r[pi].text() == "boundary") {
            section.findings.push(format!(
                "`{}` at stiffness × {}: stable up to {} s (bisection), against its estimate 2/ω_max = {} s: a ratio of {}.",
                r[mi].text(),
                bold(r[si].num()),
                bold(r[hi].num()),
                bold(r[li].num()),
                bold(r[bi].num()),
            ));
        }
        let file = format!("{}-map.png", self.name());
        Maps {
            title: "Stability: step size (s) × stiffness multiplier".into(),
            x_label: "step (s)".into(),
            y_label: "stiffness".into(),
            legend,
            panels,
        }
        .save(&out.join(&file))?;
        section.charts.push(chart_ref(file, "stable, inaccurate and diverged runs per method".into()));
        Ok(section)
    }
}

/// One cell's run, classified.
struct CellRun {
    run: Run,
    outcome: &'static str,
    error: f64,
    area: f64,
    fail_time: f64,
    limit: f64,
}

/// Diverged if the solver said so; else inaccurate if the error (when judged: not NaN) or the area
/// change (when `judge_area`) is above its threshold; else stable.
fn classify(run: Run, error: f64, area: f64, judge_area: bool, limit: f64) -> CellRun {
    let (outcome, fail_time) = match &run.outcome {
        Outcome::Diverged(crate::solver::SolverError::Diverged { time, .. }) => ("diverged", *time),
        Outcome::Diverged(_) => ("diverged", run.sim_time),
        _ if error > ERROR_THRESHOLD || (judge_area && area.abs() > AREA_THRESHOLD) => ("inaccurate", f64::NAN),
        _ => ("stable", f64::NAN),
    };
    CellRun { run, outcome, error, area, fail_time, limit }
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

/// What a cell is compared with (empty positions: no converged reference, accuracy not judged), and
/// for shells the overrides with the damping that brings runs to rest.
struct ShellReference {
    positions: Vec<glam::DVec3>,
    overrides: Vec<String>,
    omega: f64,
}

impl ShellReference {
    /// The relative error of `x`, or NaN without a reference.
    fn error(&self, x: &[glam::DVec3], rest: &[glam::DVec3]) -> f64 {
        if self.positions.is_empty() { f64::NAN } else { measure::relative_error(x, &self.positions, rest) }
    }
}

fn shell_reference(stiffness: f64) -> Result<ShellReference, EvalError> {
    let mut overrides = shell_overrides(stiffness)?;
    let r = measure::reference("cantilever", &overrides)?;
    // An unconverged reference judges nothing: the cells are then only stable or diverged.
    let positions = if r.converged { r.positions } else { Vec::new() };
    let (alpha, omega) = measure::critical_damping(&measure::setup("cantilever", "ds-static", &overrides)?)?;
    overrides.push(format!("solver.rayleigh_alpha={alpha}"));
    Ok(ShellReference { positions, overrides, omega })
}

fn implicit_shell(method: &str, h: f64, reference: &ShellReference) -> Result<CellRun, EvalError> {
    let mut over = reference.overrides.clone();
    over.push(format!("solver.step={h}"));
    let s = measure::setup("cantilever", method, &over)?;
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: 40.0 / reference.omega, max_steps: 3000, rest: 1e-7 };
    let run = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
    let error = reference.error(&run.positions, &rest);
    let area = measure::area_change(&run.positions, &s);
    Ok(classify(run, error, area, true, f64::NAN))
}

fn explicit(stiffness: f64, substep: f64) -> Result<CellRun, EvalError> {
    let mut over = shell_overrides(stiffness)?;
    over.extend([format!("solver.substep={substep}"), format!("solver.step={}", substep * EXPLICIT_FRAME as f64)]);
    let s = measure::setup("cantilever", "ds", &over)?;
    let mut solver = measure::build(&s)?;
    let limit = solver.info().iter().find(|(k, _)| *k == STABLE_LIMIT_INFO).map_or(f64::NAN, |(_, v)| *v);
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: f64::INFINITY, max_steps: EXPLICIT_SUBSTEPS / EXPLICIT_FRAME, rest: 0.0 };
    let run = measure::run(solver.as_mut(), &rest, stop);
    let area = measure::area_change(&run.positions, &s);
    // Accuracy is not judged here: 2000 substeps are milliseconds of motion, far from any rest.
    Ok(classify(run, f64::NAN, area, false, limit))
}

/// The cloth scene a method runs: the drape, on Choi & Ko's grid for `cloth-quad`, `pbd`'s own.
fn cloth_scene(method: &str) -> &'static str {
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

fn cloth_run(method: &str, stiffness: f64, h: f64) -> Result<(Run, Vec<glam::DVec3>), EvalError> {
    let scene = cloth_scene(method);
    let mut over = cloth_overrides(method, stiffness)?;
    over.push(format!("solver.step={h}"));
    let s = measure::setup(scene, method, &over)?;
    let rest = s.mesh.positions().to_vec();
    let stop = Stop { max_time: CLOTH_TIME, max_steps: u64::MAX, rest: 0.0 };
    Ok((measure::run(measure::build(&s)?.as_mut(), &rest, stop), rest))
}

fn cloth_reference(method: &str, stiffness: f64) -> Result<ShellReference, EvalError> {
    let (run, _) = cloth_run(method, stiffness, CLOTH_REFERENCE_STEP)?;
    let positions = if matches!(run.outcome, Outcome::Diverged(_)) { Vec::new() } else { run.positions };
    Ok(ShellReference { positions, overrides: Vec::new(), omega: f64::NAN })
}

fn cloth(method: &str, stiffness: f64, h: f64, reference: &ShellReference) -> Result<CellRun, EvalError> {
    let (run, rest) = cloth_run(method, stiffness, h)?;
    let error = reference.error(&run.positions, &rest);
    let area = measure::area_change(&run.positions, &measure::setup(cloth_scene(method), method, &[])?);
    // Cloth's springs resist stretch only: its area is not a measure of accuracy here.
    Ok(classify(run, error, area, false, f64::NAN))
}
