//! `lma`, `mwts` and `mwts-rs` behind the [`Solver`] trait: one implementation, a [`Variant`] tells
//! them apart (how the modal coordinates become positions, [`Shape`]).
//!
//! Stiffness, density and mode-count changes recompute the modes on a background thread; the step
//! loop keeps running on the old basis meanwhile and swaps the new one in when it is ready, carrying
//! the state over by projection. Analyses are cached on disk ([`super::cache`]). An edit made while
//! an analysis runs supersedes it: the old run stops at its next stage ([`crate::solver::supersede`]), and a
//! new run starts after a short pause so a burst of edits costs one analysis.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;

use super::basis::ModalBasis;
use super::cache::Cache;
use super::compute::{Factored, ModalAnalysis, ModalProblem, analyse_factored};
use super::dynamics::{ModalDynamics, ModalParams, Shape};
use super::ritz::{self, DragFactor, Made, StaticResponse};
use super::rotation_strain::RotationStrain;
use crate::energy::ShellStiffness;
use crate::mesh::TriMesh;
use crate::scene::Setup;
use crate::solver::params::shared::{DENSITY, GRAVITY_Y, K_AREA, K_BEND, K_LENGTH, RAYLEIGH_ALPHA, RAYLEIGH_BETA};
use crate::solver::params::{self, Param, Redo};
use crate::solver::supersede::{Background, Generation};
use crate::solver::wind::Wind;
use crate::solver::{DragSet, ParamSpec, ParamValue, Progress, Solver, SolverError, StepStats, check_finite};
use crate::solver::{ENERGY_LIMIT, Footprint, Method, energy_scale};

/// Registry entry: linear modal analysis.
pub const LMA: Method = Method {
    name: "lma",
    summary: "linear modal analysis: x = X + Φq, fast, but large rotations inflate the shell",
    build: |setup| Ok(Box::new(ModalSolver::new(setup, Variant::Lma)?)),
    footprint: Footprint::MODAL,
};

/// Registry entry: modal warping for thin shells.
pub const MWTS: Method = Method {
    name: "mwts",
    summary: "modal warping for thin shells: modal rotations warp the linear modes (1/30 s steps)",
    build: |setup| Ok(Box::new(ModalSolver::new(setup, Variant::Mwts)?)),
    footprint: Footprint::MODAL,
};

/// Registry entry: modal warping's modes with the rotation-strain reconstruction.
pub const MWTS_RS: Method = Method {
    name: "mwts-rs",
    summary: "mwts's modes, positions solved globally from triangle rotations and strains, consistent forces: \
              accurate far into large bends (1/30 s steps)",
    build: |setup| Ok(Box::new(ModalSolver::new(setup, Variant::MwtsRs)?)),
    footprint: Footprint::MODAL,
};

/// Which modal method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// `lma`: linear modal analysis.
    Lma,
    /// `mwts`: modal warping.
    Mwts,
    /// `mwts-rs`: modal warping's modes with the rotation-strain reconstruction.
    MwtsRs,
}

impl Variant {
    /// The registry name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Lma => LMA.name,
            Variant::Mwts => MWTS.name,
            Variant::MwtsRs => MWTS_RS.name,
        }
    }

    /// The shape of this variant for a mesh, its anchors and a basis.
    fn shape(self, mesh: &TriMesh, anchors: &[usize], basis: &ModalBasis) -> Result<Shape, SolverError> {
        Ok(match self {
            Variant::Lma => Shape::Linear,
            Variant::Mwts => Shape::Warp,
            Variant::MwtsRs => Shape::RotationStrain(Box::new(RotationStrain::new(mesh, anchors, basis)?)),
        })
    }
}

/// The number of modes.
pub(crate) const MODES: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear("modes", "modes", "", "Number of vibration modes (recomputed in the background).", 1.0, 256.0)
        .in_scene("solver.modes")
};
/// The modal integrator's step.
pub(crate) const STEP: ParamSpec =
    ParamSpec::linear("step", "time step", "s", "Fixed step of the modal integrator.", 1e-5, 0.1)
        .in_scene("solver.step");
/// The damping of over-determined drags.
pub(crate) const CONSTRAINT_DAMPING: ParamSpec = ParamSpec::linear(
    "constraint_damping",
    "drag damping",
    "",
    "Relative Tikhonov damping of over-determined drags.",
    1e-12,
    1.0,
)
.in_scene("solver.constraint_damping");

