//! Self-describing solver parameters: each solver publishes these and the UI/CLI are generated from them.
//!
//! A method declares each parameter once, as a [`Param`] entry of its table: the spec (name, label,
//! unit, help, range and the scene key it is read from), a getter, a setter and what a change makes
//! the method redo. The same spec checks the scene's value when the method is built
//! ([`check_scene`]) and every later change (`set_param`, the panel, `--set`): the scene's own checks
//! stop at what no method owns (meshes, selections, colliders, tracks, the camera).

use super::{Solver, SolverError};
use crate::scene::Setup;

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
    /// The dotted scene key the method reads it from (`material.k_bend`, `gravity[1]`), or `""`.
    pub key: &'static str,
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
        Self { name, label, unit, help, min, max, integer: false, key: "" }
    }

    /// The same parameter, read from the scene at the dotted `key`.
    pub const fn in_scene(self, key: &'static str) -> Self {
        Self { key, ..self }
    }

    /// Why `value` is refused (not finite, outside `[min, max]`, not whole where `integer`), if it is.
    fn refusal(&self, value: f64) -> Option<String> {
        if !value.is_finite() {
            Some("not a finite number".into())
        } else if value < self.min || value > self.max {
            Some(format!("outside the allowed range [{}, {}] {}", self.min, self.max, self.unit).trim_end().to_string())
        } else if self.integer && value.fract() != 0.0 {
            Some("not a whole number".into())
        } else {
            None
        }
    }

    /// Check a candidate value: finite, within `[min, max]`, whole if `integer`.
    pub fn check(&self, value: f64) -> Result<f64, SolverError> {
        match self.refusal(value) {
            Some(reason) => Err(SolverError::BadParam { name: self.name.to_string(), value, reason }),
            None => Ok(value),
        }
    }
}

/// Check the scene's value of every spec that has a scene key (a key the scene leaves out takes the
/// method's default); the error names the key, as the scene's own checks do.
pub fn check_scene<'a>(specs: impl IntoIterator<Item = &'a ParamSpec>, setup: &Setup) -> Result<(), SolverError> {
    let numbers = setup.scene.numbers();
    for spec in specs.into_iter().filter(|s| !s.key.is_empty()) {
        let Some(value) = numbers.get(spec.key) else { continue };
        if let Some(reason) = spec.refusal(value) {
            let (file, key) = (setup.origin.label.clone(), spec.key.to_string());
            return Err(SolverError::SceneValue { file, key, reason: format!("{value} is {reason}") });
        }
    }
    Ok(())
}

/// The specs of a table, for [`check_scene`].
pub fn specs<T>(table: &[Param<T>]) -> impl Iterator<Item = &ParamSpec> {
    table.iter().map(|p| &p.spec)
}

/// A parameter with its current value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamValue {
    /// What it is.
    pub spec: ParamSpec,
    /// Its current value.
    pub value: f64,
}

/// What a change of a parameter makes its method redo, besides storing the value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Redo {
    /// Nothing: the next step reads the value.
    Nothing,
    /// The forces and caches that depend on it (masses, gravity, the rest stiffness).
    Forces,
    /// The modal basis, recomputed in the background.
    Modes,
}

/// One parameter of a method whose state is `T`, declared once: what it is, how to read and write it,
/// and what a change costs. A method's table is a `&[Param<T>]`; its `params` and `set_param`, and
/// through them the panel and the live parameter changes, read that table.
pub struct Param<T> {
    /// Name, label, unit, help and range.
    pub spec: ParamSpec,
    /// Its current value.
    pub get: fn(&T) -> f64,
    /// Store a value already checked against [`Param::spec`].
    pub set: fn(&mut T, f64),
    /// What a change makes the method redo.
    pub redo: Redo,
}

impl<T> Clone for Param<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Param<T> {}

impl<T> Param<T> {
    /// A table entry.
    pub const fn new(spec: ParamSpec, get: fn(&T) -> f64, set: fn(&mut T, f64), redo: Redo) -> Self {
        Self { spec, get, set, redo }
    }
}

/// The current values of `table` on `state`.
pub fn values<T>(table: &[Param<T>], state: &T) -> Vec<ParamValue> {
    table.iter().map(|p| ParamValue { spec: p.spec, value: (p.get)(state) }).collect()
}

/// Set the parameter `name` of `table` on `state`, checked against its range: what the method must
/// redo, or `None` when `table` has no such parameter.
pub fn assign<T>(table: &[Param<T>], state: &mut T, name: &str, value: f64) -> Result<Option<Redo>, SolverError> {
    let Some(p) = table.iter().find(|p| p.spec.name == name) else { return Ok(None) };
    (p.set)(state, p.spec.check(value)?);
    Ok(Some(p.redo))
}

