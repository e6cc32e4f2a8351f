//! Subcommands. Each parses nothing itself: clap hands it typed arguments.

/// `println!` that hands a failed write back as an error instead of panicking (standard output
/// closed early, as by `| head`; `main` ends such a run quietly).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)?
    }};
}

mod eval;
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
    /// Threads for the numerical work (factorisations, solves, the modal analysis); default
    /// `SHELLWARP_THREADS`, else every core.
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
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
    /// Experiments: speed against accuracy, stability maps, the papers' figures; CSV, charts, summary.
    Eval(eval::EvalArgs),
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
        let mut setup = shellwarp::scene::load(&self.scene, &overrides)?;
        if self.method.is_some() {
            // An explicit method wins over an accuracy target the scene may give.
            setup.scene.solver.accuracy = None;
        }
        Ok(setup)
    }
}

impl Cli {
    /// Whether the command opens the GPU (the viewer and `render`).
    pub fn uses_gpu(&self) -> bool {
        matches!(self.command, None | Some(Command::View(_) | Command::Render(_) | Command::Eval(_)))
    }
}

/// Mesa's Vulkan device-select layer connects to Wayland while it lists GPUs, and libwayland then
/// prints "error: XDG_RUNTIME_DIR is invalid or not set in the environment." twice when that variable
/// is missing (root shells, containers), whatever the command's own outcome. Setting an environment
/// variable in-process needs `unsafe`, so a GPU command in such an environment runs itself again
/// with the layer disabled (`NODEVICE_SELECT=1`; wgpu chooses the adapter itself anyway) and exits
/// with the child's status. `None`: no need, or the re-run could not be started; carry on here.
pub fn rerun_quietly(cli: &Cli) -> Option<ExitCode> {
    let runtime_dir_ok = std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| d.to_string_lossy().starts_with('/'));
    if !cli.uses_gpu() || runtime_dir_ok || std::env::var_os("NODEVICE_SELECT").is_some() {
        return None;
    }
    let exe = std::env::current_exe().ok()?;
    let status =
        std::process::Command::new(exe).args(std::env::args_os().skip(1)).env("NODEVICE_SELECT", "1").status().ok()?;
    Some(status.code().and_then(|c| u8::try_from(c).ok()).map_or(ExitCode::FAILURE, ExitCode::from))
}

/// Run the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    use anyhow::Context;
    let threads = match cli.threads {
        Some(n) => n as usize,
        None => shellwarp::threads::from_env()
            .with_context(|| format!("environment variable {}", shellwarp::threads::ENV))?
            .unwrap_or_else(shellwarp::threads::threads),
    };
    shellwarp::threads::set(threads).context("--threads")?;
    match cli.command.unwrap_or_else(|| Command::View(view::ViewArgs::default())) {
        Command::View(args) => view::run(&args),
        Command::Scenes => scenes::run(),
        Command::Modes(args) => modes::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Eval(args) => eval::run(&args),
    }
}

/// Parse `VERTEX:X,Y,Z` (also `VERTEX:WX,WY,WZ`).
pub(crate) fn parse_drag(s: &str) -> Result<(usize, glam::DVec3), String> {
    let bad = || format!("`{s}`: expected VERTEX:X,Y,Z, e.g. 204:0.5,0.2,0.0");
    let (v, xyz) = s.split_once(':').ok_or_else(bad)?;
    let v = v.trim().parse().map_err(|_| bad())?;
    let c: Vec<f64> = xyz.split(',').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    match c[..] {
        [x, y, z] if c.iter().all(|x| x.is_finite()) => Ok((v, glam::DVec3::new(x, y, z))),
        _ => Err(bad()),
    }
}
