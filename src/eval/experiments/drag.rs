//! `drag`: the shells moved as a user moves them — the cantilever and the creature with one vertex
//! pulled by 5%, 15% and 30% of their length, the strip's tip row turned by 90°, 180° and 360° — and
//! every shell method against `ds-static` walked through the same motion.
//!
//! Each motion is one track (a pull: the vertex's translation; a twist: the tip row's place and its
//! turn), so every method follows the same one. The reference walks it in steps of at most 1 cm or
//! 6° ([`measure::walk_steps`]) and is cached between the cases of a motion
//! ([`measure::walked_reference`]); each method runs through the same keys and on to rest under
//! critical damping of its lowest mode. Beside its error and area change, each run's final shape is
//! judged by the quality readout's estimate ([`crate::solver::quality::estimate`]), so the report
//! shows how well the readout knows a model's error.

use std::path::Path;

use glam::DVec3;

use super::super::chart::{Axis, Plot, Series, Style, method_color};
use super::super::measure::{self, Stop};
use super::super::report::{Section, bold, bold_percent, number};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::{add_chart, flag, num, pareto};
use crate::scene::{Key, Setup};
use crate::solver::quality;

/// The experiment.
pub struct Drags;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("scene", ""),
    computed("motion", ""),
    computed("size", ""),
    computed("method", ""),
    computed("modes", ""),
    computed("rel_error", ""),
    computed("area_change", ""),
    computed("estimate", ""),
    computed("outcome", ""),
    computed("ref_converged", ""),
    computed("sim_time", "s"),
    computed("steps", ""),
    timed("cost", "s/s"),
];

/// The experiment's name, title and columns.
const ABOUT: About = About {
    name: "drag",
    title: "Drags and twists: every shell method against the discrete shell walked through the motion",
    columns: COLUMNS,
};

/// The pulled vertex of each scene and the direction of the pull (the creature's is the drag
/// of its head, down and sideways; the cantilever's tip corner goes up, in and sideways).
const PULLS: [(&str, usize, [f64; 3]); 2] =
    [("cantilever", 204, [-0.3, 0.5, 0.8]), ("creature", 100, [0.2585, -0.4637, 0.0082])];

/// Pull sizes, fractions of the scene's length (its extent along x).
const SIZES: [f64; 3] = [0.05, 0.15, 0.3];

/// Errors below this are drawn at it (the discrete shells' round-off would squash the chart).
const FLOOR: f64 = 1e-5;

/// Twists of the strip's tip row, degrees.
const TURNS: [f64; 3] = [90.0, 180.0, 360.0];

