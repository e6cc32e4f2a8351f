//! Modal methods for shells: linear modal analysis (LMA) and modal warping (MWTS).

pub mod basis;
pub mod cache;
pub mod compute;
pub mod dynamics;
pub mod kernel;
pub mod method;
pub mod rotation;
pub mod supersede;
pub mod warp;
