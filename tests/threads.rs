//! `--threads`: results do not depend on the thread count beyond round-off, and a bad count is a
//! clear error.

use std::process::{Command, Output};

/// Run the program with `args` and a private cache; its output.
fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    run_with_cache(&tempfile::tempdir().unwrap(), args, env)
}

/// Run the program with `args` and the mode cache in `cache`; its output.
fn run_with_cache(cache: &tempfile::TempDir, args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(args)
        .env("SHELLWARP_CACHE_DIR", cache.path())
        .env_remove("SHELLWARP_THREADS")
        .envs(env.iter().copied())
        .output()
        .unwrap()
}

/// Equal to round-off (relative 1e-12).
fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

/// The JSON a successful run printed.
fn json(args: &[&str]) -> serde_json::Value {
    let out = run(args, &[]);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn the_modal_analysis_is_the_same_on_one_thread_and_on_two() {
    // The creature (12,962 vertices): large enough that faer splits its factorisation and products.
    let analysis =
        |threads: &str| json(&["modes", "--scene", "creature", "--modes", "4", "--json", "--threads", threads]);
    let (one, two) = (analysis("1"), analysis("2"));
    assert_eq!(one["block_solves"], two["block_solves"]);
    let pairs = one["eigenvalues"].as_array().unwrap().iter().zip(two["eigenvalues"].as_array().unwrap());
    assert!(pairs.into_iter().all(|(a, b)| close(a, b)), "{} vs {}", one["eigenvalues"], two["eigenvalues"]);
}

#[test]
fn a_newton_solve_of_the_discrete_shell_is_the_same_on_one_thread_and_on_two() {
    // One implicit step of the creature: Newton iterations, each a factorisation of 38,886 unknowns.
    let step = |threads: &str| {
        json(&["sim", "--scene", "creature", "--method", "ds-implicit", "--steps", "1", "--json", "--threads", threads])
    };
    let (one, two) = (step("1"), step("2"));
    assert!(close(&one["final_energy"], &two["final_energy"]), "{} vs {}", one["final_energy"], two["final_energy"]);
    for key in ["bbox_min", "bbox_max"] {
        let pairs = one[key].as_array().unwrap().iter().zip(two[key].as_array().unwrap());
        assert!(pairs.into_iter().all(|(a, b)| close(a, b)), "{key}: {} vs {}", one[key], two[key]);
    }
    assert_eq!(one["total_iterations"], two["total_iterations"]);
    assert!(one["converged"].as_bool().unwrap() && two["converged"].as_bool().unwrap());
}

#[test]
fn modal_runs_are_the_same_to_the_bit_on_one_thread_and_on_two() {
    // `mwts-rs`: the reconstruction's triangle pass runs in two halves and its solve in two halves of
    // the elimination tree; `mwts` at 32 modes (13k vertices × 32 modes, past the split's size): its
    // vertex pass in two halves. On two threads at once or on one in turn: the same sums either way.
    // The modes (equal across thread counts to round-off only) are computed once and shared.
    let cache = tempfile::tempdir().unwrap();
    for (method, modes) in [("mwts-rs", "solver.modes=4"), ("mwts", "solver.modes=32")] {
        let run = |threads: &str| {
            let args = [
                "sim",
                "--scene",
                "creature",
                "--method",
                method,
                "--set",
                modes,
                "--steps",
                "20",
                "--json",
                "--threads",
                threads,
            ];
            let out = run_with_cache(&cache, &args, &[]);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
        };
        let (one, two) = (run("1"), run("2"));
        for key in ["final_energy", "bbox_min", "bbox_max", "area_change"] {
            assert!(!one[key].is_null(), "{method}: {key} missing: {one}");
            assert_eq!(one[key], two[key], "{method}: {key}");
        }
    }
}

#[test]
fn position_based_runs_are_the_same_to_the_bit_on_one_thread_and_on_two() {
    // The benchmark's 10,000-particle sheet (`tests/self_collision.rs`: it never intersects itself),
    // wrinkling out of its plane, so that its self-collision searches run: its sweeps' colours in
    // pieces on both threads, its triangle scans in two halves, the search's hierarchy refitted in
    // two subtrees. A colour's lanes are independent and the halves' lists are joined in order, so
    // one thread and two give the same positions to the bit, and the zero-intersection tests hold on
    // either.
    let run = |threads: &str| {
        json(&[
            "sim",
            "--scene",
            "hanging-sheet",
            "--set",
            "mesh.grid.segments=[99,99]",
            "--set",
            "solver.method=xpbd",
            "--set",
            "solver.step=0.0166666666666667",
            "--set",
            "solver.substeps=12",
            "--set",
            "solver.sweeps=1",
            "--set",
            "solver.thickness=0.002",
            "--set",
            "solver.least_area=0.2",
            "--set",
            "solver.self_collision=true",
            "--steps",
            "300",
            "--json",
            "--threads",
            threads,
        ])
    };
    let (one, two) = (run("1"), run("2"));
    let depth = one["bbox_max"][2].as_f64().unwrap() - one["bbox_min"][2].as_f64().unwrap();
    assert!(depth > 0.01, "the sheet left its plane (by {depth} m), so it was searched for pairs");
    for key in ["final_energy", "bbox_min", "bbox_max", "area_change"] {
        assert!(!one[key].is_null(), "{key} missing: {one}");
        assert_eq!(one[key], two[key], "{key}");
    }
}

#[test]
fn implicit_cloth_runs_are_the_same_to_the_bit_on_one_thread_and_on_two() {
    // The drape (961 particles, two sides of about 2,600 springs each): its linearisation's sides in
    // a join, its filtered PCG's by a pair of workers, each dot product added side by side in one
    // order. Through the impact, the contacts locking and sliding, and the halved steps, the two runs
    // take the same iterations and end in the same positions to the bit.
    let run = |threads: &str| json(&["sim", "--scene", "drape", "--steps", "120", "--json", "--threads", threads]);
    let (one, two) = (run("1"), run("2"));
    assert!(one["total_iterations"].as_u64().unwrap() > 1000, "the solves iterated: {one}");
    for key in ["final_energy", "bbox_min", "bbox_max", "area_change", "total_iterations"] {
        assert!(!one[key].is_null(), "{key} missing: {one}");
        assert_eq!(one[key], two[key], "{key}");
    }
}

#[test]
fn a_bad_thread_count_is_one_clear_error() {
    let out = run(&["scenes", "--threads", "0"], &[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--threads"), "{}", String::from_utf8_lossy(&out.stderr));
    for bad in ["0", "many", "-2"] {
        let out = run(&["scenes"], &[("SHELLWARP_THREADS", bad)]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "SHELLWARP_THREADS={bad} was accepted");
        assert!(err.starts_with("error: environment variable SHELLWARP_THREADS") && err.contains(bad), "{err}");
    }
    let out = run(&["scenes"], &[("SHELLWARP_THREADS", "2")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
