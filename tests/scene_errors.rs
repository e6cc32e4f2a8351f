//! Every scene check names its key; OBJ meshes in scenes resolve relative paths, keep the file's
//! vertex order, and report missing or broken files as mesh errors of the scene.

use std::path::{Path, PathBuf};

use shellwarp::mesh::MeshError;
use shellwarp::scene::{self, Origin, SceneError};

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
        ("material.density=0".into(), "material.density", "must be positive"),
        ("material.k_area=-1".into(), "material.k_area", "must not be negative"),
        ("material.k_length=-1".into(), "material.k_length", "must not be negative"),
        ("material.k_bend=nan".into(), "material.k_bend", "finite"),
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
        ("material.k_s=-1".into(), "material.k_s", "must not be negative"),
        ("material.k_b=nan".into(), "material.k_b", "finite"),
        ("material.c_b=-2".into(), "material.c_b", "must not be negative"),
        ("material.k_d=inf".into(), "material.k_d", "finite"),
        ("material.mu_s=-0.1".into(), "material.mu_s", "must not be negative"),
        ("material.mu_k=nan".into(), "material.mu_k", "finite"),
        ("solver.margin=0".into(), "solver.margin", "must be positive"),
        ("solver.accuracy=0".into(), "solver.accuracy", "relative error in (0, 1]"),
        ("solver.constraint_damping=0".into(), "solver.constraint_damping", "must be positive"),
        ("solver.iterations=0".into(), "solver.iterations", "at least 1"),
        ("solver.substeps=0".into(), "solver.substeps", "at least 1"),
        ("solver.sweeps=0".into(), "solver.sweeps", "at least 1"),
        ("solver.thickness=-0.01".into(), "solver.thickness", "must be positive"),
        ("solver.least_area=1".into(), "solver.least_area", "fraction of the rest area in [0, 1)"),
        ("solver.least_area=-0.1".into(), "solver.least_area", "fraction of the rest area in [0, 1)"),
        ("material.compliance_stretch=-1e-3".into(), "material.compliance_stretch", "must not be negative"),
        ("material.compliance_bend=-1".into(), "material.compliance_bend", "must not be negative"),
        ("material.pbd_stretch=1.5".into(), "material.pbd_stretch", "fraction in [0, 1]"),
        ("material.pbd_bend=-0.1".into(), "material.pbd_bend", "fraction in [0, 1]"),
        ("material.k_pressure=0".into(), "material.k_pressure", "must be positive"),
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
        ("wind.velocity=[nan, 0, 0]".into(), "wind.velocity", "finite"),
        ("wind.drag=-1".into(), "wind.drag", "must not be negative"),
        ("wind.gust=-0.5".into(), "wind.gust", "must not be negative"),
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
        ("solver.step=-0.1".into(), "solver.step", "must be positive"),
        ("solver.modes=0".into(), "solver.modes", "at least 1"),
        ("solver.rayleigh_alpha=-1".into(), "solver.rayleigh_alpha", "must not be negative"),
        ("solver.rayleigh_beta=nan".into(), "solver.rayleigh_beta", "finite"),
        ("solver.iterations=0".into(), "solver.iterations", "at least 1"),
        ("solver.tolerance=0".into(), "solver.tolerance", "must be positive"),
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
