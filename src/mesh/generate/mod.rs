//! Procedural meshes for every scene the papers use. Each returns a validated [`super::TriMesh`].

mod grid;

pub use grid::grid;
mod pending;
pub use pending::*;
