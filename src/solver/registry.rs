//! The list of methods: a name, a one-line summary and a constructor. Adding a method is one line here.

use super::script::{Script, Scripted};
use super::{Solver, SolverError, cloth, ds_explicit, ds_implicit, ds_static, modal, pbd, rigid};
use crate::scene::Setup;

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

/// Every method, in the order the UI lists them.
pub const METHODS: &[Method] = &[
    modal::method::MWTS,
    modal::method::MWTS_RS,
    modal::method::LMA,
    ds_implicit::METHOD,
    ds_static::METHOD,
    ds_explicit::METHOD,
    cloth::CLOTH,
    cloth::CLOTH_QUAD,
    pbd::PBD,
    pbd::XPBD,
    rigid::METHOD,
];

/// Methods for tests of the machinery around solvers, found by [`find`] only when the environment
/// variable `SHELLWARP_TEST_METHODS` is set, and never listed.
pub const TEST_METHODS: &[Method] = &[rigid::FAULTY];

/// Look a method up by name.
pub fn find(name: &str) -> Result<&'static Method, SolverError> {
    let tests = if std::env::var_os("SHELLWARP_TEST_METHODS").is_some() { TEST_METHODS } else { &[] };
    METHODS.iter().chain(tests).find(|m| m.name == name).ok_or_else(|| SolverError::UnknownMethod {
        name: name.to_string(),
        available: METHODS.iter().map(|m| m.name).collect::<Vec<_>>().join(", "),
    })
}

/// Build the solver the scene's `solver.method` names, or, when the scene gives `solver.accuracy`,
/// the cheapest one that meets it ([`super::auto`]), or, for a scene of `[[parts]]`, each part with its
/// own method or target ([`super::parts`]); driven by the scene's tracks, if any ([`super::script`]).
pub fn build(setup: &Setup) -> Result<Box<dyn Solver>, SolverError> {
    let (inner, why): (Box<dyn Solver>, _) = match setup.scene.solver.accuracy {
        _ if !setup.scene.parts.is_empty() => (Box::new(super::parts::Parts::new(setup)?), Vec::new()),
        Some(_) => super::auto::build(setup)?,
        None => (find(&setup.scene.solver.method)?.construct(setup)?, Vec::new()),
    };
    let script = Script::new(setup);
    if script.is_empty() && why.is_empty() {
        return Ok(inner);
    }
    Ok(Box::new(Scripted::new(inner, script, why)?))
}