/// The modal methods' parameters (the wind's follow them).
const PARAMS: &[Param<ModalSolver>] = &[
    Param::new(K_AREA, |m| m.request.stiffness.k_area, |m, v| m.request.stiffness.k_area = v, Redo::Modes),
    Param::new(K_LENGTH, |m| m.request.stiffness.k_length, |m, v| m.request.stiffness.k_length = v, Redo::Modes),
    Param::new(K_BEND, |m| m.request.stiffness.k_bend, |m, v| m.request.stiffness.k_bend = v, Redo::Modes),
    Param::new(DENSITY, |m| m.request.density, |m, v| m.request.density = v, Redo::Modes),
    Param::new(GRAVITY_Y, |m| m.gravity.y, |m, v| m.gravity.y = v, Redo::Forces),
    Param::new(RAYLEIGH_ALPHA, |m| m.params.alpha, |m, v| m.params.alpha = v, Redo::Nothing),
    Param::new(RAYLEIGH_BETA, |m| m.params.beta, |m, v| m.params.beta = v, Redo::Nothing),
    Param::new(MODES, |m| m.request.modes as f64, |m, v| m.request.modes = v as usize, Redo::Modes),
    Param::new(STEP, |m| m.params.step, |m, v| m.params.step = v, Redo::Nothing),
    Param::new(
        CONSTRAINT_DAMPING,
        |m| m.params.constraint_damping,
        |m, v| m.params.constraint_damping = v,
        Redo::Nothing,
    ),
];
/// Everything a modal analysis depends on, owned so that it can go to a background thread (`rds`
/// builds on it too).
#[derive(Debug, Clone)]
pub(crate) struct Request {
    pub(crate) cache: Cache,
    pub(crate) mesh: Arc<TriMesh>,
    pub(crate) anchors: Arc<Vec<usize>>,
    /// Lumped vertex areas (masses are these times the density).
    pub(crate) area: Arc<Vec<f64>>,
    pub(crate) density: f64,
    pub(crate) stiffness: ShellStiffness,
    pub(crate) modes: usize,
    /// Keep the rigid modes: a free shell held only by tracks must be able to move as a whole.
    pub(crate) keep_rigid: bool,
}

impl Request {
    /// The analysis a scene asks for (its mesh, anchors, material and mode count), cached in `cache`.
    pub(crate) fn of(setup: &Setup, cache: Cache) -> Self {
        let m = &setup.scene.material;
        Self {
            cache,
            mesh: Arc::new(setup.mesh.clone()),
            anchors: Arc::new(setup.anchors.clone()),
            area: Arc::new(setup.mesh.vertex_areas()),
            density: m.density,
            stiffness: ShellStiffness::from(m),
            modes: setup.scene.solver.modes,
            keep_rigid: setup.anchors.is_empty() && !setup.tracks.is_empty(),
        }
    }

    /// The lumped vertex masses, kg.
    pub(crate) fn masses(&self) -> Vec<f64> {
        self.area.iter().map(|a| a * self.density).collect()
    }

    /// Gravity `gravity` on the lumped masses plus the point loads `loads`, N.
    pub(crate) fn scene_forces(&self, gravity: DVec3, loads: &[DVec3]) -> Vec<DVec3> {
        self.area.iter().zip(loads).map(|(a, l)| gravity * (a * self.density) + *l).collect()
    }

    /// The modal problem, with `masses` from [`Request::masses`].
    pub(crate) fn problem<'a>(&'a self, masses: &'a [f64]) -> ModalProblem<'a> {
        ModalProblem {
            mesh: &self.mesh,
            anchors: &self.anchors,
            masses,
            stiffness: self.stiffness,
            modes: self.modes,
            keep_rigid: self.keep_rigid,
        }
    }

    /// What makes the factor of this shell for the drags' static responses (on any thread).
    pub(crate) fn drag_factor(&self) -> impl FnOnce() -> Made + Send + 'static {
        let request = self.clone();
        move || StaticResponse::new(&request.problem(&request.masses()))
    }

    /// Cached or freshly computed (and then cached) modes.
    pub(crate) fn run(&self, progress: &dyn Fn(f32)) -> Result<ModalAnalysis, SolverError> {
        self.run_factored(progress).map(|(a, _)| a)
    }

    /// [`Request::run`], with the factor of `K − σM` when the modes were computed (not cached).
    pub(crate) fn run_factored(
        &self,
        progress: &dyn Fn(f32),
    ) -> Result<(ModalAnalysis, Option<Factored>), SolverError> {
        let masses = self.masses();
        let problem = self.problem(&masses);
        if let Some(a) = self.cache.load(&problem) {
            return Ok((a, None));
        }
        let (a, factor) = analyse_factored(&problem, progress)?;
        self.cache.store(&problem, &a);
        Ok((a, Some(factor)))
    }
}

