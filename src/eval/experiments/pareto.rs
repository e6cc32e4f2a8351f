//! `pareto`: cost against accuracy. For three families of scenes — a beam under load, a beam twisted by
//! a drag, a cloth draped on a ball — every method and setting is one point: its wall-clock cost per
//! simulated second against its relative displacement-field error versus the family's reference. The
//! points no other point beats in both (the Pareto front) are drawn and listed.
//!
//! - `beam`: the flat `cantilever` under 2.5 g, run from rest to rest (critical damping of the lowest
//!   mode); reference `ds-static`.
//! - `twist`: the same strip without gravity, its tip row turned by 90° about the beam's axis over the
//!   first 0.5 s and held, to rest, by one track that every method follows (positions and the turn);
//!   reference `ds-static` walked through the same turn in 6° steps.
//! - `drape`: the 961-particle `drape`, 1 s of simulated time (the cloth has reached the ball and
//!   folds); reference `cloth` at h = 1/1600 s and PCG tolerance 1e-5. Beside the implicit cloth, XPBD
//!   with the same stiffnesses (substeps and sweeps) and PBD with its own per-sweep stiffness
//!   fractions (sweeps): their error mixes the numerical error with the difference of their models.

use std::path::Path;

use glam::DVec3;

use super::super::chart::{Axis, Plot, Series, Style, method_points};
use super::super::measure::{self, Run, Stop};
use super::super::report::{Section, bold};
use super::super::table::{Column, Table, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::add_chart;
use crate::solver::registry;

/// The experiment.
pub struct Pareto;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("family", ""),
    computed("method", ""),
    computed("setting", ""),
    computed("rel_error", ""),
    computed("outcome", ""),
    computed("sim_time", "s"),
    computed("steps", ""),
    computed("ref_converged", ""),
    timed("cost", "s/s"),
];

/// The experiment's name, title and columns.
const ABOUT: About = About {
    name: "pareto",
    title: "Cost against accuracy: every method and setting, and the Pareto front",
    columns: COLUMNS,
};

/// One point to measure: a method with settings (scene overrides).
struct Point {
    family: &'static str,
    method: &'static str,
    setting: String,
    overrides: Vec<String>,
}

impl Point {
    fn key(&self) -> String {
        format!("{}/{}/{}", self.family, self.method, self.setting)
    }
}

const MODES: [usize; 7] = [1, 2, 4, 8, 16, 32, 64];
const QUICK_MODES: [usize; 3] = [2, 8, 32];

/// The modal methods compared (those registered).
fn modal_methods() -> Vec<&'static str> {
    ["lma", "mwts", "mwts-rs", "rds"].into_iter().filter(|m| registry::find(m).is_ok()).collect()
}

fn points(quick: bool) -> Vec<Point> {
    let mut v = Vec::new();
    let modes: &[usize] = if quick { &QUICK_MODES } else { &MODES };
    for family in ["beam", "twist", "collapse"] {
        for method in modal_methods() {
            // `rds` up to 16 modes on the strips (its step grows with the square of the basis: 16
            // modes and 64 derivative directions already take longer than the discrete shell there),
            // at every count through the V-beam's collapse, where it is measured against basis size.
            for m in modes.iter().filter(|&&m| method != "rds" || m <= 16 || family == "collapse") {
                let overrides = vec![format!("solver.modes={m}")];
                v.push(Point { family, method, setting: format!("modes={m}"), overrides });
            }
        }
        let steps: &[(&str, f64)] = if quick {
            &[("1/30", 1.0 / 30.0)]
        } else {
            &[("1/30", 1.0 / 30.0), ("1/100", 0.01), ("1/300", 1.0 / 300.0)]
        };
        for (label, h) in steps {
            v.push(Point {
                family,
                method: "ds-implicit",
                setting: format!("h={label}"),
                overrides: vec![format!("solver.step={h}")],
            });
        }
        v.push(Point { family, method: "ds", setting: "substep=auto".into(), overrides: vec![] });
        if !quick {
            v.push(Point {
                family,
                method: "ds",
                setting: "substep=1e-5".into(),
                overrides: vec!["solver.substep=1e-5".into()],
            });
        }
    }
    let cloth: &[(f64, f64)] = if quick {
        &[(0.02, 1e-2), (0.01, 1e-2), (0.005, 1e-3)]
    } else {
        &[
            (0.02, 1e-1),
            (0.02, 1e-2),
            (0.01, 1e-1),
            (0.01, 1e-2),
            (0.01, 1e-3),
            (0.005, 1e-2),
            (0.005, 1e-3),
            (0.0025, 1e-3),
        ]
    };
    for (h, tol) in cloth {
        let overrides = vec![format!("solver.step={h}"), format!("solver.tolerance={tol}")];
        v.push(Point { family: "drape", method: "cloth", setting: format!("h={h}_tol={tol}"), overrides });
    }
    // XPBD with the cloth's stiffnesses (compliances 1/k_s and from k_b): substeps × sweeps per step.
    let xpbd: &[(f64, usize, usize)] = if quick {
        &[(0.01, 10, 2)]
    } else {
        &[(0.01, 1, 10), (0.01, 5, 2), (0.01, 10, 1), (0.01, 10, 2), (0.01, 20, 1), (1.0 / 60.0, 10, 2)]
    };
    for (h, n, it) in xpbd {
        let overrides = vec![format!("solver.step={h}"), format!("solver.substeps={n}"), format!("solver.sweeps={it}")];
        v.push(Point { family: "drape", method: "xpbd", setting: format!("h={h:.4}_n={n}_it={it}"), overrides });
    }
    // PBD as Müller et al.: one step of 1/60 s, stiffness fractions per sweep (its scene's), sweeps.
    let pbd: &[usize] = if quick { &[20] } else { &[5, 20, 80] };
    for it in pbd {
        let overrides = ["solver.step=0.0166666666666667", "material.pbd_stretch=1.0", "material.pbd_bend=0.05"]
            .map(String::from)
            .into_iter()
            .chain([format!("solver.sweeps={it}")])
            .collect();
        v.push(Point { family: "drape", method: "pbd", setting: format!("it={it}"), overrides });
    }
    v
}

