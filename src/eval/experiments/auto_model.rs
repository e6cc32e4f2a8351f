//! `auto-model`: the automatic model choice (`solver.accuracy`, [`crate::solver::auto`]) beside the
//! brute force. For each scene and target, the chooser's pick (from its error estimates) and every
//! candidate's true error at rest against the reference equilibrium (`ds-static` for shells; for cloth
//! `cloth` at h = 10 ms and PCG tolerance 1e-6, run to rest), so the cheapest candidate that truly
//! meets the target is known. Costs are the chooser's own measurements, used for both.
//!
//! A scene of `[[parts]]` (the dancer) gives each part its own target; each part is chosen for and
//! brute-forced alone, on the scene cut down to it ([`crate::solver::parts::split`]), as the solver
//! does: parts share no vertex, so the cheapest combination meeting every target is the cheapest
//! model per part. A part held only by tracks is judged held at its tracks' start, its reference
//! `ds-static` with the tracked vertices fixed there.

use std::path::Path;
use std::time::Instant;

use glam::DVec3;

use super::super::chart::{Axis, Plot, Series, Style, method_points};
use super::super::measure;
use super::super::report::{Section, bold};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::{add_chart, flag};
use crate::scene::Setup;
use crate::solver::auto::{self, Candidate, Family};
use crate::solver::{DragSet, parts};

/// The experiment.
pub struct AutoModel;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("scene", ""),
    computed("part", ""),
    computed("accuracy", ""),
    computed("method", ""),
    computed("modes", ""),
    computed("step", "s"),
    computed("tolerance", ""),
    computed("true_error", ""),
    computed("meets", ""),
    computed("failure", ""),
    timed("cost", "s/s"),
    timed("estimate", ""),
    timed("chosen", ""),
    timed("cheapest_meeting", ""),
    timed("cost_vs_cheapest", ""),
    timed("choice_time", "s"),
    timed("brute_force_time", "s"),
];

/// The experiment's name, title and columns.
const ABOUT: About =
    About { name: "auto-model", title: "The automatic model choice against the brute force", columns: COLUMNS };

/// The hanging sheet held along its whole top edge (a curtain: tensioned, one equilibrium).
const CURTAIN: &str = "anchors=[{ box = { min = [-0.6, 1.49, -0.01], max = [0.6, 1.51, 0.01] } }]";
/// The same sheet laid flat and held at its four corners (a hammock).
const HAMMOCK: [&str; 2] = [
    "placement.rotate_deg=[0, 0, 0]",
    "anchors=[{ box = { min = [-0.51, 0.99, -0.51], max = [-0.45, 1.01, -0.45] } }, \
     { box = { min = [0.45, 0.99, -0.51], max = [0.51, 1.01, -0.45] } }, \
     { box = { min = [-0.51, 0.99, 0.45], max = [-0.45, 1.01, 0.51] } }, \
     { box = { min = [0.45, 0.99, 0.45], max = [0.51, 1.01, 0.51] } }]",
];

/// (case key, scene, overrides, targets: one for the scene, or one per `[[parts]]` entry).
const SCENES: [(&str, &str, &[&str], &[f64]); 9] = [
    ("cantilever-1g", "cantilever", &[], &[0.05]),
    ("cantilever-3g", "cantilever", &["gravity=[0, -30, 0]"], &[0.1]),
    ("v-beam-10g", "v-beam", &["gravity=[0, -100, 0]"], &[0.02]),
    ("v-beam-40g", "v-beam", &["gravity=[0, -400, 0]"], &[0.05]),
    ("creature", "creature", &[], &[0.05]),
    ("creature-tight", "creature", &[], &[0.005]),
    ("curtain", "hanging-sheet", &[CURTAIN], &[0.05]),
    ("hammock", "hanging-sheet", &HAMMOCK, &[0.05]),
    ("dancer", "dancer", &[], &DANCER_TARGETS),
];

/// The dancer's per-part targets: hat, tunic, left leg, right leg.
const DANCER_TARGETS: [f64; 4] = [0.6, 0.3, 0.5, 0.05];

/// What one choice is made for: the part's index (NaN: the whole scene), its setup and its target.
type Subject = (f64, Setup, f64);

