//! `shellwarp view` (and plain `shellwarp`): the interactive viewer.

use std::path::PathBuf;
use std::process::ExitCode;

use glam::DVec3;
use shellwarp::app::soak::SoakOptions;
use shellwarp::app::viewer::{self, ViewerOptions};
use shellwarp::solver::{Drag, DragKind};

use super::render::parse_size_up_to;

/// Arguments of `shellwarp view`.
#[derive(Debug, Clone, clap::Parser)]
#[command(name = "view")]
pub struct ViewArgs {
    /// Built-in scene name or path to a scene TOML file.
    #[arg(long, short = 's', default_value = "cantilever")]
    scene: String,
    /// Method to run instead of the scene's own.
    #[arg(long, short = 'm')]
    method: Option<String>,
    /// Override a scene value, e.g. `--set material.k_bend=0.02` (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Window size, WIDTHxHEIGHT (each side at most 8192).
    #[arg(long, default_value = "1280x760", value_parser = parse_window_size)]
    size: (u32, u32),
    /// Start paused.
    #[arg(long)]
    paused: bool,
    /// Render this many frames in the window, save a screenshot to --out, and exit.
    #[arg(long, value_name = "N")]
    screenshot_after: Option<u64>,
    /// Screenshot file (F12, and --screenshot-after).
    #[arg(long, default_value = "shellwarp-screenshot.png")]
    out: PathBuf,
    /// Scripted position drag, sent through the same command channel as the mouse: VERTEX:X,Y,Z
    /// (target in metres; repeatable).
    #[arg(long, value_name = "VERTEX:X,Y,Z", value_parser = super::parse_drag)]
    drag: Vec<(usize, DVec3)>,
    /// Scripted orientation drag, like --drag: VERTEX:WX,WY,WZ (rotation vector, axis × angle in
    /// radians; repeatable).
    #[arg(long, value_name = "VERTEX:WX,WY,WZ", value_parser = super::parse_drag)]
    twist: Vec<(usize, DVec3)>,
    /// With --screenshot-after: also write the simulation state in the screenshot as JSON.
    #[arg(long, value_name = "FILE")]
    state_out: Option<PathBuf>,
    /// Run a reference ghost with this method on the same scene and drags, drawn as a wireframe, with
    /// the live relative error in the panel (refused if it cannot keep real time).
    #[arg(long, value_name = "METHOD")]
    ghost: Option<String>,
    /// Drive the window for this many seconds with a random script (drags, twists, parameter edits
    /// in and out of range, method and scene switches, resets), write a report and exit.
    #[arg(long, value_name = "SECONDS")]
    soak: Option<f64>,
    /// Where --soak writes its report (JSON).
    #[arg(long, value_name = "FILE", default_value = "soak-report.json")]
    soak_report: PathBuf,
    /// With --soak: switch only among these methods (comma-separated), and not between scenes.
    #[arg(long, value_name = "METHODS", value_delimiter = ',')]
    soak_methods: Vec<String>,
    /// With --soak: the script's seed.
    #[arg(long, value_name = "N", default_value_t = 1)]
    soak_seed: u64,
}

impl Default for ViewArgs {
    fn default() -> Self {
        <Self as clap::Parser>::parse_from(["view"])
    }
}

/// Parse a window size `WIDTHxHEIGHT`, each side from 1 to 8192.
fn parse_window_size(s: &str) -> Result<(u32, u32), String> {
    parse_size_up_to(s, 8192)
}

/// Open the viewer.
pub fn run(args: &ViewArgs) -> anyhow::Result<ExitCode> {
    let mut overrides = args.set.clone();
    if let Some(m) = &args.method {
        shellwarp::solver::registry::find(m)?;
        overrides.push(format!("solver.method={m}"));
    }
    let options = ViewerOptions {
        scene: args.scene.clone(),
        overrides,
        size: args.size,
        paused: args.paused,
        screenshot_after: args.screenshot_after,
        out: args.out.clone(),
        drags: args
            .drag
            .iter()
            .map(|&(vertex, p)| Drag { vertex, kind: DragKind::Position(p) })
            .chain(args.twist.iter().map(|&(vertex, w)| Drag { vertex, kind: DragKind::Orientation(w) }))
            .collect(),
        state_out: args.state_out.clone(),
        ghost: args.ghost.clone(),
        soak: args.soak.map(|seconds| SoakOptions {
            seconds,
            report: args.soak_report.clone(),
            methods: args.soak_methods.clone(),
            scenes: shellwarp::scene::builtin_names().into_iter().map(String::from).collect(),
            home: args.scene.clone(),
            seed: args.soak_seed,
        }),
    };
    for m in &args.soak_methods {
        shellwarp::solver::registry::find(m)?;
    }
    if let Some(g) = &args.ghost {
        shellwarp::solver::registry::find(g)?;
    }
    viewer::run(options).map_err(|e| anyhow::anyhow!(without_source_location(&format!("{e:#}"))))?;
    Ok(ExitCode::SUCCESS)
}

/// winit's OS errors begin with a place in winit's own source (`os error at /…/winit-0.30.13/src/…/mod.rs:765: `),
/// which means nothing to a user: drop it and keep the message.
fn without_source_location(message: &str) -> String {
    const MARK: &str = "os error at ";
    let Some(start) = message.find(MARK) else { return message.to_string() };
    let rest = &message[start + MARK.len()..];
    let end = rest.find(".rs:").and_then(|i| rest[i..].find(": ").map(|j| i + j + 2));
    match end {
        Some(end) => format!("{}{}", &message[..start], &rest[end..]),
        None => message.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn winit_source_locations_are_dropped() {
        let raw = "opening the display (is DISPLAY set? try xvfb-run): os error at /root/.cargo/registry/src/x/winit-0.30.13/src/platform_impl/linux/mod.rs:765: neither WAYLAND_DISPLAY nor DISPLAY is set.";
        assert_eq!(
            without_source_location(raw),
            "opening the display (is DISPLAY set? try xvfb-run): neither WAYLAND_DISPLAY nor DISPLAY is set."
        );
        assert_eq!(without_source_location("no location: fine"), "no location: fine");
    }
}
