//! The contact families, where cloth goes through things:
//!
//! - `pile` — the self-colliding strip (`pile`) dropped with its lower end 0.5–5 m above the ground,
//!   × substeps per 1/60 s frame; `xpbd` takes them as `solver.substeps`, `pbd` as that many steps
//!   of 1/(60 n) s. A particle travelling more than about an edge per substep crosses the ground
//!   or the strip's other layers between two substeps.
//! - `box` — a 0.2 m box resting on the `trampoline` (a 1 m sheet held along its edges), its mass
//!   1 to 1000 times the sheet's, × substeps: a heavy box pulls particles through its faces.
//! - `impact` — the drape dropped onto its ball from a height giving impact speed `v` (the sheet's
//!   gap above the ball `v²/2g`), 1–30 m/s, then 1 s more; the implicit cloth × its step, the
//!   position-based methods × substeps as above.
//!
//! Tunnelled: at the end a particle, or an edge's midpoint, is deeper than half the mean rest edge
//! inside a collider that is not dynamic (a contact holds particles within a thickness, far less);
//! the cloth crosses itself ([`self_intersections`]) in a scene with self-collision; a dynamic body's centre is below the cloth's
//! lowest particle (a box resting on a sagging sheet sits above the sag); or the solver itself reports a
//! particle inside a collider. Accuracy is not judged: these maps are for failures.

use glam::DVec3;

use super::super::super::measure::{self, Stop};
use super::{Probe, Row};
use crate::collision::Body;
use crate::eval::EvalError;
use crate::mesh::self_intersections;
use crate::scene::Setup;
use crate::solver::{Solver, SolverError};

/// How the families are set up, for the summary.
pub const SETUP: &str = "the self-colliding `pile` dropped from 0.5–5 m; a box of 1 to 1000 times the sheet's mass \
    resting on the `trampoline`; the drape dropped onto its ball at 1–30 m/s — each × substeps per 1/60 s frame \
    (`xpbd`: substeps, `pbd`: steps of 1/(60 n) s), the implicit cloth's impact × its step.";

const SUBSTEPS: [f64; 5] = [1.0, 2.0, 4.0, 8.0, 16.0];
const DROPS: [f64; 3] = [0.5, 2.0, 5.0];
const MASS_RATIOS: [f64; 7] = [1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0];
const BOX_SUBSTEPS: [f64; 3] = [5.0, 10.0, 20.0];
const SPEEDS: [f64; 4] = [1.0, 3.0, 10.0, 30.0];
const IMPACT_SUBSTEPS: [f64; 3] = [1.0, 4.0, 16.0];
const CLOTH_STEPS: [f64; 3] = [0.001, 0.01, 1.0 / 30.0];
const FRAME: f64 = 1.0 / 60.0;
const BOX_TIME: f64 = 2.0;

/// The rows of `family` (quick: `xpbd` on one row each, and the implicit cloth's impact at h = 0.01 s).
pub fn rows(family: &str, quick: bool) -> Vec<Row> {
    let row = |method: &'static str, y: f64, xs: &[f64]| Row { method, y, xs: xs.to_vec() };
    let both = ["xpbd", "pbd"];
    match (family, quick) {
        ("pile", true) => vec![row("xpbd", 5.0, &[2.0, 16.0])],
        ("pile", false) => both.iter().flat_map(|&m| DROPS.iter().map(move |&y| row(m, y, &SUBSTEPS))).collect(),
        ("box", true) => vec![row("xpbd", 10.0, &[1.0, 1000.0])],
        ("box", false) => {
            both.iter().flat_map(|&m| BOX_SUBSTEPS.iter().map(move |&y| row(m, y, &MASS_RATIOS))).collect()
        }
        ("impact", true) => vec![row("cloth", 0.01, &[1.0, 30.0])],
        ("impact", false) => {
            let cloth = CLOTH_STEPS.iter().map(|&y| row("cloth", y, &SPEEDS));
            cloth.chain(both.iter().flat_map(|&m| IMPACT_SUBSTEPS.iter().map(move |&y| row(m, y, &SPEEDS)))).collect()
        }
        _ => Vec::new(),
    }
}

/// Run one cell of `family`.
pub fn probe(family: &str, method: &str, x: f64, y: f64) -> Result<Probe, EvalError> {
    match family {
        "pile" => pile(method, x, y),
        "box" => on_trampoline(method, x, y),
        _ => impact(method, x, y),
    }
}

/// The overrides that give a position-based `method` `n` substeps per 1/60 s frame.
fn substeps(method: &str, n: f64) -> Vec<String> {
    if method == "pbd" {
        vec![format!("solver.step={}", FRAME / n)]
    } else {
        vec![format!("solver.step={FRAME}"), format!("solver.substeps={}", n.round().max(1.0))]
    }
}

