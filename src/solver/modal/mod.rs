//! Modal methods for shells: linear modal analysis (LMA) and modal warping (MWTS).

pub mod basis;
pub mod dynamics;
pub mod rotation;
pub mod warp;
pub mod compute;
pub mod cache;
pub mod method;