/// Families: title, and the scene each runs.
const FAMILIES: [(&str, &str); 4] = [
    ("beam", "beam under 2.5 g (cantilever strip)"),
    ("twist", "beam twisted 90° by a track"),
    ("collapse", "V-beam through the collapse of its section (1200 m/s²)"),
    ("drape", "cloth draped on a ball (961 particles)"),
];

const BEAM_GRAVITY: f64 = 2.5 * 9.81;
const COLLAPSE_GRAVITY: f64 = 1200.0;
const TWIST_DEGREES: f64 = 90.0;
const DRAPE_TIME: f64 = 1.0;

impl Experiment for Pareto {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        points(quick).iter().map(Point::key).collect()
    }

    fn run(&self, case: &str, _quick: bool, _out: &Path, _progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let point = points(false)
            .into_iter()
            .chain(points(true))
            .find(|p| p.key() == case)
            .ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let (reference, run, rest) = match point.family {
            "beam" => loaded(&point, "cantilever", BEAM_GRAVITY)?,
            "collapse" => loaded(&point, "v-beam", COLLAPSE_GRAVITY)?,
            "twist" => twist(&point)?,
            _ => drape(&point)?,
        };
        let mut table = Table::new(COLUMNS);
        table.push(vec![
            ("case", case.into()),
            ("family", point.family.into()),
            ("method", point.method.into()),
            ("setting", point.setting.clone().into()),
            ("rel_error", measure::relative_error(&run.positions, &reference.0, &rest).into()),
            ("outcome", run.outcome_word().into()),
            ("sim_time", run.sim_time.into()),
            ("steps", (run.steps as f64).into()),
            ("ref_converged", super::flag(reference.1)),
            ("cost", run.cost().into()),
        ])?;
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(self.about(), "Cost: wall-clock seconds per simulated second, one thread. Error: ‖u − u_ref‖ / ‖u_ref‖ over all \
                    vertices against the family's reference. `beam`: the flat cantilever under 2.5 g, run to rest \
                    (critical damping of its lowest mode), reference `ds-static`. `collapse`: the V-beam the same way \
                    under 1200 m/s², where its section flattens. `twist`: the strip without gravity, \
                    tip row turned 90° about its axis over 0.5 s by one track (the row's place and its turn) and \
                    held, run to rest — every method by the same track (the modal methods take the turn as one \
                    frame orientation, the discrete shells as the row's turned positions); reference `ds-static` \
                    walked through the turn in 6° steps by the same track. `drape`: the 961-particle drape after 1 s; reference `cloth` at \
                    h = 1/1600 s, PCG tolerance 1e-5; `xpbd` with the same stiffnesses (its edges also resist \
                    compression, the cloth's buckle), `pbd` with per-sweep stiffness fractions, so their error \
                    includes the difference of models. A point is on the front when no other point of its family is \
                    both cheaper and more accurate. Points whose reference did not converge are not plotted."
                .into());
        let (fi, mi, si, ei, ci, ri) = (
            table.index("family")?,
            table.index("method")?,
            table.index("setting")?,
            table.index("rel_error")?,
            table.index("cost")?,
            table.index("ref_converged")?,
        );
        for (family, title) in FAMILIES {
            let members: Vec<usize> = (0..table.rows.len())
                .filter(|&i| table.rows[i][fi].text() == family && table.rows[i][ri].num() == 1.0)
                .filter(|&i| table.rows[i][ei].num().is_finite() && table.rows[i][ci].num().is_finite())
                .collect();
            if members.is_empty() {
                continue;
            }
            let point = |i: usize| (table.rows[i][ci].num(), table.rows[i][ei].num());
            let front: Vec<usize> =
                front(&members.iter().map(|&i| point(i)).collect::<Vec<_>>()).into_iter().map(|k| members[k]).collect();
            let mut methods: Vec<String> = members.iter().map(|&i| table.rows[i][mi].text()).collect();
            methods.dedup();
            let mut series: Vec<Series> = methods
                .iter()
                .map(|m| {
                    method_points(
                        m,
                        members.iter().filter(|&&i| table.rows[i][mi].text() == *m).map(|&i| point(i)).collect(),
                    )
                })
                .collect();
            series.push(Series {
                label: "Pareto front".into(),
                color: plotters::style::RGBColor(0, 0, 0),
                style: Style::Guide,
                points: front.iter().map(|&i| point(i)).collect(),
            });
            add_chart(
                Plot {
                    title: format!("{title}: cost against error"),
                    x: Axis::log("cost (wall-clock s per simulated s)"),
                    y: Axis::log("relative displacement error"),
                    series,
                },
                &mut section,
                out,
                family,
                format!("{family}: cost against error, Pareto front dashed"),
            )?;
            let listed: Vec<String> = front
                .iter()
                .map(|&i| {
                    let r = &table.rows[i];
                    format!(
                        "`{}` {} ({} s/s, error {})",
                        r[mi].text(),
                        r[si].text(),
                        bold(r[ci].num()),
                        bold(r[ei].num())
                    )
                })
                .collect();
            section.findings.push(format!("`{family}` front, cheapest first: {}.", listed.join("; ")));
        }
        Ok(section)
    }
}

