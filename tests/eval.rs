//! `shellwarp eval --quick all`, run once as the program (the binary), and checked: every chart decodes,
//! has its stated size and is not blank; every planned case has rows; every bold number of the summary
//! is a value of its experiment's CSV; the cases run one by one from `--plan` and merged give the same
//! computed columns as the one-shot run; and the findings hold on the quick sweep (MWTS below
//! LMA with converged references, a found explicit-DS boundary near 2/ω_max, a failure of every
//! conditionally stable method, automatic choices that meet their targets at the brute force's cost).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use shellwarp::eval::report::number;
use shellwarp::eval::{self, Table};

fn shellwarp() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shellwarp"));
    let runtime = std::env::temp_dir().join("shellwarp-eval-xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    c.env("XDG_RUNTIME_DIR", runtime);
    c
}

fn run_ok(c: &mut Command) -> String {
    let out = c.output().expect("the binary runs");
    assert!(out.status.success(), "{:?} failed:\n{}", c, String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The one-shot quick run, shared by the tests of this file.
fn report() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        // In the build's scratch (a static is never dropped), replaced at each run.
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("eval-report");
        let _ = std::fs::remove_dir_all(&dir);
        run_ok(shellwarp().args(["eval", "all", "--quick", "--jobs", "2", "--out"]).arg(&dir));
        dir
    })
}

fn table(dir: &Path, experiment: &str) -> Table {
    let e = eval::find(experiment).unwrap();
    Table::read_csv(&dir.join(format!("{experiment}.csv")), e.columns()).unwrap()
}

fn rows<'a>(t: &'a Table, column: &str, value: &'a str) -> Vec<&'a Vec<eval::Value>> {
    t.filter(column, value).unwrap().collect()
}

fn num(t: &Table, row: &[eval::Value], column: &str) -> f64 {
    t.get(row, column).unwrap().num()
}

#[test]
fn every_chart_decodes_at_its_stated_size_and_is_not_blank() {
    let summary = std::fs::read_to_string(report().join("README.md")).unwrap();
    let mut charts = 0;
    for line in summary.lines().filter(|l| l.starts_with('*') && l.ends_with(" px*")) {
        // "*file.png: caption — W × H px*"
        let file = line.trim_start_matches('*').split(':').next().unwrap();
        let size = line.rsplit(" — ").next().unwrap().trim_end_matches(" px*");
        let (w, h) = size.split_once(" × ").unwrap();
        let image = image::open(report().join(file)).unwrap_or_else(|e| panic!("{file}: {e}")).to_rgb8();
        assert_eq!(image.dimensions(), (w.parse().unwrap(), h.parse().unwrap()), "{file}");
        let inked = image.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(inked > image.pixels().len() / 50, "{file} is nearly blank ({inked} pixels not white)");
        assert!(summary.contains(&format!("]({file})")), "{file} is embedded in the summary");
        charts += 1;
    }
    assert!(charts >= 10, "the summary lists {charts} charts");
}

#[test]
fn every_planned_case_has_rows() {
    for e in eval::experiments() {
        let t = table(report(), e.name());
        for case in e.cases(true) {
            assert!(!rows(&t, "case", &case).is_empty(), "{}/{case} has no rows", e.name());
        }
    }
}

/// Every bold number in an experiment's section equals a value of its CSV as printed (three
/// significant digits; `x%` is 100 × a value; signs are not printed for magnitudes).
#[test]
fn the_summary_numbers_are_the_csv_values() {
    let summary = std::fs::read_to_string(report().join("README.md")).unwrap();
    let mut checked = 0;
    for section in summary.split("\n## ").skip(1) {
        let name = section.split('`').nth(1).unwrap();
        let t = table(report(), name);
        let values: Vec<f64> = t.rows.iter().flatten().map(|v| v.num()).filter(|v| v.is_finite()).collect();
        let printed = |scale: f64| -> Vec<String> {
            values.iter().flat_map(|v| [number(v * scale), number((v * scale).abs())]).collect()
        };
        let (plain, percent) = (printed(1.0), printed(100.0));
        for bold in section.split("**").skip(1).step_by(2) {
            let Some(first) = bold.chars().next() else { continue };
            if !(first.is_ascii_digit() || first == '-') {
                continue;
            }
            let found = match bold.strip_suffix('%') {
                Some(p) => percent.iter().any(|x| x == p),
                None => plain.iter().any(|x| x == bold),
            };
            assert!(found, "{name}: **{bold}** is not a value of {name}.csv");
            checked += 1;
        }
    }
    assert!(checked > 30, "only {checked} numbers checked");
}

