//! `paper-fig4`: the paper's Figure 4 — a flat beam and a V-beam of equal bending stiffness `k_B`
//! (× 1, × 10, × 100) under gravity: their equilibria rendered side by side, and the tip deflection
//! of each method against `k_B`.
//!
//! The pair is the built-in `v-beam` (1 m × 0.2 m, 90° crease, 40 × 8 cells) and the same mesh opened
//! flat (`angle_deg = 180`), so the two differ only by the crease. Each case renders its `mwts`
//! equilibrium (surface) with the `ds-static` reference as black lines over it and the rest shape's
//! outline in white; the picture is a case artefact (`cases/<id>.png`) that the report tiles, each
//! under a caption read from the table (the tip deflections). Every panel has its own camera: one
//! viewing direction (three-quarters from the free end and above, which shows the V's cross-section
//! and the sag) moved so that the box around the rest shape and both equilibria fills the panel
//! ([`Camera::fitted`]), so a stiff beam is as large as a drooping one.

use std::path::Path;

use glam::{DVec3, Vec3};

use super::super::case::CaseId;
use super::super::chart::{Axis, Plot, Series, Style, Tiles, method_color};
use super::super::measure::{self, Stop};
use super::super::report::{Section, bold, number};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::{add_chart, chart_ref, flag, key_value, tip_deflection};
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

/// The experiment's name, title and columns.
const ABOUT: About = About {
    name: "paper-fig4",
    title: "The paper's Fig. 4: flat beam and V-beam of equal bending stiffness",
    columns: COLUMNS,
};

/// `k_B` of the × 1 pair, N·m: soft enough that the flat beam hangs and the V-beam's section works.
pub const BASE_K_BEND: f64 = 0.005;
const FACTORS: [f64; 3] = [1.0, 10.0, 100.0];
const BEAMS: [(&str, f64); 2] = [("flat", 180.0), ("V", 90.0)];
const MODES: usize = 8;

fn overrides(angle: f64, k_bend: f64) -> Vec<String> {
    vec![format!("mesh.v-beam.angle_deg={angle}"), format!("material.k_bend={k_bend}"), format!("solver.modes={MODES}")]
}

/// Where every panel is seen from (from the beam towards the eye): three-quarters, from the free end's
/// side and above, so that the V's cross-section and the sag along the beam both show.
const VIEW_FROM: Vec3 = Vec3::new(0.9, 0.55, 1.0);
/// The panels' vertical field of view, degrees.
const FOV_Y_DEG: f32 = 30.0;
/// Space left around the fitted beam, as a fraction of the panel's half-width and half-height.
const MARGIN: f32 = 0.08;
/// Colour of the rest shape's outline, linear RGBA.
const REST: [f32; 4] = [1.0, 1.0, 1.0, 1.0];

/// The camera of a panel of width/height ratio `aspect`: seen from [`VIEW_FROM`], fitted to the box
/// around every shape it draws (rest, equilibria).
fn panel_camera(shapes: &[&[DVec3]], aspect: f32) -> Result<Camera, EvalError> {
    let (lo, hi) = crate::mesh::bounds(&shapes.concat());
    let mut view = Camera::look_at(VIEW_FROM, Vec3::ZERO);
    view.fov_y_deg = FOV_Y_DEG;
    Ok(view.fitted(lo.as_vec3(), hi.as_vec3(), aspect, MARGIN)?)
}

/// The caption under `case`'s panel, from its rows of `table`: the beam, the stiffness factor and the
/// tip deflection of the reference and of `mwts` (the surface drawn).
fn caption(table: &Table, case: &str) -> Result<String, EvalError> {
    let rows: Vec<&Vec<Value>> = table.filter("case", case)?.collect();
    let of = |method: &str| rows.iter().find(|r| table.get(r, "method").is_ok_and(|m| m.text() == method));
    let reference =
        of("ds-static").ok_or_else(|| EvalError::Data(format!("paper-fig4: no reference row for {case}")))?;
    let tip = |r: &[Value]| table.get(r, "tip_deflection").map(|v| number(v.num()));
    let mwts = match of("mwts") {
        Some(r) => format!(", MWTS {}", tip(r)?),
        None => String::new(),
    };
    let (beam, factor) = (table.get(reference, "beam")?.text(), table.get(reference, "k_bend_factor")?.num());
    Ok(format!("{beam}, k_B × {factor}: tip {} m{mwts}", tip(reference)?))
}

