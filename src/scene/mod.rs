//! Scenes: TOML files (built in under `assets/scenes/`, or any path) parsed into a typed [`Scene`],
//! validated, optionally overridden with `--set key=value`, and realised into a [`Setup`]
//! (mesh, anchored vertices, point loads) that solvers are built from.

mod builtin;
mod error;
mod overrides;
mod schema;
mod script;
mod selection;
mod setup;
mod validate;

pub use builtin::{BUILTIN, builtin_names};
pub use error::SceneError;
pub use overrides::SceneNumbers;
pub use schema::{
    CameraSpec, Collider, Load, Material, MeshSource, Motion, Part, Placement, Scene, SolverSettings, WindSpec,
};
pub use script::{Joint, Key, Skeleton, Track};
pub use selection::{Aabb, Selection};
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
        serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| overrides::typed_error(&origin.label, text, overrides, e))?
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

#[cfg(test)]
mod tests {
    use super::*;

    fn origin() -> Origin {
        Origin { label: "test.toml".into(), dir: PathBuf::new() }
    }

    const MINIMAL: &str =
        "name = \"t\"\n[mesh.grid]\nsize = [1.0, 0.1]\nsegments = [4, 1]\n[solver]\nmethod = \"rigid\"\n";

    fn parse_err(text: &str) -> String {
        parse(text, &origin(), &[]).unwrap_err().to_string()
    }