/// Set `name` from a method's own `table`: what it must redo, or the error listing every parameter
/// the method has.
pub fn set<T: Solver>(table: &[Param<T>], state: &mut T, name: &str, value: f64) -> Result<Redo, SolverError> {
    match assign(table, state, name, value)? {
        Some(redo) => Ok(redo),
        None => Err(unknown(state.method(), name, state.params().iter().map(|p| p.spec.name))),
    }
}

/// The error for a parameter `name` that a method whose parameters are `names` does not have.
pub fn unknown<'a>(method: &'static str, name: &str, names: impl IntoIterator<Item = &'a str>) -> SolverError {
    SolverError::UnknownParam {
        method,
        name: name.to_string(),
        available: names.into_iter().collect::<Vec<_>>().join(", "),
    }
}

/// The quantities several methods share, each with one name, label and range.
pub mod shared {
    use super::ParamSpec;

    /// Stiffness of the shell's triangle-area (stretch) term.
    pub const K_AREA: ParamSpec = ParamSpec::linear(
        "k_area",
        "area stiffness k_A",
        "N/m",
        "Stiffness of the triangle-area (stretch) term.",
        0.0,
        1e12,
    )
    .in_scene("material.k_area");
    /// Stiffness of the shell's edge-length (shear) term.
    pub const K_LENGTH: ParamSpec = ParamSpec::linear(
        "k_length",
        "length stiffness k_L",
        "N/m",
        "Stiffness of the edge-length (shear) term.",
        0.0,
        1e12,
    )
    .in_scene("material.k_length");
    /// Stiffness of the shell's hinge (bending) term; not zero, so that a modal analysis stays regular.
    pub const K_BEND: ParamSpec = ParamSpec::linear(
        "k_bend",
        "bending stiffness k_B",
        "N·m",
        "Stiffness of the hinge (flexural) term.",
        1e-9,
        1e12,
    )
    .in_scene("material.k_bend");
    /// Mass per unit area, lumped to the vertices.
    pub const DENSITY: ParamSpec =
        ParamSpec::linear("density", "density", "kg/m²", "Surface density, lumped to the vertices.", 1e-6, 1e4)
            .in_scene("material.density");
    /// The vertical component of gravity.
    pub const GRAVITY_Y: ParamSpec = ParamSpec::linear(
        "gravity_y",
        "gravity y",
        "m/s²",
        "Vertical gravity component (negative is down; x and z come from the scene).",
        -1e4,
        1e4,
    )
    .in_scene("gravity[1]");
    /// Rayleigh damping's mass-proportional coefficient.
    pub const RAYLEIGH_ALPHA: ParamSpec =
        ParamSpec::linear("rayleigh_alpha", "mass damping α", "1/s", "Rayleigh damping C = αM + βK₀.", 0.0, 1e4)
            .in_scene("solver.rayleigh_alpha");
    /// Rayleigh damping's stiffness-proportional coefficient.
    pub const RAYLEIGH_BETA: ParamSpec =
        ParamSpec::linear("rayleigh_beta", "stiffness damping β", "s", "Rayleigh damping C = αM + βK₀.", 0.0, 1e4)
            .in_scene("solver.rayleigh_beta");
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: ParamSpec = ParamSpec {
        name: "k",
        label: "stiffness",
        unit: "N/m",
        help: "",
        min: 0.0,
        max: 10.0,
        integer: false,
        key: "",
    };

    #[test]
    fn check_refuses_nan_negative_and_fractional_integers() {
        assert_eq!(K.check(2.5), Ok(2.5));
        assert!(K.check(f64::NAN).is_err());
        assert!(K.check(-1.0).is_err());
        assert!(K.check(11.0).is_err());
        let n = ParamSpec { integer: true, ..K };
        assert!(n.check(2.5).is_err());
        assert_eq!(n.check(3.0), Ok(3.0));
        let table = [Param::new(n, |x: &f64| *x, |x, v| *x = v, Redo::Forces)];
        let mut x = 1.0;
        assert_eq!(assign(&table, &mut x, "k", 4.0), Ok(Some(Redo::Forces)));
        assert_eq!((x, values(&table, &x)[0].value), (4.0, 4.0));
        assert_eq!(assign(&table, &mut x, "q", 1.0), Ok(None));
        assert!(assign(&table, &mut x, "k", 2.5).is_err(), "checked against the spec");
        assert_eq!(x, 4.0, "a refused value is not stored");
    }
}
