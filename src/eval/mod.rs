//! `shellwarp eval`: experiments that measure speed against accuracy, map where methods go unstable,
//! repeat the papers' experiments and check the automatic model choice.
//!
//! An experiment is a list of independent *cases* (one gravity level, one step size × stiffness, one
//! scene...), a table schema, and a report. Running a case yields rows ([`table::Table`]) written to
//! `DIR/cases/<id>.csv`; merging reads every case file of a directory back, writes one CSV per
//! experiment, draws its charts (PNG) and writes the Markdown summary `DIR/README.md` from those
//! CSVs alone. A one-shot `eval` is exactly plan → run every case → merge, so cases spread over many
//! machines ([`plan`] prints one command per case) and merged afterwards give the same tables.
//!
//! Convention of the summaries: every number printed in **bold** is a value of the experiment's CSV,
//! as it reads there (rounded for print); everything else is prose, settings or thresholds.
//!
//! # Adding an experiment
//!
//! `experiments/perf.rs` is the smallest; copy its shape. A file under `experiments/` with its
//! table's [`Column`]s (the first is `case`; `computed` columns must agree between runs, `timed` ones
//! are wall-clock figures), an [`About`] naming it, and `impl Experiment`: `cases` lists the case
//! keys (a smaller list when `quick`), `run` computes one case's rows from nothing but its key, and
//! `report` writes the summary section and charts from the merged table alone ([`report::Section::new`],
//! charts through `experiments::add_chart`). Then one line in `experiments::ALL`; `eval --plan`,
//! `--case`, the merge and the tests of every experiment's plan pick it up from there.

pub mod case;
pub mod chart;
pub mod experiments;
pub mod measure;
pub mod report;
pub mod runner;
pub mod table;
pub mod typeset;

use std::path::{Path, PathBuf};

pub use case::CaseId;
pub use runner::{chosen, merge, merge_only, plan, run_case, run_cases};
pub use table::{Column, Table, Value};

use crate::render::RenderError;
use crate::scene::SceneError;
use crate::solver::SolverError;

/// Why an evaluation could not be run or reported.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// No experiment of that name.
    #[error("unknown experiment `{name}` (available: {available})")]
    UnknownExperiment {
        /// The name asked for.
        name: String,
        /// Comma-separated experiment names.
        available: String,
    },
    /// A case id that no experiment plans.
    #[error("unknown case `{0}` (see `shellwarp eval --plan EXPERIMENT`)")]
    UnknownCase(String),
    /// A scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A solver could not be built or failed outside what the case measures.
    #[error("{context}: {error}")]
    Solver {
        /// What was being run.
        context: String,
        /// The solver's error.
        error: SolverError,
    },
    /// A picture could not be rendered.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A chart could not be drawn.
    #[error("drawing {path}: {reason}")]
    Chart {
        /// The chart's file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// Tables that do not hold what a report needs.
    #[error("{0}")]
    Data(String),
    /// A reference solution did not converge, so nothing can be compared with it.
    #[error("reference not converged: {0}")]
    Reference(String),
}

impl EvalError {
    /// Wrap a solver error with what was being run.
    pub fn solver(context: impl Into<String>) -> impl FnOnce(SolverError) -> EvalError {
        let context = context.into();
        move |error| EvalError::Solver { context, error }
    }
}

/// What an experiment is called and what its table holds.
#[derive(Debug, Clone, Copy)]
pub struct About {
    /// Name on the command line (`paper-fig6`).
    pub name: &'static str,
    /// Section title in the summary.
    pub title: &'static str,
    /// The columns of its table; the first is always `case`.
    pub columns: &'static [Column],
}

/// One experiment: its cases, its table and its report.
pub trait Experiment: Sync {
    /// Its name, title and columns.
    fn about(&self) -> &'static About;
    /// Name on the command line (`paper-fig6`).
    fn name(&self) -> &'static str {
        self.about().name
    }
    /// Section title in the summary.
    fn title(&self) -> &'static str {
        self.about().title
    }
    /// The columns of its table; the first is always `case`.
    fn columns(&self) -> &'static [Column] {
        self.about().columns
    }
    /// The case keys (without the experiment's name), in report order. `quick` plans a smaller sweep.
    fn cases(&self, quick: bool) -> Vec<String>;
    /// Run one case. A case that makes pictures writes them beside its table in `out`
    /// ([`CaseId::artefact`]); `progress` receives the fraction done, for long cases.
    fn run(&self, case: &str, quick: bool, out: &Path, progress: &dyn Fn(f32)) -> Result<Table, EvalError>;
    /// Draw the charts into `out` and write the summary section from the merged table.
    fn report(&self, table: &Table, out: &Path) -> Result<report::Section, EvalError>;
}

/// Every experiment, in the summary's order.
pub fn experiments() -> &'static [&'static dyn Experiment] {
    experiments::ALL
}

/// Look an experiment up by name.
pub fn find(name: &str) -> Result<&'static dyn Experiment, EvalError> {
    experiments().iter().copied().find(|e| e.name() == name).ok_or_else(|| EvalError::UnknownExperiment {
        name: name.to_string(),
        available: experiments().iter().map(|e| e.name()).collect::<Vec<_>>().join(", "),
    })
}

/// Write `bytes` to `path` atomically ([`crate::atomic`]), creating its folder.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), EvalError> {
    let io = |e: std::io::Error| EvalError::Io { path: path.to_path_buf(), reason: e.to_string() };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    crate::atomic::write(path, bytes).map_err(io)
}
