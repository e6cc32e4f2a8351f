//! Modal methods for shells: linear modal analysis (LMA) and modal warping (MWTS).

pub mod rotation;
pub mod warp;
