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
    /// Build a solver for a realised scene.
    pub build: fn(&Setup) -> Result<Box<dyn Solver>, SolverError>,
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

/// Look a method up by name.
pub fn find(name: &str) -> Result<&'static Method, SolverError> {
    METHODS.iter().find(|m| m.name == name).ok_or_else(|| SolverError::UnknownMethod {
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
        None => ((find(&setup.scene.solver.method)?.build)(setup)?, Vec::new()),
    };
    let script = Script::new(setup);
    if script.is_empty() && why.is_empty() {
        return Ok(inner);
    }
    Ok(Box::new(Scripted::new(inner, script, why)?))
}
