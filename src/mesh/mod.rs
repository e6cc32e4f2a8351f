//! Triangle meshes: geometry, topology built once, validation, OBJ in/out and procedural generators.
//!
//! Positions are `f64` for simulation; the renderer converts to `f32` itself.

mod error;
mod intersections;
mod topology;
mod trimesh;

pub use error::MeshError;
pub use intersections::self_intersections;
pub use topology::{Edge, Hinge, Topology};
pub use trimesh::TriMesh;
pub(crate) use trimesh::{area_of, bounds, sides};
pub mod generate;
pub mod obj;
