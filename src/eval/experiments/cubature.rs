//! `cubature`: how well `rds`'s optimised cubature of the shell energy (a few weighted elements
//! instead of all) reproduces the exact reduced force and equilibrium, against its size, with the
//! modes alone and with `rds`'s default basis (load responses and derivative directions).
//!
//! Per case: the cubature fitted to the basis (its kept elements, training residual and fitting
//! time), its force error `|f_S(c) − f(c)| / |f(c)|` on 20 poses it was not fitted to (mean and
//! largest), and where the scene is small enough, the shift of the equilibrium under a load it
//! makes (`rds` with the cubature against `rds` over every element, both run to rest at α = 2ω₁) and
//! the time of a step with and without it.

use std::path::Path;
use std::time::Instant;

use super::super::chart::{Axis, Plot, Series, Style, method_color};
use super::super::measure::{self, Stop};
use super::super::report::{Section, bold, bold_percent};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::{add_chart, key_value, num};
use crate::solver::modal::cache::Cache;
use crate::solver::reduced::Rds;

/// The experiment.
pub struct Cubature;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("scene", ""),
    computed("basis", ""),
    computed("modes", ""),
    computed("coordinates", ""),
    computed("asked", ""),
    computed("kept", ""),
    computed("elements", ""),
    computed("training_error", ""),
    computed("unseen_mean", ""),
    computed("unseen_max", ""),
    computed("shift", ""),
    timed("fit", "s"),
    timed("step_exact", "s"),
    timed("step_cubature", "s"),
];

/// The experiment's name, title and columns.
const ABOUT: About = About {
    name: "cubature",
    title: "The cubature of rds: force and equilibrium error against its size",
    columns: COLUMNS,
};

/// The scenes: modes, the load of the equilibrium (m/s², none: not run), the sizes asked.
const SCENES: [(&str, usize, Option<f64>, &[usize]); 3] = [
    ("cantilever", 8, Some(35.0), &[50, 100, 200, 400, 800]),
    ("v-beam", 8, Some(400.0), &[50, 100, 200, 400, 800]),
    ("creature", 4, None, &[300]),
];

/// The quick sweep.
const QUICK: [(&str, usize, Option<f64>, &[usize]); 1] = [("cantilever", 8, Some(35.0), &[100, 300])];

/// The bases: the modes alone, and `rds`'s default (with the load responses and derivative directions).
const BASES: [&str; 2] = ["modes", "derivatives"];

/// The poses the force error is measured on.
const UNSEEN: usize = 20;

