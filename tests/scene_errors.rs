//! Every scene check names its key, and so does every method's check of the scene values it reads;
//! OBJ meshes in scenes resolve relative paths, keep the file's
//! vertex order, and report missing or broken files as mesh errors of the scene.

use std::path::{Path, PathBuf};

use shellwarp::mesh::MeshError;
use shellwarp::scene::{self, Origin, SceneError, Setup};
use shellwarp::solver::{self, ParamSpec, SolverError, registry};

const BASE: &str = "name = \"t\"\n[mesh.grid]\nsize = [1.0, 0.1]\nsegments = [4, 1]\n[solver]\nmethod = \"rigid\"\n";

fn origin() -> Origin {
    Origin { label: "test.toml".into(), dir: PathBuf::new() }
}

/// Each `--set` makes one value invalid; the error must name exactly that key and say why.
#[test]
fn every_validation_check_names_its_key() {
    let mesh = |m: &str| format!("mesh={{ {m} }}");
    let grid = |size: &str, segments: &str| mesh(&format!("grid = {{ size = {size}, segments = {segments} }}"));
    let sheet = |size: &str, edge: &str| mesh(&format!("delaunay-sheet = {{ size = {size}, edge = {edge} }}"));
    let vbeam = |l: &str, w: &str, a: &str, s: &str| {
        mesh(&format!("v-beam = {{ length = {l}, width = {w}, angle_deg = {a}, segments = {s} }}"))
    };
    let sphere = |r: &str, rings: &str, sectors: &str| {
        mesh(&format!("uv-sphere = {{ radius = {r}, rings = {rings}, sectors = {sectors} }}"))
    };
    let track = |body: &str| {
        let select = if body.starts_with("select") { "" } else { "select = { indices = [0] }, " };
        format!("tracks=[{{ {select}{body} }}]")
    };
    let joints = |list: &str| format!("skeleton={{ joints = [{list}] }}");
    let part = |body: &str| format!("parts=[{{ select = {{ indices = [0] }}, {body} }}]");
    let cases: Vec<(String, &str, &str)> = vec![
        (grid("[1.0, -0.1]", "[4, 1]"), "mesh.size", "must be positive"),
        (grid("[1.0, 0.1]", "[4, 0]"), "mesh.segments", "at least 1"),
        (sheet("[1.0, nan]", "0.1"), "mesh.size", "finite"),
        (sheet("[1.0, 1.0]", "0.0"), "mesh.edge", "must be positive"),
        (sheet("[1.0, 1.0]", "1e-4"), "mesh.edge", "too small"),
        (vbeam("0", "1", "90", "[4, 2]"), "mesh.length", "must be positive"),
        (vbeam("1", "-1", "90", "[4, 2]"), "mesh.width", "must be positive"),
        (vbeam("1", "1", "nan", "[4, 2]"), "mesh.angle_deg", "finite"),
        (vbeam("1", "1", "5", "[4, 2]"), "mesh.angle_deg", "[10, 180]"),
        (vbeam("1", "1", "90", "[0, 2]"), "mesh.segments", "at least 1"),
        (vbeam("1", "1", "90", "[4, 0]"), "mesh.segments", "at least 2"),
        (vbeam("1", "1", "90", "[4, 3]"), "mesh.segments", "even"),
        (mesh("icosphere = { radius = 0, frequency = 2 }"), "mesh.radius", "must be positive"),
        (mesh("icosphere = { radius = 1, frequency = 0 }"), "mesh.frequency", "at least 1"),
        (sphere("inf", "4", "8"), "mesh.radius", "finite"),
        (sphere("1", "1", "8"), "mesh.rings", "at least 2"),
        (sphere("1", "4", "2"), "mesh.sectors", "at least 3"),
        (mesh("creature = { length = -2, frequency = 8 }"), "mesh.length", "must be positive"),
        (mesh("creature = { length = 2, frequency = 1 }"), "mesh.frequency", "at least 2"),
        (mesh("obj = { path = \"\" }"), "mesh.path", "is empty"),
        ("placement.scale=0".into(), "placement.scale", "must be positive"),
        ("placement.rotate_deg=[0, inf, 0]".into(), "placement.rotate_deg", "finite"),
        ("placement.translate=[nan, 0, 0]".into(), "placement.translate", "finite"),
        ("anchors=[{ box = { min = [nan, 0, 0], max = [1, 1, 1] } }]".into(), "anchors[0].box.min", "finite"),
        ("anchors=[{ box = { min = [0, 0, 0], max = [1, inf, 1] } }]".into(), "anchors[0].box.max", "finite"),
        ("anchors=[{ box = { min = [1, 0, 0], max = [0, 1, 1] } }]".into(), "anchors[0].box", "min must not exceed"),
        ("anchors=[{ indices = [0] }, { indices = [] }]".into(), "anchors[1].indices", "is empty"),
        ("anchors=[{ indices = [0], box = { min = [0, 0, 0], max = [1, 1, 1] } }]".into(), "anchors[0]", "exactly one"),
        ("gravity=[0, nan, 0]".into(), "gravity", "finite"),
        ("loads=[{ select = { indices = [] }, force = [0, 0, 0] }]".into(), "loads[0].select.indices", "is empty"),
        ("loads=[{ select = { indices = [1] }, force = [0, inf, 0] }]".into(), "loads[0].force", "finite"),
        ("colliders=[{ sphere = { center = [nan, 0, 0], radius = 1 } }]".into(), "colliders[0].center", "finite"),
        ("colliders=[{ sphere = { center = [0, 0, 0], radius = 0 } }]".into(), "colliders[0].radius", "positive"),
        ("colliders=[{ plane = { point = [0, inf, 0], normal = [0, 1, 0] } }]".into(), "colliders[0].point", "finite"),
        ("colliders=[{ plane = { point = [0, 0, 0], normal = [0, nan, 0] } }]".into(), "colliders[0].normal", "finite"),
        ("colliders=[{ plane = { point = [0, 0, 0], normal = [0, 0, 0] } }]".into(), "colliders[0].normal", "zero"),
        (
            "colliders=[{ sphere = { center = [0, 0, 0], radius = 1, motion = { velocity = [nan, 0, 0] } } }]".into(),
            "colliders[0].motion.velocity",
            "finite",
        ),
        (
            "colliders=[{ sphere = { center = [0, 0, 0], radius = 1, motion = { amplitude = [0, inf, 0] } } }]".into(),
            "colliders[0].motion.amplitude",
            "finite",
        ),
        (
            "colliders=[{ plane = { point = [0, 0, 0], normal = [0, 1, 0], motion = { frequency = -1 } } }]".into(),
            "colliders[0].motion.frequency",
            "must not be negative",
        ),
        (
            "colliders=[{ sphere = { center = [0, 0, 0], radius = 1, motion = { spin = [0, nan, 0] } } }]".into(),
            "colliders[0].motion.spin",
            "finite",
        ),
        ("colliders=[{ mesh = { path = \"\" } }]".into(), "colliders[0].path", "is empty"),
        ("colliders=[{ mesh = { path = \"b.obj\", scale = 0 } }]".into(), "colliders[0].scale", "must be positive"),
        (
            "colliders=[{ mesh = { path = \"b.obj\", translate = [0, nan, 0] } }]".into(),
            "colliders[0].translate",
            "finite",
        ),
        ("solver.accuracy=0".into(), "solver.accuracy", "relative error in (0, 1]"),
        (
            "colliders=[{ sphere = { center = [0, 0, 0], radius = 0.1, mass = 0.0 } }]".into(),
            "colliders[0].mass",
            "must be positive",
        ),
        (
            "colliders=[{ box = { center = [0, 0, 0], half_extents = [0.1, 0.0, 0.1] } }]".into(),
            "colliders[0].half_extents",
            "must be positive",
        ),
        ("placement.copies=0".into(), "placement.copies", "at least 1"),
        ("placement.copy_offset=[0, nan, 0]".into(), "placement.copy_offset", "finite"),
        (
            track("keys = [{ time = 1.0, position = [0, 0, 0] }, { time = 0.5, position = [0, 0, 0] }]"),
            "tracks[0].keys[1].time",
            "must come after",
        ),
        (track("keys = [{ time = -1.0, position = [0, 0, 0] }]"), "tracks[0].keys[0].time", "must not be negative"),
        (track("keys = [{ time = 0.0 }]"), "tracks[0].keys[0]", "give a position, a rotation or both"),
        (
            track("keys = [{ time = 0.0, position = [0, 0, 0] }, { time = 1.0, rotation = [0, 0, 1] }]"),
            "tracks[0].keys[1]",
            "same fields",
        ),
        (track("keys = [{ time = 0.0, rotation = [0, inf, 0] }]"), "tracks[0].keys[0].rotation", "finite"),
        (track(""), "tracks[0]", "exactly one of `keys` or `joint`"),
        (track("joint = \"knee\""), "tracks[0].joint", "no skeleton joint `knee`"),
        (
            track("select = { indices = [] }, keys = [{ time = 0.0, position = [0, 0, 0] }]"),
            "tracks[0].select.indices",
            "is empty",
        ),
        (
            joints("{ name = \"a\", offset = [0, 0, 0] }, { name = \"a\", offset = [0, 0, 0] }"),
            "skeleton.joints[1].name",
            "used twice",
        ),
        (joints("{ name = \"a\", parent = \"b\", offset = [0, 0, 0] }"), "skeleton.joints[0].parent", "no joint `b`"),
        (
            joints("{ name = \"a\", offset = [0, 0, 0], keys = [{ time = 0.0, position = [0, 0, 0] }] }"),
            "skeleton.joints[0].keys[0].position",
            "only a rotation",
        ),
        ("solver.accuracy=1.5".into(), "solver.accuracy", "relative error in (0, 1]"),
        ("solver.accuracy=nan".into(), "solver.accuracy", "relative error in (0, 1]"),
        (part("accuracy = 0.0"), "parts[0].accuracy", "relative error in (0, 1]"),
        (part("accuracy = nan"), "parts[0].accuracy", "relative error in (0, 1]"),
        (part("accuracy = -inf"), "parts[0].accuracy", "relative error in (0, 1]"),
        ("solver.method=\"\"".into(), "solver.method", "required unless solver.accuracy"),
        ("camera.eye=[0, nan, 3]".into(), "camera.eye", "finite"),
        ("camera.target=[inf, 0, 0]".into(), "camera.target", "finite"),
        ("camera.fov_deg=0.5".into(), "camera.fov_deg", "[1, 170]"),
        ("camera.fov_deg=nan".into(), "camera.fov_deg", "[1, 170]"),
    ];
    for (set, key, reason) in cases {
        match scene::parse(BASE, &origin(), std::slice::from_ref(&set)) {
            Err(SceneError::Invalid { file, key: k, reason: r }) => {
                assert_eq!((file.as_str(), k.as_str()), ("test.toml", key), "--set {set}: {r}");
                assert!(r.contains(reason), "--set {set}: `{k}`: {r} (expected {reason:?})");
            }
            other => panic!("--set {set}: expected an invalid `{key}`, got {other:?}"),
        }
    }
}

