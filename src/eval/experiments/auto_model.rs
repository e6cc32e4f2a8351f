//! `auto-model`: the automatic model choice (`solver.accuracy`, [`crate::solver::auto`]) beside the
//! brute force. For each scene and target, the chooser's pick (from its error estimates) and every
//! candidate's true error at rest against the reference equilibrium (`ds-static` for shells; for cloth
//! `cloth` at h = 10 ms and PCG tolerance 1e-6, run to rest), so the cheapest candidate that truly
//! meets the target is known. Costs are the chooser's own measurements, used for both.

use std::path::Path;

use super::super::chart::{Axis, Plot, Series, Style, method_color};
use super::super::measure;
use super::super::report::{Section, bold};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{EvalError, Experiment};
use super::{chart_ref, f};
use crate::solver::auto::{self, Candidate, Family};

/// The experiment.
pub struct AutoModel;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("scene", ""),
    computed("accuracy", ""),
    computed("method", ""),
    computed("modes", ""),
    computed("step", "s"),
    computed("tolerance", ""),
    computed("true_error", ""),
    computed("meets", ""),
    timed("cost", "s/s"),
    timed("estimate", ""),
    timed("chosen", ""),
    timed("cheapest_meeting", ""),
    timed("cost_vs_cheapest", ""),
];

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

/// (case key, scene, overrides, target).
const SCENES: [(&str, &str, &[&str], f64); 7] = [
    ("cantilever-1g", "cantilever", &[], 0.05),
    ("cantilever-3g", "cantilever", &["gravity=[0, -30, 0]"], 0.1),
    ("v-beam-10g", "v-beam", &["gravity=[0, -100, 0]"], 0.02),
    ("v-beam-40g", "v-beam", &["gravity=[0, -400, 0]"], 0.05),
    ("creature", "creature", &[], 0.05),
    ("curtain", "hanging-sheet", &[CURTAIN], 0.05),
    ("hammock", "hanging-sheet", &HAMMOCK, 0.05),
];

