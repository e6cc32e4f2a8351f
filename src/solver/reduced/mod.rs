//! `rds`, the reduced discrete shell: the full nonlinear discrete-shell energy of Grinspun et al.
//! (2003), restricted to a few coordinates `c` that move the shell through the rotation-strain
//! reconstruction of `mwts-rs` (Huang et al. 2011; Pan, Bao & Huang 2015).
//!
//! - **Kinematics** ([`energy`]): `x(c)` is the least-squares fit of edge vectors to per-triangle
//!   targets `exp([W_t c_o]×) exp([W_t c_i]×)(I + E_t c)(X_j − X_i)`, so rows of the shell turn by
//!   any angle: the rotation of the first-order coordinates `c_o` (modes and load responses) acts on
//!   triangles the others `c_i` (derivative directions, drag responses) have turned in the material
//!   frame. Summing the two into one rotation vector instead locks the V-beam's fold through its
//!   collapse (its closest shape carries 21 J of membrane energy where the shell's has 12 J; 17%
//!   off at 1200 m/s² against 9% composed, BENCHMARKS.md); to second order the two agree.
//! - **Basis** ([`basis`]): the `m` lowest modes and their modal derivatives (Barbič & James 2005)
//!   less the reconstruction's own second order, pruned by mass-PCA; the modes' span is kept
//!   exactly.
//! - **Energy**: `E(x(c))` over every element, its force by the reconstruction's adjoint; or over an
//!   optimised cubature of a few elements ([`cubature`]).
//! - **Dynamics** ([`method`]): backward Euler at 1/30 s by Newton in `c`; drags as stiff springs
//!   ([`springs`]).
//! - **Cache** ([`stored`]): the basis and the cubature kept on disk beside the modes.
//!
//! Why the correction: the full energy on the reconstruction of the modes alone locks (the fit leaves
//! small membrane strains that a membrane 10⁴ times stiffer than bending punishes), and the
//! displacement-space derivatives added as they are carry the rotations' second order a second time;
//! `ψ_ij − χ_ij` adds only what the reconstruction lacks (measured in BENCHMARKS.md).

pub mod basis;
pub mod cubature;
pub mod energy;
pub mod method;
pub mod springs;
pub mod stored;

pub use method::{RDS, Rds};

use crate::scene::Setup;

/// Whether `rds` can model `setup`'s shell: it needs anchors, for its modal derivatives solve with
/// the rest stiffness, singular for a shell held by nothing.
pub fn suits(setup: &Setup) -> bool {
    !setup.anchors.is_empty()
}
