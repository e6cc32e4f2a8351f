//! `stability`: where each method fails, found by sweeping the axes along which methods break — not
//! by cases written for a failure. Five families, each a map per method over two axes:
//!
//! - `step` — step size × stiffness (shells × 0.01 to × 1000, soft being large deformation; a
//!   gravity scale is the same axis for the static shape, which depends on `ρ g / k` alone; cloth
//!   × 1 to × 1000): [`step`];
//! - `drag` — the creature's head dragged a distance × at a speed (its ramp time; 0 is a jump), every
//!   reduced shell method: [`drag`];
//! - `pile` — the self-colliding strip dropped from 0.5–5 m × substeps per 1/60 s frame
//!   (`pbd`, `xpbd`); `box` — the mass ratio of a box resting on a trampoline (1:1 to 1000:1) ×
//!   substeps; `impact` — the drape dropped onto its ball at 1–30 m/s × the step (implicit cloth) or
//!   substeps (position-based): [`contact`].
//!
//! Each run is classified ([`Class`]): *diverged* (the solver's own message), *tunnelled* (a
//! particle or an edge's midpoint ends deeper than half an edge inside a collider, the cloth
//! crosses itself by the exact check of [`crate::mesh::self_intersections`], a dynamic body ends
//! below the cloth's lowest particle, or the solver reports a particle inside a collider), *inflated* (area change
//! above [`INFLATED`]), *inaccurate* (error above [`ERROR_THRESHOLD`] or, for shells, area change
//! above [`AREA_THRESHOLD`]) or *stable*. Along each row (one method, one value of the second axis)
//! the first change between a working (stable, inaccurate) and a failed cell is narrowed by
//! bisection — geometric on continuous axes, on the integers for substeps — and reported as that
//! row's boundary with the failing side's message.

mod contact;
mod drag;
mod step;

use std::path::Path;

use super::super::chart::{Cell, MapPanel, Maps};
use super::super::measure::{Outcome, Run};
use super::super::report::{Section, bold, bold_percent, number};
use super::super::table::{Column, Table, Value, computed, timed};
use super::super::{About, EvalError, Experiment};
use super::chart_ref;
use crate::solver::SolverError;

/// The experiment.
pub struct Stability;

const COLUMNS: &[Column] = &[
    computed("case", ""),
    computed("family", ""),
    computed("method", ""),
    computed("x", ""),
    computed("y", ""),
    computed("probe", ""),
    computed("outcome", ""),
    computed("rel_error", ""),
    computed("area_change", ""),
    computed("fail_time", "s"),
    computed("message", ""),
    computed("estimated_limit", "s"),
    computed("boundary_vs_estimate", ""),
    computed("failed_at", ""),
    timed("cost", "s/s"),
];

/// The experiment's name, title and columns.
const ABOUT: About = About { name: "stability", title: "Stability maps: where each method fails", columns: COLUMNS };

/// Relative displacement error above which a run that did not fail is *inaccurate*.
pub const ERROR_THRESHOLD: f64 = 0.1;
/// Relative area change above which a shell run is *inaccurate*.
pub const AREA_THRESHOLD: f64 = 0.01;
/// Relative area change above which a run is *inflated* (a failure).
pub const INFLATED: f64 = 0.1;

/// What became of one run, from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Within every bound.
    Stable,
    /// Error or area change past its bound.
    Inaccurate,
    /// Area change past [`INFLATED`].
    Inflated,
    /// Through a collider or through itself.
    Tunnelled,
    /// The solver reported a divergence.
    Diverged,
}

impl Class {
    const ALL: [Class; 5] = [Class::Stable, Class::Inaccurate, Class::Inflated, Class::Tunnelled, Class::Diverged];