/// The case's subjects: the scene with its one target, or each of its parts with its own.
fn subjects(mut setup: Setup, targets: &[f64]) -> Result<Vec<Subject>, EvalError> {
    if setup.scene.parts.is_empty() {
        let target = targets.first().copied().unwrap_or(f64::NAN);
        return Ok(vec![(f64::NAN, setup, target)]);
    }
    setup.scene.parts.iter_mut().zip(targets).for_each(|(p, &t)| p.accuracy = Some(t));
    let pieces = parts::split(&setup).map_err(EvalError::solver(format!("the parts of {}", setup.scene.name)))?;
    Ok(pieces.into_iter().zip(targets).enumerate().map(|(k, (piece, &t))| (k as f64, piece.setup, t)).collect())
}

/// `ds-static` at its defaults, one step from rest, on the shell held at its anchors and at its
/// tracks' targets at time 0.
fn shell_reference(setup: &Setup) -> Result<Vec<DVec3>, EvalError> {
    let mut s = auto::held(setup);
    s.scene.solver.method = "ds-static".into();
    s.scene.solver.accuracy = None;
    let name = &setup.scene.name;
    let mut solver = auto::start(&s, &DragSet::default()).map_err(EvalError::solver(format!("ds-static on {name}")))?;
    let stats = solver.step().map_err(EvalError::solver(format!("ds-static on {name}")))?;
    if !stats.converged {
        return Err(EvalError::Reference(format!("ds-static on {name} ({:.2e})", stats.relative_residual)));
    }
    Ok(solver.positions().to_vec())
}

/// One subject's rows: the choice (timed), then the brute force (timed: the candidates' costs, as the
/// chooser measured them, the reference and every candidate run to rest), the cheapest candidate that
/// truly meets the target (candidates are in cost order).
fn brute_force(
    case: &str,
    scene: &str,
    (part, setup, accuracy): &Subject,
    table: &mut Table,
    progress: &dyn Fn(f32),
) -> Result<(), EvalError> {
    let clock = Instant::now();
    let choice = auto::choose(setup, *accuracy).map_err(EvalError::solver(format!("choosing for {scene}")))?;
    let choice_time = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let rest = setup.mesh.positions().to_vec();
    let reference = match choice.family {
        Family::Shell => shell_reference(setup)?,
        Family::Cloth => {
            let fine = Candidate { step: Some(0.01), tolerance: Some(1e-6), ..choice.candidates[0].clone() };
            auto::at_rest(setup, &fine).map_err(EvalError::solver(format!("the cloth reference on {scene}")))?
        }
    };
    let n = choice.candidates.len();
    let errors = (choice.candidates.iter().enumerate())
        .map(|(i, c)| {
            progress(i as f32 / n as f32);
            match c.failure {
                Some(_) => Ok(f64::NAN),
                None => {
                    let x = auto::at_rest(setup, c).map_err(EvalError::solver(format!("{} on {scene}", c.label())))?;
                    Ok(measure::relative_error(&x, &reference, &rest))
                }
            }
        })
        .collect::<Result<Vec<f64>, EvalError>>()?;
    let brute_force_time = choice.costing + clock.elapsed().as_secs_f64();
    let best = errors.iter().position(|&e| e <= *accuracy);
    for (i, (c, &error)) in choice.candidates.iter().zip(&errors).enumerate() {
        let ratio = match best {
            Some(b) if i == choice.chosen => c.cost / choice.candidates[b].cost,
            _ => f64::NAN,
        };
        table.push(vec![
            ("case", case.into()),
            ("scene", scene.into()),
            ("part", (*part).into()),
            ("accuracy", (*accuracy).into()),
            ("method", c.method.into()),
            ("modes", c.modes.map_or(f64::NAN, |m| m as f64).into()),
            ("step", c.step.unwrap_or(f64::NAN).into()),
            ("tolerance", c.tolerance.unwrap_or(f64::NAN).into()),
            ("true_error", error.into()),
            ("meets", flag(error <= *accuracy)),
            ("cost", c.cost.into()),
            ("estimate", c.estimate.into()),
            ("chosen", flag(i == choice.chosen)),
            ("cheapest_meeting", if best.is_some() { flag(Some(i) == best) } else { f64::NAN.into() }),
            ("cost_vs_cheapest", ratio.into()),
            ("failure", c.failure.clone().unwrap_or_default().into()),
            ("choice_time", choice_time.into()),
            ("brute_force_time", brute_force_time.into()),
        ])?;
    }
    Ok(())
}

