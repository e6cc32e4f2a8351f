//! Errors raised while finding, parsing, validating or realising a scene.

use crate::mesh::MeshError;

/// Why a scene could not be loaded. Every variant names the file (or built-in scene) first.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Read {
        /// The file.
        file: String,
        /// The I/O error.
        reason: String,
    },
    /// Neither a built-in scene name nor an existing file.
    #[error("`{name}` is neither a built-in scene ({available}) nor a scene file")]
    Unknown {
        /// What was asked for.
        name: String,
        /// Comma-separated built-in names.
        available: String,
    },
    /// Malformed TOML, a missing or unknown key, or a value of the wrong type.
    #[error("{file}:{line}:{column}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// 1-based line of the offending key or value.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong, naming the key.
        message: String,
    },
    /// A well-typed value that makes no sense (negative radius, NaN stiffness...).
    #[error("{file}: `{key}`: {reason}")]
    Invalid {
        /// The file.
        file: String,
        /// Dotted key path.
        key: String,
        /// Why it was refused.
        reason: String,
    },
    /// The mesh could not be made or read.
    #[error("{file}: mesh: {error}")]
    Mesh {
        /// The file.
        file: String,
        /// The mesh error (part of this message, so deliberately not also its `source`).
        error: MeshError,
    },
    /// A `--set key=value` override that cannot be applied.
    #[error("--set {arg}: {reason}")]
    Override {
        /// The argument as given.
        arg: String,
        /// Why it was refused.
        reason: String,
    },
}
