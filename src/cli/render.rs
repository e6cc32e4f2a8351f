//! `shellwarp render`: run a scene for some frames headless and save a PNG.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use shellwarp::app::scene_view::{SceneView, ViewOptions};
use shellwarp::render::{Headless, save_png};
use shellwarp::solver;

use super::SceneArgs;

/// Arguments of `shellwarp render`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("output").required(true).args(["out", "out_dir"])))]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Number of solver steps before the picture is taken (with --out-dir: steps to simulate).
    #[arg(long, default_value_t = 30)]
    frames: u64,
    /// With --out-dir: save a picture every K steps.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..), requires = "out_dir")]
    every: u64,
    /// Write a numbered PNG sequence into this directory (frame-000001.png, ...) instead of one picture.
    #[arg(long, value_name = "DIR")]
    out_dir: Option<PathBuf>,
    /// Image size, WIDTHxHEIGHT (at most the GPU's largest texture side).
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Overlay the mesh's edges.
    #[arg(long)]
    wireframe: bool,
    /// Output PNG file.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Parse `WIDTHxHEIGHT`, each side from 1 to `max`.
pub fn parse_size_up_to(s: &str, max: u32) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT, e.g. 1280x720")?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&n| (1..=max).contains(&n));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("`{s}`: width and height must be whole numbers from 1 to {max}")),
    }
}

/// Parse `WIDTHxHEIGHT` for an offscreen picture: the GPU's own limit is checked when it is opened.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    parse_size_up_to(s, 65_536)
}

/// Simulate, draw, save.
pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let mut solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    // Open the GPU before simulating: a missing adapter or a size it cannot draw fails at once.
    let mut headless = Headless::new(args.size.0, args.size.1).context("starting the renderer")?;
    let view = SceneView::new(&setup);
    let options = ViewOptions { wireframe: args.wireframe };
    let mut picture = |solver: &dyn solver::Solver, time: f64, path: &std::path::Path| -> anyhow::Result<()> {
        let drags: Vec<_> = solver.drags().iter().copied().collect();
        let frame = view.frame(view.camera(), solver.positions(), time, &drags, options, &solver.body_poses());
        let image = headless.render(&frame).context("rendering")?;
        // Written to a temporary file and renamed: an interrupted run leaves no partial PNG under a final
        // name. The error names the file already.
        save_png(&image, path).context("saving the picture")
    };
    if let Some(dir) = &args.out_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let pictures = args.frames / args.every;
    let digits = pictures.to_string().len().max(6);
    let mut time = 0.0;
    for step in 1..=args.frames {
        match solver.step() {
            Ok(stats) => time = stats.sim_time,
            Err(e) => bail!("{}: simulation diverged at step {step}: {e}", setup.origin.label),
        }
        if let Some(dir) = &args.out_dir
            && step % args.every == 0
        {
            picture(solver.as_ref(), time, &dir.join(format!("frame-{:0digits$}.png", step / args.every)))?;
        }
    }
    match (&args.out, &args.out_dir) {
        (Some(out), _) => {
            picture(solver.as_ref(), time, out)?;
            say!("{}: {} steps of {} → {}", setup.scene.name, args.frames, solver.method(), out.display());
        }
        (None, Some(dir)) => say!(
            "{}: {} steps of {}, {pictures} pictures (every {} steps) → {}/frame-*.png",
            setup.scene.name,
            args.frames,
            solver.method(),
            args.every,
            dir.display()
        ),
        (None, None) => bail!("give --out FILE.png or --out-dir DIR"),
    }
    Ok(ExitCode::SUCCESS)
}
