//! Scripted motion in scene files: constraint tracks (keyframed position and rotation targets on a
//! selection of vertices that moves as one rigid frame) and a small skeleton (joints with parents,
//! offsets and keyframed rotations) whose joint frames tracks can follow.
//!
//! ```toml
//! [[tracks]]
//! select = { box = { min = [0.47, -1, -1], max = [1, 1, 1] } }
//! loop = true
//! keys = [ { time = 0.0, rotation = [0, 0, 0] }, { time = 1.0, rotation = [1.57, 0, 0] } ]
//!
//! [[skeleton.joints]]
//! name = "hip"
//! offset = [0, 1, 0]                       # the root: its rest position in the world
//! keys = [ { time = 0.0, rotation = [0, 0, 0] }, { time = 0.5, rotation = [0, 0, 0.3] } ]
//! [[tracks]]
//! select = { box = { .. } }
//! joint = "hip"                            # follow the joint's frame: position and orientation
//! ```

use serde::{Deserialize, Serialize};

use super::selection::Selection;

/// A constraint track: the selected vertices follow a rigid frame given by keyframes or by a joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Track {
    /// The constrained vertices.
    pub select: Selection,
    /// Centre of the frame's rotation, metres (default: the centroid of the selection at rest).
    #[serde(default)]
    pub pivot: Option<[f64; 3]>,
    /// Keyframes, in increasing time (not with `joint`).
    #[serde(default)]
    pub keys: Vec<Key>,
    /// Follow this skeleton joint's frame instead of keyframes (position and orientation).
    #[serde(default)]
    pub joint: Option<String>,
    /// Start again from the first key after the last one.
    #[serde(default, rename = "loop")]
    pub looping: bool,
}

/// One keyframe: the frame's translation from rest and/or its rotation at `time`. Every key of a
/// track gives the same fields; both interpolate linearly (a rotation key is the turn written).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key {
    /// Time, s.
    pub time: f64,
    /// Translation of the frame from its rest place, metres.
    #[serde(default)]
    pub position: Option<[f64; 3]>,
    /// Rotation of the frame from rest about the pivot, as a rotation vector (axis × angle, radians).
    #[serde(default)]
    pub rotation: Option<[f64; 3]>,
}

/// A skeleton: joints with parents, drawn as lines, moved by keyframed rotations (forward kinematics).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Skeleton {
    /// The joints; a parent comes before its children.
    pub joints: Vec<Joint>,
    /// Start again from the first key after the last one (every joint).
    #[serde(default, rename = "loop")]
    pub looping: bool,
}

/// One joint: its place relative to its parent's frame (the root: in the world) and its own
/// keyframed rotation relative to the parent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Joint {
    /// Name tracks refer to.
    pub name: String,
    /// The parent joint's name (none: the root).
    #[serde(default)]
    pub parent: Option<String>,
    /// Offset from the parent's origin in the parent's frame (root: world position), metres.
    pub offset: [f64; 3],
    /// Rotation keys (only `time` and `rotation`); none: no rotation of its own.
    #[serde(default)]
    pub keys: Vec<Key>,
}