#[test]
fn cases_planned_run_one_by_one_and_merged_give_the_one_shot_tables() {
    let dir = std::env::temp_dir().join(format!("shellwarp-eval-split-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let experiments = ["paper-fig4", "stability"];
    let plan = run_ok(shellwarp().args(["eval", "--plan", "--quick", "--out", "somewhere"]).args(experiments));
    let mut parts = Vec::new();
    for (i, line) in plan.lines().enumerate() {
        // shellwarp eval --case 'ID' --quick --out 'somewhere'
        let id = line.split('\'').nth(1).unwrap();
        assert!(line.starts_with("shellwarp eval --case ") && line.contains("--quick"), "{line}");
        let part = dir.join(format!("machine-{}", i % 3));
        run_ok(shellwarp().args(["eval", "--case", id, "--quick", "--out"]).arg(&part));
        parts.push(part);
    }
    parts.dedup();
    let merged = dir.join("merged");
    run_ok(shellwarp().args(["eval", "--merge"]).args(&parts).arg("--out").arg(&merged));
    for name in experiments {
        let (one, split) = (table(report(), name), table(&merged, name));
        assert_eq!(one.rows.len(), split.rows.len(), "{name}: rows");
        for (a, b) in one.rows.iter().zip(&split.rows) {
            for (c, (x, y)) in one.columns.iter().zip(a.iter().zip(b)) {
                if c.kind == eval::table::Kind::Computed && c.name != "message" {
                    assert!(x == y || (x.num().is_nan() && y.num().is_nan()), "{name}.{}: {x:?} vs {y:?}", c.name);
                }
            }
        }
        assert!(merged.join(format!("{name}.csv")).is_file());
    }
    assert!(merged.join("paper-fig4-equilibria.png").is_file(), "the case pictures travel with the merge");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn paper_fig6_mwts_beats_lma_rds_beats_mwts_rs_against_converged_references_and_mwts_keeps_a_fraction_of_lmas_area_change()
 {
    let t = table(report(), "paper-fig6");
    let mut levels = 0;
    let mut by_case: BTreeMap<String, Vec<&Vec<eval::Value>>> = BTreeMap::new();
    t.rows.iter().for_each(|r| by_case.entry(r[0].text()).or_default().push(r));
    for (case, rs) in &by_case {
        let get = |m: &str| rs.iter().find(|r| t.get(r, "method").unwrap().text() == m).copied().unwrap();
        let (lma, mwts, reference) = (get("lma"), get("mwts"), get("ds-static"));
        assert!(num(&t, reference, "ref_relative_residual") <= 1e-8, "{case}: reference not converged");
        assert!(num(&t, mwts, "rel_error") < num(&t, lma, "rel_error"), "{case}: MWTS error not below LMA's");
        // Where `mwts-rs` is off by more than 0.1%, `rds` is closer (below it both are still
        // settling when the quick sweep stops them).
        let (rs, rds) = (num(&t, get("mwts-rs"), "rel_error"), num(&t, get("rds"), "rel_error"));
        assert!(rds < rs.max(1e-3), "{case}: rds error {rds} not below mwts-rs's {rs}");
        if num(&t, lma, "area_change").abs() > 0.01 {
            let fraction = num(&t, mwts, "area_vs_lma");
            assert!(fraction <= 0.25, "{case}: MWTS's area change is {fraction:.3} of LMA's");
        }
        levels += 1;
    }
    assert!(levels >= 6, "both quick sweeps ({levels} levels)");
}

#[test]
fn stability_sweeps_find_the_explicit_limit_mwts_inflating_xpbd_tunnelling_and_a_heavy_box_sinking() {
    let t = table(report(), "stability");
    let boundaries = rows(&t, "probe", "boundary");
    let text = |r: &Vec<eval::Value>, c: &str| t.get(r, c).unwrap().text();
    let found = |family: &str, method: &str, class: &str| {
        boundaries
            .iter()
            .filter(|r| text(r, "family") == family && text(r, "method") == method && text(r, "outcome") == class)
            .copied()
            .collect::<Vec<_>>()
    };
    // The explicit method's limit, by bisection, near its own estimate 2/ω_max.
    let explicit = found("step", "ds", "diverged");
    assert!(!explicit.is_empty(), "the sweep found the explicit boundary");
    for b in &explicit {
        let ratio = num(&t, b, "boundary_vs_estimate");
        assert!((ratio - 1.0).abs() <= 0.2, "boundary / (2/ω_max) = {ratio:.3}");
        assert!(text(b, "message").contains("diverged"), "the solver's own message is kept: {}", text(b, "message"));
    }
    // `mwts` inflates under a large drag of the creature, and works under a small one.
    for b in found("drag", "mwts", "inflated") {
        assert!(num(&t, b, "area_change") > 0.1 && text(b, "message").contains("area changed"));
        assert!(num(&t, b, "x") > 0.05 && num(&t, b, "x") < 0.53, "a boundary inside the swept distances");
    }
    assert!(!found("drag", "mwts", "inflated").is_empty(), "mwts never inflated");
    // `xpbd` tunnels through the ground or itself at too few substeps, and a heavy box sinks through it.
    let pile = found("pile", "xpbd", "tunnelled");
    assert!(!pile.is_empty() && pile.iter().all(|b| num(&t, b, "x") >= 1.0 && !text(b, "message").is_empty()));
    let sinking = found("box", "xpbd", "tunnelled");
    assert!(!sinking.is_empty(), "no box sank through xpbd cloth");
    assert!(sinking.iter().all(|b| num(&t, b, "x") > 1.0 && num(&t, b, "x") < 1000.0), "a mass ratio within the sweep");
    // Every boundary sits between a working and a failed probe of its row.
    for b in &boundaries {
        let case = text(b, "case");
        let probes: Vec<_> = rows(&t, "case", &case).into_iter().filter(|r| text(r, "probe") != "boundary").collect();
        let at = |x: f64| probes.iter().find(|r| num(&t, r, "x") == x).map(|r| text(r, "outcome"));
        let worked = at(num(&t, b, "x")).unwrap_or_else(|| panic!("{case}: the boundary is a probed value"));
        assert!(worked == "stable" || worked == "inaccurate", "{case}: the boundary's own run {worked}");
    }
}

#[test]
fn automatic_choices_meet_their_targets_at_the_brute_force_cost() {
    let t = table(report(), "auto-model");
    let mut scenes = 0;
    let mut cases: Vec<String> = t.rows.iter().map(|r| r[0].text()).collect();
    cases.dedup();
    for case in &cases {
        // One choice per case, or per part of the dancer's.
        for chosen in rows(&t, "case", case).into_iter().filter(|r| num(&t, r, "chosen") == 1.0) {
            let part = num(&t, chosen, "part");
            assert_eq!(num(&t, chosen, "meets"), 1.0, "{case} {part}: the choice misses its target");
            let ratio = num(&t, chosen, "cost_vs_cheapest");
            assert!(ratio <= 1.1, "{case} {part}: the choice costs {ratio:.2} × the brute force's cheapest");
        }
        scenes += 1;
    }
    assert!(scenes >= 5, "{scenes} scenes");
    assert!(cases.iter().any(|c| c == "hammock") && cases.iter().any(|c| c.starts_with("v-beam")), "beams and cloth");
    let dancer = rows(&t, "case", "dancer").into_iter().filter(|r| num(&t, r, "chosen") == 1.0).count();
    assert_eq!(dancer, 4, "one choice per part of the dancer");
}