impl Experiment for Cubature {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        let scenes: &[(&str, usize, Option<f64>, &[usize])] = if quick { &QUICK } else { &SCENES };
        scenes
            .iter()
            .flat_map(|(scene, _, _, sizes)| {
                BASES.iter().flat_map(move |b| sizes.iter().map(move |n| format!("{scene}/{b}/n={n}")))
            })
            .collect()
    }

    fn run(&self, case: &str, _quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let unknown = || EvalError::UnknownCase(case.into());
        let mut parts = case.split('/');
        let (scene, basis, size) = (parts.next(), parts.next(), parts.next());
        let (Some(scene), Some(basis), Some(size)) = (scene, basis, size) else { return Err(unknown()) };
        let size = key_value(size, "n")? as usize;
        let &(_, modes, load, _) = SCENES.iter().find(|s| s.0 == scene).ok_or_else(unknown)?;
        if !BASES.contains(&basis) {
            return Err(unknown());
        }
        let mut overrides = vec![format!("solver.modes={modes}")];
        if basis == "modes" {
            overrides.extend(["solver.derivatives=0".into(), "solver.load_responses=0".into()]);
        }
        if let Some(g) = load {
            overrides.push(format!("gravity=[0, {}, 0]", -g));
        }
        let base = measure::setup(scene, "rds", &overrides)?;
        let (alpha, omega) = measure::critical_damping(&base)?;
        overrides.push(format!("solver.rayleigh_alpha={alpha}"));
        // A cache of this case's own: the modes and the basis are built once, untimed, and both
        // timed builds read them, so that they differ by the cubature's fit alone.
        let dir =
            std::env::temp_dir().join(format!("shellwarp-cubature-{}-{}", std::process::id(), case.replace('/', "_")));
        let cache = Cache::at(&dir);
        let build = |cubature: usize| -> Result<(Rds, f64), EvalError> {
            let mut o = overrides.clone();
            o.push(format!("solver.cubature={cubature}"));
            let s = measure::setup(scene, "rds", &o)?;
            let t = Instant::now();
            let rds =
                Rds::with_cache(&s, cache.clone()).map_err(EvalError::solver(format!("building rds for {scene}")))?;
            Ok((rds, t.elapsed().as_secs_f64()))
        };
        let built = build(0).and_then(|_| Ok((build(0)?, build(size)?)));
        let _ = std::fs::remove_dir_all(&dir);
        let ((mut exact, plain), (mut sampled, fitted)) = built?;
        progress(0.3);
        let cubature = sampled.cubature().cloned().ok_or_else(unknown)?;
        let errors = sampled.cubature_errors(UNSEEN).unwrap_or_default();
        let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        let largest = errors.iter().copied().fold(0.0, f64::max);
        let mesh = &base.mesh;
        let elements = mesh.triangles().len() + mesh.topology().edges.len() + mesh.topology().hinges.len();
        progress(0.5);
        let (mut shift, mut step_exact, mut step_cubature) = (f64::NAN, f64::NAN, f64::NAN);
        if load.is_some() {
            let rest = mesh.positions();
            let stop = Stop { max_time: 25.0 / omega, max_steps: u64::MAX, rest: 1e-7 };
            let a = measure::run(&mut exact, rest, stop);
            let b = measure::run(&mut sampled, rest, stop);
            shift = measure::relative_error(&b.positions, &a.positions, rest);
            step_exact = a.wall / a.steps.max(1) as f64;
            step_cubature = b.wall / b.steps.max(1) as f64;
        }
        let mut table = Table::new(COLUMNS);
        table.push(vec![
            ("case", case.into()),
            ("scene", scene.into()),
            ("basis", basis.into()),
            ("modes", num(modes as u64)),
            ("coordinates", num(sampled.basis().len() as u64)),
            ("asked", num(size as u64)),
            ("kept", num(cubature.elements.len() as u64)),
            ("elements", num(elements as u64)),
            ("training_error", cubature.training_error.into()),
            ("unseen_mean", mean.into()),
            ("unseen_max", largest.into()),
            ("shift", shift.into()),
            ("fit", (fitted - plain).max(0.0).into()),
            ("step_exact", step_exact.into()),
            ("step_cubature", step_cubature.into()),
        ])?;
        progress(1.0);
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(
            self.about(),
            format!(
                "`rds` with its energy summed over an optimised cubature (An, Kim & James 2008: elements chosen \
                 greedily, weights ≥ 0 by non-negative least squares, fitted to the exact reduced force on \
                 random poses) of at most the asked number of elements, on the strip and the V-beam (8 modes) \
                 and the creature (4 modes), with the modes alone and with the default basis (load responses and \
                 derivative directions). \
                 Force error: |f_S − f| / |f| on {UNSEEN} poses the fit has not seen (mean and largest). Shift: \
                 the equilibrium under the strip's 35 m/s² and the V-beam's 400 m/s² with the cubature against \
                 the one over every element, ‖x_S − x‖ / ‖x − X‖. One thread."
            ),
        );
        let col = |name: &str| table.index(name);
        let (si, bi, ki, ei, mi, xi, hi, ti) = (
            col("scene")?,
            col("basis")?,
            col("kept")?,
            col("elements")?,
            col("unseen_mean")?,
            col("unseen_max")?,
            col("shift")?,
            col("fit")?,
        );
        let mut series = Vec::new();
        for (scene, ..) in SCENES {
            for basis in BASES {
                let mut rows: Vec<&Vec<Value>> =
                    table.rows.iter().filter(|r| r[si].text() == scene && r[bi].text() == basis).collect();
                if rows.is_empty() {
                    continue;
                }
                rows.sort_by(|a, b| a[ki].num().total_cmp(&b[ki].num()));
                let label = format!("{scene}, {basis}");
                series.push(Series {
                    color: method_color(scene),
                    style: if basis == "modes" { Style::Line } else { Style::Dashed },
                    points: rows.iter().map(|r| (r[ki].num(), r[mi].num())).collect(),
                    label: label.clone(),
                });
                let met = rows.iter().find(|r| r[mi].num() < 0.01);
                let last = rows[rows.len() - 1];
                let shift = if last[hi].num().is_finite() {
                    format!(", the equilibrium {} from every element's", bold_percent(last[hi].num()))
                } else {
                    String::new()
                };
                section.findings.push(format!(
                    "`{scene}` ({basis}): {} of {} elements give a force error of {} on average, {} at most, \
                     fitted in {} s{shift}; {}.",
                    bold(last[ki].num()),
                    bold(last[ei].num()),
                    bold_percent(last[mi].num()),
                    bold_percent(last[xi].num()),
                    bold(last[ti].num()),
                    match met {
                        Some(r) => format!("the mean is below 1% from {} elements", bold(r[ki].num())),
                        None => "the mean stays above 1% at every size measured".into(),
                    },
                ));
            }
        }
        add_chart(
            Plot {
                title: "rds cubature: force error on unseen poses against its size".into(),
                x: Axis::log("elements kept"),
                y: Axis::log("mean relative force error |f_S − f| / |f|"),
                series,
            },
            &mut section,
            out,
            "error",
            "mean force error on unseen poses against the elements kept (dashed: with derivative directions)".into(),
        )?;
        Ok(section)
    }
}