    /// The word in the table.
    pub fn word(self) -> &'static str {
        match self {
            Class::Stable => "stable",
            Class::Inaccurate => "inaccurate",
            Class::Inflated => "inflated",
            Class::Tunnelled => "tunnelled",
            Class::Diverged => "diverged",
        }
    }

    /// Inflated, tunnelled or diverged: what a boundary separates from stable and inaccurate.
    pub fn failed(self) -> bool {
        matches!(self, Class::Inflated | Class::Tunnelled | Class::Diverged)
    }

    fn colour(self) -> plotters::style::RGBColor {
        use plotters::style::RGBColor;
        match self {
            Class::Stable => RGBColor(110, 190, 110),
            Class::Inaccurate => RGBColor(240, 200, 80),
            Class::Inflated => RGBColor(170, 110, 210),
            Class::Tunnelled => RGBColor(70, 130, 220),
            Class::Diverged => RGBColor(215, 70, 60),
        }
    }
}

/// One classified run.
pub struct Probe {
    run: Run,
    class: Class,
    error: f64,
    area: f64,
    /// Why a run that the solver did not stop failed (tunnelled), or empty.
    why: String,
    limit: f64,
}

impl Probe {
    /// Classify `run`: diverged if the solver said so (tunnelled if it said a particle is inside a
    /// collider), tunnelled if `tunnel` names a crossing, inflated past [`INFLATED`] when `judge_area`,
    /// inaccurate past the error bound (NaN: not judged) or the area bound (when `judge_area`).
    pub fn new(run: Run, error: f64, area: f64, judge_area: bool, tunnel: Option<String>) -> Self {
        let class = match (&run.outcome, &tunnel) {
            (_, Some(_)) => Class::Tunnelled,
            (Outcome::Diverged(e), _) if e.to_string().contains("inside collider") => Class::Tunnelled,
            (Outcome::Diverged(_), _) => Class::Diverged,
            _ if judge_area && area.abs() > INFLATED => Class::Inflated,
            _ if error > ERROR_THRESHOLD || (judge_area && area.abs() > AREA_THRESHOLD) => Class::Inaccurate,
            _ => Class::Stable,
        };
        Self { run, class, error, area, why: tunnel.unwrap_or_default(), limit: f64::NAN }
    }

    /// The same, with the method's own estimate of its stable step.
    pub fn with_limit(self, limit: f64) -> Self {
        Self { limit, ..self }
    }

    /// The simulated time of the failure (NaN for a run that did not fail).
    fn fail_time(&self) -> f64 {
        match &self.run.outcome {
            Outcome::Diverged(SolverError::Diverged { time, .. }) => *time,
            _ if self.class.failed() => self.run.sim_time,
            _ => f64::NAN,
        }
    }

    /// The solver's message, or the crossing found, or the area change past its bound.
    fn message(&self) -> String {
        match self.class {
            Class::Inflated => format!("area changed by {:+.1}%", 100.0 * self.area),
            _ if !self.why.is_empty() => self.why.clone(),
            _ => self.run.message(),
        }
    }
}

/// A family of sweeps: its axes, its methods and rows.
struct Family {
    name: &'static str,
    x_label: &'static str,
    y_label: &'static str,
    /// The second axis's name in case keys.
    y_key: &'static str,
    /// Whether the first axis takes whole numbers (bisected on the integers).
    integer: bool,
}

const FAMILIES: [Family; 5] = [
    Family { name: "step", x_label: "step (s)", y_label: "stiffness ×", y_key: "stiffness", integer: false },
    Family { name: "drag", x_label: "drag distance (m)", y_label: "ramp (s)", y_key: "ramp", integer: false },
    Family { name: "pile", x_label: "substeps per 1/60 s", y_label: "drop (m)", y_key: "drop", integer: true },
    Family { name: "box", x_label: "box : cloth mass", y_label: "substeps", y_key: "substeps", integer: false },
    Family {
        name: "impact",
        x_label: "impact speed (m/s)",
        y_label: "step (s) / substeps",
        y_key: "y",
        integer: false,
    },
];

