//! The one seam every simulation method plugs into: the [`Solver`] trait, its parameters, drag
//! constraints, statistics, and the [`registry`] of methods by name; [`build`] makes the solver a
//! scene asks for.
//!
//! The viewer, the headless renderer, `sim` and `eval` drive solvers only through this trait.
//!
//! # Adding a method
//!
//! `rigid.rs` is the smallest complete method; copy its shape.
//!
//! 1. A file (or folder) under `solver/` with the solver's state and `impl Solver`: `step` advances one
//!    fixed step and returns [`StepStats`] (call [`check_finite`] on the new state, so divergence is
//!    reported, never propagated); `reset` returns to rest keeping parameters and drags; `drags_mut`
//!    gives the [`DragSet`] it honours (position drags at least; orientation drags where it has
//!    rotations).
//! 2. Its parameter table, one [`params::Param`] per parameter: the spec (name, label, unit, help,
//!    range, and with [`ParamSpec::in_scene`] the scene key it is read from), getter, setter and what a
//!    change makes it redo. `params` and `set_param` are [`params::values`] and [`params::set`] over
//!    it; the panel, `--set` and the live changes read nothing else. Shared quantities take the specs
//!    of [`params::shared`].
//! 3. A `pub const METHOD: Method` in that file: its name (for scene files, `--method` and the panel),
//!    a one-line summary, the constructor from a realised [`Setup`](crate::scene::Setup) (first
//!    [`params::check_scene`] over its table, then read the scene's material and `[solver]` table;
//!    refuse what it cannot simulate with [`SolverError::Unsuitable`]), and its memory [`Footprint`].
//! 4. One line in [`registry::METHODS`]. The panel's method list, `sim`, `render`, the evaluation's
//!    method sweeps and the fuzzer pick it up from there.
//! 5. Tests beside it that would fail if it were wrong (a known equilibrium, a conserved quantity, or
//!    agreement with another method), and the method added to the evaluation's families where it
//!    competes (`eval/experiments`).

pub mod auto;
pub mod cloth;
mod drag;
mod ds_explicit;
mod ds_implicit;
pub mod ds_static;
mod error;
pub mod modal;
mod newton;
pub mod params;
pub mod parts;
pub mod pbd;
pub mod quality;
pub mod reduced;
pub mod registry;
mod rigid;
pub mod run;
pub mod script;
mod shell_model;
mod stability;
mod stats;
pub mod supersede;
pub mod wind;

pub use drag::{Drag, DragId, DragKind, DragSet, FrameDrag};
pub use ds_explicit::{DsExplicit, STABLE_LIMIT_INFO};
pub use ds_implicit::DsImplicit;
pub use ds_static::DsStatic;
pub use error::SolverError;
pub use newton::{Inertia, NewtonReport, NewtonSettings};
pub use params::{ParamSpec, ParamValue};
pub use registry::METHODS;
pub use shell_model::{ENERGY_LIMIT, ShellModel, energy_scale};
pub use stats::{StepStats, check_finite};

use glam::DVec3;

use crate::scene::Setup;

/// A simulation method stepping one mesh at its own fixed time step.
pub trait Solver: Send {
    /// The registry name of this method (e.g. `"mwts"`).
    fn method(&self) -> &'static str;

    /// The fixed step `h` in seconds that [`Solver::step`] advances.
    fn time_step(&self) -> f64;

    /// Advance by one fixed step. On divergence returns [`SolverError::Diverged`]; the solver stays
    /// usable after [`Solver::reset`].
    fn step(&mut self) -> Result<StepStats, SolverError>;

    /// Current vertex positions, in the order of the scene's mesh.
    fn positions(&self) -> &[DVec3];

    /// Return to the initial state (rest shape, zero velocity, time zero); parameters and drags are kept.
    fn reset(&mut self);

    /// The tunable parameters with their current values, for the UI and `--set`.
    fn params(&self) -> Vec<ParamValue>;

    /// Set one parameter by name. The value is checked against its [`ParamSpec`] first.
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError>;

    /// The drag constraints currently imposed.
    fn drags(&self) -> &DragSet;

    /// Mutable access to the drag constraints: add, move or remove while running.
    fn drags_mut(&mut self) -> &mut DragSet;

    /// Background work in progress (e.g. recomputing modes after a parameter change), if any.
    fn progress(&self) -> Option<Progress> {
        None
    }