/// A scene for `method` on a small anchored sheet, with the `--set` arguments `set`.
fn method_scene(method: &str, set: &[String]) -> Result<Setup, SceneError> {
    let text = format!(
        "name = \"t\"\n[mesh.grid]\nsize = [1.0, 0.2]\nsegments = [6, 2]\n[[anchors]]\n\
         box = {{ min = [-0.6, -1, -1], max = [-0.4, 1, 1] }}\n[solver]\nmethod = \"{method}\"\nmodes = 4\n"
    );
    let scene = scene::parse(&text, &origin(), set)?;
    Setup::new(scene, origin())
}

/// `--set` giving the scene key of `spec` the value `value` (a whole vector for `gravity[1]`).
fn set_key(spec: &ParamSpec, value: f64) -> String {
    let number = match value {
        v if v.is_nan() => "nan".to_string(),
        v if spec.integer => format!("{}", v as i64),
        v => format!("{v:?}"),
    };
    match spec.key.split_once('[') {
        Some((vector, index)) => {
            let index: usize = index.trim_end_matches(']').parse().unwrap();
            let mut v = ["0.0".to_string(), "0.0".to_string(), "0.0".to_string()];
            v[index] = number;
            format!("{vector}=[{}]", v.join(", "))
        }
        None => format!("{}={number}", spec.key),
    }
}

