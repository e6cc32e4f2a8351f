//! Self-describing solver parameters: each solver publishes these and the UI/CLI are generated from them.

use super::SolverError;

/// Description of one tunable parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Key used by `--set`, scene files and the panel (e.g. `"k_bend"`).
    pub name: &'static str,
    /// Short human label.
    pub label: &'static str,
    /// Unit string (`"N/m"`, `"kg/m²"`, `""` for dimensionless).
    pub unit: &'static str,
    /// One sentence of hover help.
    pub help: &'static str,
    /// Smallest allowed value (inclusive).
    pub min: f64,
    /// Largest allowed value (inclusive).
    pub max: f64,
    /// Whether only whole numbers are allowed (mode counts, iterations).
    pub integer: bool,
}

impl ParamSpec {
    /// A real parameter in `[min, max]` (set `integer` with struct update syntax).
    pub const fn linear(
        name: &'static str,
        label: &'static str,
        unit: &'static str,
        help: &'static str,
        min: f64,
        max: f64,
    ) -> Self {
        Self { name, label, unit, help, min, max, integer: false }
    }

    /// Check a candidate value: finite, within `[min, max]`, whole if `integer`.
    pub fn check(&self, value: f64) -> Result<f64, SolverError> {
        let bad = |reason: String| SolverError::BadParam { name: self.name.to_string(), value, reason };
        if !value.is_finite() {
            return Err(bad("not a finite number".into()));
        }
        if value < self.min || value > self.max {
            return Err(bad(format!("outside the allowed range [{}, {}] {}", self.min, self.max, self.unit)));
        }
        if self.integer && value.fract() != 0.0 {
            return Err(bad("must be a whole number".into()));
        }
        Ok(value)
    }

    /// Find `name` among `specs`, or the error listing what exists.
    pub fn find<'a>(method: &'static str, specs: &'a [ParamSpec], name: &str) -> Result<&'a ParamSpec, SolverError> {
        specs.iter().find(|s| s.name == name).ok_or_else(|| SolverError::UnknownParam {
            method,
            name: name.to_string(),
            available: specs.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
        })
    }
}

/// A parameter with its current value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamValue {
    /// What it is.
    pub spec: ParamSpec,
    /// Its current value.
    pub value: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: ParamSpec =
        ParamSpec { name: "k", label: "stiffness", unit: "N/m", help: "", min: 0.0, max: 10.0, integer: false };

    #[test]
    fn check_refuses_nan_negative_and_fractional_integers() {
        assert_eq!(K.check(2.5), Ok(2.5));
        assert!(K.check(f64::NAN).is_err());
        assert!(K.check(-1.0).is_err());
        assert!(K.check(11.0).is_err());
        let n = ParamSpec { integer: true, ..K };
        assert!(n.check(2.5).is_err());
        assert_eq!(n.check(3.0), Ok(3.0));
        assert!(matches!(ParamSpec::find("m", &[K], "q"), Err(SolverError::UnknownParam { .. })));
    }
}