/// The modal solver (LMA, MWTS or MWTS-RS).
pub struct ModalSolver {
    method: &'static str,
    request: Request,
    loads: Vec<DVec3>,
    gravity: DVec3,
    /// The scene's wind, whether the modal force holds some of it, and the positions a step ago (for
    /// the shell's velocity).
    wind: Wind,
    blown: bool,
    /// [`ENERGY_LIMIT`] times the scene's forces' work across the shell, J: past it a step has
    /// diverged.
    energy_limit: f64,
    previous: Vec<DVec3>,
    params: ModalParams,
    dynamics: ModalDynamics,
    analysis: ModalAnalysis,
    drags: DragSet,
    /// The factor for the static responses of the current analysis's shell.
    factor: DragFactor,
    /// The groups of dragged vertices whose responses are in the dynamics' basis.
    groups: Vec<Vec<usize>>,
    /// The drag revision the basis was last fitted to.
    drag_revision: Option<u64>,
    steps: u64,
    pending: Option<Background<ModalAnalysis>>,
    generation: Generation,
}

/// How long a background analysis waits for further edits before it starts.
const SETTLE: Duration = Duration::from_millis(200);

impl ModalSolver {
    /// Build from a scene (computing or loading the modes synchronously), caching analyses in the
    /// default location ([`Cache::from_env`]).
    pub fn new(setup: &Setup, variant: Variant) -> Result<Self, SolverError> {
        Self::with_cache(setup, variant, Cache::from_env())
    }

    /// Build from a scene, caching analyses in `cache`.
    pub fn with_cache(setup: &Setup, variant: Variant, cache: Cache) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        let s = &setup.scene.solver;
        let request = Request::of(setup, cache);
        let method = variant.name();
        let analysis = request.run(&|_| {}).map_err(|e| named(e, method))?;
        let shape = variant.shape(&setup.mesh, &setup.anchors, &analysis.basis)?;
        let params = ModalParams {
            step: s.step.unwrap_or(1.0 / 30.0),
            alpha: s.rayleigh_alpha,
            beta: s.rayleigh_beta,
            constraint_damping: s.constraint_damping.unwrap_or(1e-2),
        };
        let mut solver = Self {
            method,
            dynamics: ModalDynamics::new(analysis.basis.clone(), setup.mesh.positions().to_vec(), Vec::new(), shape),
            request,
            loads: setup.loads.clone(),
            gravity: setup.gravity(),
            wind: Wind::of(setup)?,
            blown: false,
            energy_limit: f64::INFINITY,
            previous: setup.mesh.positions().to_vec(),
            params,
            analysis,
            drags: DragSet::new(setup.mesh.vertex_count(), true),
            factor: DragFactor::default(),
            groups: Vec::new(),
            drag_revision: None,
            steps: 0,
            pending: None,
            generation: Generation::default(),
        };
        solver.update_forces();
        Ok(solver)
    }

    /// The current modal analysis (eigenvalues, residuals, timings).
    pub fn analysis(&self) -> &ModalAnalysis {
        &self.analysis
    }

    /// Gravity on the lumped masses plus the point loads, N.
    fn scene_forces(&self) -> Vec<DVec3> {
        self.request.scene_forces(self.gravity, &self.loads)
    }

    /// Take the scene's forces, and the divergence limit they set, after a change of gravity, the
    /// loads or the density.
    fn update_forces(&mut self) {
        let forces = self.scene_forces();
        self.energy_limit = ENERGY_LIMIT * energy_scale(&forces, self.request.mesh.bounding_box());
        self.dynamics.set_forces(forces);
    }

    /// The wind on the shell as the last step left it (its velocity from the step before), projected
    /// onto the modes with the coming step's positions update, like gravity: held over a step, as the
    /// modal force always is. Calm air that was calm before costs nothing.
    fn apply_wind(&mut self) {
        let calm = self.wind.is_calm();
        if calm && !self.blown {
            return;
        }
        let x = self.dynamics.positions();
        let h = self.params.step;
        let v: Vec<DVec3> = x.iter().zip(&self.previous).map(|(a, b)| (*a - *b) / h).collect();
        let time = self.steps as f64 * h;
        let forces = self.wind.forces(time, (x, &v), self.request.mesh.triangles(), &self.scene_forces());
        self.dynamics.hold_forces(&forces);
        self.blown = !calm;
    }

    /// Fit the basis to the position drags: the modes plus the static responses to forces at the
    /// dragged vertices while any are dragged ([`super::ritz`]), the modes alone when none are.
    fn follow_drags(&mut self) -> Result<(), SolverError> {
        if self.drag_revision == Some(self.drags.revision()) {
            return Ok(());
        }
        self.drag_revision = Some(self.drags.revision());
        let groups = ritz::dragged_groups(&self.drags);
        if groups == self.groups {
            return Ok(());
        }
        let basis = if groups.is_empty() {
            self.analysis.basis.clone()
        } else {
            let response = self.factor.get(self.request.drag_factor())?;
            response.augment(&self.analysis.basis, &self.request.mesh, &groups)?
        };
        self.dynamics.replace_basis(basis, &self.request.masses());
        self.groups = groups;
        Ok(())
    }

    /// Start recomputing the modes for the current parameters on a background thread.
    fn recompute(&mut self) {
        let request = self.request.clone();
        let work = move |report: &dyn Fn(f32)| request.run(report);
        self.pending = Some(Background::start("shellwarp-modes", "modal analysis", &self.generation, SETTLE, work));
    }

    /// Swap in a finished background basis, if any.
    fn poll_pending(&mut self) -> Result<(), SolverError> {
        match self.pending.as_ref().and_then(Background::ready) {
            Some(result) => self.swap(result),
            None => Ok(()),
        }
    }

    /// Whether the drags' factor is at hand or being made ([`Solver::expect_drags`]).
    pub fn drags_prepared(&self) -> bool {
        self.factor.prepared()
    }

    /// Block until a background recomputation (if any) has finished, and swap its basis in: for
    /// deterministic runs (tests, headless renders), where the swap must not depend on timing.
    pub fn wait_for_modes(&mut self) -> Result<(), SolverError> {
        match self.pending.as_ref().map(Background::wait) {
            Some(result) => self.swap(result),
            None => Ok(()),
        }
    }

    /// Carry the state over to a finished analysis (or report why it failed).
    fn swap(&mut self, result: Result<ModalAnalysis, SolverError>) -> Result<(), SolverError> {
        self.pending = None;
        let analysis = result.map_err(|e| named(e, self.method))?;
        let masses = self.request.masses();
        self.dynamics.replace_basis(analysis.basis.clone(), &masses);
        self.analysis = analysis;
        // The responses belong to the old shell: refit them to the new one at the next step.
        self.factor.renew(None, self.request.drag_factor());
        (self.groups, self.drag_revision) = (Vec::new(), None);
        Ok(())
    }
}

