//! Scenes: TOML files (built in under `assets/scenes/`, or any path) parsed into a typed [`Scene`],
//! validated, optionally overridden with `--set key=value`, and realised into a [`Setup`]
//! (mesh, anchored vertices, point loads) that solvers are built from.

mod builtin;
mod error;
mod overrides;
mod schema;
mod setup;
mod validate;

pub use builtin::{BUILTIN, builtin_names};
pub use error::SceneError;
pub use schema::{Aabb, CameraSpec, Collider, Load, Material, MeshSource, Placement, Scene, Selection, SolverSettings};
pub use setup::Setup;

use std::path::{Path, PathBuf};

/// Where a scene's text came from: its label for messages and the directory relative paths resolve against.
#[derive(Debug, Clone, PartialEq)]
pub struct Origin {
    /// File path or `assets/scenes/NAME.toml` for built-ins, used in every error message.
    pub label: String,
    /// Directory that relative paths in the scene (OBJ meshes) are resolved against.
    pub dir: PathBuf,
}

/// Find a scene by built-in name or file path and return its text and origin.
pub fn find(name_or_path: &str) -> Result<(String, Origin), SceneError> {
    let path = Path::new(name_or_path);
    if path.is_file() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::Read { file: name_or_path.to_string(), reason: e.to_string() })?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        return Ok((text, Origin { label: name_or_path.to_string(), dir }));
    }
    if let Some((name, text)) = BUILTIN.iter().find(|(n, _)| *n == name_or_path) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
        return Ok((text.to_string(), Origin { label: format!("assets/scenes/{name}.toml"), dir }));
    }
    if path.extension().is_some_and(|e| e == "toml") || name_or_path.contains(std::path::MAIN_SEPARATOR) {
        return Err(SceneError::Read { file: name_or_path.to_string(), reason: "no such file".into() });
    }
    Err(SceneError::Unknown { name: name_or_path.to_string(), available: builtin_names().join(", ") })
}

/// Parse scene text, apply `key=value` overrides, and validate.
pub fn parse(text: &str, origin: &Origin, overrides: &[String]) -> Result<Scene, SceneError> {
    let scene: Scene = if overrides.is_empty() {
        toml::from_str(text).map_err(|e| overrides::parse_error(&origin.label, text, &e))?
    } else {
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| overrides::parse_error(&origin.label, text, &e))?;
        for arg in overrides {
            overrides::apply(&mut table, arg)?;
        }
        toml::Value::Table(table).try_into().map_err(|e| overrides::parse_error(&origin.label, "", &e))?
    };
    scene.validate().map_err(|(key, reason)| SceneError::Invalid { file: origin.label.clone(), key, reason })?;
    Ok(scene)
}

/// Find, parse, override, validate and realise a scene in one call.
pub fn load(name_or_path: &str, overrides: &[String]) -> Result<Setup, SceneError> {
    let (text, origin) = find(name_or_path)?;
    let scene = parse(&text, &origin, overrides)?;
    Setup::new(scene, origin)
}
