//! `paper-fig4`: the paper's Figure 4 — a flat beam and a V-beam of equal bending stiffness `k_B`
//! (× 1, × 10, × 100) under gravity: their equilibria rendered side by side, and the tip deflection
//! of each method against `k_B`.
//!
//! The pair is the built-in `v-beam` (1 m × 0.2 m, 90° crease, 40 × 8 cells) and the same mesh opened
//! flat (`angle_deg = 180`), so the two differ only by the crease. Each case renders its `mwts`
//! equilibrium (surface) with the `ds-static` reference as black lines over it; the picture is a case
//! artefact (`cases/<id>.png`) that the report tiles.

use std::path::Path;

use glam::{DVec3, Vec3};

use super::super::chart::{Axis, Plot, Series, Style, Tiles, method_color};
use super::super::measure::{self, Stop};
use super::super::report::{Section, bold};
use super::super::runner::CaseId;
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{EvalError, Experiment};
use super::{chart_ref, f, key_value, tip_deflection};
use crate::app::scene_view::{SceneView, ViewOptions};
use crate::render::{Camera, Headless, load_png, save_png};

/// The experiment.
pub struct PaperFig4;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("beam", ""),
    computed("k_bend_factor", ""),
    computed("k_bend", "N·m"),
    computed("method", ""),
    computed("tip_deflection", "m"),
    computed("rel_error", ""),
    computed("area_change", ""),
    computed("ref_converged", ""),
    timed("wall", "s"),
];

/// `k_B` of the × 1 pair, N·m: soft enough that the flat beam hangs and the V-beam's section works.
pub const BASE_K_BEND: f64 = 0.005;
const FACTORS: [f64; 3] = [1.0, 10.0, 100.0];
const BEAMS: [(&str, f64); 2] = [("flat", 180.0), ("V", 90.0)];
const MODES: usize = 8;

fn overrides(angle: f64, k_bend: f64) -> Vec<String> {
    vec![format!("mesh.v-beam.angle_deg={angle}"), format!("material.k_bend={k_bend}"), format!("solver.modes={MODES}")]
}

/// The side view every tile is drawn from.
fn camera() -> Camera {
    let mut c = Camera::look_at(Vec3::new(0.45, 0.25, 2.1), Vec3::new(0.02, -0.38, 0.0));
    c.fov_y_deg = 40.0;
    c
}

