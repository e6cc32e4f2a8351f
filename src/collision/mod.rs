//! Rigid bodies that cloth collides with: spheres, planes and closed triangle meshes, each placed by
//! a scripted motion (constant velocity, oscillation, spin). A query gives the signed distance,
//! outward normal and the body's surface velocity at a point — what contact handling needs. Also the
//! geometry of self-collision: closest points ([`closest`]) and a refittable hierarchy of a
//! deforming mesh's triangles ([`bvh`]), and which vertices' fans of triangles are flat ([`fans`]).

mod body;
pub mod bvh;
pub mod closest;
pub mod fans;
mod mesh_distance;
mod shape;

pub use body::{Body, Contact, Motion, Placed};
pub use mesh_distance::MeshDistance;
pub use shape::{Shape, Surface};

/// Why a body could not be made.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum CollisionError {
    /// A mesh collider must be closed so that inside and outside are defined.
    #[error("a collider mesh must be closed, but this one has {boundary_edges} boundary edges")]
    OpenMesh {
        /// Number of edges with a single triangle.
        boundary_edges: usize,
    },
}