/// `scene` by `method` with `overrides`, its placement raised so that its lowest point is `gap`
/// metres above `floor` (a height measured on the scene as written).
fn raised(
    scene: &str,
    method: &str,
    overrides: &[String],
    gap: impl Fn(&Setup) -> (f64, f64),
) -> Result<Setup, EvalError> {
    let s = measure::setup(scene, method, overrides)?;
    let (floor, want) = gap(&s);
    let lowest = s.mesh.positions().iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let mut t = s.scene.placement.translate;
    t[1] += floor + want - lowest;
    let mut over = overrides.to_vec();
    over.push(format!("placement.translate=[{}, {}, {}]", t[0], t[1], t[2]));
    measure::setup(scene, method, &over)
}

fn pile(method: &str, n: f64, drop: f64) -> Result<Probe, EvalError> {
    let s = raised("pile", method, &substeps(method, n), |_| (0.0, drop))?;
    let g = DVec3::from(s.scene.gravity).length();
    run_judged(&s, (2.0 * drop / g).sqrt() + 1.0)
}

fn on_trampoline(method: &str, ratio: f64, n: f64) -> Result<Probe, EvalError> {
    let mut s = measure::setup("trampoline", method, &substeps(method, n))?;
    let sheet = s.scene.material.density * measure::area(s.mesh.positions(), s.mesh.triangles());
    for body in s.bodies.iter_mut().filter(|b| b.mass.is_some()) {
        body.mass = Some(ratio * sheet);
    }
    run_judged(&s, BOX_TIME)
}

fn impact(method: &str, v: f64, y: f64) -> Result<Probe, EvalError> {
    let (scene, over) = match method {
        "cloth" => ("drape", vec![format!("solver.step={y}")]),
        "pbd" => ("pbd-drape", substeps(method, y)),
        _ => ("drape", substeps(method, y)),
    };
    let s = raised(scene, method, &over, |s| {
        // The top of the highest fixed collider (the ball), and the gap a fall turns into speed `v`.
        let top = |b: &Body| {
            let above = b.origin + DVec3::Y * 1e3;
            above.y - b.at(0.0).surface(above).0
        };
        let highest = s.bodies.iter().filter(|b| b.mass.is_none()).map(top).fold(f64::NEG_INFINITY, f64::max);
        (highest, v * v / (2.0 * DVec3::from(s.scene.gravity).length()))
    })?;
    let g = DVec3::from(s.scene.gravity).length();
    run_judged(&s, v / g + 1.0)
}

/// Run `s` for `seconds` and classify it by its tunnelling checks, made at every 1/60 s of simulated
/// time: the first crossing ends the run (a cloth through itself or a collider only gets slower).
fn run_judged(s: &Setup, seconds: f64) -> Result<Probe, EvalError> {
    let mut solver = measure::build(s)?;
    let rest = s.mesh.positions().to_vec();
    let (mut found, mut checked, mut steps) = (None, -1.0, 0);
    let mut check = |solver: &mut dyn Solver, t: f64| {
        steps += 1;
        let frame = (t / FRAME).floor();
        if frame > checked {
            checked = frame;
            found = tunnelled(s, &*solver, solver.positions(), t);
            if let Some(reason) = &found {
                return Err(SolverError::Diverged { step: steps - 1, time: t, reason: reason.clone() });
            }
        }
        Ok(())
    };
    let stop = Stop { max_time: seconds, max_steps: u64::MAX, rest: 0.0 };
    let run = measure::run_driven(solver.as_mut(), &rest, stop, &mut check);
    let found = found.or_else(|| tunnelled(s, solver.as_ref(), &run.positions, run.sim_time));
    let area = measure::area_change(&run.positions, s);
    Ok(Probe::new(run, f64::NAN, area, false, found))
}

/// How the cloth at `x` (time `t`) went through a collider or itself, if it did (module documentation).
fn tunnelled(s: &Setup, solver: &dyn Solver, x: &[DVec3], t: f64) -> Option<String> {
    let edges = &s.mesh.topology().edges;
    let rest = s.mesh.positions();
    let depth =
        0.5 * edges.iter().map(|e| rest[e.v[0]].distance(rest[e.v[1]])).sum::<f64>() / edges.len().max(1) as f64;
    let midpoints = edges.iter().map(|e| 0.5 * (x[e.v[0]] + x[e.v[1]]));
    let points: Vec<DVec3> = x.iter().copied().chain(midpoints).collect();
    for (b, body) in s.bodies.iter().enumerate().filter(|(_, b)| b.mass.is_none()) {
        let placed = body.at(t);
        if let Some(d) = points.iter().map(|&p| placed.surface(p).0).find(|&d| d < -depth) {
            return Some(format!("the cloth is {:.1} mm inside collider {b}, more than half an edge", -1e3 * d));
        }
    }
    let lowest = x.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let poses = solver.body_poses();
    for ((b, _), (centre, _)) in s.bodies.iter().enumerate().zip(&poses).filter(|((_, body), _)| body.mass.is_some()) {
        if centre.y < lowest {
            return Some(format!("body {b} is {:.0} mm below the cloth's lowest particle", 1e3 * (lowest - centre.y)));
        }
    }
    // Through itself: judged where the scene asks the method to prevent it.
    let crossings = if s.scene.solver.self_collision { self_intersections(x, s.mesh.triangles()) } else { 0 };
    (crossings > 0).then(|| format!("the cloth crosses itself ({crossings} pair(s) of triangles)"))
}
