//! Modal methods for shells: linear modal analysis (LMA), modal warping (MWTS) and modal warping's
//! modes with a rotation-strain reconstruction (MWTS-RS).

pub mod basis;
pub mod cache;
pub mod compute;
pub mod dynamics;
pub mod kernel;
pub mod laplacian;
pub mod method;
pub mod ritz;
pub mod rotation;
pub mod rotation_strain;
pub mod rs_pass;
pub mod warp;
