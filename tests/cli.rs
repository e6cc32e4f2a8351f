//! The command-line contract: subcommands, JSON output, and one clear error line with a non-zero exit.

use std::process::Command;

fn shellwarp(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shellwarp")).args(args).output().expect("binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn scenes_lists_every_builtin_and_method() {
    let (code, out, _) = shellwarp(&["scenes"]);
    assert_eq!(code, 0);
    for name in shellwarp::scene::builtin_names() {
        assert!(out.contains(name), "{name} missing from:\n{out}");
    }
    for m in shellwarp::solver::METHODS {
        assert!(out.contains(m.name), "{} missing", m.name);
    }
}

#[test]
fn output_closed_early_ends_the_run_quietly() {
    use std::process::Stdio;
    // The reader goes away before the first line (as `| head -0` does): every write fails.
    let mut child = Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["eval", "--plan", "all"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("binary ends");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(0), "{err}");
}

#[test]
fn sim_json_reports_steps_timing_energy_and_bbox() {
    let (code, out, err) = shellwarp(&["sim", "--scene", "cantilever", "--method", "rigid", "--steps", "4", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON object");
    assert_eq!(v["steps"], 4);
    assert_eq!(v["method"], "rigid");
    assert!(v["step_seconds"]["mean"].as_f64().is_some());
    assert!(v["final_energy"].as_f64().is_some());
    let (lo, hi) = (&v["bbox_min"], &v["bbox_max"]);
    assert!((hi[0].as_f64().unwrap() - lo[0].as_f64().unwrap() - 1.0).abs() < 1e-12, "strip is 1 m long");
    assert!(v["diverged"].is_null());
}

#[test]
fn sim_json_reports_newton_convergence_of_ds_static() {
    let (code, out, err) =
        shellwarp(&["sim", "--scene", "cantilever", "--method", "ds-static", "--steps", "2", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON object");
    assert_eq!((v["method"].as_str(), v["steps"].as_u64()), (Some("ds-static"), Some(2)));
    assert_eq!(v["converged"], true, "{v}");
    assert_eq!(v["unconverged_steps"], 0);
    // The scene's tolerance is 1e-8 relative; the first step from rest takes a few Newton iterations,
    // the second starts at the equilibrium and takes none.
    let relative = v["final_relative_residual"].as_f64().unwrap();
    assert!(relative > 0.0 && relative <= 1e-8, "{relative}");
    assert!(v["final_residual"].as_f64().unwrap() > 0.0);
    assert!(v["total_iterations"].as_u64().unwrap() >= 3, "{v}");
    let t = &v["step_seconds"];
    let (min, mean, max) = (t["min"].as_f64().unwrap(), t["mean"].as_f64().unwrap(), t["max"].as_f64().unwrap());
    assert!(0.0 < min && min <= mean && mean <= max, "{t}");
    // It sags: the tip is below the clamp.
    assert!(v["bbox_min"][1].as_f64().unwrap() < -0.1, "{v}");
}

#[test]
fn sim_reports_a_diverging_ds_run_with_exit_code_1() {
    let (code, out, err) =
        shellwarp(&["sim", "--scene", "cantilever", "--method", "ds", "--set", "solver.substep=1e-3", "--json"]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: simulation diverged at step 1") && err.contains("stable limit"), "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON object");
    let reason = v["diverged"].as_str().expect("diverged is the reason");
    assert!(reason.contains("diverged") && reason.contains("substep"), "{reason}");
    assert_eq!(v["steps"], 0);
    assert_eq!(v["converged"], false);
    // No step completed: the timing is zeros (not −0.0) and the box is the last finite state, the rest shape.
    fn negative_zero(v: &serde_json::Value) -> bool {
        match v {
            serde_json::Value::Number(n) => n.as_f64().is_some_and(|x| x == 0.0 && x.is_sign_negative()),
            serde_json::Value::Array(a) => a.iter().any(negative_zero),
            serde_json::Value::Object(o) => o.values().any(negative_zero),
            _ => false,
        }
    }
    assert!(!negative_zero(&v), "{out}");
    assert_eq!(v["step_seconds"]["mean"].as_f64(), Some(0.0));
    assert_eq!(v["bbox_min"][0].as_f64(), Some(-0.5));
    assert_eq!(v["bbox_max"][0].as_f64(), Some(0.5));
    let notes = v["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap_or("").contains("ABOVE the estimated stable limit")), "{notes:?}");
}

#[test]
fn sim_writes_the_final_mesh_as_obj() {
    let dir = std::env::temp_dir().join(format!("shellwarp-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("out.obj");
    let (code, _, err) =
        shellwarp(&["sim", "-s", "cantilever", "-m", "rigid", "--steps", "1", "--obj", obj.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let mesh = shellwarp::mesh::obj::load_obj(&obj).expect("written OBJ loads back");
    assert_eq!(mesh.vertex_count(), 205);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_gives_one_clear_line_and_nonzero_exit() {
    let cases: [(&[&str], &str); 5] = [
        (&["sim", "--scene", "no-such-scene"], "neither a built-in scene"),
        (&["sim", "--scene", "missing/file.toml"], "missing/file.toml: cannot read"),
        (&["sim", "--scene", "cantilever", "--method", "warp9"], "unknown method `warp9`"),
        (
            &["sim", "--scene", "cantilever", "--set", "material.k_bend=nan"],
            "`material.k_bend`: NaN is not a finite number",
        ),
        (&["sim", "--scene", "cantilever", "--set", "material.k_bent=1"], "unknown field `k_bent`"),
    ];
    for (args, expected) in cases {
        let (code, out, err) = shellwarp(args);
        assert_ne!(code, 0, "{args:?} should fail");
        assert!(out.is_empty(), "{args:?} printed to stdout: {out}");
        assert_eq!(err.lines().count(), 1, "{args:?}: one line expected, got:\n{err}");
        assert!(err.starts_with("error: ") && err.contains(expected), "{args:?}: {err}");
    }
}

#[test]
fn broken_scene_file_is_reported_with_its_path() {
    let dir = std::env::temp_dir().join(format!("shellwarp-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(
        &path,
        "name = \"bad\"\n[mesh.grid]\nsize = [1.0, 1.0]\nsegments = [2, 2]\n[solver]\nmethod = \"rigid\"\nstepp = 1\n",
    )
    .unwrap();
    let (code, _, err) = shellwarp(&["sim", "--scene", path.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(err.contains("bad.toml:7:1:") && err.contains("stepp"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn no_gpu_adapter_and_no_display_are_one_clear_line() {
    // Restricting wgpu to a backend this platform does not have leaves no adapter at all.
    let out = Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["render", "--scene", "cantilever", "--frames", "0", "--out"])
        .arg(std::env::temp_dir().join("shellwarp-no-gpu.png"))
        .env("WGPU_BACKEND", "dx12")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("no GPU adapter found"), "{err}");

    let out = Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("opening the display"), "{err}");
}

#[test]
fn render_writes_a_numbered_sequence_of_distinct_frames() {
    let dir = std::env::temp_dir().join(format!("shellwarp-seq-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (code, _, err) = shellwarp(&[
        "render",
        "--scene",
        "cantilever",
        "--frames",
        "20",
        "--every",
        "2",
        "--size",
        "240x160",
        "--out-dir",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    let expected: Vec<String> = (1..=10).map(|i| format!("frame-{i:06}.png")).collect();
    assert_eq!(names, expected, "ten zero-padded frames and nothing else");
    let frames: Vec<_> = names.iter().map(|n| image::open(dir.join(n)).unwrap().to_rgba8()).collect();
    for (i, pair) in frames.windows(2).enumerate() {
        assert_ne!(pair[0], pair[1], "frames {} and {} are identical: the shell did not move", i + 1, i + 2);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_interrupted_sequence_leaves_only_whole_pictures() {
    let dir = std::env::temp_dir().join(format!("shellwarp-seq-kill-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut child = Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["render", "--scene", "cantilever", "--frames", "100000", "--size", "640x400", "--out-dir"])
        .arg(&dir)
        .env("NODEVICE_SELECT", "1") // no re-run of itself in a child that the kill would miss
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    let count = || std::fs::read_dir(&dir).map_or(0, |d| d.count());
    while count() < 5 && start.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let mut finals = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if name.starts_with("frame-") && name.ends_with(".png") {
            image::open(dir.join(&name)).unwrap_or_else(|e| panic!("{name} is not a whole PNG: {e}"));
            finals += 1;
        } else {
            assert!(name.starts_with('.') && name.ends_with(".tmp"), "unexpected file {name}");
        }
    }
    assert!(finals >= 4, "{finals} pictures before the kill");
    std::fs::remove_dir_all(&dir).unwrap();
}
