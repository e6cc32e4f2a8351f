//! The list of methods: a name, a one-line summary and a constructor. Adding a method is one line here.

use super::{Method, Solver, SolverError, cloth, ds_explicit, ds_implicit, ds_static, modal, pbd, reduced, rigid};
use crate::scene::Setup;

/// Every method, in the order the UI lists them.
pub const METHODS: &[Method] = &[
    modal::method::MWTS,
    modal::method::MWTS_RS,
    modal::method::LMA,
    reduced::RDS,
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

/// Build the method the scene's `solver.method` names, driven by the scene's tracks, if any: the
/// scene's accuracy target and parts are not read (see [`super::build`] for those).
pub fn build_named(setup: &Setup) -> Result<Box<dyn Solver>, SolverError> {
    super::script::drive(find(&setup.scene.solver.method)?.construct(setup)?, setup, Vec::new())
}
