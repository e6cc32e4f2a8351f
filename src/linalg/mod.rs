//! Linear algebra: eigen solvers (and, from the shell branch, sparse assembly and factorisations).

pub mod lanczos;
