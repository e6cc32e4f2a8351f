//! `shellwarp sim`: run a scene headless for N steps and report statistics.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use glam::DVec3;
use serde::Serialize;
use shellwarp::solver::{self, Drag, DragKind, StepStats, quality};

use super::SceneArgs;

/// Arguments of `shellwarp sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Number of fixed steps to take.
    #[arg(long, default_value_t = 30)]
    steps: u64,
    /// Write the final mesh (the last finite state if the run diverged) to this OBJ file.
    #[arg(long)]
    obj: Option<PathBuf>,
    /// Print one JSON object instead of a text summary.
    #[arg(long)]
    json: bool,
    /// Position drag held from the first step: VERTEX:X,Y,Z (repeatable).
    #[arg(long, value_name = "VERTEX:X,Y,Z", value_parser = super::parse_drag)]
    drag: Vec<(usize, DVec3)>,
    /// Orientation drag held from the first step: VERTEX:WX,WY,WZ, a rotation vector in radians
    /// (repeatable; methods with orientation drags only).
    #[arg(long, value_name = "VERTEX:WX,WY,WZ", value_parser = super::parse_drag)]
    twist: Vec<(usize, DVec3)>,
}

/// Summary statistics of a series of seconds; all zero when no step completed.
#[derive(Debug, Serialize)]
struct Timing {
    mean: f64,
    median: f64,
    min: f64,
    max: f64,
    total: f64,
}

/// Shortest and longest step time the median histogram resolves, seconds (others go to the end bins).
const HISTOGRAM_RANGE: (f64, f64) = (1e-9, 1e5);
/// Ratio between neighbouring histogram bins: the median is exact to about ±0.05 %.
const BIN_RATIO: f64 = 1.001;

/// Step times in constant memory, however many steps: exact count, total, minimum and maximum, and
/// the median from a histogram of log-spaced bins.
#[derive(Debug)]
struct StepTimes {
    count: u64,
    total: f64,
    min: f64,
    max: f64,
    bins: Vec<u64>,
}

impl StepTimes {
    fn new() -> Self {
        let (lo, hi) = HISTOGRAM_RANGE;
        let bins = ((hi / lo).ln() / BIN_RATIO.ln()).ceil() as usize + 1;
        Self { count: 0, total: 0.0, min: f64::INFINITY, max: f64::NEG_INFINITY, bins: vec![0; bins] }
    }

    fn push(&mut self, seconds: f64) {
        self.count += 1;
        self.total += seconds;
        self.min = self.min.min(seconds);
        self.max = self.max.max(seconds);
        let bin = ((seconds.max(HISTOGRAM_RANGE.0) / HISTOGRAM_RANGE.0).ln() / BIN_RATIO.ln()) as usize;
        let last = self.bins.len() - 1;
        self.bins[bin.min(last)] += 1;
    }

    /// The statistics (all zero without samples). The median is the upper one for an even count.
    fn summary(&self) -> Timing {
        if self.count == 0 {
            return Timing { mean: 0.0, median: 0.0, min: 0.0, max: 0.0, total: 0.0 };
        }
        let rank = self.count / 2 + 1;
        let mut seen = 0;
        let bin = self.bins.iter().position(|&c| {
            seen += c;
            seen >= rank
        });
        // The bin's geometric centre, never outside the observed range.
        let centre = bin.map_or(self.max, |b| HISTOGRAM_RANGE.0 * BIN_RATIO.powf(b as f64 + 0.5));
        Timing {
            mean: self.total / self.count as f64,
            median: centre.clamp(self.min, self.max),
            min: self.min,
            max: self.max,
            total: self.total,
        }
    }
}

/// The JSON report.
#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    method: String,
    vertices: usize,
    steps: u64,
    time_step: f64,
    sim_time: f64,
    step_seconds: Timing,
    final_energy: f64,
    final_residual: f64,
    /// The last step's residual relative to its solve's scale (what the tolerance bounds).
    final_relative_residual: f64,
    total_iterations: u64,
    /// Whether every completed step's inner solve met its tolerance (and at least one step completed).
    converged: bool,
    /// Steps whose inner solve stopped above its tolerance.
    unconverged_steps: u64,
    /// Bounding box of the final positions (of the last finite state if the run diverged).
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    diverged: Option<String>,
    /// Choices the method made by itself (e.g. an automatic substep).
    notes: Vec<String>,
    /// Relative area change of the final shape.
    area_change: f64,
    /// The final shape's estimated relative error against the full discrete shell (a few Newton
    /// iterations of its equations, drags pinned); null for the cloths and `rigid`.
    estimated_error: Option<f64>,
}

