//! `shellwarp modes`: the modal analysis of a shell scene — eigenvalues, frequencies, residuals and
//! the precompute time by stage.

use std::process::ExitCode;

use serde::Serialize;
use shellwarp::energy::ShellStiffness;
use shellwarp::solver::modal::compute::{EIGEN_BLOCK, MAX_RESIDUAL, ModalProblem, PrecomputeTimings, analyse};

use super::SceneArgs;

/// Arguments of `shellwarp modes`.
#[derive(Debug, clap::Args)]
pub struct ModesArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Number of modes (default: the scene's `solver.modes`).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    modes: Option<u32>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    vertices: usize,
    anchored: usize,
    modes: usize,
    rigid_modes_skipped: usize,
    eigenvalues: Vec<f64>,
    frequencies_hz: Vec<f64>,
    relative_residuals: Vec<f64>,
    /// Modes whose residual is above 1e-8, accepted only within the round-off floor.
    above_target: Vec<usize>,
    lambda_max_bound: f64,
    block_solves: usize,
    vectors_per_block: usize,
    seconds: PrecomputeTimings,
    total_seconds: f64,
}

/// Compute (never from the cache: this command measures) and print.
pub fn run(args: &ModesArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let m = &setup.scene.material;
    let masses = setup.masses();
    let problem = ModalProblem {
        mesh: &setup.mesh,
        anchors: &setup.anchors,
        masses: &masses,
        stiffness: ShellStiffness::from(m),
        modes: args.modes.map_or(setup.scene.solver.modes, |m| m as usize),
        keep_rigid: false,
    };
    let bar = indicatif::ProgressBar::new(100).with_message("modal analysis");
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let a = analyse(&problem, &|f| bar.set_position((f * 100.0) as u64))?;
    bar.finish_and_clear();
    let (t, above) = (a.timings, a.above_target());
    let report = Report {
        scene: setup.scene.name.clone(),
        vertices: setup.mesh.vertex_count(),
        anchored: setup.anchors.len(),
        modes: a.basis.modes(),
        rigid_modes_skipped: a.rigid_modes,
        eigenvalues: a.basis.eigenvalues.clone(),
        frequencies_hz: a.basis.frequencies_hz(),
        relative_residuals: a.residuals.clone(),
        above_target: above.iter().map(|(j, _)| *j).collect(),
        lambda_max_bound: a.lambda_max,
        block_solves: a.solves,
        vectors_per_block: EIGEN_BLOCK,
        seconds: t,
        total_seconds: t.assembly + t.factorisation + t.eigen,
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("{}: {} vertices ({} anchored), {} modes", report.scene, report.vertices, report.anchored, report.modes);
    println!("{:>5} {:>14} {:>12} {:>12}", "mode", "λ (1/s²)", "f (Hz)", "residual");
    for (j, ((l, f), r)) in
        report.eigenvalues.iter().zip(&report.frequencies_hz).zip(&report.relative_residuals).enumerate()
    {
        let flag = if report.above_target.contains(&j) { " *" } else { "" };
        println!("{j:>5} {l:>14.6e} {f:>12.5} {r:>12.2e}{flag}");
    }
    for (j, floor) in above {
        println!(
            "* mode {j}: residual above {MAX_RESIDUAL:.0e}: it stopped improving at round-off, under the bound \
             64ε·λmax/λ = {floor:.1e} (no f64 vector does better; see the docs of MAX_RESIDUAL)"
        );
    }
    println!(
        "precompute: assembly {:.1} ms, factorisation {:.1} ms, eigen {:.1} ms ({} block solves of {}), total {:.1} ms",
        t.assembly * 1e3,
        t.factorisation * 1e3,
        t.eigen * 1e3,
        report.block_solves,
        report.vectors_per_block,
        report.total_seconds * 1e3
    );
    Ok(ExitCode::SUCCESS)
}
