//! Errors of the sparse linear algebra.

/// Why a sparse operation failed.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum LinalgError {
    /// A matrix file that cannot be read.
    #[error("{0}")]
    Input(String),
    /// The matrix is too large for the 32-bit value slots.
    #[error("sparse matrix with {0} stored entries is too large")]
    TooLarge(usize),
    /// A stencil names a vertex that does not exist.
    #[error("stencil vertex {vertex} out of range (there are {count} vertices)")]
    BadStencil {
        /// The vertex.
        vertex: usize,
        /// How many there are.
        count: usize,
    },
    /// An element block with the wrong size for its stencil.
    #[error("element {element}: block of {len} values does not fit its stencil")]
    BadBlock {
        /// The element.
        element: usize,
        /// Number of values given.
        len: usize,
    },
    /// The symbolic factorisation failed (out of memory, index overflow).
    #[error("symbolic factorisation failed: {0}")]
    Symbolic(String),
    /// Right-hand sides that do not fit the matrix.
    #[error("right-hand side of {len} values does not hold {columns} columns of {rows} rows")]
    BadRhs {
        /// Values given.
        len: usize,
        /// Rows of the matrix.
        rows: usize,
        /// Columns asked for.
        columns: usize,
    },
    /// The matrix is not (numerically) positive definite.
    #[error("matrix is not positive definite: {0}")]
    NotPositiveDefinite(String),
}
