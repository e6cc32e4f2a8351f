//! The settings of `pbd` and `xpbd`, apart from their state and scratch, and their parameters as the
//! panel, `--set` and the scene see them: one table entry each, with its spec (range, unit, help,
//! scene key) and how it reads and writes the settings.

use glam::DVec3;

use super::{Pbd, Variant};
use crate::scene::Setup;
use crate::solver::params::shared::{DENSITY, GRAVITY_Y};
use crate::solver::params::{self, Param, Redo};
use crate::solver::{ParamSpec, ParamValue, SolverError};

const STEP: ParamSpec =
    ParamSpec::linear("step", "time step", "s", "One step of the simulation (split into substeps).", 1e-5, 0.1)
        .in_scene("solver.step");
const SWEEPS: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear("sweeps", "sweeps", "", "Gauss–Seidel sweeps over the constraints per substep.", 1.0, 1000.0)
        .in_scene("solver.sweeps")
};
const DAMPING: ParamSpec = ParamSpec::linear(
    "damping",
    "damping",
    "1/s",
    "Velocity damping rate of the cloth and the dynamic bodies (air drag).",
    0.0,
    100.0,
);
const MU_S: ParamSpec = ParamSpec::linear(
    "mu_s",
    "static friction μ_s",
    "",
    "A contact sticks while its slip is within μ_s × its normal push.",
    0.0,
    10.0,
)
.in_scene("material.mu_s");
const MU_K: ParamSpec = ParamSpec::linear(
    "mu_k",
    "kinetic friction μ_k",
    "",
    "A sliding contact is slowed by μ_k × its normal push.",
    0.0,
    10.0,
)
.in_scene("material.mu_k");
const THICKNESS: ParamSpec = ParamSpec::linear(
    "thickness",
    "thickness",
    "m",
    "Collision thickness of the cloth (bodies and itself).",
    1e-6,
    1.0,
)
.in_scene("solver.thickness");
const LEAST_AREA: ParamSpec = ParamSpec::linear(
    "least_area",
    "least area",
    "",
    "Least area a triangle keeps, / its rest area (0: free to collapse in its plane and turn over).",
    0.0,
    0.99,
)
.in_scene("solver.least_area");
const K_PRESSURE: ParamSpec = ParamSpec::linear(
    "k_pressure",
    "pressure k",
    "",
    "Balloon: held volume / rest volume (0: no volume constraint; closed meshes only).",
    0.0,
    100.0,
)
.in_scene("material.k_pressure");
const PBD_STRETCH: ParamSpec = ParamSpec::linear(
    "pbd_stretch",
    "stretch k",
    "",
    "Stretch stiffness in [0, 1], corrected for the iteration count.",
    0.0,
    1.0,
)
.in_scene("material.pbd_stretch");
const PBD_BEND: ParamSpec = ParamSpec::linear(
    "pbd_bend",
    "bending k",
    "",
    "Bending stiffness in [0, 1], corrected for the iteration count.",
    0.0,
    1.0,
)
.in_scene("material.pbd_bend");
const SUBSTEPS: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear("substeps", "substeps", "", "Substeps per step (small substeps beat more sweeps).", 1.0, 1000.0)
        .in_scene("solver.substeps")
};
const K_S: ParamSpec =
    ParamSpec::linear("k_s", "stretch stiffness k_s", "N/m", "Edge stiffness: compliance 1/k_s.", 1e-6, 1e9)
        .in_scene("material.k_s");
const K_B: ParamSpec =
    ParamSpec::linear("k_b", "bending rigidity k_b", "N·m", "Hinge stiffness k_b × 6|e|²/(A₁ + A₂).", 0.0, 1e3)
        .in_scene("material.k_b");
const COMPRESSION: ParamSpec = ParamSpec::linear(
    "compression",
    "compression",
    "",
    "Fraction of its stretch stiffness an edge keeps in compression (0: tension only).",
    0.0,
    1.0,
)
.in_scene("material.compression");

/// Parameters both methods have.
const COMMON: &[Param<Settings>] = &[
    Param::new(STEP, |p| p.step, |p, v| p.step = v, Redo::Nothing),
    Param::new(SWEEPS, |p| p.sweeps as f64, |p, v| p.sweeps = v as usize, Redo::Nothing),
    Param::new(DENSITY, |p| p.density, |p, v| p.density = v, Redo::Nothing),
    Param::new(GRAVITY_Y, |p| p.gravity.y, |p, v| p.gravity.y = v, Redo::Nothing),
    Param::new(DAMPING, |p| p.damping, |p, v| p.damping = v, Redo::Nothing),
    Param::new(MU_S, |p| p.mu.0, |p, v| p.mu.0 = v, Redo::Nothing),
    Param::new(MU_K, |p| p.mu.1, |p, v| p.mu.1 = v, Redo::Nothing),
    Param::new(THICKNESS, |p| p.thickness, |p, v| p.thickness = v, Redo::Nothing),
    Param::new(LEAST_AREA, |p| p.least_area, |p, v| p.least_area = v, Redo::Nothing),
    Param::new(K_PRESSURE, |p| p.k_pressure, |p, v| p.k_pressure = v, Redo::Nothing),
];

/// Parameters of `pbd` only.
const PBD_PARAMS: &[Param<Settings>] = &[
    Param::new(PBD_STRETCH, |p| p.stiffness.0, |p, v| p.stiffness.0 = v, Redo::Nothing),
    Param::new(PBD_BEND, |p| p.stiffness.1, |p, v| p.stiffness.1 = v, Redo::Nothing),
];

