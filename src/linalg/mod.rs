//! Sparse linear algebra for the implicit and static solvers and for the modal stiffness:
//! shift-invert Lanczos for the lowest modes ([`lanczos`]),
//! the block sparsity pattern of a `3n × 3n` Hessian computed once from element stencils, numeric
//! assembly through precomputed value slots, DOF reduction for anchored vertices, and a sparse
//! Cholesky wrapper (faer) that factorises the pattern symbolically once, its variant for a 3-vector
//! per unknown of a scalar matrix ([`VectorCholesky`]), and Baraff–Witkin's
//! filtered PCG for constrained particle systems ([`filtered_pcg`]); hot loops compiled for the CPU's
//! best instruction set ([`isa`]) over per-particle vectors padded to four lanes ([`padded`]),
//! arithmetic that one formula writes for a number and for SIMD lanes alike ([`real`]), slices that
//! threads write at once, each its own entries ([`shared`]);
//! non-negative least squares ([`nnls`]) and a deterministic generator ([`random`]).

mod assembly;
mod cholesky;
mod dofs;
mod error;
pub mod filtered_pcg;
pub mod isa;
pub mod lanczos;
pub mod matrix_market;
pub mod nnls;
pub mod ordering;
pub mod padded;
pub mod random;
pub mod real;
pub mod shared;
mod substitution;
mod supernodal_solve;
mod supernodal_split;
pub mod tree_split;
mod vector_cholesky;

pub use assembly::BlockAssembler;
pub use cholesky::SparseCholesky;
pub use dofs::DofMap;
pub use error::LinalgError;
pub use vector_cholesky::VectorCholesky;
