//! Procedural meshes for every scene the papers use. Each returns a validated [`super::TriMesh`].

mod grid;
mod sphere;
mod v_beam;

pub use grid::grid;
pub use sphere::{icosphere, uv_sphere};
pub use v_beam::v_beam;