/// Run the simulation and print the report; exit code 1 if it diverged.
pub fn run(args: &SimArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let mut solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    let drags = (args.drag.iter().map(|&(vertex, p)| Drag { vertex, kind: DragKind::Position(p) }))
        .chain(args.twist.iter().map(|&(vertex, w)| Drag { vertex, kind: DragKind::Orientation(w) }));
    for drag in drags {
        solver.drags_mut().add(drag).with_context(|| format!("a drag on vertex {}", drag.vertex))?;
    }
    let mut times = StepTimes::new();
    let mut last = StepStats::default();
    let mut iterations = 0u64;
    let mut unconverged = 0u64;
    let mut diverged = None;
    // The positions to report: the current ones, or the last finite state before a divergence.
    let mut finite: Vec<DVec3> = solver.positions().to_vec();
    // The steps on a pool thread: each step's joins then start without a hand-over (`on_pool`).
    shellwarp::threads::on_pool(|| {
        for _ in 0..args.steps {
            match solver.step() {
                Ok(stats) => {
                    times.push(stats.wall_seconds);
                    iterations += u64::from(stats.iterations);
                    unconverged += u64::from(!stats.converged);
                    last = stats;
                    finite.copy_from_slice(solver.positions());
                }
                Err(e) => {
                    diverged = Some(e.to_string());
                    break;
                }
            }
        }
    });
    let (lo, hi) = finite.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    if let Some(path) = &args.obj {
        // The error names the file already.
        shellwarp::mesh::obj::save_obj(path, &finite, setup.mesh.triangles()).context("writing the final mesh")?;
    }
    let estimated_error = if quality::judged(solver.method()) && diverged.is_none() {
        Some(quality::estimate(&setup, &finite, solver.drags()).context("estimating the error")?)
    } else {
        None
    };
    let report = Report {
        scene: setup.scene.name.clone(),
        method: solver.method().to_string(),
        vertices: setup.mesh.vertex_count(),
        steps: times.count,
        time_step: solver.time_step(),
        sim_time: last.sim_time,
        step_seconds: times.summary(),
        final_energy: last.energy,
        final_residual: last.residual,
        final_relative_residual: last.relative_residual,
        total_iterations: iterations,
        converged: times.count > 0 && unconverged == 0,
        unconverged_steps: unconverged,
        bbox_min: lo.to_array(),
        bbox_max: hi.to_array(),
        diverged,
        notes: solver.notes(),
        area_change: setup.mesh.area_change(&finite),
        estimated_error,
    };
    if args.json {
        say!("{}", serde_json::to_string(&report)?);
    } else {
        say!(
            "{} with {}: {} vertices, {} steps of {:.5} s, mean step {:.3} ms (max {:.3} ms), energy {:.6e} J",
            report.scene,
            report.method,
            report.vertices,
            report.steps,
            report.time_step,
            report.step_seconds.mean * 1e3,
            report.step_seconds.max * 1e3,
            report.final_energy
        );
        say!("bounding box: {:?} .. {:?}", report.bbox_min, report.bbox_max);
        let estimate = report.estimated_error.map_or(String::new(), |e| format!(", estimated error {:.2}%", 100.0 * e));
        say!("area change {:+.3}%{estimate}", 100.0 * report.area_change);
        if report.unconverged_steps > 0 {
            say!(
                "{} of {} steps stopped above the solver tolerance (last relative residual {:.2e})",
                report.unconverged_steps,
                report.steps,
                report.final_relative_residual
            );
        }
        for n in &report.notes {
            say!("note: {n}");
        }
    }
    match &report.diverged {
        Some(reason) => {
            eprintln!("error: simulation {reason}");
            Ok(ExitCode::FAILURE)
        }
        None => Ok(ExitCode::SUCCESS),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_times_are_exact_except_the_median_within_a_bin() {
        let mut t = StepTimes::new();
        assert_eq!(t.summary().median, 0.0);
        t.push(0.25);
        assert_eq!(t.summary().median, 0.25, "one sample is its own median");
        let mut t = StepTimes::new();
        for ms in (1..=1001).rev() {
            t.push(f64::from(ms) * 1e-3);
        }
        let s = t.summary();
        assert_eq!((s.min, s.max), (1e-3, 1001.0 * 1e-3));
        assert!((s.total - 501.501).abs() < 1e-9 && (s.mean - 0.501).abs() < 1e-12, "{s:?}");
        assert!((s.median / 0.501 - 1.0).abs() < 1e-3, "median {}", s.median);
        // Out-of-range samples land in the end bins but keep min and max exact.
        t.push(0.0);
        t.push(1e9);
        assert_eq!((t.summary().min, t.summary().max), (0.0, 1e9));
    }
}
