//! State and physics shared by the three discrete-shell solvers (`ds`, `ds-implicit`, `ds-static`):
//! the shell energy, lumped masses, free DOFs (anchors and position drags removed), external forces
//! (gravity on the lumped masses plus the scene's point loads), the reduced Hessian pattern with its
//! Cholesky analysis, and the shared parameters.
//!
//! No contact: a scene's `[[colliders]]` are ignored by every DS method (documented in the README and
//! the method summaries); the shell passes through them.
//!
//! Damping is Rayleigh with the *rest* stiffness, `C = α M + β K₀`: linear, the same damping the modal
//! methods apply per mode (`α + β λᵢ`), so the DS references are comparable with them.

use glam::DVec3;

use super::params::shared::{DENSITY, GRAVITY_Y, K_AREA, K_BEND, K_LENGTH, RAYLEIGH_ALPHA, RAYLEIGH_BETA};
use super::params::{self, Param, Redo};
use super::wind::Wind;
use super::{DragKind, DragSet, ParamValue, SolverError};
use crate::energy::{DiscreteShell, HessianMode, ShellStiffness};
use crate::linalg::{BlockAssembler, DofMap, SparseCholesky};
use crate::mesh::TriMesh;
use crate::scene::Setup;

/// How far above [`energy_scale`] a shell's energy may rise before a step counts as diverged.
pub const ENERGY_LIMIT: f64 = 1e6;

/// A shell's characteristic energy `max(1, Σ|f| · L)` under the external forces `forces`, with `L`
/// the diagonal of the bounding box `(lo, hi)`, J: the work the loads do across the whole body.
pub fn energy_scale(forces: &[DVec3], (lo, hi): (DVec3, DVec3)) -> f64 {
    (forces.iter().map(|f| f.length()).sum::<f64>() * (hi - lo).length()).max(1.0)
}

/// The parameters every DS method has, in this order: the shell's stiffnesses, density, gravity and
/// damping (the wind's follow them).
const SHELL_PARAMS: &[Param<ShellModel>] = &[
    Param::new(K_AREA, |m| m.stiffness.k_area, |m, v| m.stiffness.k_area = v, Redo::Forces),
    Param::new(K_LENGTH, |m| m.stiffness.k_length, |m, v| m.stiffness.k_length = v, Redo::Forces),
    Param::new(K_BEND, |m| m.stiffness.k_bend, |m, v| m.stiffness.k_bend = v, Redo::Forces),
    Param::new(DENSITY, |m| m.density, |m, v| m.density = v, Redo::Forces),
    Param::new(GRAVITY_Y, |m| m.gravity.y, |m, v| m.gravity.y = v, Redo::Forces),
    Param::new(RAYLEIGH_ALPHA, |m| m.alpha, |m, v| m.alpha = v, Redo::Nothing),
    Param::new(RAYLEIGH_BETA, |m| m.beta, |m, v| m.beta = v, Redo::Nothing),
];

/// The discrete-shell system: energy, masses, constraints and forces of one scene.
#[derive(Debug)]
pub struct ShellModel {
    /// The elastic energy.
    pub shell: DiscreteShell,
    /// The stiffnesses the parameters set (the shell takes them on the next [`Redo::Forces`]).
    stiffness: ShellStiffness,
    mesh: TriMesh,
    anchored: Vec<bool>,
    drag_revision: u64,
    /// Prescribed positions of dragged vertices (vertex, target).
    prescribed: Vec<(usize, DVec3)>,
    dofs: DofMap,
    masses: Vec<f64>,
    gravity: DVec3,
    loads: Vec<DVec3>,
    f_ext: Vec<DVec3>,
    density: f64,
    /// The scene's wind, and whether the external forces hold some of it.
    wind: Wind,
    blown: bool,
    /// Rayleigh mass damping α, 1/s.
    pub alpha: f64,
    /// Rayleigh stiffness damping β, s.
    pub beta: f64,
    pub(crate) asm: BlockAssembler,
    pub(crate) chol: Option<SparseCholesky>,
    k0: Option<Vec<f64>>,
}