/// One row of a family: a method, the second axis's value and the first axis's grid.
struct Row {
    method: &'static str,
    y: f64,
    xs: Vec<f64>,
}

fn family(name: &str) -> Result<&'static Family, EvalError> {
    FAMILIES.iter().find(|f| f.name == name).ok_or_else(|| EvalError::UnknownCase(name.into()))
}

/// The rows of a family.
fn rows(family: &str, quick: bool) -> Vec<Row> {
    match family {
        "step" => step::rows(quick),
        "drag" => drag::rows(quick),
        _ => contact::rows(family, quick),
    }
}

/// Run one cell of a family's row.
fn probe(family: &str, method: &str, x: f64, y: f64) -> Result<Probe, EvalError> {
    match family {
        "step" => step::probe(method, x, y),
        "drag" => drag::probe(method, x, y),
        _ => contact::probe(family, method, x, y),
    }
}

/// Bisection steps along a row.
fn bisections(quick: bool) -> usize {
    if quick { 3 } else { 5 }
}

/// The first neighbouring pair of grid cells (in `xs`'s order) of which exactly one failed.
fn transition(xs: &[f64], classes: &[Class]) -> Option<(f64, f64)> {
    (1..xs.len()).find(|&i| classes[i - 1].failed() != classes[i].failed()).map(|i| (xs[i - 1], xs[i]))
}

/// The middle of `a` and `b`: geometric on a positive continuous axis, else arithmetic; on integers
/// rounded, `None` once they are neighbours.
fn middle(a: f64, b: f64, integer: bool) -> Option<f64> {
    if integer {
        let m = ((a + b) / 2.0).round();
        (m != a && m != b).then_some(m)
    } else if a > 0.0 && b > 0.0 {
        Some((a * b).sqrt())
    } else {
        Some((a + b) / 2.0)
    }
}

