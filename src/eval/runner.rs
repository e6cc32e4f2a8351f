//! Planning, running and merging cases. A one-shot evaluation is [`run_cases`] then [`merge`]; the
//! same two steps split over machines are [`plan`], one [`run_case`] per printed command, and
//! [`merge`] of the directories the cases wrote.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::case::{CASES_DIR, CaseId};
use super::report::{self, Section};
use super::table::Table;
use super::{EvalError, Experiment, experiments, find};

/// The named experiments (`all` for every one), in the summary's order.
pub fn chosen(names: &[String]) -> Result<Vec<&'static dyn Experiment>, EvalError> {
    for n in names.iter().filter(|n| *n != "all") {
        find(n)?;
    }
    Ok(experiments().iter().copied().filter(|e| names.iter().any(|n| n == "all" || n == e.name())).collect())
}

/// Every case of the named experiments (`all` for every experiment), in report order.
pub fn plan(names: &[String], quick: bool) -> Result<Vec<CaseId>, EvalError> {
    Ok(chosen(names)?
        .iter()
        .flat_map(|e| e.cases(quick).into_iter().map(|key| CaseId { experiment: e.name(), key }))
        .collect())
}

/// Run one case and write its table to `out/cases/`.
pub fn run_case(case: &CaseId, quick: bool, out: &Path, progress: &dyn Fn(f32)) -> Result<(), EvalError> {
    let e = find(case.experiment)?;
    let table = e.run(&case.key, quick, out, progress)?;
    table.write_csv(&case.path(out))
}

/// What [`run_cases`] reports while it works.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A case started.
    Started(String),
    /// A case finished (successfully or not).
    Finished(String),
}

/// Run cases on `jobs` threads (each case on one thread), writing their tables to `out/cases/`.
/// Every case runs even if another fails; the error lists the failed ones.
pub fn run_cases(
    cases: &[CaseId],
    quick: bool,
    out: &Path,
    jobs: usize,
    events: &(dyn Fn(Event) + Sync),
) -> Result<(), EvalError> {
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs.clamp(1, cases.len().max(1)) {
            scope.spawn(|| {
                while let Some(case) = cases.get(next.fetch_add(1, Ordering::Relaxed)) {
                    events(Event::Started(case.id()));
                    if let Err(e) = run_case(case, quick, out, &|_| {}) {
                        failures.lock().unwrap_or_else(|p| p.into_inner()).push(format!("{}: {e}", case.id()));
                    }
                    events(Event::Finished(case.id()));
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap_or_else(|p| p.into_inner());
    if failures.is_empty() {
        Ok(())
    } else {
        Err(EvalError::Data(format!("{} case(s) failed:\n  {}", failures.len(), failures.join("\n  "))))
    }
}

/// Read the case tables found in `inputs` (each an output directory of `eval` or `eval --case`),
/// write one CSV per experiment, its charts and the summary into `out`. Returns the summary's
/// sections. Experiments without any case file are left out; cases missing from an experiment's plan
/// are listed in its section (and returned as an error after everything else is written).
pub fn merge(inputs: &[PathBuf], out: &Path) -> Result<Vec<Section>, EvalError> {
    merge_only(inputs, out, experiments())
}

/// [`merge`] restricted to some experiments (a one-shot run reports what it ran, whatever else an
/// output directory holds from earlier runs).
pub fn merge_only(inputs: &[PathBuf], out: &Path, only: &[&'static dyn Experiment]) -> Result<Vec<Section>, EvalError> {
    let mut sections = Vec::new();
    let mut missing_all = Vec::new();
    for e in only {
        let mut table = Table::new(e.columns());
        let mut found = Vec::new();
        // Whichever sweep (quick or full) contains every case found is the plan they came from.
        let plans = [e.cases(true), e.cases(false)];
        for key in plans[0].iter().chain(&plans[1]) {
            if found.contains(key) {
                continue;
            }
            let case = CaseId { experiment: e.name(), key: key.clone() };
            if let Some(dir) = inputs.iter().find(|dir| case.path(dir).is_file()) {
                table.extend(Table::read_csv(&case.path(dir), e.columns())?)?;
                copy_artefacts(&case, dir, out)?;
                found.push(key.clone());
            }
        }
        if found.is_empty() {
            continue;
        }
        let plan = plans.iter().find(|p| found.iter().all(|k| p.contains(k))).unwrap_or(&plans[1]);
        let missing: Vec<String> =
            plan.iter().filter(|k| !found.contains(k)).map(|k| format!("{}/{k}", e.name())).collect();
        // Rows in plan order, whatever order the files were found in.
        let order = |row: &Vec<super::Value>| plan.iter().position(|k| *k == row[0].text()).unwrap_or(usize::MAX);
        table.rows.sort_by_key(order);
        table.write_csv(&out.join(format!("{}.csv", e.name())))?;
        let mut section = e.report(&table, out)?;
        section.missing = missing.clone();
        missing_all.extend(missing);
        sections.push(section);
    }
    report::write_summary(out, &sections)?;
    if missing_all.is_empty() {
        Ok(sections)
    } else {
        Err(EvalError::Data(format!("missing cases (run them and merge again): {}", missing_all.join(", "))))
    }
}

/// Copy the files a case wrote beside its table in `from` (same name, other extension) to `out`.
fn copy_artefacts(case: &CaseId, from: &Path, out: &Path) -> Result<(), EvalError> {
    let table = case.path(from);
    let (Some(dir), Some(stem)) = (table.parent(), table.file_stem()) else { return Ok(()) };
    let io = |path: &Path, e: std::io::Error| EvalError::Io { path: path.to_path_buf(), reason: e.to_string() };
    if std::fs::canonicalize(from).ok() == std::fs::canonicalize(out).ok() {
        return Ok(());
    }
    for entry in std::fs::read_dir(dir).map_err(|e| io(dir, e))? {
        let path = entry.map_err(|e| io(dir, e))?.path();
        if path.file_stem() == Some(stem) && path.extension().is_some_and(|x| x != "csv") {
            let target = out.join(CASES_DIR).join(path.file_name().unwrap_or_default());
            std::fs::create_dir_all(out.join(CASES_DIR)).map_err(|e| io(out, e))?;
            std::fs::copy(&path, &target).map_err(|e| io(&target, e))?;
        }
    }
    Ok(())
}