impl ShellModel {
    /// Build from a realised scene.
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        params::check_scene(params::specs(SHELL_PARAMS), setup)?;
        let m = &setup.scene.material;
        let k = ShellStiffness::from(m);
        let shell = DiscreteShell::new(&setup.mesh, k).map_err(|e| SolverError::Numerical(e.to_string()))?;
        let anchored = setup.anchored_mask();
        let dofs = DofMap::without(&anchored);
        let asm = shell.hessian_pattern(&dofs).map_err(|e| SolverError::Numerical(e.to_string()))?;
        let mut model = Self {
            shell,
            stiffness: k,
            mesh: setup.mesh.clone(),
            anchored,
            drag_revision: 0,
            prescribed: Vec::new(),
            dofs,
            masses: Vec::new(),
            gravity: setup.gravity(),
            loads: setup.loads.clone(),
            f_ext: Vec::new(),
            density: m.density,
            wind: Wind::of(setup)?,
            blown: false,
            alpha: setup.scene.solver.rayleigh_alpha,
            beta: setup.scene.solver.rayleigh_beta,
            asm,
            chol: None,
            k0: None,
        };
        model.update_forces();
        Ok(model)
    }

    fn update_forces(&mut self) {
        self.masses = self.mesh.vertex_areas().into_iter().map(|a| a * self.density).collect();
        self.f_ext = self.scene_forces();
    }

    /// The external forces the parameters define: gravity on the lumped masses plus point loads, N.
    pub(crate) fn scene_forces(&self) -> Vec<DVec3> {
        self.masses.iter().zip(&self.loads).map(|(&m, &l)| self.gravity * m + l).collect()
    }

    /// The scene's forces plus the wind's on the shell at `x` moving with `v` at time `t`, N.
    pub(crate) fn loads(&self, t: f64, x: &[DVec3], v: &[DVec3]) -> Vec<DVec3> {
        self.wind.forces(t, (x, v), self.mesh.triangles(), &self.scene_forces())
    }

    /// Make the external forces the scene's plus the wind's at this state (nothing to do in calm air
    /// that was calm before): the wind is taken at the start of each step (or substep) and held over it.
    pub(crate) fn apply_wind(&mut self, t: f64, x: &[DVec3], v: &[DVec3]) {
        let calm = self.wind.is_calm();
        if !calm || self.blown {
            self.f_ext = self.loads(t, x, v);
        }
        self.blown = !calm;
    }

    /// Replace the external forces (a stage of a load path) until the next parameter change, which
    /// restores [`ShellModel::scene_forces`].
    pub(crate) fn set_external_forces(&mut self, f: Vec<DVec3>) {
        debug_assert_eq!(f.len(), self.f_ext.len());
        self.f_ext = f;
    }

    /// Rest positions.
    pub fn rest(&self) -> &[DVec3] {
        self.mesh.positions()
    }

    /// Lumped vertex masses, kg.
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }

    /// The free DOFs.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// External force on every vertex (gravity on the lumped mass plus point loads), N.
    pub fn external_forces(&self) -> &[DVec3] {
        &self.f_ext
    }

    /// Whether any vertex is held (anchor or drag).
    pub fn has_constraints(&self) -> bool {
        self.dofs.free_count() < self.dofs.vertex_count()
    }

    /// A characteristic energy scale, [`energy_scale`] of the scene's forces (gravity and point
    /// loads; not the wind, which grows with the motion it would measure), J.
    pub fn energy_scale(&self) -> f64 {
        energy_scale(&self.scene_forces(), self.mesh.bounding_box())
    }

    /// Potential energy `W(x) − Σ f_ext·(x − X)` (elastic plus load potential, zero at rest), J.
    pub fn potential(&self, x: &[DVec3]) -> f64 {
        self.shell.energy(x) - self.load_work(x)
    }

    fn load_work(&self, x: &[DVec3]) -> f64 {
        x.iter().zip(self.rest()).zip(&self.f_ext).map(|((x, r), f)| f.dot(*x - *r)).sum()
    }

    /// Kinetic energy `½ Σ m |v|²`, J.
    pub fn kinetic(&self, v: &[DVec3]) -> f64 {
        0.5 * v.iter().zip(&self.masses).map(|(v, m)| m * v.length_squared()).sum::<f64>()
    }

    /// Gradient of the potential, `∇W − f_ext`, per vertex (into `g`); returns the potential.
    pub fn potential_gradient(&self, x: &[DVec3], g: &mut [DVec3]) -> f64 {
        let w = self.shell.gradient(x, g);
        g.iter_mut().zip(&self.f_ext).for_each(|(g, f)| *g -= *f);
        w - self.load_work(x)
    }

    /// Assemble the reduced Hessian of `W` at `x` into [`ShellModel::assembler`].
    pub(crate) fn assemble(&mut self, x: &[DVec3], mode: HessianMode) {
        self.shell.assemble_hessian(&mut self.asm, x, mode);
    }

    /// The reduced rest stiffness `K₀` values (computed once, again after stiffness changes).
    /// Overwrites the assembler's current values when it has to compute them.
    pub(crate) fn rest_stiffness(&mut self) -> &[f64] {
        if self.k0.is_none() {
            let rest = self.rest().to_vec();
            self.shell.assemble_hessian(&mut self.asm, &rest, HessianMode::Exact);
            self.k0 = Some(self.asm.values().to_vec());
        }
        self.k0.as_deref().unwrap_or_default()
    }

    /// `out = β K₀ v` on reduced vectors (zero if β = 0).
    pub(crate) fn stiffness_damping(&mut self, v: &[f64], out: &mut [f64]) {
        if self.beta == 0.0 {
            out.fill(0.0);
            return;
        }
        self.rest_stiffness_product(v, out);
        out.iter_mut().for_each(|o| *o *= self.beta);
    }

    /// `out = K₀ v` on reduced vectors.
    pub(crate) fn rest_stiffness_product(&mut self, v: &[f64], out: &mut [f64]) {
        self.rest_stiffness();
        if let Some(k0) = &self.k0 {
            self.asm.multiply(Some(k0), v, 1, out);
        }
    }

    /// Reduced lumped masses, one per DOF.
    pub(crate) fn reduced_masses(&self) -> Vec<f64> {
        self.dofs.free_vertices().iter().flat_map(|&v| [self.masses[v]; 3]).collect()
    }

    /// Apply the drags: dragged vertices become prescribed (removed DOFs, placed at their targets).
    /// Rebuilds the DOF map and patterns when the drag set changed. Returns whether it changed.
    pub(crate) fn apply_drags(
        &mut self,
        drags: &DragSet,
        x: &mut [DVec3],
        v: &mut [DVec3],
    ) -> Result<bool, SolverError> {
        let changed = drags.revision() != self.drag_revision;
        if changed {
            self.drag_revision = drags.revision();
            self.prescribed = drags
                .iter()
                .filter_map(|(_, d)| match d.kind {
                    DragKind::Position(p) => Some((d.vertex, p)),
                    DragKind::Orientation(_) => None,
                })
                .collect();
            let mut fixed = self.anchored.clone();
            self.prescribed.iter().for_each(|&(i, _)| fixed[i] = true);
            let dofs = DofMap::without(&fixed);
            if dofs != self.dofs {
                self.dofs = dofs;
                self.asm = self.shell.hessian_pattern(&self.dofs).map_err(|e| SolverError::Numerical(e.to_string()))?;
                self.chol = None;
                self.k0 = None;
            }
        }
        for &(i, p) in &self.prescribed {
            x[i] = p;
            v[i] = DVec3::ZERO;
        }
        Ok(changed)
    }

    /// Current values of [`SHELL_PARAMS`] and the wind's.
    pub(crate) fn params(&self) -> Vec<ParamValue> {
        [params::values(SHELL_PARAMS, self), self.wind.params()].concat()
    }

    /// Set one of [`SHELL_PARAMS`] or the wind's; `Ok(false)` if `name` is none of them.
    pub(crate) fn set_param(&mut self, name: &str, value: f64) -> Result<bool, SolverError> {
        if self.wind.set_param(name, value)? {
            return Ok(true);
        }
        match params::assign(SHELL_PARAMS, self, name, value)? {
            None => return Ok(false),
            Some(Redo::Nothing) => {}
            Some(_) => {
                if let Err(e) = self.shell.set_stiffness(self.stiffness) {
                    // The shell kept its stiffnesses: so do the parameters.
                    self.stiffness = self.shell.stiffness();
                    return Err(SolverError::BadParam { name: name.into(), value, reason: e.to_string() });
                }
                self.k0 = None;
                self.update_forces();
            }
        }
        Ok(true)
    }
}