impl Experiment for Stability {
    fn about(&self) -> &'static About {
        &ABOUT
    }

    fn cases(&self, quick: bool) -> Vec<String> {
        FAMILIES
            .iter()
            .flat_map(|f| {
                rows(f.name, quick).into_iter().map(move |r| format!("{}/{}/{}={}", f.name, r.method, f.y_key, r.y))
            })
            .collect()
    }

    fn run(&self, case: &str, quick: bool, _out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError> {
        let bad = || EvalError::UnknownCase(case.into());
        let mut parts = case.splitn(3, '/');
        let (Some(name), Some(method), Some(y)) = (parts.next(), parts.next(), parts.next()) else { return Err(bad()) };
        let family = family(name)?;
        let y: f64 = y
            .strip_prefix(family.y_key)
            .and_then(|v| v.strip_prefix('='))
            .and_then(|v| v.parse().ok())
            .ok_or_else(bad)?;
        let row = rows(name, quick).into_iter().find(|r| r.method == method && r.y == y).ok_or_else(bad)?;
        let mut table = Table::new(COLUMNS);
        let mut push = |x: f64, what: &str, p: &Probe, failed_at: f64| {
            table.push(vec![
                ("case", case.into()),
                ("family", name.into()),
                ("method", row.method.into()),
                ("x", x.into()),
                ("y", y.into()),
                ("probe", what.into()),
                ("outcome", p.class.word().into()),
                ("rel_error", p.error.into()),
                ("area_change", p.area.into()),
                ("fail_time", p.fail_time().into()),
                ("message", p.message().into()),
                ("estimated_limit", p.limit.into()),
                ("boundary_vs_estimate", if failed_at.is_nan() { f64::NAN } else { x / p.limit }.into()),
                ("failed_at", failed_at.into()),
                ("cost", p.run.cost().into()),
            ])
        };
        let mut grid = Vec::new();
        for (i, &x) in row.xs.iter().enumerate() {
            let p = probe(name, method, x, y)?;
            push(x, "grid", &p, f64::NAN)?;
            grid.push(p);
            progress((i + 1) as f32 / (row.xs.len() + bisections(quick)) as f32);
        }
        // Narrow the first change between working and failed cells.
        let classes: Vec<Class> = grid.iter().map(|p| p.class).collect();
        let Some((mut ok, mut bad_x)) = transition(&row.xs, &classes) else { return Ok(table) };
        let at = |x: f64| row.xs.iter().position(|&v| v == x).unwrap_or(0);
        if classes[at(ok)].failed() {
            std::mem::swap(&mut ok, &mut bad_x);
        }
        // The failed grid cell is the failure nearest the boundary until a bisection finds a nearer one.
        let mut failing = grid.swap_remove(at(bad_x));
        for k in 0..bisections(quick) {
            let Some(mid) = middle(ok, bad_x, family.integer) else { break };
            let p = probe(name, method, mid, y)?;
            push(mid, "bisection", &p, f64::NAN)?;
            if p.class.failed() {
                (bad_x, failing) = (mid, p);
            } else {
                ok = mid;
            }
            progress((row.xs.len() + k + 1) as f32 / (row.xs.len() + bisections(quick)) as f32);
        }
        // The boundary: the last working value, with the nearest failure's value, class and message.
        push(ok, "boundary", &failing, bad_x)?;
        Ok(table)
    }

    fn report(&self, table: &Table, out: &Path) -> Result<Section, EvalError> {
        let mut section = Section::new(
            self.about(),
            format!(
                "Five families of sweeps, each cell one run. `step`: {} `drag`: {} `pile`, `box`, `impact`: {} \
                 Classes: diverged (the solver's own message); tunnelled (a particle or an edge's midpoint deeper than \
                 half an edge inside a collider, the cloth through itself by an exact test, a dynamic body below the cloth, or \
                 the solver's report of a particle inside a collider); inflated (area change above {INFLATED}); \
                 inaccurate (error above {ERROR_THRESHOLD} or, for shells, area change above {AREA_THRESHOLD}); \
                 stable. Along each row the first change between a working and a failed cell is narrowed by \
                 bisection and reported with the failure's message.",
                step::SETUP,
                drag::SETUP,
                contact::SETUP
            ),
        );
        let columns = Columns::of(table)?;
        for family in &FAMILIES {
            let panels = panels(table, &columns, family.name);
            if panels.is_empty() {
                continue;
            }
            let file = format!("{}-{}-map.png", self.name(), family.name);
            Maps {
                title: format!("Stability ({}): {} × {}", family.name, family.x_label, family.y_label),
                x_label: family.x_label.into(),
                y_label: family.y_label.into(),
                legend: Class::ALL.iter().map(|c| (c.word().to_string(), c.colour())).collect(),
                panels,
            }
            .save(&out.join(&file))?;
            section.charts.push(chart_ref(file, format!("`{}`: the class of every run per method", family.name)));
        }
        section.findings.extend(findings(table, &columns));
        Ok(section)
    }
}

/// The table's column indices.
struct Columns {
    family: usize,
    method: usize,
    x: usize,
    y: usize,
    probe: usize,
    outcome: usize,
    area: usize,
    fail_time: usize,
    message: usize,
    limit: usize,
    ratio: usize,
    failed_at: usize,
}

impl Columns {
    fn of(t: &Table) -> Result<Self, EvalError> {
        Ok(Self {
            family: t.index("family")?,
            method: t.index("method")?,
            x: t.index("x")?,
            y: t.index("y")?,
            probe: t.index("probe")?,
            outcome: t.index("outcome")?,
            area: t.index("area_change")?,
            fail_time: t.index("fail_time")?,
            message: t.index("message")?,
            limit: t.index("estimated_limit")?,
            ratio: t.index("boundary_vs_estimate")?,
            failed_at: t.index("failed_at")?,
        })
    }
}