/// Every method checks each scene value it reads against its parameter's range when it is built,
/// naming the scene key as the scene's own checks do: a value past either end of the range, or not
/// a number, is refused (a key that is not the scene's would fail to parse here).
#[test]
fn every_method_checks_the_scene_values_it_reads_naming_their_keys() {
    for method in registry::METHODS.iter().chain(registry::TEST_METHODS) {
        let setup = method_scene(method.name, &[]).unwrap();
        let solver = method.construct(&setup).unwrap_or_else(|e| panic!("{}: {e}", method.name));
        let keyed: Vec<ParamSpec> = solver.params().into_iter().map(|p| p.spec).filter(|s| !s.key.is_empty()).collect();
        assert!(!keyed.is_empty(), "{}: no parameter read from the scene", method.name);
        for spec in keyed {
            let below = if spec.min > 0.0 { spec.min / 10.0 } else { spec.min - 1.0 };
            let mut bad = vec![spec.max * 10.0 + 1.0, below];
            // (The scene itself refuses a vector with a non-finite component, `gravity` for one.)
            if !spec.integer && !spec.key.contains('[') {
                bad.push(f64::NAN);
            }
            for value in bad {
                let set = set_key(&spec, value);
                // A balloon's pressure needs a closed mesh.
                let closed = "mesh={ icosphere = { radius = 0.5, frequency = 1 } }".to_string();
                let sets =
                    if spec.key == "material.k_pressure" { vec![closed, set.clone()] } else { vec![set.clone()] };
                let setup =
                    method_scene(method.name, &sets).unwrap_or_else(|e| panic!("{}: --set {set}: {e}", method.name));
                match method.construct(&setup) {
                    Err(SolverError::SceneValue { file, key, reason }) => {
                        assert_eq!(
                            (file.as_str(), key.as_str()),
                            ("test.toml", spec.key),
                            "{}: --set {set}",
                            method.name
                        );
                        let why = if value.is_nan() { "not a finite number" } else { "outside the allowed range" };
                        assert!(reason.contains(why), "{}: --set {set}: {reason}", method.name);
                    }
                    Err(e) => panic!("{}: --set {set}: expected `{}` refused, got {e}", method.name, spec.key),
                    Ok(_) => panic!("{}: --set {set}: accepted", method.name),
                }
            }
        }
    }
}

