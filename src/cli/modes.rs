//! `shellwarp modes`: the modal analysis of a shell scene — eigenvalues, frequencies, residuals and
//! the precompute time by stage.

use std::process::ExitCode;

use serde::Serialize;
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
    /// Also write the problem for other solvers: DIR/K.mtx and DIR/M.mtx (Matrix Market, free DOFs,
    /// exactly what the analysis solves) and DIR/shellwarp.json (shift, tolerances, eigenvalues, times).
    #[arg(long, value_name = "DIR")]
    export: Option<std::path::PathBuf>,
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
    let masses = setup.masses();
    let problem = ModalProblem::of_scene(&setup, &masses, args.modes.map_or(setup.scene.solver.modes, |m| m as usize))?;
    let bar = indicatif::ProgressBar::new(100).with_message("modal analysis");
    if args.json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let a = analyse(&problem, &|f| bar.set_position((f * 100.0) as u64))?;
    bar.finish_and_clear();
    let (t, above) = (a.timings, a.above_target());
    if let Some(dir) = &args.export {
        export(dir, &problem, &a)?;
    }
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
        say!("{}", serde_json::to_string(&report)?);
        return Ok(ExitCode::SUCCESS);
    }
    say!("{}: {} vertices ({} anchored), {} modes", report.scene, report.vertices, report.anchored, report.modes);
    say!("{:>5} {:>14} {:>12} {:>12}", "mode", "λ (1/s²)", "f (Hz)", "residual");
    for (j, ((l, f), r)) in
        report.eigenvalues.iter().zip(&report.frequencies_hz).zip(&report.relative_residuals).enumerate()
    {
        let flag = if report.above_target.contains(&j) { " *" } else { "" };
        say!("{j:>5} {l:>14.6e} {f:>12.5} {r:>12.2e}{flag}");
    }
    for (j, floor) in above {
        say!(
            "* mode {j}: residual above {MAX_RESIDUAL:.0e}: it stopped improving at round-off, under the bound \
             64ε·λmax/λ = {floor:.1e} (no f64 vector does better; see the docs of MAX_RESIDUAL)"
        );
    }
    say!(
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

/// What `--export` writes beside the matrices.
#[derive(Debug, Serialize)]
struct Exported {
    dofs: usize,
    modes: usize,
    shift: f64,
    lanczos_tolerance: f64,
    target_residual: f64,
    eigenvalues: Vec<f64>,
    seconds: PrecomputeTimings,
    total_seconds: f64,
}

/// Write K, M (Matrix Market) and the analysis' own figures into `dir`.
fn export(
    dir: &std::path::Path,
    problem: &ModalProblem<'_>,
    a: &shellwarp::solver::modal::compute::ModalAnalysis,
) -> anyhow::Result<()> {
    use anyhow::Context;
    use shellwarp::linalg::matrix_market::{diagonal_text, symmetric_text};
    use shellwarp::solver::modal::compute::{LANCZOS_TOLERANCE, TARGET_RESIDUAL, system};
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let sys = system(problem)?;
    let note = "shellwarp modal analysis: free DOFs of the anchored shell, x/y/z of each free vertex in turn";
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        shellwarp::atomic::write(&path, text.as_bytes()).with_context(|| format!("writing {}", path.display()))
    };
    write("K.mtx", symmetric_text(sys.k.matrix(), &format!("{note}\nK: exact rest stiffness, N/m")))?;
    write("M.mtx", diagonal_text(&sys.mass, &format!("{note}\nM: lumped mass, kg")))?;
    let t = a.timings;
    let info = Exported {
        dofs: sys.mass.len(),
        modes: a.basis.modes(),
        shift: sys.shift,
        lanczos_tolerance: LANCZOS_TOLERANCE,
        target_residual: TARGET_RESIDUAL,
        eigenvalues: a.basis.eigenvalues.clone(),
        seconds: t,
        total_seconds: t.assembly + t.factorisation + t.eigen,
    };
    write("shellwarp.json", serde_json::to_string_pretty(&info)?)
}