/// Parameters of `xpbd` only.
const XPBD_PARAMS: &[Param<Settings>] = &[
    Param::new(SUBSTEPS, |p| p.substeps as f64, |p, v| p.substeps = v as usize, Redo::Nothing),
    Param::new(K_S, |p| p.k_s, Settings::set_k_s, Redo::Nothing),
    Param::new(K_B, |p| p.k_b, Settings::set_k_b, Redo::Nothing),
    Param::new(COMPRESSION, |p| p.compression, |p, v| p.compression = v, Redo::Nothing),
];

/// The scene's compliances, which `xpbd` takes instead of `k_s` and `k_b` when given.
const COMPLIANCES: [ParamSpec; 2] = [
    ParamSpec::linear("compliance_stretch", "stretch compliance", "m/N", "Compliance of the edges.", 0.0, 1e6)
        .in_scene("material.compliance_stretch"),
    ParamSpec::linear("compliance_bend", "bending compliance", "1/(N·m)", "Compliance of the hinges.", 0.0, 1e9)
        .in_scene("material.compliance_bend"),
];

/// The parameters of `variant` besides the common ones.
fn own(variant: Variant) -> &'static [Param<Settings>] {
    match variant {
        Variant::Pbd => PBD_PARAMS,
        Variant::Xpbd => XPBD_PARAMS,
    }
}

/// What `pbd` and `xpbd` are set to: their step, sweeps and material, as the scene gives them and
/// the parameters change them.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Settings {
    pub step: f64,
    pub sweeps: usize,
    pub substeps: usize,
    pub density: f64,
    pub gravity: DVec3,
    /// Velocity damping rate of the cloth and the dynamic bodies, 1/s.
    pub damping: f64,
    /// Static and kinetic friction.
    pub mu: (f64, f64),
    pub thickness: f64,
    pub k_pressure: f64,
    /// The least area a triangle keeps, / its rest area (0: none).
    pub least_area: f64,
    /// `pbd`'s stretch and bending stiffness fractions.
    pub stiffness: (f64, f64),
    /// `xpbd`'s compliances as the scene gives them (absent: from `k_s` and `k_b`).
    pub compliance: (Option<f64>, Option<f64>),
    pub k_s: f64,
    pub k_b: f64,
    /// The fraction of its stretch stiffness an edge keeps in compression (XPBD).
    pub compression: f64,
}

impl Settings {
    /// The scene's settings for `variant`, checked against the parameters' ranges; the thickness is a
    /// tenth of `mean_edge` unless the scene gives it.
    pub fn new(variant: Variant, setup: &Setup, mean_edge: f64) -> Result<Self, SolverError> {
        let compliances: &[ParamSpec] = if variant == Variant::Xpbd { &COMPLIANCES } else { &[] };
        params::check_scene(params::specs(COMMON).chain(params::specs(own(variant))).chain(compliances), setup)?;
        let (m, s) = (&setup.scene.material, &setup.scene.solver);
        Ok(Self {
            step: s.step.unwrap_or(1.0 / 60.0),
            sweeps: s.sweeps,
            substeps: if variant == Variant::Pbd { 1 } else { s.substeps },
            density: m.density,
            gravity: setup.gravity(),
            damping: 0.1,
            mu: (m.mu_s, m.mu_k),
            thickness: s.thickness.unwrap_or(0.1 * mean_edge),
            k_pressure: m.k_pressure.unwrap_or(0.0),
            least_area: s.least_area.unwrap_or(0.0),
            stiffness: (m.pbd_stretch, m.pbd_bend),
            compliance: (m.compliance_stretch, m.compliance_bend),
            k_s: m.k_s,
            k_b: m.k_b,
            compression: m.compression,
        })
    }

    /// A new stretch stiffness: the compliance follows on the next step.
    fn set_k_s(&mut self, k_s: f64) {
        self.k_s = k_s;
        self.compliance.0 = None;
    }

    /// A new bending stiffness: the compliance follows on the next step.
    fn set_k_b(&mut self, k_b: f64) {
        self.k_b = k_b;
        self.compliance.1 = None;
    }

    /// The compliances of the stretch and bending constraints: the scene's, else `1/k_s` and `1/k_b`.
    pub fn compliances(&self) -> (f64, f64) {
        let stretch = self.compliance.0.unwrap_or(1.0 / self.k_s);
        let bend = self.compliance.1.unwrap_or(if self.k_b > 0.0 { 1.0 / self.k_b } else { f64::INFINITY });
        (stretch, bend)
    }
}

impl Pbd {
    /// Every parameter with its value, the wind's last.
    pub(super) fn param_values(&self) -> Vec<ParamValue> {
        let own = own(self.variant);
        [params::values(COMMON, &self.settings), params::values(own, &self.settings), self.wind.params()].concat()
    }

    /// Set the parameter `name` to `value`, checked against its range (and, for the pressure, the mesh).
    pub(super) fn set(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if name == K_PRESSURE.name && K_PRESSURE.check(value)? > 0.0 && !self.model.is_closed() {
            return Err(SolverError::BadParam {
                name: name.into(),
                value,
                reason: "needs a closed mesh, and this mesh is not closed".into(),
            });
        }
        if self.wind.set_param(name, value)? || params::assign(COMMON, &mut self.settings, name, value)?.is_some() {
            return Ok(());
        }
        match params::assign(own(self.variant), &mut self.settings, name, value)? {
            Some(_) => Ok(()),
            None => Err(params::unknown(self.method_name(), name, self.param_values().iter().map(|p| p.spec.name))),
        }
    }
}
