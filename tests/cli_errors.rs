//! Failures of the command line: each is one clear line on stderr (naming the file, argument or key at
//! fault, once), nothing on stdout, and a non-zero exit code — never a panic or an abort.

use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

fn shellwarp() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellwarp"));
    // Modal analyses must not read or pollute the user's cache: theirs is in the build's scratch.
    c.env("SHELLWARP_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-errors-cache"));
    c
}

/// An empty directory of the test's own, removed when it is dropped.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("shellwarp-cli-errors-{name}-")).tempdir().unwrap()
}

/// Assert `out` is a clean failure whose single stderr line contains every string of `expected`, and return it.
fn one_line_failure(what: &str, out: &Output, expected: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{what} should fail");
    assert_eq!(out.status.code(), Some(1), "{what}: exit code (101 is a panic): {err}");
    assert!(out.stdout.is_empty(), "{what} printed to stdout: {}", String::from_utf8_lossy(&out.stdout));
    assert_eq!(err.lines().count(), 1, "{what}: one line expected, got:\n{err}");
    assert!(err.starts_with("error: "), "{what}: {err}");
    for e in expected {
        assert!(err.contains(e), "{what}: expected {e:?} in: {err}");
    }
    err
}

/// Arguments rendering the cantilever, undeformed, at `size` to `png`.
fn render_rigid<'a>(size: &'a str, png: &'a Path) -> [&'a str; 11] {
    let out = png.to_str().unwrap();
    ["render", "-s", "cantilever", "-m", "rigid", "--frames", "0", "--size", size, "--out", out]
}

fn run(args: &[&str]) -> Output {
    shellwarp().args(args).output().expect("the binary runs")
}

#[test]
fn scene_and_override_errors_name_what_is_wrong() {
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["sim", "-s", "cantilever", "--set", "material.k_bend=abc"],
            &["--set material.k_bend=abc: `material.k_bend`: invalid type: string \"abc\", expected f64"],
        ),
        (&["sim", "-s", "cantilever", "--set", "name=[1"], &["--set name=[1: not a TOML value"]),
        (
            &["sim", "-s", "cantilever", "--set", "placement.scale=1e300"],
            &["assets/scenes/cantilever.toml: mesh: vertex coordinates reach", "overflow"],
        ),
        (
            &["sim", "-s", "cantilever", "-m", "lma", "--set", "solver.modes=100000"],
            &["`solver.modes`: 100000 is outside the allowed range [1, 256]"],
        ),
        (
            &[
                "sim",
                "-s",
                "cantilever",
                "-m",
                "lma",
                "--set",
                "solver.modes=100",
                "--set",
                "mesh.grid.segments=[4, 1]",
            ],
            &["method `lma` cannot run this scene: 100 modes"],
        ),
        (&["sim", "-s", "cantilever", "--set", "mesh.grid.segments=[100000, 100000]"], &["`segments`: too large"]),
    ];
    for (args, expected) in cases {
        one_line_failure(&format!("{args:?}"), &run(args), expected);
    }
}

#[test]
fn a_mesh_error_is_printed_once() {
    let dir = scratch("obj-scene");
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, "name = \"s\"\n[mesh.obj]\npath = \"gone.obj\"\n[solver]\nmethod = \"rigid\"\n").unwrap();
    let err =
        one_line_failure("missing OBJ", &run(&["sim", "-s", scene.to_str().unwrap()]), &["gone.obj: file not found"]);
    assert_eq!(err.matches("file not found").count(), 1, "{err}");
}

#[test]
fn unwritable_outputs_name_the_path_once() {
    let dir = scratch("outputs");
    let png = dir.path().join("no-such-dir/x.png");
    let out = run(&render_rigid("64x48", &png));
    let err = one_line_failure("render --out", &out, &["cannot write PNG"]);
    assert_eq!(err.matches("x.png").count(), 1, "{err}");
    let obj = dir.path().join("no-such-dir/x.obj");
    let out = run(&["sim", "-s", "cantilever", "-m", "rigid", "--steps", "1", "--obj", obj.to_str().unwrap()]);
    let err = one_line_failure("sim --obj", &out, &["cannot write"]);
    assert_eq!(err.matches("x.obj").count(), 1, "{err}");
}

