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
    /// Image size, WIDTHxHEIGHT (at most the GPU's largest texture side).
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Overlay the mesh's edges.
    #[arg(long)]
    wireframe: bool,
    /// Output PNG file.
    #[arg(long)]
    out: PathBuf,
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
    let image = headless.render(&frame).context("rendering")?;
    // The error names the file already.
    save_png(&image, &args.out).context("saving the picture")?;
    println!("{}: {} steps of {} → {}", setup.scene.name, args.frames, solver.method(), args.out.display());
    Ok(ExitCode::SUCCESS)
}
