//! shellwarp: real-time thin shells and cloth.
//!
//! Data flows one way: a [`scene`] file becomes a [`mesh`] and parameters, a [`solver`] steps it,
//! and the positions become a frame for the [`render`]er or numbers for the evaluator.
//! The [`app`] ties solver and renderer together; nothing below it knows about it.

pub mod app;
pub mod atomic;
pub mod collision;
pub mod energy;
pub mod eval;
pub mod linalg;
pub mod memory;
pub mod mesh;
pub mod render;
pub mod scene;
pub mod solver;
pub mod threads;
