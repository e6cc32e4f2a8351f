//! Implicit particle cloth: Noh & Jung's particle system on triangle meshes after Choi &
//! Ko's "Stable but responsive cloth", and Choi & Ko's quad-grid original for comparison.
//!
//! - [`graph`]: neighbours (edge and diagonal), valence weights, masses;
//! - [`system`]: spring forces and the symmetric linearised backward Euler system;
//! - [`contact`]: body contacts as velocity constraints with locking, recovery, release and friction;
//! - [`method`]: the [`crate::solver::Solver`] that steps it with the filtered PCG.

pub mod contact;
pub mod graph;
pub mod method;
pub mod system;

pub use method::{CLOTH, CLOTH_QUAD, Cloth, LinearStep, Variant};