/// The sorted distinct values of a column over some rows.
fn distinct(rows: &[&Vec<Value>], column: usize) -> Vec<f64> {
    let mut v: Vec<f64> = rows.iter().map(|r| r[column].num()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// One map panel per method of `family` that has grid cells, in the table's order.
fn panels(table: &Table, c: &Columns, family: &str) -> Vec<MapPanel> {
    let grid: Vec<&Vec<Value>> =
        table.rows.iter().filter(|r| r[c.family].text() == family && r[c.probe].text() == "grid").collect();
    let mut names: Vec<String> = grid.iter().map(|r| r[c.method].text()).collect();
    names.dedup();
    names
        .iter()
        .map(|name| {
            let mine: Vec<&Vec<Value>> = grid.iter().copied().filter(|r| r[c.method].text() == *name).collect();
            let (xs, ys) = (distinct(&mine, c.x), distinct(&mine, c.y));
            let at = |v: &[f64], x: f64| v.iter().position(|&a| a == x).unwrap_or(0);
            let cells = mine
                .iter()
                .map(|r| Cell {
                    column: at(&xs, r[c.x].num()),
                    row: at(&ys, r[c.y].num()),
                    category: Class::ALL.iter().position(|k| k.word() == r[c.outcome].text()).unwrap_or(4),
                })
                .collect();
            // The explicit method's own estimate of its limit at stiffness × 1, on the (log) step axis.
            let marker = mine.iter().find(|r| r[c.y].num() == 1.0 && r[c.limit].num().is_finite()).and_then(|r| {
                let (first, last) = (*xs.first()?, *xs.last()?);
                let ratio = (last / first).ln() / (xs.len() - 1).max(1) as f64;
                Some(((r[c.limit].num() / first).ln() / ratio + 0.5, "2/ω_max at × 1".to_string()))
            });
            MapPanel {
                title: name.clone(),
                columns: xs.iter().map(|&x| number(x)).collect(),
                rows: ys
                    .iter()
                    .map(|&y| if family == "drag" && y == 0.0 { "jump".into() } else { number(y) })
                    .collect(),
                cells,
                marker,
            }
        })
        .collect()
}

/// The label of a second-axis value (the drag's ramp 0 is a jump).
fn y_text(family: &str, y: f64) -> String {
    if family == "drag" && y == 0.0 { "jump".into() } else { bold(y) }
}

/// Whether a table cell names a failed class.
fn failed(v: &Value) -> bool {
    Class::ALL.iter().any(|k| k.failed() && k.word() == v.text())
}

/// One sentence per boundary found, one per method for the rows that failed throughout, and one per
/// method that never failed.
fn findings(table: &Table, c: &Columns) -> Vec<String> {
    let mut out = Vec::new();
    for family in &FAMILIES {
        let mine: Vec<&Vec<Value>> = table.rows.iter().filter(|r| r[c.family].text() == family.name).collect();
        let mut names: Vec<String> = mine.iter().map(|r| r[c.method].text()).collect();
        names.dedup();
        for name in names {
            let rows: Vec<&Vec<Value>> = mine.iter().copied().filter(|r| r[c.method].text() == name).collect();
            for b in rows.iter().filter(|r| r[c.probe].text() == "boundary") {
                let class = b[c.outcome].text();
                let mut s = format!(
                    "`{name}` ({}, {} {}): works at {} {}, {class} at {}",
                    family.name,
                    family.y_label,
                    y_text(family.name, b[c.y].num()),
                    bold(b[c.x].num()),
                    family.x_label,
                    bold(b[c.failed_at].num()),
                );
                if class == "inflated" {
                    s += &format!(" (area {})", bold_percent(b[c.area].num()));
                }
                if b[c.fail_time].num().is_finite() {
                    s += &format!(" after {} s", bold(b[c.fail_time].num()));
                }
                s += &format!(": \"{}\"", b[c.message].text());
                if b[c.ratio].num().is_finite() {
                    s += &format!(
                        "; its estimate 2/ω_max = {} s, a ratio of {}",
                        bold(b[c.limit].num()),
                        bold(b[c.ratio].num())
                    );
                }
                out.push(s + ".");
            }
            let grid: Vec<&Vec<Value>> = rows.iter().copied().filter(|r| r[c.probe].text() == "grid").collect();
            // Rows failed at every value of the first axis: no boundary inside the sweep.
            let whole: Vec<f64> = distinct(&grid, c.y)
                .into_iter()
                .filter(|&y| grid.iter().filter(|r| r[c.y].num() == y).all(|r| failed(&r[c.outcome])))
                .collect();
            if !whole.is_empty() {
                let worst = grid.iter().filter(|r| whole.contains(&r[c.y].num()));
                let area = worst
                    .clone()
                    .map(|r| r[c.area].num())
                    .filter(|a| a.is_finite())
                    .max_by(|a, b| a.abs().total_cmp(&b.abs()));
                let mut classes: Vec<String> = worst.map(|r| r[c.outcome].text()).collect();
                classes.sort();
                classes.dedup();
                out.push(format!(
                    "`{name}` ({}): {} at every {} for {} {}{}.",
                    family.name,
                    classes.join(" or "),
                    family.x_label,
                    family.y_label,
                    whole.iter().map(|&y| y_text(family.name, y)).collect::<Vec<_>>().join(", "),
                    area.map_or(String::new(), |a| format!(" (area change up to {})", bold_percent(a))),
                ));
            }
            if !grid.iter().any(|r| failed(&r[c.outcome])) {
                let inaccurate = grid.iter().filter(|r| r[c.outcome].text() == "inaccurate").count();
                out.push(format!(
                    "`{name}` ({}): no failure in {} cells ({inaccurate} inaccurate).",
                    family.name,
                    grid.len()
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transitions_are_found_either_way_and_integer_bisection_stops_at_neighbours() {
        use Class::*;
        assert_eq!(transition(&[1.0, 2.0, 4.0], &[Stable, Inaccurate, Tunnelled]), Some((2.0, 4.0)));
        assert_eq!(transition(&[1.0, 2.0, 4.0], &[Diverged, Stable, Stable]), Some((1.0, 2.0)));
        assert_eq!(transition(&[1.0, 2.0], &[Stable, Inaccurate]), None);
        assert_eq!(middle(4.0, 8.0, true), Some(6.0));
        assert_eq!(middle(4.0, 5.0, true), None);
        assert!((middle(1.0, 100.0, false).unwrap() - 10.0).abs() < 1e-12);
        assert_eq!(middle(0.0, 1.0, false), Some(0.5));
    }

    /// A table with a grid for every method of a family gives a drawn panel per method — a one-row
    /// method too — and a test on it fails if a method present in the table has no cells.
    #[test]
    fn every_method_in_the_table_has_a_panel_with_its_cells() {
        let mut t = Table::new(COLUMNS);
        let cells = [("xpbd", 1.0, 2.0, "tunnelled"), ("xpbd", 4.0, 2.0, "stable"), ("pbd", 1.0, 5.0, "diverged")];
        for (m, x, y, outcome) in cells {
            t.push(vec![
                ("case", "c".into()),
                ("family", "pile".into()),
                ("method", m.into()),
                ("x", x.into()),
                ("y", y.into()),
                ("probe", "grid".into()),
                ("outcome", outcome.into()),
            ])
            .unwrap();
        }
        let c = Columns::of(&t).unwrap();
        let panels = panels(&t, &c, "pile");
        let methods: Vec<String> = t.rows.iter().map(|r| r[c.method].text()).collect();
        for m in methods {
            let p = panels.iter().find(|p| p.title == m).unwrap_or_else(|| panic!("`{m}` has no panel"));
            assert!(!p.cells.is_empty() && p.cells.iter().all(|k| k.column < p.columns.len() && k.row < p.rows.len()));
        }
        let xpbd = &panels[0];
        assert_eq!((xpbd.columns.len(), xpbd.rows.len(), xpbd.cells[0].category), (2, 1, 3));
    }
}
