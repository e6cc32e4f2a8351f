//! Errors raised while building, validating or reading a mesh.

use std::path::PathBuf;

/// Why a mesh was refused. Every variant names the offending element so the user can find it.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// The mesh has no vertices or no triangles.
    #[error("mesh is empty ({vertices} vertices, {triangles} triangles)")]
    Empty {
        /// Number of vertices given.
        vertices: usize,
        /// Number of triangles given.
        triangles: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate")]
    NonFinite {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Index of the triangle.
        triangle: usize,
        /// The out-of-range vertex index.
        index: usize,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// Coordinates so large that lengths and areas overflow (e.g. a huge scale).
    #[error("vertex coordinates reach {largest:.3e}: too large, lengths and areas overflow")]
    Overflow {
        /// The largest absolute coordinate.
        largest: f64,
    },
    /// A triangle has (near) zero area or repeats a vertex.
    #[error("triangle {triangle} is degenerate (area {area:.3e})")]
    DegenerateTriangle {
        /// Index of the triangle.
        triangle: usize,
        /// Its area.
        area: f64,
    },
    /// An edge is shared by more than two triangles.
    #[error("edge ({a}, {b}) is non-manifold: shared by {count} triangles")]
    NonManifoldEdge {
        /// First vertex of the edge.
        a: usize,
        /// Second vertex of the edge.
        b: usize,
        /// Number of triangles sharing it.
        count: usize,
    },
    /// Two triangles sharing an edge traverse it in the same direction (inconsistent winding).
    #[error("edge ({a}, {b}) is traversed in the same direction by two triangles: inconsistent orientation")]
    InconsistentOrientation {
        /// First vertex of the edge.
        a: usize,
        /// Second vertex of the edge.
        b: usize,
    },
    /// Two triangles on the same three vertices with opposite windings (a zero-volume "pillow"):
    /// the hinges between them have coinciding opposite vertices.
    #[error("triangles {first} and {second} join the same three vertices (a doubled sheet)")]
    DuplicateTriangle {
        /// Index of the first triangle.
        first: usize,
        /// Index of the second.
        second: usize,
    },
    /// A vertex is used by no triangle.
    #[error("vertex {vertex} is not used by any triangle")]
    UnreferencedVertex {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A generator or a placement was given parameters that cannot make a mesh.
    #[error("invalid mesh parameter `{name}`: {reason}")]
    BadParameter {
        /// The parameter's name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// A mesh that would need more memory than the machine has.
    #[error(transparent)]
    TooLarge(#[from] crate::memory::TooLarge),
    /// Reading or writing a mesh file failed.
    #[error("{path}: {reason}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}
