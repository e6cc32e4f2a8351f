//! The mode cache shared by several programs at once (the evaluation's parallel cases on one
//! cluster's disk): four processes start together on an empty cache and all compute or read the same
//! entry. Every one succeeds with the same shape to the bit, one valid file is left and no temporary
//! one, and a later run reads it. A short version runs in the suite; the hundred-round one is
//! `cargo test --release --test cache_shared -- --ignored`.

use std::path::Path;
use std::process::{Command, Output};

const PROCESSES: usize = 4;

fn sim(cache: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["sim", "--scene", "cantilever", "--steps", "3", "--json"])
        .env("SHELLWARP_CACHE_DIR", cache)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary starts")
}

/// The bounding box a run printed (its shape, to the bit).
fn bbox(out: &Output) -> String {
    assert!(out.status.success(), "a run failed: {}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    format!("{} {}", json["bbox_min"], json["bbox_max"])
}

fn rounds(n: usize) {
    for round in 0..n {
        let dir = tempfile::tempdir().unwrap();
        let children: Vec<_> = (0..PROCESSES).map(|_| sim(dir.path())).collect();
        let shapes: Vec<String> = children.into_iter().map(|c| bbox(&c.wait_with_output().unwrap())).collect();
        assert!(shapes.iter().all(|s| *s == shapes[0]), "round {round}: the processes disagree: {shapes:?}");
        let files: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(files.len(), 1, "round {round}: one entry and no temporary file: {files:?}");
        assert!(files[0].starts_with("modes-") && files[0].ends_with(".bin"), "{files:?}");
        // A later run reads the entry: an invalid one would be recomputed and written again.
        let written = || std::fs::metadata(dir.path().join(&files[0])).unwrap().modified().unwrap();
        let before = written();
        assert_eq!(bbox(&sim(dir.path()).wait_with_output().unwrap()), shapes[0], "round {round}: from the cache");
        assert_eq!(written(), before, "round {round}: the entry was valid and read, not written again");
    }
}

#[test]
fn four_processes_sharing_an_empty_cache_all_succeed_and_leave_one_valid_entry() {
    rounds(3);
}

/// The hundred rounds of the hardening issue.
#[test]
#[ignore]
fn four_processes_sharing_an_empty_cache_a_hundred_times() {
    rounds(100);
}
