//! `shellwarp sim`: run a scene headless for N steps and report statistics.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use glam::DVec3;
use serde::Serialize;
use shellwarp::solver::{self, StepStats};

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

impl Timing {
    fn of(samples: &[f64]) -> Self {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let total: f64 = s.iter().sum::<f64>() + 0.0; // `+ 0.0` turns the empty sum's −0.0 into 0.0
        let n = s.len().max(1) as f64;
        let pick = |i: usize| s.get(i).copied().unwrap_or(0.0);
        Timing { mean: total / n, median: pick(s.len() / 2), min: pick(0), max: pick(s.len().saturating_sub(1)), total }
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
}

/// Run the simulation and print the report; exit code 1 if it diverged.
pub fn run(args: &SimArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let mut solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    let mut times = Vec::with_capacity(args.steps as usize);
    let mut last = StepStats::default();
    let mut iterations = 0u64;
    let mut unconverged = 0u64;
    let mut diverged = None;
    // The positions to report: the current ones, or the last finite state before a divergence.
    let mut finite: Vec<DVec3> = solver.positions().to_vec();
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
    let (lo, hi) = finite.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    if let Some(path) = &args.obj {
        shellwarp::mesh::obj::save_obj(path, &finite, setup.mesh.triangles())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let report = Report {
        scene: setup.scene.name.clone(),
        method: solver.method().to_string(),
        vertices: setup.mesh.vertex_count(),
        steps: times.len() as u64,
        time_step: solver.time_step(),
        sim_time: last.sim_time,
        step_seconds: Timing::of(&times),
        final_energy: last.energy,
        final_residual: last.residual,
        final_relative_residual: last.relative_residual,
        total_iterations: iterations,
        converged: !times.is_empty() && unconverged == 0,
        unconverged_steps: unconverged,
        bbox_min: lo.to_array(),
        bbox_max: hi.to_array(),
        diverged,
        notes: solver.notes(),
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
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
        println!("bounding box: {:?} .. {:?}", report.bbox_min, report.bbox_max);
        if report.unconverged_steps > 0 {
            println!(
                "{} of {} steps stopped above the solver tolerance (last relative residual {:.2e})",
                report.unconverged_steps, report.steps, report.final_relative_residual
            );
        }
        report.notes.iter().for_each(|n| println!("note: {n}"));
    }
    match &report.diverged {
        Some(reason) => {
            eprintln!("error: simulation {reason}");
            Ok(ExitCode::FAILURE)
        }
        None => Ok(ExitCode::SUCCESS),
    }
}
