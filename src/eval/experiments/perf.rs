//! `paper-perf`: the papers' timings beside ours, as ratios. The modal-warping paper: a 13,117-vertex
//! dinosaur shell with 4 modes, about 18 s of preprocessing (Matlab `eigs`) and about 200 frames/s
//! (2007, Pentium D 3.46 GHz, in Maya, drawing included). The cloth paper: a 958-particle cloth
//! dropped on a ball, 1.014 s per step at h = 0.01 s (Core 2 Duo). Ours: the 12,962-vertex
//! `creature` with 4 modes (modal analysis measured afresh, never from the cache, then MWTS steps
//! under gravity) and the 961-particle `drape` (3 s at h = 0.01 s), one thread.

use std::path::Path;

use super::super::chart::{Bars, method_color};
use super::super::measure::{self, Stop};
use super::super::report::{Section, bold};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::chart_ref;

/// The experiment.
pub struct PaperPerf;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("scene", ""),
    computed("method", ""),
    computed("quantity", ""),
    computed("unit", ""),
    computed("paper", ""),
    timed("value", ""),
    timed("speedup", ""),
];

/// The experiment's name, title and columns.
const ABOUT: About = About { name: "paper-perf", title: "The papers' timings beside ours", columns: COLUMNS };

/// The modal paper's preprocessing time, s, and frame rate, 1/s.
pub const PAPER_PRECOMPUTE: f64 = 18.0;
/// The modal paper's frames per second.
pub const PAPER_FPS: f64 = 200.0;
/// The cloth paper's time per step at h = 0.01 s, s.
pub const PAPER_CLOTH_STEP: f64 = 1.014;

impl Experiment for PaperPerf {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, _quick: bool) -> Vec<String> {
        vec!["creature".into(), "drape".into()]
    }

    fn run(&self, case: &str, quick: bool, _out: &Path, _progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let mut table = Table::new(COLUMNS);
        let mut push = |method: &str, quantity: &str, unit: &str, value: f64, paper: f64, speedup: f64| {
            table.push(vec![
                ("case", case.into()),
                ("scene", case.into()),
                ("method", method.to_string().into()),
                ("quantity", quantity.to_string().into()),
                ("unit", unit.to_string().into()),
                ("paper", paper.into()),
                ("value", value.into()),
                ("speedup", speedup.into()),
            ])
        };
        match case {
            "creature" => {
                let setup = measure::setup("creature", "mwts", &[])?;
                let a = measure::modal_analysis(&setup, setup.scene.solver.modes)?;
                let t = a.timings;
                let total = t.assembly + t.factorisation + t.eigen;
                let nan = f64::NAN;
                push("modal", "assembly", "s", t.assembly, nan, nan)?;
                push("modal", "factorisation", "s", t.factorisation, nan, nan)?;
                push("modal", "eigen solve", "s", t.eigen, nan, nan)?;
                push("modal", "precompute", "s", total, PAPER_PRECOMPUTE, PAPER_PRECOMPUTE / total)?;
                let steps = if quick { 100 } else { 600 };
                for method in ["mwts", "lma"] {
                    let s = measure::setup("creature", method, &[])?;
                    let mut solver = measure::build(&s)?;
                    let stop = Stop { max_time: f64::INFINITY, max_steps: steps, rest: 0.0 };
                    let run = measure::run(solver.as_mut(), s.mesh.positions(), stop);
                    let per_step = run.wall / run.steps.max(1) as f64;
                    let rate = 1.0 / per_step;
                    push(method, "step", "s", per_step, nan, nan)?;
                    let paper = if method == "mwts" { PAPER_FPS } else { nan };
                    push(method, "steps per second", "1/s", rate, paper, rate / paper)?;
                }
            }
            "drape" => {
                let s = measure::setup("drape", "cloth", &[])?;
                let mut solver = measure::build(&s)?;
                let stop = Stop { max_time: if quick { 1.0 } else { 3.0 }, max_steps: u64::MAX, rest: 0.0 };
                let run = measure::run(solver.as_mut(), s.mesh.positions(), stop);
                let per_step = run.wall / run.steps.max(1) as f64;
                push("cloth", "step", "s", per_step, PAPER_CLOTH_STEP, PAPER_CLOTH_STEP / per_step)?;
            }
            _ => return Err(EvalError::UnknownCase(case.into())),
        }
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(
            self.about(),
            "The modal-warping paper: dinosaur shell, 13,117 vertices, 4 modes, about 18 s of preprocessing \
                    (Matlab eigs) and about 200 frames/s drawn in Maya (2007, Pentium D 3.46 GHz). The cloth paper: \
                    958 particles dropped on a ball, 1.014 s per step at h = 0.01 s (Core 2 Duo). Ours: the \
                    12,962-vertex `creature` with 4 modes (modal analysis computed afresh; then 600 MWTS steps under \
                    gravity, step only, no drawing) and the 961-particle `drape` (300 steps of 0.01 s), one thread. \
                    Speed-up = the paper's time ÷ ours (or our rate ÷ the paper's); different machines 15–20 years \
                    apart, so the ratio says what the method costs today, not that the code is N× better."
                .into(),
        );
        let (qi, mi, vi, pi, si) = (
            table.index("quantity")?,
            table.index("method")?,
            table.index("value")?,
            table.index("paper")?,
            table.index("speedup")?,
        );
        let compared: Vec<&Vec<Value>> = table.rows.iter().filter(|r| r[pi].num().is_finite()).collect();
        let mut groups = Vec::new();
        for r in &compared {
            let label = format!("{} {}", r[mi].text(), r[qi].text());
            groups.push((label, vec![("speed-up".to_string(), r[si].num(), method_color(&r[mi].text()))]));
            let unit = match r[qi].text().as_str() {
                "steps per second" => "steps/s",
                _ => "s",
            };
            section.findings.push(format!(
                "{} {}: {} {unit} against the paper's {} {unit}, a speed-up of {}.",
                r[mi].text(),
                r[qi].text(),
                bold(r[vi].num()),
                bold(r[pi].num()),
                bold(r[si].num()),
            ));
        }
        let stage = |name: &str| table.rows.iter().find(|r| r[qi].text() == name).map(|r| r[vi].num());
        if let (Some(a), Some(f), Some(e)) = (stage("assembly"), stage("factorisation"), stage("eigen solve")) {
            section.findings.push(format!(
                "The creature's modal analysis: assembly {} s, factorisation {} s, eigen solve {} s.",
                bold(a),
                bold(f),
                bold(e)
            ));
        }
        let file = format!("{}-speedup.png", self.name());
        Bars {
            title: "Speed-up over the papers' figures (their time ÷ ours)".into(),
            y_label: "speed-up (×)".into(),
            groups,
        }
        .save(&out.join(&file))?;
        section.charts.push(chart_ref(file, "speed-up over the papers' published timings".into()));
        Ok(section)
    }
}