impl Experiment for PaperFig4 {
    fn name(&self) -> &'static str {
        "paper-fig4"
    }

    fn title(&self) -> &'static str {
        "The paper's Fig. 4: flat beam and V-beam of equal bending stiffness"
    }

    fn columns(&self) -> &'static [Column] {
        COLUMNS
    }

    fn cases(&self, _quick: bool) -> Vec<String> {
        BEAMS.iter().flat_map(|(beam, _)| FACTORS.iter().map(move |k| format!("{beam}/kb={k}"))).collect()
    }

    fn run(&self, case: &str, quick: bool, out: &Path, _progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let (beam, k) = case.split_once('/').ok_or_else(|| EvalError::UnknownCase(case.into()))?;
        let factor = key_value(k, "kb")?;
        let angle = BEAMS.iter().find(|b| b.0 == beam).ok_or_else(|| EvalError::UnknownCase(case.into()))?.1;
        let k_bend = BASE_K_BEND * factor;
        let mut over = overrides(angle, k_bend);
        let reference = measure::reference("v-beam", &over)?;
        let base = measure::setup("v-beam", "mwts", &over)?;
        let rest = base.mesh.positions().to_vec();
        let (alpha, omega) = measure::critical_damping(&base)?;
        over.push(format!("solver.rayleigh_alpha={alpha}"));
        let mut table = Table::new(COLUMNS);
        let row = |method: &str, x: &[DVec3], wall: f64| -> Vec<(&'static str, Value)> {
            vec![
                ("case", case.into()),
                ("beam", beam.into()),
                ("k_bend_factor", factor.into()),
                ("k_bend", k_bend.into()),
                ("method", method.to_string().into()),
                ("tip_deflection", tip_deflection(x, &rest).into()),
                ("rel_error", measure::relative_error(x, &reference.positions, &rest).into()),
                ("area_change", measure::area_change(x, &base).into()),
                ("ref_converged", f(reference.converged)),
                ("wall", wall.into()),
            ]
        };
        table.push(row("ds-static", &reference.positions, reference.wall))?;
        let stop = Stop { max_time: if quick { 12.0 } else { 25.0 } / omega, max_steps: u64::MAX, rest: 1e-7 };
        let mut mwts = Vec::new();
        for method in ["lma", "mwts"] {
            let s = measure::setup("v-beam", method, &over)?;
            let run = measure::run(measure::build(&s)?.as_mut(), &rest, stop);
            table.push(row(method, &run.positions, run.wall))?;
            if method == "mwts" {
                mwts = run.positions;
            }
        }
        // The picture: the MWTS equilibrium, the reference's edges over it.
        let (w, h) = Tiles::tile_size(FACTORS.len(), BEAMS.len());
        let mut headless = Headless::new(w, h)?;
        let view = SceneView::new(&base);
        let mut frame = view.frame(camera(), &mwts, 0.0, &[], ViewOptions { wireframe: false });
        let p = |v: usize| reference.positions[v].as_vec3().to_array();
        for e in &base.mesh.topology().edges {
            frame.line(p(e.v[0]), p(e.v[1]), [0.0, 0.0, 0.0, 1.0]);
        }
        let image = headless.render(&frame)?;
        let id = CaseId { experiment: "paper-fig4", key: case.to_string() };
        let path = id.artefact(out, "png");
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| EvalError::Io { path: dir.to_path_buf(), reason: e.to_string() })?;
        }
        save_png(&image, path)?;
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section {
            experiment: self.name().into(),
            title: self.title().into(),
            setup: format!(
                "The built-in `v-beam` (1 m × 0.2 m, 40 × 8 cells, 90° crease) and the same mesh opened flat, \
                 k_B = {BASE_K_BEND} N·m × 1, × 10, × 100, gravity 9.81 m/s², clamped by two rows. `lma` and \
                 `mwts` ({MODES} modes) run to rest under critical damping of the lowest mode; `ds-static` is the \
                 reference. Pictures: the `mwts` equilibrium (surface) with the reference's edges (black lines)."
            ),
            ..Section::default()
        };
        let (bi, ki, mi, ti) = (
            table.index("beam")?,
            table.index("k_bend_factor")?,
            table.index("method")?,
            table.index("tip_deflection")?,
        );
        let mut series = Vec::new();
        for (beam, _) in BEAMS {
            for method in ["ds-static", "mwts", "lma"] {
                let points = table
                    .rows
                    .iter()
                    .filter(|r| r[bi].text() == beam && r[mi].text() == method)
                    .map(|r| (r[ki].num(), r[ti].num()))
                    .collect();
                let style = if beam == "flat" { Style::Line } else { Style::Dashed };
                series.push(Series { label: format!("{method}, {beam}"), color: method_color(method), style, points });
            }
        }
        let file = format!("{}-tip.png", self.name());
        Plot {
            title: "Tip deflection under gravity against bending stiffness".into(),
            x: Axis::log("bending stiffness k_B / k_B(×1)"),
            y: Axis::log("tip deflection (m)"),
            series,
        }
        .save(&out.join(&file))?;
        section.charts.push(chart_ref(file, "tip deflection of the flat beam (solid) and the V-beam (dashed)".into()));
        // The tiles: flat beams on the first row, V-beams on the second.
        let mut tiles = Vec::new();
        for row in table.rows.iter().filter(|r| r[mi].text() == "ds-static") {
            let id = CaseId { experiment: "paper-fig4", key: row[0].text() };
            let picture = load_png(id.artefact(out, "png"))?;
            tiles.push((
                picture,
                format!(
                    "{}-beam, k_B × {}: tip {} m",
                    row[bi].text(),
                    row[ki].num(),
                    super::super::report::number(row[ti].num())
                ),
            ));
        }
        if tiles.len() == FACTORS.len() * BEAMS.len() {
            let file = format!("{}-equilibria.png", self.name());
            Tiles {
                title: "Equilibria: MWTS (surface) and the nonlinear reference (lines)".into(),
                columns: FACTORS.len(),
                tiles,
            }
            .save(&out.join(&file))?;
            section.charts.push(chart_ref(file, "equilibria of the flat beam (top) and the V-beam (bottom)".into()));
        }
        for (beam, _) in BEAMS {
            let tip = |method: &str, factor: f64| {
                table
                    .rows
                    .iter()
                    .find(|r| r[bi].text() == beam && r[mi].text() == method && r[ki].num() == factor)
                    .map(|r| r[ti].num())
            };
            if let (Some(soft), Some(stiff)) = (tip("ds-static", 1.0), tip("ds-static", 100.0)) {
                section.findings.push(format!(
                    "The {beam}-beam's tip drops {} m at k_B × 1 and {} m at × 100 (reference).",
                    bold(soft),
                    bold(stiff)
                ));
            }
        }
        Ok(section)
    }
}
