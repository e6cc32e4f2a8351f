//! Subcommands. Each parses nothing itself: clap hands it typed arguments.

mod modes;
mod render;
mod scenes;
mod sim;
mod view;

use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

/// Real-time thin shells (modal warping, linear modal analysis, discrete shells) and implicit particle cloth.
#[derive(Debug, Parser)]
#[command(name = "shellwarp", version, about)]
pub struct Cli {
    /// What to do; without one, the viewer opens on the default scene.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Open the interactive viewer (the default).
    View(view::ViewArgs),
    /// List the built-in scenes and the registered methods.
    Scenes,
    /// Modal analysis of a shell scene: eigenvalues, frequencies, residuals, precompute time.
    Modes(modes::ModesArgs),
    /// Run a scene for some frames and save a picture (PNG), without a window.
    Render(render::RenderArgs),
    /// Run a scene headless and report timing, energy and the final bounding box.
    Sim(sim::SimArgs),
}

/// Which scene, with which method and overrides: shared by every subcommand that loads a scene.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// Built-in scene name (see `shellwarp scenes`) or path to a scene TOML file.
    #[arg(long, short = 's')]
    pub scene: String,
    /// Method to run instead of the scene's own (see `shellwarp scenes`).
    #[arg(long, short = 'm')]
    pub method: Option<String>,
    /// Override a scene value, e.g. `--set material.k_bend=0.02` (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl SceneArgs {
    /// Load and realise the scene with the method override and `--set` values applied.
    pub fn load(&self) -> anyhow::Result<shellwarp::scene::Setup> {
        let mut overrides = self.set.clone();
        if let Some(m) = &self.method {
            shellwarp::solver::registry::find(m)?;
            overrides.push(format!("solver.method={m}"));
        }
        Ok(shellwarp::scene::load(&self.scene, &overrides)?)
    }
}

/// Run the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command.unwrap_or_else(|| Command::View(view::ViewArgs::default())) {
        Command::View(args) => view::run(&args),
        Command::Scenes => scenes::run(),
        Command::Modes(args) => modes::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Sim(args) => sim::run(&args),
    }
}
