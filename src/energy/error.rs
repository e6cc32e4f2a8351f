//! Errors raised when an energy cannot be built.

/// Why an energy could not be set up from a rest mesh.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum EnergyError {
    /// A stiffness is negative or not finite.
    #[error("stiffness `{name}` = {value} must be finite and not negative")]
    BadStiffness {
        /// Which stiffness.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A rest triangle has (near) zero area, so the energies would divide by zero.
    #[error("rest triangle {triangle} is degenerate (area {area:e})")]
    DegenerateTriangle {
        /// Triangle index.
        triangle: usize,
        /// Its rest area.
        area: f64,
    },
    /// A rest edge has (near) zero length.
    #[error("rest edge {edge} is degenerate (length {length:e})")]
    DegenerateEdge {
        /// Edge index.
        edge: usize,
        /// Its rest length.
        length: f64,
    },
}
