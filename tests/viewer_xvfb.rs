//! The real viewer window under Xvfb on llvmpipe: a scripted drag through the same command channel
//! the mouse uses deflects the shell toward the target, and the window screenshot shows it. A run
//! without the drag is the negative control: every visual check must tell the two apart.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{DVec3, Vec2};
use image::{RgbaImage, imageops};
use shellwarp::app::orbit::project;
use shellwarp::app::viewer::ViewerState;
use shellwarp::render::{ImageDiff, compare_images, load_png, save_png};

/// The method the viewer test drives, and the dragged vertex (the cantilever's free-end corner).
const METHOD: &str = "mwts";
const VERTEX: usize = 204;
const TARGET: [f64; 3] = [0.5, 0.25, 0.05];

/// Run the viewer for 45 frames, with or without the drag; the screenshot and the state it shows.
fn run_viewer(dir: &Path, name: &str, drag: bool) -> (ViewerState, RgbaImage) {
    let shot = dir.join(format!("{name}.png"));
    let state = dir.join(format!("{name}.json"));
    let mut command = Command::new("xvfb-run");
    command.args(["-a", "-s", "-screen 0 1024x640x24"]).arg(env!("CARGO_BIN_EXE_shellwarp"));
    command.args([
        "view",
        "--scene",
        "cantilever",
        "--method",
        METHOD,
        "--size",
        "800x480",
        "--screenshot-after",
        "45",
    ]);
    if drag {
        let [x, y, z] = TARGET;
        command.args(["--drag", &format!("{VERTEX}:{x},{y},{z}")]);
    }
    let out = command
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

/// The 3D viewport of a screenshot (the panel's text changes from run to run; the scene does not).
fn viewport(shot: &RgbaImage, state: &ViewerState) -> RgbaImage {
    let [x, y, w, h] = state.viewport.map(|v| v.round() as u32);
    imageops::crop_imm(shot, x, y, w, h).to_image()
}

/// Where `point` appears in the window.
fn pixel_of(state: &ViewerState, point: DVec3) -> Vec2 {
    let [x, y, w, h] = state.viewport;
    project(&state.camera(), point.as_vec3(), Vec2::new(w, h)).expect("in front of the camera") + Vec2::new(x, y)
}

/// Pixels of the shell's orange within `radius` pixels of `centre` (not the yellow drag marker, the
/// blue anchors, the grey grid or the blue-grey background).
fn shell_pixels_near(shot: &RgbaImage, centre: Vec2, radius: i32) -> usize {
    let (cx, cy) = (centre.x.round() as i32, centre.y.round() as i32);
    let mut count = 0;
    for y in cy - radius..=cy + radius {
        for x in cx - radius..=cx + radius {
            let inside = x >= 0 && y >= 0 && (x as u32) < shot.width() && (y as u32) < shot.height();
            if !inside || (x - cx).pow(2) + (y - cy).pow(2) > radius * radius {
                continue;
            }
            let [r, g, b, _] = shot.get_pixel(x as u32, y as u32).0.map(i32::from);
            if r > 110 && r > g + 30 && g > b + 20 {
                count += 1;
            }
        }
    }
    count
}

/// The tight budget for the viewport against its reference: driver differences and a few pixels of
/// residual motion (the dragged shell settles within a second; the screenshot is taken later), but
/// not a shell in another place (an undragged run differs by about 0.006 and 3 %).
fn matches_reference(diff: &ImageDiff) -> bool {
    diff.mean_abs < 0.002 && diff.frac_over_threshold < 0.005
}

#[test]
fn scripted_drag_deflects_the_shell_in_the_real_window() {
    let dir = std::env::temp_dir().join(format!("shellwarp-viewer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ((state, shot), (control, control_shot)) = std::thread::scope(|s| {
        let dragged = s.spawn(|| run_viewer(&dir, "drag", true));
        let control = s.spawn(|| run_viewer(&dir, "no-drag", false));
        (dragged.join().unwrap(), control.join().unwrap())
    });

    // The simulation state: the tip is pulled up toward the target; without the drag it sags.
    assert!(state.steps > 0 && control.steps > 0, "both simulations ran");
    let (v, target) = state.position_drags.first().copied().expect("the drag is active");
    assert_eq!((v, target), (VERTEX, TARGET));
    assert!(control.position_drags.is_empty());
    let (tip, sagged) = (DVec3::from(state.positions[VERTEX]), DVec3::from(control.positions[VERTEX]));
    assert!(tip.y > 0.5 * TARGET[1], "tip y {} moved toward the target {}", tip.y, TARGET[1]);
    assert!(sagged.y < 0.0, "without the drag the tip sags ({})", sagged.y);
    assert!(state.positions[12][1].abs() < 0.02, "the clamped end stays put ({})", state.positions[12][1]);

    // The window shows it: shell pixels near the dragged tip (a row 10 cm inboard of it: the target's
    // marker covers the tip itself), none there without the drag, and none where the undragged tip
    // would be.
    let inboard = VERTEX - 4 * 5;
    let (at_tip, at_sag) = (pixel_of(&state, DVec3::from(state.positions[inboard])), pixel_of(&state, sagged));
    assert!(at_tip.distance(at_sag) > 40.0, "the two tips are far apart on screen: {at_tip} vs {at_sag}");
    let near = |img: &RgbaImage, p: Vec2| shell_pixels_near(img, p, 6);
    assert!(near(&shot, at_tip) > 6, "no shell drawn by the dragged tip {at_tip}: {}", near(&shot, at_tip));
    assert!(near(&control_shot, at_sag) > 6, "no shell drawn at the sagging tip {at_sag}");
    assert!(near(&control_shot, at_tip) < 3, "the control shows a shell by the dragged tip");
    assert!(near(&shot, at_sag) < 3, "the dragged shot shows a shell where the tip would sag");

    // And against the reference viewport made on lavapipe: the dragged run matches it within a tight
    // budget, the control does not.
    let reference = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/reference/viewer-drag.png");
    if std::env::var_os("SHELLWARP_BLESS").is_some() {
        save_png(&viewport(&shot, &state), &reference).unwrap();
    }
    let want = load_png(&reference).unwrap();
    let diff = compare_images(&viewport(&shot, &state), &want).unwrap();
    assert!(matches_reference(&diff), "the viewport differs from the reference: {diff}");
    let control_diff = compare_images(&viewport(&control_shot, &control), &want).unwrap();
    assert!(!matches_reference(&control_diff), "an undeflected shell passes the reference check: {control_diff}");
    eprintln!("viewport vs reference: drag {diff}; control {control_diff}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_unattended_screenshot_that_cannot_be_saved_fails_with_one_clear_line() {
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 640x480x24"])
        .arg(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["view", "--scene", "cantilever", "--size", "480x320", "--screenshot-after", "3"])
        .args(["--out", "/nonexistent-shellwarp-dir/shot.png"])
        .output()
        .expect("xvfb-run is installed (apt-get install xvfb xauth)");
    assert!(!out.status.success(), "the run must fail");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = stderr.lines().find(|l| l.starts_with("error:")).unwrap_or_default();
    assert!(line.contains("/nonexistent-shellwarp-dir/shot.png"), "stderr: {stderr}");
}