impl Experiment for AutoModel {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        SCENES.iter().filter(|s| !quick || s.1 != "creature").map(|s| s.0.to_string()).collect()
    }

    fn run(&self, case: &str, _quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let &(_, scene, over, targets) =
            SCENES.iter().find(|s| s.0 == case).ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let overrides: Vec<String> = over.iter().map(|s| s.to_string()).collect();
        let subjects = subjects(crate::scene::load(scene, &overrides)?, targets)?;
        let mut table = Table::new(COLUMNS);
        let n = subjects.len() as f32;
        for (i, subject) in subjects.iter().enumerate() {
            brute_force(case, scene, subject, &mut table, &|done| progress((i as f32 + done) / n))?;
        }
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(
            self.about(),
            "Each scene gives `solver.accuracy` (the target below). The chooser measures every candidate's cost \
                 (a few timed steps), then estimates errors in order of cost until one meets the target: shells by \
                 three Newton iterations of the full discrete-shell equations from the candidate's equilibrium, \
                 cloth by relaxing the candidate's rest state with five near-static implicit steps (0.1 s, PCG \
                 tolerance 1e-8). Errors are of the equilibrium \
                 under the scene's loads. The brute force runs every candidate to rest against the reference \
                 (`ds-static`; cloth: `cloth` at h = 10 ms, PCG tolerance 1e-6) and takes the cheapest that truly \
                 meets the target. Scenes: `creature-tight` is the creature under its weight at 0.5%, below any \
                 modal method's error at 64 modes; `curtain` is the hanging sheet held along its top edge, `hammock` the \
                 same sheet laid flat and held at its corners; `dancer` gives each of its parts (0 the hat, 1 the \
                 tunic, 2 and 3 the legs, free shells held by tracks) its own target, and each part is chosen for \
                 and brute-forced alone, held at its tracks' start (reference: `ds-static` with the tracked \
                 vertices fixed there). Cost ratio = chosen ÷ brute-force cheapest, same cost measurements. \
                 Search time: the chooser's (costs, then estimates) against the brute force's (the same costs, \
                 the reference and every candidate run to rest)."
                .into(),
        );
        let idx = |n: &str| table.index(n);
        let (si, pi, ai, mi, oi, hi, ti, ei, xi, chi, ki, ri, mti, ci, bi) = (
            idx("case")?,
            idx("part")?,
            idx("accuracy")?,
            idx("method")?,
            idx("modes")?,
            idx("step")?,
            idx("tolerance")?,
            idx("true_error")?,
            idx("estimate")?,
            idx("chosen")?,
            idx("cheapest_meeting")?,
            idx("cost_vs_cheapest")?,
            idx("meets")?,
            idx("choice_time")?,
            idx("brute_force_time")?,
        );
        let label = |r: &Vec<Value>| {
            let mut setting = String::new();
            if r[oi].num().is_finite() {
                setting += &format!(", {} modes", r[oi].num());
            }
            if r[hi].num().is_finite() {
                setting += &format!(", h = {} s", r[hi].num());
            }
            if r[ti].num().is_finite() {
                setting += &format!(", tolerance {:e}", r[ti].num());
            }
            format!("`{}`{setting}", r[mi].text())
        };
        // One choice per case, or per part of a case of parts.
        let mut subjects: Vec<(String, String)> = table.rows.iter().map(|r| (r[si].text(), r[pi].text())).collect();
        subjects.dedup();
        let mut estimated = Vec::new();
        for (case, part) in &subjects {
            let rows: Vec<&Vec<Value>> = table.filter("case", case)?.filter(|r| r[pi].text() == *part).collect();
            let chosen = rows.iter().find(|r| r[chi].num() == 1.0);
            let best = rows.iter().find(|r| r[ki].num() == 1.0);
            let acc = rows.first().map_or(f64::NAN, |r| r[ai].num());
            let name = rows.first().map_or(String::new(), |r| match r[pi].num() {
                k if k.is_finite() => format!("`{case}` part {k}"),
                _ => format!("`{case}`"),
            });
            match (chosen, best) {
                (Some(c), Some(b)) => section.findings.push(format!(
                    "{name} (target {}): chose {} (estimated {}, true {}, {}); brute force: {} (true {}); cost \
                     ratio {}; chosen in {} s, brute force {} s.",
                    bold(acc),
                    label(c),
                    bold(c[xi].num()),
                    bold(c[ei].num()),
                    if c[mti].num() == 1.0 { "meets" } else { "MISSES" },
                    label(b),
                    bold(b[ei].num()),
                    bold(c[ri].num()),
                    bold(c[ci].num()),
                    bold(c[bi].num()),
                )),
                (Some(c), None) => section.findings.push(format!(
                    "{name} (target {}): no candidate meets the target; chose {} (true error {}).",
                    bold(acc),
                    label(c),
                    bold(c[ei].num())
                )),
                _ => {}
            }
            estimated.extend(
                rows.iter().filter(|r| r[xi].num().is_finite()).map(|r| (r[mi].text(), r[ei].num(), r[xi].num())),
            );
        }
        // A case of parts: the choice over all its parts against the brute force over all of them.
        let mut cases: Vec<String> = subjects.iter().filter(|s| !s.1.is_empty()).map(|s| s.0.clone()).collect();
        cases.dedup();
        for case in &cases {
            let chosen: Vec<&Vec<Value>> = table.filter("case", case)?.filter(|r| r[chi].num() == 1.0).collect();
            let agree = chosen.iter().filter(|r| r[ki].num() == 1.0).count();
            let (choice, brute) = chosen.iter().fold((0.0, 0.0), |(a, b), r| (a + r[ci].num(), b + r[bi].num()));
            section.findings.push(format!(
                "`{case}`, every part with its own target: {}; the brute force agrees on {agree} of {} parts. \
                 Search time: the choice {} s, the brute force {} s, {}× as long.",
                chosen.iter().map(|r| format!("part {}: {}", r[pi].num(), label(r))).collect::<Vec<_>>().join("; "),
                chosen.len(),
                crate::eval::report::number(choice),
                crate::eval::report::number(brute),
                crate::eval::report::number(brute / choice),
            ));
        }
        // Estimate against truth, every estimated candidate: on the diagonal when the estimate is right.
        let mut methods: Vec<String> = estimated.iter().map(|e| e.0.clone()).collect();
        methods.sort();
        methods.dedup();
        let mut series: Vec<Series> = methods
            .iter()
            .map(|m| {
                method_points(
                    m,
                    estimated.iter().filter(|e| e.0 == *m && e.1 > 0.0 && e.2 > 0.0).map(|e| (e.1, e.2)).collect(),
                )
            })
            .collect();
        let span = estimated
            .iter()
            .flat_map(|e| [e.1, e.2])
            .filter(|v| *v > 0.0)
            .fold((f64::INFINITY, 0.0f64), |a, v| (a.0.min(v), a.1.max(v)));
        if span.0 < span.1 {
            series.push(Series {
                label: "estimate = truth".into(),
                color: plotters::style::RGBColor(0, 0, 0),
                style: Style::Guide,
                points: vec![(span.0, span.0), (span.1, span.1)],
            });
        }
        add_chart(
            Plot {
                title: "Error estimates of the chooser against the true errors".into(),
                x: Axis::log("true relative error (against the reference)"),
                y: Axis::log("estimated relative error"),
                series,
            },
            &mut section,
            out,
            "estimates",
            "the chooser's error estimates against the true errors".into(),
        )?;
        Ok(section)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dancer's case: every part gets the model the brute force finds cheapest among those that
    /// truly meet the part's target, and the legs (mirror images) get different models for their
    /// different targets: the loose one a cheaper reduced model, the tight one the full equations.
    #[test]
    fn each_dancer_part_gets_the_brute_force_cheapest_model_for_its_own_target() {
        // The case writes nothing beside its table.
        let t = AutoModel.run("dancer", true, Path::new("unused"), &|_| {}).unwrap();
        let col = |name: &str| t.index(name).unwrap();
        let (part, chosen, best, cost, method) =
            (col("part"), col("chosen"), col("cheapest_meeting"), col("cost"), col("method"));
        let mut winners = Vec::new();
        for (k, target) in DANCER_TARGETS.iter().enumerate() {
            let rows: Vec<&Vec<Value>> = t.rows.iter().filter(|r| r[part].num() == k as f64).collect();
            let c: Vec<usize> = (0..rows.len()).filter(|&i| rows[i][chosen].num() == 1.0).collect();
            let b: Vec<usize> = (0..rows.len()).filter(|&i| rows[i][best].num() == 1.0).collect();
            assert_eq!((c.len(), b.len()), (1, 1), "part {k}: one choice and one brute-force answer");
            assert_eq!(c, b, "part {k} (target {target}): the choice is not the brute force's cheapest");
            winners.push(rows[c[0]]);
        }
        let (loose, tight) = (winners[2], winners[3]);
        assert_eq!(tight[method].text(), "ds-implicit", "only the full equations meet 5% on a leg");
        assert!(loose[cost].num() < tight[cost].num(), "the loose leg's model is the cheaper");
        assert_ne!(loose[method].text(), "ds-implicit");
    }
}
