//! `shellwarp scenes`: what can be run.

use std::process::ExitCode;

use shellwarp::scene::{BUILTIN, Origin, parse};
use shellwarp::solver::METHODS;

/// Print every built-in scene (name, default method, description) and every method.
pub fn run() -> anyhow::Result<ExitCode> {
    say!("Built-in scenes:");
    for (name, text) in BUILTIN {
        let origin = Origin { label: format!("assets/scenes/{name}.toml"), dir: Default::default() };
        let scene = parse(text, &origin, &[])?;
        say!("  {name:<16} {:<12} {}", scene.solver.method, scene.description);
    }
    say!("\nMethods:");
    for m in METHODS {
        say!("  {:<16} {}", m.name, m.summary);
    }
    Ok(ExitCode::SUCCESS)
}
