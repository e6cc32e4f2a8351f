//! A case of an evaluation, `experiment/key`, and the files it writes under an output directory.

use std::path::{Path, PathBuf};

use super::{EvalError, find};

/// Directory of the per-case tables inside an output directory.
pub const CASES_DIR: &str = "cases";

/// A case: the experiment it belongs to and its key, written `experiment/key`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaseId {
    /// The experiment's name.
    pub experiment: &'static str,
    /// The case key within it.
    pub key: String,
}

impl CaseId {
    /// Parse `experiment/key`, checking that the experiment plans this key (in either sweep size).
    pub fn parse(id: &str) -> Result<Self, EvalError> {
        let (name, key) = id.split_once('/').ok_or_else(|| EvalError::UnknownCase(id.to_string()))?;
        let e = find(name)?;
        if !e.cases(false).iter().chain(&e.cases(true)).any(|k| k == key) {
            return Err(EvalError::UnknownCase(id.to_string()));
        }
        Ok(Self { experiment: e.name(), key: key.to_string() })
    }

    /// `experiment/key`.
    pub fn id(&self) -> String {
        format!("{}/{}", self.experiment, self.key)
    }

    /// The case's table file under `out`: the id with `/` spelled `~` (keys never contain `~`).
    pub fn path(&self, out: &Path) -> PathBuf {
        self.artefact(out, "csv")
    }

    /// Another file the case writes beside its table (e.g. a picture), by extension. A merge copies
    /// these along with the table.
    pub fn artefact(&self, out: &Path, extension: &str) -> PathBuf {
        out.join(CASES_DIR).join(format!("{}.{extension}", self.id().replace('/', "~")))
    }
}
