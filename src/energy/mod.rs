//! Pure functions of positions: values, gradients and Hessians of the elastic energies.
//!
//! Nothing here keeps simulation state; everything is checked against central finite differences.
//! The discrete shell energy (Grinspun et al. 2003) lives in [`shell`], built from the
//! per-element terms in [`stretch`] (edge length, triangle area) and [`hinge`] (dihedral angle).
//! The cloth's particle springs (Choi & Ko's stretch and buckling springs) are in [`springs`].

pub mod constraints;
mod error;
pub mod hinge;
pub mod shell;
pub mod springs;
pub mod stretch;

pub use error::EnergyError;
pub use shell::{DiscreteShell, EnergyTerms, HessianMode, ShellStiffness};

#[cfg(test)]
pub(crate) mod fd;
#[cfg(test)]
mod tests;
