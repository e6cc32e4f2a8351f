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
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Number of solver steps before the picture is taken.
    #[arg(long, default_value_t = 30)]
    frames: u64,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Overlay the mesh's edges.
    #[arg(long)]
    wireframe: bool,
    /// Output PNG file.
    #[arg(long)]
    out: PathBuf,
}

/// Parse `WIDTHxHEIGHT` (each 1..=8192).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT, e.g. 1280x720")?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&n| (1..=8192).contains(&n));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("`{s}`: width and height must be whole numbers from 1 to 8192")),
    }
}

/// Simulate, draw, save.
pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    let setup = args.scene.load()?;
    let mut solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    let mut time = 0.0;
    for _ in 0..args.frames {
        match solver.step() {
            Ok(stats) => time = stats.sim_time,
            Err(e) => bail!("{}: simulation diverged before the picture: {e}", setup.origin.label),
        }
    }
    let view = SceneView::new(&setup);
    let drags: Vec<_> = solver.drags().iter().copied().collect();
    let frame = view.frame(view.camera(), solver.positions(), time, &drags, ViewOptions { wireframe: args.wireframe });
    let mut headless = Headless::new(args.size.0, args.size.1).context("starting the renderer")?;
    let image = headless.render(&frame).context("rendering")?;
    save_png(&image, &args.out).with_context(|| format!("saving {}", args.out.display()))?;
    println!("{}: {} steps of {} → {}", setup.scene.name, args.frames, solver.method(), args.out.display());
    Ok(ExitCode::SUCCESS)
}
