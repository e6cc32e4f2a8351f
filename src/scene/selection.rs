//! Which vertices a scene's anchors, loads, drags and tracks act on: a box or a list of indices.

use serde::{Deserialize, Serialize};

/// A set of vertices: those inside an axis-aligned box, or listed by index (exactly one of the two).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Selection {
    /// Select vertices inside this box (after placement).
    #[serde(default, rename = "box")]
    pub aabb: Option<Aabb>,
    /// Select these vertex indices.
    #[serde(default)]
    pub indices: Option<Vec<usize>>,
}

/// An axis-aligned box, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}