    /// Finish background work that is ready (e.g. swap in recomputed modes) without stepping, so a
    /// paused simulation still shows it; [`Solver::step`] does this too. An error is the background
    /// work's failure; the solver keeps its previous state. Methods without background work keep the
    /// default, which does nothing.
    fn poll(&mut self) -> Result<(), SolverError> {
        Ok(())
    }

    /// A user may drag soon (the viewer says so when it opens a scene): make ready in the
    /// background what a first drag needs (the modal methods' and `rds`'s factored stiffness for
    /// the drags' static responses), so that the drag does not wait for it in a step. Headless runs
    /// do not call it and make that work when a drag comes, if one does. Methods whose drags need
    /// nothing prepared keep the default, which does nothing.
    fn expect_drags(&mut self) {}

    /// Read-only figures describing the state in use, as (label, value), for the UI (e.g. the number
    /// of modes of the active basis while another one is being computed). Empty by default.
    fn info(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }

    /// The pose (centre, rotation) of every collider of the scene, in its order, at the current time,
    /// when the method moves them itself (dynamic bodies); empty (the default) when every collider
    /// follows its scripted motion.
    fn body_poses(&self) -> Vec<(DVec3, glam::DQuat)> {
        Vec::new()
    }

    /// Choices the method made by itself that a user should know about (e.g. a substep lowered to
    /// stay stable), one sentence each; `sim` prints them. None by default.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
}

/// A registered simulation method.
#[derive(Debug, Clone, Copy)]
pub struct Method {
    /// Name used in scene files, `--method` and the UI.
    pub name: &'static str,
    /// One line saying what it is.
    pub summary: &'static str,
    /// Build a solver for a realised scene (through [`Method::construct`], which checks the memory first).
    pub build: fn(&Setup) -> Result<Box<dyn Solver>, SolverError>,
    /// What it needs in memory.
    pub footprint: Footprint,
}

/// Memory a method needs, in bytes per vertex (and per vertex and mode for the modal methods): its
/// peak resident memory on a 16,441-vertex strip, rounded up to cover the sparse factor's fill
/// growing with size (the 100,002-vertex creature's analysis peaks at 20 KB a vertex).
#[derive(Debug, Clone, Copy)]
pub struct Footprint {
    /// Bytes a vertex.
    pub per_vertex: u64,
    /// Bytes a vertex and mode (modes, their rotations and the Lanczos blocks), zero without modes.
    pub per_vertex_mode: u64,
}

impl Footprint {
    /// A method that factors the full shell's stiffness (modal analysis, Newton).
    pub const FACTORED: Self = Self { per_vertex: 24_000, per_vertex_mode: 0 };
    /// A method that keeps modes besides the factor.
    pub const MODAL: Self = Self { per_vertex: 24_000, per_vertex_mode: 240 };
    /// A particle method: sparse products, colours and contact lists.
    pub const PARTICLES: Self = Self { per_vertex: crate::memory::LEAST_PER_VERTEX, per_vertex_mode: 0 };
}

impl Method {
    /// The memory this method would need for `setup`, bytes.
    pub fn memory(&self, setup: &Setup) -> u64 {
        let per_vertex = self.footprint.per_vertex_mode.saturating_mul(setup.scene.solver.modes as u64);
        crate::memory::times(setup.mesh.vertex_count(), self.footprint.per_vertex.saturating_add(per_vertex))
    }

    /// Build a solver for `setup`, refusing up front one that would need more memory than the machine has.
    pub fn construct(&self, setup: &Setup) -> Result<Box<dyn Solver>, SolverError> {
        crate::memory::check(self.memory(setup), || {
            format!("`{}` with {} modes on {} vertices", self.name, setup.scene.solver.modes, setup.mesh.vertex_count())
        })?;
        (self.build)(setup)
    }
}

/// Build the solver the scene's `solver.method` names, or, when the scene gives `solver.accuracy`,
/// the cheapest one that meets it ([`auto`]), or, for a scene of `[[parts]]`, each part with its own
/// method or target ([`parts`]); driven by the scene's tracks, if any ([`script`]).
pub fn build(setup: &Setup) -> Result<Box<dyn Solver>, SolverError> {
    let (inner, why): (Box<dyn Solver>, _) = match setup.scene.solver.accuracy {
        _ if !setup.scene.parts.is_empty() => (Box::new(parts::Parts::new(setup)?), Vec::new()),
        Some(_) => auto::build(setup)?,
        None => (registry::find(&setup.scene.solver.method)?.construct(setup)?, Vec::new()),
    };
    script::drive(inner, setup, why)
}

/// A background task's label and completed fraction in `[0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// What is being computed.
    pub label: String,
    /// Fraction done.
    pub fraction: f32,
}
