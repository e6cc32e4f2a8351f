//! The real viewer window under Xvfb on llvmpipe: a scripted drag through the same command channel
//! the mouse uses deflects the shell toward the target, and the window screenshot shows it.

use std::path::PathBuf;
use std::process::Command;

use shellwarp::app::viewer::ViewerState;
use shellwarp::render::{compare_images, load_png, save_png};

/// The method the viewer test drives, and the dragged vertex (the cantilever's free-end corner).
const METHOD: &str = "mwts";
const VERTEX: usize = 204;

fn run_viewer(dir: &std::path::Path) -> (ViewerState, image::RgbaImage) {
    let shot = dir.join("view.png");
    let state = dir.join("state.json");
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x640x24"])
        .arg(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["view", "--scene", "cantilever", "--method", METHOD, "--size", "800x480"])
        .args(["--drag", &format!("{VERTEX}:0.5,0.25,0.05"), "--screenshot-after", "45"])
        .arg("--out")
        .arg(&shot)
        .arg("--state-out")
        .arg(&state)
        .output()
        .expect("xvfb-run is installed (apt-get install xvfb xauth)");
    assert!(out.status.success(), "viewer failed: {}", String::from_utf8_lossy(&out.stderr));
    let state: ViewerState = serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
    (state, load_png(&shot).unwrap())
}

#[test]
fn scripted_drag_deflects_the_shell_in_the_real_window() {
    let dir = std::env::temp_dir().join(format!("shellwarp-viewer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (state, shot) = run_viewer(&dir);
    assert!(state.steps > 0, "the simulation ran");
    let (v, target) = state.position_drags.first().copied().expect("the drag is active");
    assert_eq!(v, VERTEX);
    // Without the drag the tip sags below the rest plane; with it, it is pulled up toward the target.
    let y = state.positions[VERTEX][1];
    assert!(y > 0.5 * target[1], "tip y {y} moved toward the target {}", target[1]);
    let root = state.positions[12][1];
    assert!(root.abs() < 0.02, "the clamped end stays put ({root})");
    // And the window shows it: compared with the reference screenshot made on lavapipe.
    let reference = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/reference/viewer-drag.png");
    if std::env::var_os("SHELLWARP_BLESS").is_some() {
        save_png(&shot, &reference).unwrap();
    }
    let want = load_png(&reference).unwrap();
    let diff = compare_images(&shot, &want).unwrap();
    // The panel's text (fps, timings) changes from run to run: a loose per-pixel budget.
    assert!(diff.mean_abs < 0.02 && diff.frac_over_threshold < 0.03, "window differs from reference: {diff}");
    std::fs::remove_dir_all(&dir).ok();
}