/// The points (cost, error) no other point beats in both (cheaper or as cheap, and more accurate or
/// as accurate, and better in one), cheapest first: their indices.
pub(super) fn front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let (c, e) = points[i];
            !points.iter().enumerate().any(|(j, &(cj, ej))| j != i && cj <= c && ej <= e && (cj < c || ej < e))
        })
        .collect();
    front.sort_by(|a, b| points[*a].0.total_cmp(&points[*b].0));
    front
}

type Measured = ((Vec<DVec3>, bool), Run, Vec<DVec3>);

/// `scene` under gravity `g`, run to rest, against `ds-static`.
fn loaded(point: &Point, scene: &str, g: f64) -> Result<Measured, EvalError> {
    let gravity = vec![format!("gravity=[0, {}, 0]", -g)];
    let reference = measure::reference(scene, &gravity)?;
    let mut over = gravity.clone();
    let base = measure::setup(scene, point.method, &over)?;
    let (alpha, omega) = measure::critical_damping(&base)?;
    over.push(format!("solver.rayleigh_alpha={alpha}"));
    over.extend(point.overrides.iter().cloned());
    let s = measure::setup(scene, point.method, &over)?;
    let rest = s.mesh.positions().to_vec();
    let run = measure::run(
        measure::build(&s)?.as_mut(),
        &rest,
        Stop { max_time: 40.0 / omega, max_steps: u64::MAX, rest: 1e-7 },
    );
    Ok(((reference.positions, reference.converged), run, rest))
}

fn twist(point: &Point) -> Result<Measured, EvalError> {
    let zero_g = vec!["gravity=[0, 0, 0]".to_string()];
    // Reference: ds-static walked through the turn in steps of 6°, by the same track.
    let steps = measure::walk_steps(0.0, TWIST_DEGREES);
    let seconds = steps as f64 / 30.0;
    let mut s = measure::setup("cantilever", "ds-static", &zero_g)?;
    let rest = s.mesh.positions().to_vec();
    measure::twist_tip(&mut s, TWIST_DEGREES, seconds);
    let reference = measure::walked_reference(&s, steps)?;
    let mut over = zero_g.clone();
    let (alpha, omega) = measure::critical_damping(&s)?;
    over.push(format!("solver.rayleigh_alpha={alpha}"));
    over.extend(point.overrides.iter().cloned());
    let mut s = measure::setup("cantilever", point.method, &over)?;
    measure::twist_tip(&mut s, TWIST_DEGREES, seconds);
    let stop = Stop { max_time: seconds + 40.0 / omega, max_steps: u64::MAX, rest: 1e-7 };
    let run = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
    Ok((reference, run, rest))
}

fn drape(point: &Point) -> Result<Measured, EvalError> {
    let stop = Stop { max_time: DRAPE_TIME, max_steps: u64::MAX, rest: 0.0 };
    let s = measure::setup("drape", "cloth", &["solver.step=0.000625".into(), "solver.tolerance=1e-5".into()])?;
    let rest = s.mesh.positions().to_vec();
    let reference = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
    let converged = matches!(reference.outcome, measure::Outcome::Ran);
    let s = measure::setup("drape", point.method, &point.overrides)?;
    let run = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
    // The drape's displacement is measured from the placed rest sheet.
    Ok(((reference.positions, converged), run, rest))
}
