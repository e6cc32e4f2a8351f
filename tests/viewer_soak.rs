//! The real window under Xvfb driven by a random script (`view --soak`): drags and twists added and
//! moved, parameters edited in and out of range, methods and scenes switched, resets — and a solver
//! that panics or hangs on command. The window must survive all of it (exit cleanly), never draw a
//! non-finite position, show every panic with its message and every hang as stuck, and recover from
//! each (by *Reset* or a method switch).
//! The 30-second soak and the panicking solver are in the suite; the 10-minute soak, which also
//! checks that resident memory at home stays flat after its first minute, is
//! `cargo test --release --test viewer_soak -- --ignored`.

use std::process::Command;

use shellwarp::app::soak::SoakReport;

/// One soak at a time: each runs a software-rendered window flat out on a 2-core machine, and the
/// frame-time bounds assume it has the machine to itself.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Run the viewer for `seconds` with the soak's extra arguments; its report.
fn soak(name: &str, seconds: u32, extra: &[&str]) -> SoakReport {
    let _machine = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::Builder::new().prefix(&format!("shellwarp-soak-{name}-")).tempdir().unwrap();
    let report = dir.path().join("report.json");
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x640x24"])
        .arg(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["view", "--size", "800x480", "--soak", &seconds.to_string(), "--soak-report"])
        .arg(&report)
        .args(extra)
        .env("SHELLWARP_TEST_METHODS", "1")
        .env("SHELLWARP_CACHE_DIR", dir.path().join("cache"))
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("xvfb-run is installed (apt-get install xvfb xauth)");
    assert!(out.status.success(), "the window did not survive: {}", String::from_utf8_lossy(&out.stderr));
    let report: SoakReport = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    eprintln!("{name}: {}", serde_json::to_string(&report).unwrap());
    report
}

/// What every soak must show: it ran its time, drew frames, none non-finite, no frame stuck.
fn healthy(r: &SoakReport, seconds: f64) {
    // The last frame recorded starts before the time is up (within the longest frame allowed below).
    assert!(r.seconds >= seconds - 2.0, "ran {} s", r.seconds);
    assert!(r.frames as f64 > 2.0 * seconds, "{} frames in {} s", r.frames, r.seconds);
    assert_eq!(r.non_finite_frames, 0, "frames drew a non-finite position");
    for (minute, [median, p99, _]) in r.frame_ms_by_minute.iter().enumerate() {
        assert!(*median < 500.0 && *p99 < 2000.0, "minute {minute}: frames {median} ms median, {p99} ms p99");
    }
}

#[test]
fn a_panicking_or_hanging_solver_in_the_real_window_is_shown_and_recovered() {
    // `faulty` alone: a switch to a method that cannot fault would end the test's faults by chance.
    let r = soak("faulty", 25, &["-m", "faulty", "--soak-methods", "faulty", "--soak-seed", "3"]);
    healthy(&r, 25.0);
    assert!(r.events.get("fault").copied().unwrap_or(0) >= 1, "the script set the fault: {:?}", r.events);
    assert!(!r.panics.is_empty(), "a panic was shown");
    for p in &r.panics {
        assert!(p.contains("panicked") && p.contains("fault was set") && p.contains("Reset"), "{p}");
    }
    assert!(!r.hangs.is_empty(), "a hang was shown: {r:?}");
    assert!(r.hangs.iter().all(|h| h.contains("`faulty` stuck in a step")), "{:?}", r.hangs);
    // Every fault but one in the last moments before the end was recovered from.
    let faults = r.panics.len() + r.hangs.len();
    assert!(r.recovered as usize + 1 >= faults && r.recovered >= 2, "{} of {faults} recovered", r.recovered);
}

#[test]
fn a_thirty_second_soak_of_the_real_window() {
    let r = soak("30s", 30, &[]);
    healthy(&r, 30.0);
    let kinds = r.events.len();
    let total: u64 = r.events.values().sum();
    assert!(kinds >= 6 && total >= 30, "{total} events of {kinds} kinds: {:?}", r.events);
    assert!(!r.errors.is_empty(), "out-of-range edits were refused with a message");
}

#[test]
#[ignore]
fn a_ten_minute_soak_of_the_real_window_keeps_its_memory_flat() {
    let r = soak("10min", 600, &[]);
    healthy(&r, 600.0);
    // Memory at home (the first scene at rest, revisited each minute): flat within 10% of the first visit.
    let home: Vec<f64> = r.home_mb.iter().map(|s| s.1).collect();
    eprintln!("resident memory at home, each minute: {home:.0?} MB");
    assert!(home.len() >= 8, "visited home {} times", home.len());
    let peak = home.iter().copied().fold(0.0, f64::max);
    assert!(peak <= 1.1 * home[0], "memory at home grew from {:.0} MB to {peak:.0} MB", home[0]);
}
