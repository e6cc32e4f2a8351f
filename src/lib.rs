//! shellwarp: real-time thin shells and cloth.
//!
//! Data flows one way: a [`scene`] file becomes a [`mesh`] and parameters, a [`solver`] steps it,
//! and the positions become a frame for the renderer or numbers for the evaluator.

pub mod energy;
pub mod linalg;
pub mod mesh;
pub mod scene;
pub mod solver;