/// A part's own setting that its method refuses is named as the part's key.
#[test]
fn a_part_setting_out_of_range_names_the_part() {
    let part = "parts=[{ select = { box = { min = [-1, -1, -1], max = [1, 1, 1] } }, method = \"mwts\", modes = 0 }]";
    match solver::build(&method_scene("mwts", &[part.to_string()]).unwrap()) {
        Err(SolverError::SceneValue { key, reason, .. }) => {
            assert_eq!(key, "parts[0].modes", "{reason}");
        }
        other => panic!("expected parts[0].modes refused, got {:?}", other.err()),
    }
    let setup = method_scene("mwts", &["solver.modes=0".to_string()]).unwrap();
    assert!(matches!(solver::build(&setup), Err(SolverError::SceneValue { key, .. }) if key == "solver.modes"));
}

/// A whole number past TOML's (`--set` cannot give one, a file can) is refused by its key.
#[test]
fn whole_numbers_past_64_bits_signed_name_their_key() {
    for (from, to, key) in [
        ("method = \"rigid\"", "method = \"rigid\"\nsweeps = 18446744073709551615", "solver.sweeps"),
        ("segments = [4, 1]", "segments = [4, 9223372036854775808]", "mesh.grid.segments[1]"),
    ] {
        match scene::parse(&BASE.replace(from, to), &origin(), &[]) {
            Err(SceneError::Invalid { key: k, reason, .. }) => {
                assert_eq!(k, key, "{reason}");
                assert!(reason.contains("larger than the largest whole number"), "{reason}");
            }
            other => panic!("{to}: expected `{key}` refused, got {other:?}"),
        }
    }
}

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shellwarp-scene-errors-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn obj_scene(dir: &Path, obj_path: &str, anchors: &str) -> String {
    let path = dir.join("scene.toml");
    let text = format!(
        "name = \"obj\"\n[mesh.obj]\npath = \"{obj_path}\"\n[[anchors]]\nindices = {anchors}\n[solver]\nmethod = \"rigid\"\n"
    );
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn obj_mesh_resolves_relative_to_the_scene_and_keeps_vertex_order() {
    let dir = scratch("relative");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    // The faces use vertex 4 first: index 3 must still be the fourth `v` line, (0, 1, 0).
    std::fs::write(dir.join("meshes/quad.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 4 1 3\nf 3 1 2\n").unwrap();
    let scene = obj_scene(&dir, "meshes/quad.obj", "[3]");
    let setup = scene::load(&scene, &[]).unwrap();
    assert_eq!(setup.mesh.vertex_count(), 4);
    assert_eq!(setup.anchors, vec![3]);
    assert_eq!(setup.mesh.positions()[3], glam::DVec3::Y);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn missing_and_broken_obj_files_are_mesh_errors_of_the_scene() {
    let dir = scratch("broken");
    let scene = obj_scene(&dir, "missing.obj", "[0]");
    match scene::load(&scene, &[]) {
        Err(SceneError::Mesh { file, error: MeshError::Io { path, reason } }) => {
            assert_eq!((file, reason.as_str()), (scene.clone(), "file not found"));
            assert_eq!(path, dir.join("missing.obj"));
        }
        other => panic!("expected a missing-file mesh error, got {other:?}"),
    }
    std::fs::write(dir.join("broken.obj"), "v 0 0 0\nv 1 0 oops\n").unwrap();
    let scene = obj_scene(&dir, "broken.obj", "[0]");
    let e = scene::load(&scene, &[]).unwrap_err();
    assert!(matches!(e, SceneError::Mesh { error: MeshError::Io { .. }, .. }), "{e:?}");
    let message = e.to_string();
    let expected = format!(
        "{scene}: mesh: {}: line 2: vertex coordinate `oops` is not a number",
        dir.join("broken.obj").display()
    );
    assert_eq!(message, expected);
    // The message is the whole story: no `source` to print a second time.
    assert!(std::error::Error::source(&e).is_none());
    std::fs::write(dir.join("pillow.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n").unwrap();
    let scene = obj_scene(&dir, "pillow.obj", "[0]");
    assert!(matches!(
        scene::load(&scene, &[]),
        Err(SceneError::Mesh { error: MeshError::DuplicateTriangle { first: 0, second: 1 }, .. })
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn placement_overflow_is_reported_as_such() {
    let e = scene::load("cantilever", &["placement.scale=1e300".into()]).unwrap_err().to_string();
    assert_eq!(
        e,
        "assets/scenes/cantilever.toml: mesh: vertex coordinates reach 5.000e299: too large, lengths and areas overflow"
    );
}

/// A mesh collider is read when the scene is loaded: a missing file or an open mesh is an error that
/// names the collider, and a closed mesh relative to the scene file loads.
/// A pressure needs a closed mesh: an open one is refused when the scene is loaded, by name.
#[test]
fn pressure_on_an_open_mesh_is_refused() {
    let origin = Origin { label: "open.toml".into(), dir: PathBuf::new() };
    let text = BASE.replace("method = \"rigid\"", "method = \"xpbd\"") + "[material]\nk_pressure = 1.5\n";
    let scene = scene::parse(&text, &origin, &[]).unwrap();
    match scene::Setup::new(scene, origin) {
        Err(SceneError::Invalid { key, reason, file }) => {
            assert_eq!((key.as_str(), file.as_str()), ("material.k_pressure", "open.toml"));
            assert!(reason.contains("not closed"), "{reason}");
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn mesh_colliders_must_exist_and_be_closed() {
    let dir = scratch("collider");
    // A tetrahedron (closed, outward) and a single triangle (open).
    std::fs::write(dir.join("tet.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n")
        .unwrap();
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let scene = |collider: &str| {
        let path = dir.join("scene.toml");
        let text = format!(
            "name = \"c\"\n[mesh.grid]\nsize = [1.0, 1.0]\nsegments = [2, 2]\n[[colliders]]\nmesh = {{ path = \"{collider}\" }}\n[solver]\nmethod = \"cloth\"\n"
        );
        std::fs::write(&path, text).unwrap();
        scene::load(&path.to_string_lossy(), &[])
    };
    let setup = scene("tet.obj").expect("a closed mesh collider loads");
    assert_eq!(setup.bodies.len(), 1);
    for (file, want) in [("missing.obj", "not found"), ("tri.obj", "must be closed")] {
        match scene(file) {
            Err(SceneError::Invalid { key, reason, .. }) => {
                assert_eq!(key, "colliders[0]");
                assert!(reason.contains(want), "{file}: {reason}");
            }
            other => panic!("{file}: {other:?}"),
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
