//! The parameters of `pbd` and `xpbd` as the panel, `--set` and the evaluator see them: their specs
//! (range, unit, help) and how each reads and writes the solver.

use super::{Pbd, Variant};
use crate::solver::wind;
use crate::solver::{ParamSpec, ParamValue, SolverError};

/// Parameters both methods have.
const COMMON: [ParamSpec; 10] = [
    ParamSpec::linear("step", "time step", "s", "One step of the simulation (split into substeps).", 1e-5, 0.1),
    ParamSpec {
        integer: true,
        ..ParamSpec::linear(
            "sweeps",
            "sweeps",
            "",
            "Gauss–Seidel sweeps over the constraints per substep.",
            1.0,
            1000.0,
        )
    },
    ParamSpec::linear("density", "density", "kg/m²", "Surface density; lumped to particles.", 1e-6, 1e4),
    ParamSpec::linear("gravity_y", "gravity y", "m/s²", "Vertical gravity (x and z from the scene).", -1e3, 1e3),
    ParamSpec::linear(
        "damping",
        "damping",
        "1/s",
        "Velocity damping rate of the cloth and the dynamic bodies (air drag).",
        0.0,
        100.0,
    ),
    ParamSpec::linear(
        "mu_s",
        "static friction μ_s",
        "",
        "A contact sticks while its slip is within μ_s × its normal push.",
        0.0,
        10.0,
    ),
    ParamSpec::linear(
        "mu_k",
        "kinetic friction μ_k",
        "",
        "A sliding contact is slowed by μ_k × its normal push.",
        0.0,
        10.0,
    ),
    ParamSpec::linear(
        "thickness",
        "thickness",
        "m",
        "Collision thickness of the cloth (bodies and itself).",
        1e-6,
        1.0,
    ),
    ParamSpec::linear(
        "least_area",
        "least area",
        "",
        "Least area a triangle keeps, / its rest area (0: free to collapse in its plane and turn over).",
        0.0,
        0.99,
    ),
    ParamSpec::linear(
        "k_pressure",
        "pressure k",
        "",
        "Balloon: held volume / rest volume (0: no volume constraint; closed meshes only).",
        0.0,
        100.0,
    ),
];

/// Parameters of `pbd` only.
const PBD_PARAMS: [ParamSpec; 2] = [
    ParamSpec::linear(
        "pbd_stretch",
        "stretch k",
        "",
        "Stretch stiffness in [0, 1], corrected for the iteration count.",
        0.0,
        1.0,
    ),
    ParamSpec::linear(
        "pbd_bend",
        "bending k",
        "",
        "Bending stiffness in [0, 1], corrected for the iteration count.",
        0.0,
        1.0,
    ),
];

/// Parameters of `xpbd` only.
const XPBD_PARAMS: [ParamSpec; 4] = [
    ParamSpec {
        integer: true,
        ..ParamSpec::linear(
            "substeps",
            "substeps",
            "",
            "Substeps per step (small substeps beat more sweeps).",
            1.0,
            1000.0,
        )
    },
    ParamSpec::linear("k_s", "stretch stiffness k_s", "N/m", "Edge stiffness: compliance 1/k_s.", 1e-6, 1e9),
    ParamSpec::linear("k_b", "bending rigidity k_b", "N·m", "Hinge stiffness k_b × 6|e|²/(A₁ + A₂).", 0.0, 1e3),
    ParamSpec::linear(
        "compression",
        "compression",
        "",
        "Fraction of its stretch stiffness an edge keeps in compression (0: tension only).",
        0.0,
        1.0,
    ),
];

/// `value` checked against the range of the parameter `name` of either variant (for `method`'s errors).
pub(super) fn check(method: &'static str, name: &str, value: f64) -> Result<f64, SolverError> {
    let all: Vec<ParamSpec> = COMMON.iter().chain(&PBD_PARAMS).chain(&XPBD_PARAMS).copied().collect();
    ParamSpec::find(method, &all, name)?.check(value)
}

impl Pbd {
    /// The parameters of this variant (the wind's not included).
    fn all_params(&self) -> Vec<ParamSpec> {
        let extra: &[ParamSpec] = match self.variant {
            Variant::Pbd => &PBD_PARAMS,
            Variant::Xpbd => &XPBD_PARAMS,
        };
        COMMON.iter().chain(extra).copied().collect()
    }

    /// Every parameter with its value, the wind's last.
    pub(super) fn param_values(&self) -> Vec<ParamValue> {
        self.all_params()
            .into_iter()
            .map(|spec| {
                let value = match spec.name {
                    "step" => self.step,
                    "sweeps" => self.sweeps as f64,
                    "density" => self.density,
                    "gravity_y" => self.gravity.y,
                    "damping" => self.damping,
                    "mu_s" => self.mu.0,
                    "mu_k" => self.mu.1,
                    "thickness" => self.thickness,
                    "k_pressure" => self.k_pressure,
                    "least_area" => self.least_area,
                    "pbd_stretch" => self.stiffness.0,
                    "pbd_bend" => self.stiffness.1,
                    "substeps" => self.substeps as f64,
                    "k_s" => self.k_s,
                    "compression" => self.compression,
                    _ => self.k_b,
                };
                ParamValue { spec, value }
            })
            .chain(self.wind.params())
            .collect()
    }

    /// Set the parameter `name` to `value`, checked against its range (and, for the pressure, the mesh).
    pub(super) fn set(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.wind.set_param(name, value)? {
            return Ok(());
        }
        let all: Vec<ParamSpec> = self.all_params().into_iter().chain(wind::PARAMS).collect();
        let value = ParamSpec::find(self.method_name(), &all, name)?.check(value)?;
        match name {
            "step" => self.step = value,
            "sweeps" => self.sweeps = value as usize,
            "density" => self.density = value,
            "gravity_y" => self.gravity.y = value,
            "damping" => self.damping = value,
            "mu_s" => self.mu.0 = value,
            "mu_k" => self.mu.1 = value,
            "thickness" => self.thickness = value,
            "k_pressure" if value > 0.0 && !self.model.is_closed() => {
                return Err(SolverError::BadParam {
                    name: name.into(),
                    value,
                    reason: "needs a closed mesh, and this mesh is not closed".into(),
                });
            }
            "k_pressure" => self.k_pressure = value,
            "least_area" => self.least_area = value,
            "pbd_stretch" => self.stiffness.0 = value,
            "pbd_bend" => self.stiffness.1 = value,
            "substeps" => self.substeps = value as usize,
            "compression" => self.compression = value,
            "k_s" => {
                self.k_s = value;
                self.compliance.0 = None;
            }
            _ => {
                self.k_b = value;
                self.compliance.1 = None;
            }
        }
        Ok(())
    }
}