/// The modal analysis reports itself as method `modal`: name the method the user chose instead.
pub(crate) fn named(e: SolverError, method: &'static str) -> SolverError {
    match e {
        SolverError::Unsuitable { reason, .. } => SolverError::Unsuitable { method, reason },
        e => e,
    }
}

impl Solver for ModalSolver {
    fn method(&self) -> &'static str {
        self.method
    }

    fn time_step(&self) -> f64 {
        self.params.step
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.poll_pending()?;
        self.follow_drags()?;
        self.apply_wind();
        self.previous.copy_from_slice(self.dynamics.positions());
        self.dynamics.step(&self.params, &self.drags);
        self.steps += 1;
        let time = self.steps as f64 * self.params.step;
        let energy = self.dynamics.energy();
        // The positions are a continuous function of `q` with finite coefficients (any finite `q` gives
        // finite positions short of overflow, which the energy limit catches first), so checking the
        // modal state stands for scanning every vertex.
        if !self.dynamics.q.iter().chain(&self.dynamics.v).all(|x| x.is_finite()) {
            let reason = "the modal coordinates are not finite".to_string();
            return Err(SolverError::Diverged { step: self.steps, time, reason });
        }
        check_finite(self.steps, time, &[], energy, self.energy_limit)?;
        Ok(StepStats {
            wall_seconds: start.elapsed().as_secs_f64(),
            sim_time: time,
            energy,
            residual: 0.0,
            iterations: 0,
            ..StepStats::default()
        })
    }

    fn positions(&self) -> &[DVec3] {
        self.dynamics.positions()
    }

    fn reset(&mut self) {
        self.dynamics.reset();
        self.previous.copy_from_slice(self.dynamics.positions());
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        [params::values(PARAMS, self), self.wind.params()].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.wind.set_param(name, value)? {
            return Ok(());
        }
        match params::set(PARAMS, self, name, value)? {
            Redo::Nothing => {}
            Redo::Forces => self.update_forces(),
            Redo::Modes => {
                // The masses follow the density at once; the stiffnesses and the count with the new modes.
                self.update_forces();
                self.recompute();
            }
        }
        Ok(())
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }

    fn progress(&self) -> Option<Progress> {
        self.pending
            .as_ref()
            .map(|p| Progress { label: format!("computing {} modes", self.request.modes), fraction: p.fraction() })
    }

    fn poll(&mut self) -> Result<(), SolverError> {
        self.poll_pending()
    }

    fn expect_drags(&mut self) {
        self.factor.expect(self.request.drag_factor());
    }

    fn info(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("active modes", self.analysis.basis.modes() as f64),
            ("drag modes", (self.dynamics.basis.modes() - self.analysis.basis.modes()) as f64),
        ]
    }
}

impl Drop for ModalSolver {
    fn drop(&mut self) {
        // A background analysis of a solver that is gone is pointless: stop it.
        self.generation.cancel_all();
    }
}