impl Experiment for AutoModel {
    fn name(&self) -> &'static str {
        "auto-model"
    }

    fn title(&self) -> &'static str {
        "The automatic model choice against the brute force"
    }

    fn columns(&self) -> &'static [Column] {
        COLUMNS
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        SCENES.iter().filter(|s| !quick || s.0 != "creature").map(|s| s.0.to_string()).collect()
    }

    fn run(&self, case: &str, _quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let &(_, scene, over, accuracy) =
            SCENES.iter().find(|s| s.0 == case).ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let overrides: Vec<String> = over.iter().map(|s| s.to_string()).collect();
        let setup = crate::scene::load(scene, &overrides)?;
        let choice = auto::choose(&setup, accuracy).map_err(EvalError::solver(format!("choosing for {scene}")))?;
        let rest = setup.mesh.positions().to_vec();
        let reference = match choice.family {
            Family::Shell => {
                let r = measure::reference(scene, &overrides)?;
                if !r.converged {
                    return Err(EvalError::Reference(format!("ds-static on {scene} ({:.2e})", r.relative_residual)));
                }
                r.positions
            }
            Family::Cloth => {
                let fine = Candidate { step: Some(0.01), tolerance: Some(1e-6), ..choice.candidates[0].clone() };
                auto::at_rest(&setup, &fine).map_err(EvalError::solver(format!("the cloth reference on {scene}")))?
            }
        };
        let mut table = Table::new(COLUMNS);
        let n = choice.candidates.len();
        for (i, c) in choice.candidates.iter().enumerate() {
            let x = auto::at_rest(&setup, c).map_err(EvalError::solver(format!("{} on {scene}", c.label())))?;
            let error = measure::relative_error(&x, &reference, &rest);
            table.push(vec![
                ("case", case.into()),
                ("scene", scene.into()),
                ("accuracy", accuracy.into()),
                ("method", c.method.into()),
                ("modes", c.modes.map_or(f64::NAN, |m| m as f64).into()),
                ("step", c.step.unwrap_or(f64::NAN).into()),
                ("tolerance", c.tolerance.unwrap_or(f64::NAN).into()),
                ("true_error", error.into()),
                ("meets", f(error <= accuracy)),
                ("cost", c.cost.into()),
                ("estimate", c.estimate.into()),
                ("chosen", f(i == choice.chosen)),
            ])?;
            progress((i + 1) as f32 / n as f32);
        }
        // The brute force: the cheapest candidate that truly meets the target (candidates are in cost order).
        let (mi, ci, ki, chi, ri) = (
            table.index("meets")?,
            table.index("cost")?,
            table.index("cheapest_meeting")?,
            table.index("chosen")?,
            table.index("cost_vs_cheapest")?,
        );
        let best = table.rows.iter().position(|r| r[mi].num() == 1.0);
        if let Some(b) = best {
            let best_cost = table.rows[b][ci].num();
            for (i, r) in table.rows.iter_mut().enumerate() {
                r[ki] = f(i == b);
                if r[chi].num() == 1.0 {
                    r[ri] = Value::Num(r[ci].num() / best_cost);
                }
            }
        }
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section {
            experiment: self.name().into(),
            title: self.title().into(),
            setup:
                "Each scene gives `solver.accuracy` (the target below). The chooser measures every candidate's cost \
                 (a few timed steps), then estimates errors in order of cost until one meets the target: shells by \
                 three Newton iterations of the full discrete-shell equations from the candidate's equilibrium, \
                 cloth by relaxing the candidate's rest state with five near-static implicit steps (0.1 s, PCG \
                 tolerance 1e-8). Errors are of the equilibrium \
                 under the scene's loads. The brute force runs every candidate to rest against the reference \
                 (`ds-static`; cloth: `cloth` at h = 10 ms, PCG tolerance 1e-6) and takes the cheapest that truly \
                 meets the target. Scenes: `curtain` is the hanging sheet held along its top edge, `hammock` the \
                 same sheet laid flat and held at its corners. Cost ratio = chosen ÷ brute-force cheapest, same \
                 cost measurements."
                    .into(),
            ..Section::default()
        };
        let idx = |n: &str| table.index(n);
        let (si, ai, mi, oi, hi, ti, ei, xi, chi, ki, ri, mti) = (
            idx("case")?,
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
        let mut cases: Vec<String> = table.rows.iter().map(|r| r[si].text()).collect();
        cases.dedup();
        let mut estimated = Vec::new();
        for case in &cases {
            let rows: Vec<&Vec<Value>> = table.filter("case", case)?.collect();
            let chosen = rows.iter().find(|r| r[chi].num() == 1.0);
            let best = rows.iter().find(|r| r[ki].num() == 1.0);
            let acc = rows.first().map_or(f64::NAN, |r| r[ai].num());
            match (chosen, best) {
                (Some(c), Some(b)) => section.findings.push(format!(
                    "`{case}` (target {}): chose {} (estimated {}, true {}, {}); brute force: {} (true {}); cost ratio {}.",
                    bold(acc),
                    label(c),
                    bold(c[xi].num()),
                    bold(c[ei].num()),
                    if c[mti].num() == 1.0 { "meets" } else { "MISSES" },
                    label(b),
                    bold(b[ei].num()),
                    bold(c[ri].num()),
                )),
                (Some(c), None) => section.findings.push(format!(
                    "`{case}` (target {}): no candidate meets the target; chose {} (true error {}).",
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
        // Estimate against truth, every estimated candidate: on the diagonal when the estimate is right.
        let mut methods: Vec<String> = estimated.iter().map(|e| e.0.clone()).collect();
        methods.sort();
        methods.dedup();
        let mut series: Vec<Series> = methods
            .iter()
            .map(|m| Series {
                label: m.clone(),
                color: method_color(m),
                style: Style::Points,
                points: estimated.iter().filter(|e| e.0 == *m && e.1 > 0.0 && e.2 > 0.0).map(|e| (e.1, e.2)).collect(),
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
        let file = format!("{}-estimates.png", self.name());
        Plot {
            title: "Error estimates of the chooser against the true errors".into(),
            x: Axis::log("true relative error (against the reference)"),
            y: Axis::log("estimated relative error"),
            series,
        }
        .save(&out.join(&file))?;
        section.charts.push(chart_ref(file, "the chooser's error estimates against the true errors".into()));
        Ok(section)
    }
}
