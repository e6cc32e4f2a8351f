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
    /// Write the final mesh to this OBJ file.
    #[arg(long)]
    obj: Option<PathBuf>,
    /// Print one JSON object instead of a text summary.
    #[arg(long)]
    json: bool,
}

/// Summary statistics of a series of seconds.
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
        let total: f64 = s.iter().sum();
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
    total_iterations: u64,
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
    diverged: Option<String>,
}

/// Run the simulation and print the report; exit code 1 if it diverged.
pub fn run(args: &SimArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let mut solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    let mut times = Vec::with_capacity(args.steps as usize);
    let mut last = StepStats::default();
    let mut iterations = 0u64;
    let mut diverged = None;
    for _ in 0..args.steps {
        match solver.step() {
            Ok(stats) => {
                times.push(stats.wall_seconds);
                iterations += u64::from(stats.iterations);
                last = stats;
            }
            Err(e) => {
                diverged = Some(e.to_string());
                break;
            }
        }
    }
    let (lo, hi) =
        solver.positions().iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    if let Some(path) = &args.obj {
        shellwarp::mesh::obj::save_obj(path, solver.positions(), setup.mesh.triangles())
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
        total_iterations: iterations,
        bbox_min: lo.to_array(),
        bbox_max: hi.to_array(),
        diverged,
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
    }
    match &report.diverged {
        Some(reason) => {
            eprintln!("error: simulation diverged: {reason}");
            Ok(ExitCode::FAILURE)
        }
        None => Ok(ExitCode::SUCCESS),
    }
}
