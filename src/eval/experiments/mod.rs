//! The experiments, and the small helpers their cases and reports share.

mod auto_model;
mod cubature;
mod drag;
mod fig4;
mod fig6;
mod pareto;
mod perf;
mod stability;

use glam::DVec3;

pub use auto_model::AutoModel;
pub use cubature::Cubature;
pub use drag::Drags;
pub use fig4::PaperFig4;
pub use fig6::PaperFig6;
pub use pareto::Pareto;
pub use perf::PaperPerf;
pub use stability::Stability;

use std::path::Path;

use super::chart::Plot;
use super::report::{ChartRef, Section};
use super::table::Value;
use super::{EvalError, Experiment, chart};

/// Every experiment, in the summary's order.
pub const ALL: &[&dyn Experiment] =
    &[&PaperFig6, &PaperFig4, &PaperPerf, &Pareto, &Drags, &Stability, &AutoModel, &Cubature];

/// A chart of the standard size, for a section.
fn chart_ref(file: String, caption: String) -> ChartRef {
    ChartRef { file, caption, size: chart::SIZE }
}

/// Draw `plot` into `out` as `EXPERIMENT-NAME.png` and list it in `section` under `caption`.
fn add_chart(plot: Plot, section: &mut Section, out: &Path, name: &str, caption: String) -> Result<(), EvalError> {
    let file = format!("{}-{name}.png", section.experiment);
    plot.save(&out.join(&file))?;
    section.charts.push(chart_ref(file, caption));
    Ok(())
}

/// A flag as a number cell (1 or 0).
fn flag(on: bool) -> Value {
    Value::Num(if on { 1.0 } else { 0.0 })
}

/// A count as a number cell.
fn num(n: impl Into<u64>) -> Value {
    Value::Num(n.into() as f64)
}

/// The number in a case-key part `name=value`.
fn key_value(part: &str, name: &str) -> Result<f64, EvalError> {
    part.strip_prefix(name)
        .and_then(|r| r.strip_prefix('='))
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| EvalError::UnknownCase(format!("`{part}`: expected {name}=NUMBER")))
}

/// Mean downward displacement of the tip: the vertices at the largest rest `x` (the free end of the
/// beams, which are clamped at their smallest `x`), m.
fn tip_deflection(x: &[DVec3], rest: &[DVec3]) -> f64 {
    let end = rest.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
    let tip: Vec<usize> = (0..rest.len()).filter(|&i| rest[i].x > end - 1e-9).collect();
    tip.iter().map(|&i| rest[i].y - x[i].y).sum::<f64>() / tip.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_experiment_starts_with_the_case_column_and_has_unique_cases() {
        for e in ALL {
            assert_eq!(e.columns()[0].name, "case", "{}", e.name());
            for quick in [false, true] {
                let cases = e.cases(quick);
                assert!(!cases.is_empty(), "{}", e.name());
                let mut unique = cases.clone();
                unique.sort();
                unique.dedup();
                assert_eq!(unique.len(), cases.len(), "{}: repeated case keys", e.name());
                assert!(cases.iter().all(|c| !c.contains('~')), "keys never contain `~` (file names)");
            }
        }
    }

    #[test]
    fn key_values_parse_or_name_the_part() {
        assert_eq!(key_value("g=2.5", "g").unwrap(), 2.5);
        assert!(key_value("h=2", "g").is_err());
        assert!(key_value("g=x", "g").is_err());
    }
}