/// The models of a scene: the modal methods at these mode counts, `rds` where it is affordable, and
/// `ds-implicit` where it is (not on the 12,962-vertex creature, at 1.6 s a step).
fn models(scene: &str, quick: bool) -> Vec<(&'static str, Option<usize>)> {
    let modes: &[usize] = match (scene, quick) {
        (_, true) => &[8],
        ("creature", false) => &[4, 8, 16],
        _ => &[4, 8, 32],
    };
    let mut v: Vec<(&'static str, Option<usize>)> =
        ["lma", "mwts", "mwts-rs"].iter().flat_map(|&m| modes.iter().map(move |&k| (m, Some(k)))).collect();
    // `rds` where its full energy is affordable: on the creature (0.4 s a step) at 4 modes, in the
    // full sweep only.
    let reduced: &[usize] = match (scene, quick) {
        ("creature", true) => &[],
        ("creature", false) => &[4],
        _ => modes,
    };
    v.extend(reduced.iter().map(|&k| ("rds", Some(k))));
    if scene != "creature" {
        v.push(("ds-implicit", None));
    }
    v
}

/// One track's motion.
enum Motion {
    /// A vertex translated by `offset`, m.
    Pull { vertex: usize, offset: DVec3 },
    /// The strip's tip row turned about its axis, its place held.
    Twist { degrees: f64 },
}

impl Motion {
    /// The steps of 1/30 s in which the reference walks it (and the track plays it).
    fn steps(&self) -> usize {
        match self {
            Motion::Pull { offset, .. } => measure::walk_steps(offset.length(), 0.0),
            Motion::Twist { degrees } => measure::walk_steps(0.0, *degrees),
        }
    }

    /// Give `setup` the track that plays the motion over `steps` / 30 s and then holds it.
    fn apply(&self, setup: &mut Setup, steps: usize) {
        let seconds = steps as f64 / 30.0;
        match *self {
            Motion::Pull { vertex, offset } => {
                let key = |time: f64, at: DVec3| Key { time, position: Some(at.to_array()), rotation: None };
                measure::add_track(setup, vec![vertex], vec![key(0.0, DVec3::ZERO), key(seconds, offset)]);
            }
            Motion::Twist { degrees } => measure::twist_tip(setup, degrees, seconds),
        }
    }
}

/// A case key: `SCENE/pull=FRACTION` or `strip/twist=DEGREES`.
fn parse(case: &str) -> Result<(&str, &str, f64), EvalError> {
    let (scene, motion) = case.split_once('/').ok_or_else(|| bad_case(case))?;
    let (kind, size) = motion.split_once('=').ok_or_else(|| bad_case(case))?;
    Ok((scene, kind, size.parse().map_err(|_| bad_case(case))?))
}

impl Experiment for Drags {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        if quick {
            return vec!["cantilever/pull=0.15".into(), "strip/twist=180".into()];
        }
        let pulls = PULLS.iter().flat_map(|(scene, ..)| SIZES.iter().map(move |s| format!("{scene}/pull={s}")));
        pulls.chain(TURNS.iter().map(|t| format!("strip/twist={t}"))).collect()
    }

    fn run(&self, case: &str, quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let (scene, kind, size) = parse(case)?;
        let (file, overrides) = match scene {
            "strip" => ("cantilever", vec!["gravity=[0, 0, 0]".to_string()]),
            s => (s, Vec::new()),
        };
        let base = measure::setup(file, "ds-static", &overrides)?;
        let rest = base.mesh.positions().to_vec();
        let motion = match kind {
            "pull" => {
                let &(_, vertex, direction) = PULLS.iter().find(|p| p.0 == scene).ok_or_else(|| bad_case(case))?;
                let (lo, hi) = base.mesh.bounding_box();
                Motion::Pull { vertex, offset: DVec3::from(direction).normalize() * size * (hi.x - lo.x) }
            }
            "twist" => Motion::Twist { degrees: size },
            _ => return Err(bad_case(case)),
        };
        let steps = motion.steps();
        let mut reference_setup = base.clone();
        motion.apply(&mut reference_setup, steps);
        let (reference, converged) = measure::walked_reference(&reference_setup, steps)?;
        let (alpha, omega) = measure::critical_damping(&base)?;
        let stop = Stop { max_time: steps as f64 / 30.0 + 25.0 / omega, max_steps: u64::MAX, rest: 1e-7 };
        let mut table = Table::new(COLUMNS);
        let motion_word = if kind == "pull" { "pull" } else { "twist" };
        let models = models(scene, quick);
        for (i, &(method, modes)) in models.iter().enumerate() {
            let mut over = overrides.clone();
            over.push(format!("solver.rayleigh_alpha={alpha}"));
            over.extend(modes.map(|m| format!("solver.modes={m}")));
            let mut s = measure::setup(file, method, &over)?;
            motion.apply(&mut s, steps);
            let mut solver = measure::build(&s)?;
            let run = measure::run(solver.as_mut(), &rest, stop);
            let estimate = quality::estimate(&s, &run.positions, solver.drags()).unwrap_or(f64::NAN);
            table.push(vec![
                ("case", case.into()),
                ("scene", scene.into()),
                ("motion", motion_word.into()),
                ("size", size.into()),
                ("method", method.into()),
                ("modes", modes.map_or(Value::Num(f64::NAN), |m| num(m as u64))),
                ("rel_error", measure::relative_error(&run.positions, &reference, &rest).into()),
                ("area_change", measure::area_change(&run.positions, &s).into()),
                ("estimate", estimate.into()),
                ("outcome", run.outcome_word().into()),
                ("ref_converged", flag(converged)),
                ("sim_time", run.sim_time.into()),
                ("steps", num(run.steps)),
                ("cost", run.cost().into()),
            ])?;
            progress((i + 1) as f32 / models.len() as f32);
        }
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(
            self.about(),
            "One vertex of the `cantilever` (its tip corner, up, in and sideways) and of the `creature` \
                    (vertex 100 of its head, down and sideways) pulled by 5%, 15% and 30% of the scene's length, and \
                    the strip (the cantilever without gravity) with its tip row turned by 90°, 180° and 360° and \
                    held in place. Each motion is one track that every method follows (the modal methods hold a \
                    pull as a spring of relative compliance 1e-2, with the shell's static responses to the dragged \
                    vertex in their basis, and take a turn as one frame orientation); the reference is `ds-static` \
                    walked through the same track in steps of at most 1 cm or 6° (positions held exactly). Each \
                    method runs through the track and on to rest under critical damping of the lowest mode. \
                    Error: ‖u − u_ref‖ / ‖u_ref‖; area change: (A − A₀) / A₀; estimate: the quality readout's \
                    estimated error of the final shape (Newton on the full shell from it); cost: wall-clock \
                    seconds per simulated second, one thread."
                .into(),
        );
        let col = |name: &str| table.index(name);
        let (ki, zi, mi, ni) = (col("motion")?, col("size")?, col("method")?, col("modes")?);
        let (ei, ai, ti, ci, ri) =
            (col("rel_error")?, col("area_change")?, col("estimate")?, col("cost")?, col("ref_converged")?);
        let label = |r: &Vec<Value>| match r[ni].num() {
            m if m.is_finite() => format!("{} {m}", r[mi].text()),
            _ => r[mi].text(),
        };
        for scene in ["cantilever", "creature", "strip"] {
            let rows: Vec<&Vec<Value>> = table.filter("scene", scene)?.filter(|r| r[ri].num() == 1.0).collect();
            let Some(first) = rows.first() else { continue };
            let kind = first[ki].text();
            let unit = if kind == "pull" { "pull (fraction of the length)" } else { "turn of the tip row (°)" };
            // One series per model at 8 modes (and ds-implicit): error against the motion's size.
            let mut labels: Vec<String> =
                rows.iter().filter(|r| r[ni].num() == 8.0 || r[ni].num().is_nan()).map(|r| label(r)).collect();
            labels.dedup();
            labels.sort();
            labels.dedup();
            let series: Vec<Series> = labels
                .iter()
                .map(|l| Series {
                    label: l.clone(),
                    color: method_color(l.split(' ').next().unwrap_or_default()),
                    style: Style::Line,
                    points: (rows.iter().filter(|r| label(r) == *l))
                        .map(|r| (r[zi].num(), r[ei].num().max(FLOOR)))
                        .collect(),
                })
                .collect();
            add_chart(
                Plot {
                    title: format!("{scene}: error against the walked discrete shell"),
                    x: Axis::log(unit),
                    y: Axis::log("relative displacement error |u − u_ref| / |u_ref|"),
                    series,
                },
                &mut section,
                out,
                &format!("{scene}-error"),
                format!("{scene}: error against the size of the {kind}, 8 modes (errors below {FLOOR:e} drawn at it)"),
            )?;
            for size in rows.iter().map(|r| r[zi].num()).fold(Vec::<f64>::new(), |mut v, z| {
                if !v.contains(&z) {
                    v.push(z);
                }
                v
            }) {
                let at: Vec<&&Vec<Value>> = rows.iter().filter(|r| r[zi].num() == size).collect();
                let best = at.iter().min_by(|a, b| a[ei].num().total_cmp(&b[ei].num()));
                let cheapest = at
                    .iter()
                    .filter(|r| r[ei].num() <= quality::DEFAULT_TARGET)
                    .min_by(|a, b| a[ci].num().total_cmp(&b[ci].num()));
                let area = at
                    .iter()
                    .filter(|r| r[mi].text() == "mwts")
                    .map(|r| r[ai].num())
                    .fold(0.0, |m: f64, a| if a.abs() > m.abs() { a } else { m });
                let what = if kind == "pull" {
                    format!("pulled by {}", bold(size))
                } else {
                    format!("turned by {}°", bold(size))
                };
                let cheap = cheapest.map_or("no model is within 5%".to_string(), |r| {
                    format!(
                        "the cheapest within 5% is `{}` ({}, {} s/s)",
                        label(r),
                        bold_percent(r[ei].num()),
                        bold(r[ci].num())
                    )
                });
                if let Some(b) = best {
                    section.findings.push(format!(
                        "`{scene}` {what}: the most accurate is `{}` ({}); {cheap}; `mwts`'s largest area change {}.",
                        label(b),
                        bold_percent(b[ei].num()),
                        bold_percent(area),
                    ));
                }
            }
        }
        // How well the readout's estimate knows the error, where the error is past the target.
        let ratios: Vec<f64> = table
            .rows
            .iter()
            .filter(|r| r[ri].num() == 1.0 && r[ei].num() > quality::DEFAULT_TARGET && r[ti].num().is_finite())
            .map(|r| r[ti].num() / r[ei].num())
            .collect();
        if !ratios.is_empty() {
            let within = ratios.iter().filter(|&&q| (0.5..=2.0).contains(&q)).count();
            let (lo, hi) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &q| (lo.min(q), hi.max(q)));
            section.findings.push(format!(
                "The readout's estimate against the error, where the error exceeds 5%: within a factor 2 in {} of \
                 {} runs (ratio {} to {}); below it, it underestimates where the model ended on another branch of \
                 the shell's equilibria than the walked reference, or where Newton from a poor shape stops short.",
                within,
                ratios.len(),
                number(lo),
                number(hi)
            ));
        }
        // Cost against error over all of a scene's motions (mean cost, worst error): the models no other
        // beats in both.
        for scene in ["cantilever", "creature", "strip"] {
            let rows: Vec<&Vec<Value>> = table.filter("scene", scene)?.filter(|r| r[ri].num() == 1.0).collect();
            let mut labels: Vec<String> = rows.iter().map(|r| label(r)).collect();
            labels.sort();
            labels.dedup();
            let points: Vec<(f64, f64)> = labels
                .iter()
                .map(|l| {
                    let of: Vec<&&Vec<Value>> = rows.iter().filter(|r| label(r) == *l).collect();
                    let cost = of.iter().map(|r| r[ci].num()).sum::<f64>() / of.len() as f64;
                    (cost, of.iter().map(|r| r[ei].num()).fold(0.0, f64::max))
                })
                .collect();
            if points.is_empty() {
                continue;
            }
            let listed: Vec<String> = pareto::front(&points)
                .iter()
                .map(|&i| format!("`{}` ({} s/s, {})", labels[i], number(points[i].0), bold_percent(points[i].1)))
                .collect();
            section.findings.push(format!(
                "`{scene}`, mean cost and worst error over its motions; the front, cheapest first: {}.",
                listed.join("; ")
            ));
        }
        Ok(section)
    }
}

fn bad_case(case: &str) -> EvalError {
    EvalError::UnknownCase(case.into())
}
