//! Shared by the modal twist tests: a strip's tip twisted about its axis by an orientation drag,
//! ramped over a second as a hand would turn it, with the worst figures of every step.

use glam::DVec3;
use shellwarp::eval::measure::area_change;
use shellwarp::scene::Setup;
use shellwarp::solver::{Drag, DragKind, Solver};

/// Steps over which the twist target turns (1 s), as a hand would turn it; then it holds.
pub const RAMP: usize = 30;

/// Vertices per cross-section row of the strips twisted here.
pub const PER_ROW: usize = 5;

/// The worst figures of a twist run over every step.
pub struct Twist {
    /// Largest relative change of a cross-section's width.
    pub width: f64,
    /// Largest twist between neighbouring rows, rad.
    pub row_step: f64,
    /// Largest change of one row's twist from one step to the next, rad.
    pub time_step: f64,
    /// Largest relative change of the centreline's length (from the second clamped row to the tip).
    pub centreline: f64,
    /// Largest relative change of the area.
    pub area: f64,
    /// Largest angle between the normals of two triangles sharing an edge, rad (a flipped triangle
    /// makes it exceed a right angle).
    pub fold: f64,
    /// Final twist of the tip row, rad.
    pub end: f64,
    /// Relative area change at the last step (signed).
    pub end_area: f64,
}

/// The relative area change of the strip of `setup` if its free part were a helicoid twisted by
/// `degrees` about a straight axis, its clamped part flat. The free part (length `L`, width `w`,
/// twist rate `k = θ/L`) is `(s, r cos ks, r sin ks)` for `s ∈ [0, L]`, `r ∈ [−w/2, w/2]`, with area
/// element `√(1 + k²r²) dr ds`: `A = L ∫ √(1 + k²r²) dr = L (w/2 √(1 + (kw/2)²) + asinh(kw/2)/k)`
/// (every ruling keeps its length `w`; the edges, at `r = ±w/2`, lengthen by `√(1 + (kw/2)²)`).
pub fn helicoid_area_change(setup: &Setup, degrees: f64) -> f64 {
    let rest = setup.mesh.positions();
    let w = (rest[PER_ROW - 1] - rest[0]).length();
    let end = rest.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    let start = rest.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
    let clamp = setup.anchors.iter().map(|&v| rest[v].x).fold(start, f64::max);
    let (total, free) = (end - start, end - clamp);
    let k = degrees.to_radians() / free;
    let half = 0.5 * k * w;
    let twisted = if k == 0.0 { free * w } else { free * (0.5 * w * (1.0 + half * half).sqrt() + half.asinh() / k) };
    (twisted + (total - free) * w) / (total * w) - 1.0
}

/// Twist angle of each cross-section row about the beam axis, unwrapped from the clamp outwards.
pub fn twist_profile(x: &[DVec3], rows: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(rows);
    let mut prev = 0.0;
    for i in 0..rows {
        let d = x[i * PER_ROW + PER_ROW - 1] - x[i * PER_ROW];
        let mut a = (-d.y).atan2(d.z);
        while a - prev > std::f64::consts::PI {
            a -= std::f64::consts::TAU;
        }
        while a - prev < -std::f64::consts::PI {
            a += std::f64::consts::TAU;
        }
        out.push(a);
        prev = a;
    }
    out
}

/// Twist the tip (vertex `tip`) of the strip of `setup` by `degrees` about its axis with an
/// orientation drag on solver `s`, checking every one of 90 steps.
pub fn twist(s: &mut dyn Solver, setup: &Setup, tip: usize, degrees: f64) -> Twist {
    let rest = setup.mesh.positions();
    let rows = rest.len() / PER_ROW;
    let width = (rest[PER_ROW - 1] - rest[0]).length();
    let centreline =
        |x: &[DVec3]| (1..rows - 1).map(|i| (x[(i + 1) * PER_ROW + 2] - x[i * PER_ROW + 2]).length()).sum::<f64>();
    let length = centreline(rest);
    let target = |step: usize| DVec3::X * degrees.to_radians() * ((step + 1).min(RAMP) as f64 / RAMP as f64);
    let id = s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Orientation(target(0)) }).unwrap();
    let mut worst = Twist {
        width: 0.0,
        row_step: 0.0,
        time_step: 0.0,
        centreline: 0.0,
        area: 0.0,
        fold: 0.0,
        end: 0.0,
        end_area: 0.0,
    };
    let tris = setup.mesh.triangles();
    let mut previous = vec![0.0; rows];
    for step in 0..90 {
        s.drags_mut().retarget(id, DragKind::Orientation(target(step))).unwrap();
        s.step().unwrap_or_else(|e| panic!("{degrees}°, step {step}: {e}"));
        let x = s.positions();
        assert!(x.iter().all(|p| p.is_finite()), "{degrees}°, step {step}: finite");
        for i in 0..rows {
            let w = (x[i * PER_ROW + PER_ROW - 1] - x[i * PER_ROW]).length();
            worst.width = worst.width.max((w / width - 1.0).abs());
        }
        worst.centreline = worst.centreline.max((centreline(x) / length - 1.0).abs());
        worst.end_area = area_change(x, setup);
        worst.area = worst.area.max(worst.end_area.abs());
        let normal = |t: usize| (x[tris[t][1]] - x[tris[t][0]]).cross(x[tris[t][2]] - x[tris[t][0]]);
        for h in &setup.mesh.topology().hinges {
            worst.fold = worst.fold.max(normal(h.faces[0]).angle_between(normal(h.faces[1])));
        }
        let profile = twist_profile(x, rows);
        for w in profile.windows(2) {
            worst.row_step = worst.row_step.max((w[1] - w[0]).abs());
        }
        for (a, b) in profile.iter().zip(&previous) {
            worst.time_step = worst.time_step.max((a - b).abs());
        }
        previous = profile;
    }
    worst.end = previous[rows - 1];
    worst
}
