//! Procedural meshes for every scene the papers use. Each returns a validated [`super::TriMesh`].

mod creature;
mod delaunay;
mod grid;
mod sphere;
mod v_beam;

pub use creature::creature;
pub use delaunay::delaunay_sheet;
pub use grid::grid;
pub use sphere::{icosphere, uv_sphere};
pub use v_beam::v_beam;