    #[test]
    fn every_builtin_scene_parses_and_validates() {
        for (name, text) in BUILTIN {
            let o = Origin { label: format!("{name}.toml"), dir: PathBuf::new() };
            let s = parse(text, &o, &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(&s.name, name, "scene name matches its registry name");
        }
    }

    #[test]
    fn minimal_scene_gets_defaults() {
        let s = parse(MINIMAL, &origin(), &[]).unwrap();
        assert_eq!(s.gravity, [0.0, -9.81, 0.0]);
        assert_eq!(s.material, Material::default());
        assert_eq!(s.solver.modes, 8);
    }

    #[test]
    fn unknown_key_names_file_line_and_key() {
        let e = parse_err(&MINIMAL.replace("[solver]", "[solver]\nmodez = 3"));
        assert!(e.starts_with("test.toml:6:1:"), "{e}");
        assert!(e.contains("modez"), "{e}");
    }

    #[test]
    fn wrong_type_and_missing_key_are_reported() {
        let e = parse_err(&MINIMAL.replace("segments = [4, 1]", "segments = \"many\""));
        assert!(e.starts_with("test.toml:4:12: `segments`: invalid type"), "{e}");
        let e = parse_err(&MINIMAL.replace("name = \"t\"\n", ""));
        assert!(e.contains("name"), "{e}");
        let e = parse_err(&MINIMAL.replace("[mesh.grid]", "[mesh.blob]"));
        assert!(e.contains("blob"), "{e}");
        let e = parse_err("name = [");
        assert!(e.starts_with("test.toml:1:"), "{e}");
    }

    #[test]
    fn bad_values_name_their_key() {
        let cases = [
            ("size = [1.0, 0.1]", "size = [1.0, -0.1]", "mesh.size"),
            ("name = \"t\"", "name = \"t\"\ngravity = [0.0, nan, 0.0]", "gravity"),
            ("[solver]", "[[anchors]]\nindices = []\n[solver]", "anchors[0].indices"),
            ("[solver]", "[[anchors]]\n[solver]", "anchors[0]"),
            ("[solver]", "[[anchors]]\nbox = { min = [1, 1, 1], max = [0, 0, 0] }\n[solver]", "anchors[0].box"),
            (
                "[solver]",
                "[[colliders]]\nsphere = { center = [0, 0, 0], radius = -1.0 }\n[solver]",
                "colliders[0].radius",
            ),
            (
                "[solver]",
                "[[colliders]]\nplane = { point = [0, 0, 0], normal = [0, 0, 0] }\n[solver]",
                "colliders[0].normal",
            ),
            ("method = \"rigid\"", "method = \"rigid\"\naccuracy = 0.0", "solver.accuracy"),
        ];
        for (from, to, key) in cases {
            let e = parse_err(&MINIMAL.replace(from, to));
            assert!(e.starts_with(&format!("test.toml: `{key}`:")), "expected key {key}: {e}");
        }
    }

    #[test]
    fn overrides_apply_and_are_validated() {
        let s = parse(MINIMAL, &origin(), &["material.k_bend=0.5".into(), "solver.modes=4".into()]).unwrap();
        assert_eq!(s.material.k_bend, 0.5);
        assert_eq!(s.solver.modes, 4);
        let e = parse(MINIMAL, &origin(), &["material.k_bnd=0.5".into()]).unwrap_err().to_string();
        assert!(e.contains("k_bnd"), "{e}");
        let e = parse(MINIMAL, &origin(), &["placement.scale=-2".into()]).unwrap_err().to_string();
        assert!(e.contains("placement.scale"), "{e}");
    }

    #[test]
    fn override_type_errors_name_the_argument_and_key() {
        let set = |args: &[&str]| {
            let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
            parse(MINIMAL, &origin(), &args).unwrap_err().to_string()
        };
        assert_eq!(
            set(&["solver.modes=4", "material.k_bend=abc"]),
            "--set material.k_bend=abc: `material.k_bend`: invalid type: string \"abc\", expected f64"
        );
        let e = set(&["mesh.grid.segments=[4]"]);
        assert!(e.starts_with("--set mesh.grid.segments=[4]: `mesh.grid.segments`:"), "{e}");
        let e = set(&["material.k_bnd=0.5"]);
        assert!(e.starts_with("--set material.k_bnd=0.5:") && e.contains("k_bnd"), "{e}");
        // A table replaced by a scalar: the error is inside what the argument replaced.
        let e = set(&["camera=3"]);
        assert!(e.starts_with("--set camera=3: `camera`:"), "{e}");
        // An error in the file itself keeps its line even when overrides are given.
        let broken = MINIMAL.replace("segments = [4, 1]", "segments = \"many\"");
        let e = parse(&broken, &origin(), &["material.k_bend=0.5".into()]).unwrap_err().to_string();
        assert!(e.starts_with("test.toml:4:12: `segments`: invalid type"), "{e}");
    }

    #[test]
    fn selections_resolve_to_vertices_or_fail() {
        let text = MINIMAL.replace(
            "[solver]",
            "[[anchors]]\nbox = { min = [-1, -1, -1], max = [-0.4, 1, 1] }\n[[loads]]\nselect = { indices = [9] }\nforce = [0, -2, 0]\n[solver]",
        );
        let setup = Setup::new(parse(&text, &origin(), &[]).unwrap(), origin()).unwrap();
        // Grid 4×1 cells: vertices (i, j) → 2i + j; x = -0.5 + 0.25 i. Box keeps i = 0.
        assert_eq!(setup.anchors, vec![0, 1]);
        assert_eq!(setup.loads[9], glam::DVec3::new(0.0, -2.0, 0.0));
        assert!((setup.masses().iter().sum::<f64>() - 0.5 * 0.1).abs() < 1e-12);
        let empty = MINIMAL.replace("[solver]", "[[anchors]]\nbox = { min = [5, 5, 5], max = [6, 6, 6] }\n[solver]");
        let e = Setup::new(parse(&empty, &origin(), &[]).unwrap(), origin()).unwrap_err().to_string();
        assert_eq!(e, "test.toml: `anchors[0]`: selects no vertex");
        let oob = MINIMAL.replace("[solver]", "[[anchors]]\nindices = [99]\n[solver]");
        let e = Setup::new(parse(&oob, &origin(), &[]).unwrap(), origin()).unwrap_err().to_string();
        assert!(e.contains("vertex 99 does not exist"), "{e}");
    }

    #[test]
    fn find_distinguishes_missing_files_from_unknown_names() {
        assert!(matches!(find("cantilever"), Ok((_, o)) if o.label == "assets/scenes/cantilever.toml"));
        assert!(matches!(find("missing.toml"), Err(SceneError::Read { .. })));
        assert!(matches!(find("no-such-scene"), Err(SceneError::Unknown { .. })));
    }
}
