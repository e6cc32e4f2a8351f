//! The Markdown summary `README.md` of an evaluation directory: one section per experiment with its
//! findings (one sentence each, numbers from the CSV in **bold**) and its charts.

use std::fmt::Write as _;
use std::path::Path;

use super::{About, EvalError};

/// A chart in the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct ChartRef {
    /// File name relative to the output directory.
    pub file: String,
    /// What it shows.
    pub caption: String,
    /// Its size in pixels, as stated in the summary.
    pub size: (u32, u32),
}

/// One experiment's part of the summary.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Section {
    /// The experiment's name.
    pub experiment: String,
    /// Heading.
    pub title: String,
    /// What was run, how, and against what (settings; no data numbers in bold here).
    pub setup: String,
    /// Findings, one sentence each.
    pub findings: Vec<String>,
    /// Charts.
    pub charts: Vec<ChartRef>,
    /// Planned cases with no table (filled in by the merge).
    pub missing: Vec<String>,
}

impl Section {
    /// The section of the experiment `about`, with its setup paragraph and nothing found yet.
    pub fn new(about: &About, setup: String) -> Self {
        Self { experiment: about.name.into(), title: about.title.into(), setup, ..Self::default() }
    }
}

/// A number from the data, as printed in the summary: three significant digits, **bold**.
pub fn bold(x: f64) -> String {
    format!("**{}**", number(x))
}

/// A fraction from the data printed as a percentage, **bold** (the CSV holds the fraction).
pub fn bold_percent(x: f64) -> String {
    format!("**{}%**", number(100.0 * x))
}

/// Three significant digits, scientific outside `[1e-3, 1e5)`.
pub fn number(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() {
        format!("{x}")
    } else if a == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.2e}")
    }
}

/// CPU model and core count of this machine (figures are meaningless without them).
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores")
}

/// Write `out/README.md` from the sections.
pub fn write_summary(out: &Path, sections: &[Section]) -> Result<(), EvalError> {
    let mut s = String::new();
    let _ = writeln!(s, "# shellwarp evaluation\n");
    let _ = writeln!(
        s,
        "Written by `shellwarp eval` on {} (shellwarp {}). Every number in **bold** is a value of the \
         experiment's CSV beside this file (three significant digits); times are wall-clock on this machine.\n",
        machine(),
        env!("CARGO_PKG_VERSION"),
    );
    for sec in sections {
        let _ = writeln!(s, "## {} (`{}`)\n", sec.title, sec.experiment);
        if !sec.setup.is_empty() {
            let _ = writeln!(s, "{}\n", sec.setup);
        }
        if !sec.missing.is_empty() {
            let _ = writeln!(s, "**Incomplete:** no table for {}.\n", sec.missing.join(", "));
        }
        for f in &sec.findings {
            let _ = writeln!(s, "- {f}");
        }
        if !sec.findings.is_empty() {
            s.push('\n');
        }
        for c in &sec.charts {
            let _ = writeln!(s, "![{}]({})\n", c.caption, c.file);
            let _ = writeln!(s, "*{}: {} — {} × {} px*\n", c.file, c.caption, c.size.0, c.size.1);
        }
        let _ = writeln!(s, "Data: [`{0}.csv`]({0}.csv)\n", sec.experiment);
    }
    super::write_atomically(&out.join("README.md"), s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_three_significant_digits() {
        assert_eq!(number(0.123456), "0.123");
        assert_eq!(number(12.3456), "12.3");
        assert_eq!(number(1234.56), "1235");
        assert_eq!(number(1.5e-5), "1.50e-5");
        assert_eq!(number(0.0), "0");
        assert_eq!(bold_percent(0.0834), "**8.34%**");
    }
}