#[test]
fn render_sizes_beyond_the_gpu_or_memory_are_clear_errors() {
    // Without XDG_RUNTIME_DIR (root shells, containers) libwayland would add two lines of its own.
    let out = shellwarp()
        .args(["render", "-s", "cantilever", "--frames", "0", "--size", "40000x10", "--out", "never.png"])
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    one_line_failure("40000x10", &out, &["invalid render size 40000x10: this GPU allows at most"]);
    // Under a 1.5 GB address-space limit an 8192² picture (with 4× MSAA) cannot be allocated: wgpu's
    // out-of-memory error must come back as one line, not a panic. (Enough memory would be a success.)
    let dir = scratch("oom");
    let png = dir.path().join("big.png");
    let script = format!(
        "ulimit -v 1500000 && exec '{}' render -s cantilever -m rigid --frames 0 --size 8192x8192 --out '{}'",
        env!("CARGO_BIN_EXE_shellwarp"),
        png.display()
    );
    let out = Command::new("sh").args(["-c", &script]).output().unwrap();
    if out.status.success() {
        assert!(png.exists(), "a render that succeeds writes its picture");
    } else {
        one_line_failure("8192x8192 under ulimit", &out, &[]);
    }
}

#[test]
fn work_needing_more_memory_than_the_machine_is_refused_up_front_with_the_estimate() {
    // A placement whose copies overflow any budget (it grew the fuzzer to 24 GB before this check).
    let out = run(&["sim", "-s", "cantilever", "--set", "placement.copies=4294967296"]);
    one_line_failure("4294967296 copies", &out, &["`placement.copies`: too large: 880468295680 vertices"]);

    // The rest against a budget set small (`SHELLWARP_MEMORY`, bytes), each with its estimate.
    let small = |args: &[&str], budget: &str| shellwarp().args(args).env("SHELLWARP_MEMORY", budget).output().unwrap();
    // 20 creatures: 259,240 vertices at about 25 KB each for `mwts` with 4 modes.
    let out = small(&["sim", "-s", "creature", "--set", "placement.copies=20"], "2000000000");
    one_line_failure(
        "20 creatures in 2 GB",
        &out,
        &["`mwts` with 4 modes on 259240 vertices would need about 6.47 GB of memory; this machine has 2.00 GB"],
    );
    // The same on a particle method fits: about 1 GB.
    let out =
        small(&["sim", "-s", "creature", "-m", "xpbd", "--steps", "1", "--set", "placement.copies=20"], "2000000000");
    assert!(out.status.success(), "xpbd on 20 creatures fits 2 GB: {}", String::from_utf8_lossy(&out.stderr));
    // An OBJ file is sized before it is read.
    let dir = scratch("obj-budget");
    let obj = dir.path().join("tri.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, "name = \"s\"\n[mesh.obj]\npath = \"tri.obj\"\n[solver]\nmethod = \"rigid\"\n").unwrap();
    let out = small(&["sim", "-s", scene.to_str().unwrap(), "--steps", "1"], "100");
    one_line_failure(
        "a 32-byte OBJ in 100 bytes",
        &out,
        &["tri.obj would need about 512 bytes of memory; this machine has 100 bytes"],
    );
    // A picture: 4 million pixels at 64 bytes.
    let png = dir.path().join("big.png");
    let out = small(&render_rigid("2000x2000", &png), "100000000");
    one_line_failure("2000x2000 in 100 MB", &out, &["a 2000x2000 picture would need about 256 MB of memory"]);
    assert!(!png.exists());
}

#[test]
fn huge_step_counts_run_in_bounded_memory() {
    // Statistics are kept per run, not per step: a practically endless run starts and keeps going
    // (pre-allocating per-step storage would abort at once).
    let mut child = shellwarp()
        .args(["sim", "-s", "cantilever", "-m", "rigid", "--steps", &u64::MAX.to_string()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let still_running = child.try_wait().unwrap().is_none();
    child.kill().ok();
    let out = child.wait_with_output().unwrap();
    assert!(still_running, "sim exited early: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn no_display_message_has_no_source_location() {
    let out = shellwarp()
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    let err = one_line_failure("no display", &out, &["opening the display", "DISPLAY"]);
    assert!(!err.contains(".rs:") && !err.contains("os error at"), "{err}");
}