impl Experiment for PaperFig4 {
    fn about(&self) -> &'static About {
        &ABOUT
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
                ("ref_converged", flag(reference.converged)),
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
        let camera = panel_camera(&[&rest, &mwts, &reference.positions], w as f32 / h as f32)?;
        let mut frame = view.frame(camera, &mwts, 0.0, &[], ViewOptions { wireframe: false }, &[]);
        let topology = base.mesh.topology();
        let p = |x: &[DVec3], v: usize| x[v].as_vec3().to_array();
        for e in &topology.edges {
            frame.line(p(&reference.positions, e.v[0]), p(&reference.positions, e.v[1]), [0.0, 0.0, 0.0, 1.0]);
        }
        for e in topology.boundary_edges.iter().map(|&i| &topology.edges[i]) {
            frame.line(p(&rest, e.v[0]), p(&rest, e.v[1]), REST);
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
        let mut section = Section::new(
            self.about(),
            format!(
                "The built-in `v-beam` (1 m × 0.2 m, 40 × 8 cells, 90° crease) and the same mesh opened flat, \
                 k_B = {BASE_K_BEND} N·m × 1, × 10, × 100, gravity 9.81 m/s², clamped by two rows. `lma` and \
                 `mwts` ({MODES} modes) run to rest under critical damping of the lowest mode; `ds-static` is the \
                 reference. Pictures: the `mwts` equilibrium (surface) with the reference's edges (black lines) \
                 and the rest shape's outline (white), each panel fitted to its beam and seen from the free \
                 end's side and above; under each, the tip deflection of the reference (and of `mwts`)."
            ),
        );
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
        add_chart(
            Plot {
                title: "Tip deflection under gravity against bending stiffness".into(),
                x: Axis::log("bending stiffness k_B / k_B(×1)"),
                y: Axis::log("tip deflection (m)"),
                series,
            },
            &mut section,
            out,
            "tip",
            "tip deflection of the flat beam (solid) and the V-beam (dashed)".into(),
        )?;
        // The tiles: flat beams on the first row, V-beams on the second.
        let mut tiles = Vec::new();
        for row in table.rows.iter().filter(|r| r[mi].text() == "ds-static") {
            let id = CaseId { experiment: "paper-fig4", key: row[0].text() };
            let picture = load_png(id.artefact(out, "png"))?;
            tiles.push((picture, caption(table, &row[0].text())?));
        }
        if tiles.len() == FACTORS.len() * BEAMS.len() {
            let file = format!("{}-equilibria.png", self.name());
            Tiles {
                title: "Flat beam (top) and V-beam (bottom): MWTS (surface), reference (lines), rest (white)".into(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::v_beam;

    #[test]
    fn every_panel_shows_its_whole_beam_and_the_beam_fills_it() {
        let (w, h) = Tiles::tile_size(FACTORS.len(), BEAMS.len());
        let aspect = w as f32 / h as f32;
        for (_, angle) in BEAMS {
            let rest = v_beam(1.0, 0.2, angle, [40, 8]).unwrap().positions().to_vec();
            // A slight sag (the V-beam's), and a droop of most of the length (the soft flat beam's).
            for sag in [0.01, 0.9] {
                let bent: Vec<DVec3> =
                    rest.iter().map(|p| DVec3::new(p.x, p.y - sag * (p.x + 0.5).powi(2), p.z)).collect();
                let camera = panel_camera(&[&rest, &bent], aspect).unwrap();
                let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
                for p in rest.iter().chain(&bent) {
                    let clip = camera.view_proj(aspect) * p.as_vec3().extend(1.0);
                    let ndc = [clip.x / clip.w, clip.y / clip.w];
                    assert!(
                        clip.w > 0.0 && ndc.iter().all(|c| c.abs() <= 1.0),
                        "angle {angle}, sag {sag}: {p} at {ndc:?}"
                    );
                    for k in 0..2 {
                        lo[k] = lo[k].min(ndc[k]);
                        hi[k] = hi[k].max(ndc[k]);
                    }
                }
                // Clip coordinates span 2 across the panel.
                let cover = [(hi[0] - lo[0]) / 2.0, (hi[1] - lo[1]) / 2.0];
                assert!(cover[0] >= 0.5 || cover[1] >= 0.5, "angle {angle}, sag {sag}: covers {cover:?} of the panel");
            }
        }
    }

    #[test]
    fn a_caption_carries_the_tables_tip_deflections() {
        let mut table = Table::new(COLUMNS);
        for (method, tip) in [("ds-static", 0.011129388), ("lma", 0.0109815), ("mwts", 0.0109936)] {
            table
                .push(vec![
                    ("case", "V/kb=1".into()),
                    ("beam", "V".into()),
                    ("k_bend_factor", 1.0.into()),
                    ("method", method.to_string().into()),
                    ("tip_deflection", tip.into()),
                ])
                .unwrap();
        }
        let text = caption(&table, "V/kb=1").unwrap();
        assert!(text.starts_with("V, k_B × 1: "), "{text}");
        assert!(text.contains(&format!("tip {} m", number(0.011129388))), "{text}");
        assert!(text.contains(&number(0.0109936)), "{text}");
        assert!(caption(&table, "flat/kb=1").is_err(), "no rows, no caption");
    }
}
