//! The README cannot rot: its example scene parses and loads, and its command synopsis lists exactly
//! the options each subcommand's `--help` has (the options of the bare `shellwarp` line go with
//! every subcommand).

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::process::Command;

use shellwarp::scene::{self, Origin, Setup};

fn readme() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).expect("README.md is readable")
}

/// The first fenced block of `lang` after the heading `heading`.
fn block(text: &str, heading: &str, lang: &str) -> String {
    let section = text.split(heading).nth(1).unwrap_or_else(|| panic!("README has no `{heading}`"));
    let fence = format!("```{lang}\n");
    let body = section.split(&fence).nth(1).unwrap_or_else(|| panic!("no {lang} block under `{heading}`"));
    body.split("```").next().unwrap_or_default().to_string()
}

#[test]
fn readme_example_scene_parses_and_loads() {
    let text = block(&readme(), "## Scene files", "toml");
    let origin = Origin { label: "README.md".into(), dir: PathBuf::new() };
    let scene = scene::parse(&text, &origin, &[]).unwrap_or_else(|e| panic!("README example scene: {e}"));
    assert_eq!(scene.name, "cantilever");
    assert_eq!((scene.anchors.len(), scene.loads.len(), scene.colliders.len()), (1, 1, 1));
    let setup = Setup::new(scene, origin).unwrap_or_else(|e| panic!("README example scene: {e}"));
    assert_eq!(setup.mesh.vertex_count(), 41 * 5);
    // The anchor box ends at x = −0.474: the first two columns of the 41 × 5 grid.
    assert_eq!(setup.anchors.len(), 2 * 5);
}

/// The options every subcommand takes: those of the synopsis's bare `shellwarp` line, which the
/// program's own `--help` lists too.
fn global_options(synopsis: &str) -> BTreeSet<String> {
    let line =
        synopsis.lines().find(|l| l.starts_with("shellwarp ") && l[10..].trim_start().starts_with('[')).unwrap_or("");
    let globals = long_options(line.split("   ").next().unwrap_or(""));
    let help = Command::new(env!("CARGO_BIN_EXE_shellwarp")).arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    let options: String = help.lines().filter(|l| l.trim_start().starts_with('-')).collect::<Vec<_>>().join("\n");
    assert_eq!(globals, long_options(&options), "README's bare `shellwarp` line vs `shellwarp --help`");
    globals
}

/// Every `--long` option in `text`, except `--help` and `--version`.
fn long_options(text: &str) -> BTreeSet<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| w.starts_with("--") && w.len() > 2 && !["--help", "--version"].contains(w))
        .map(str::to_string)
        .collect()
}

#[test]
fn readme_synopsis_matches_every_subcommands_help() {
    let synopsis = block(&readme(), "## Command line", "text");
    let globals = global_options(&synopsis);
    for sub in ["view", "scenes", "render", "sim", "modes"] {
        // The subcommand's line and its indented continuation lines, without the descriptions at the right.
        let mut lines = synopsis.lines().skip_while(|l| !l.starts_with(&format!("shellwarp {sub} ")));
        let first = lines.next().unwrap_or_else(|| panic!("README synopsis has no `shellwarp {sub}` line"));
        let mut usage = first.split("   ").take(2).collect::<Vec<_>>().join(" ");
        for l in lines.take_while(|l| l.starts_with(' ')) {
            usage.push_str(l);
        }
        let help = Command::new(env!("CARGO_BIN_EXE_shellwarp")).args([sub, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&help.stdout);
        // Options are the help lines that start with `-`.
        let options: String = help.lines().filter(|l| l.trim_start().starts_with('-')).collect::<Vec<_>>().join("\n");
        let usage: BTreeSet<String> = long_options(&usage).union(&globals).cloned().collect();
        assert_eq!(usage, long_options(&options), "README synopsis of `{sub}` vs its --help");
    }
}

/// `eval` has one synopsis line per mode; together they list exactly its options.
#[test]
fn readme_synopsis_of_eval_lists_its_options() {
    let synopsis = block(&readme(), "## Command line", "text");
    let usage: String = synopsis.lines().filter(|l| l.starts_with("shellwarp eval ")).collect::<Vec<_>>().join("\n");
    assert!(usage.lines().count() >= 4, "run, plan, case and merge lines");
    let help = Command::new(env!("CARGO_BIN_EXE_shellwarp")).args(["eval", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    let options: String = help.lines().filter(|l| l.trim_start().starts_with('-')).collect::<Vec<_>>().join("\n");
    let usage: BTreeSet<String> = long_options(&usage).union(&global_options(&synopsis)).cloned().collect();
    assert_eq!(usage, long_options(&options), "README synopsis of `eval` vs its --help");
}
