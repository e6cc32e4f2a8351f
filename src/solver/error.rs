//! Errors a solver reports.

/// Why a solver could not be built, tuned or stepped.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SolverError {
    /// No method of that name is registered.
    #[error("unknown method `{name}` (available: {available})")]
    UnknownMethod {
        /// The name asked for.
        name: String,
        /// Comma-separated registered names.
        available: String,
    },
    /// The method cannot simulate this scene (wrong kind of mesh, missing anchors...).
    #[error("method `{method}` cannot run this scene: {reason}")]
    Unsuitable {
        /// The method.
        method: &'static str,
        /// Why.
        reason: String,
    },
    /// A parameter name the method does not have.
    #[error("method `{method}` has no parameter `{name}` (it has: {available})")]
    UnknownParam {
        /// The method.
        method: &'static str,
        /// The name given.
        name: String,
        /// Comma-separated parameter names.
        available: String,
    },
    /// A parameter value outside its allowed range, or not finite.
    #[error("parameter `{name}` = {value}: {reason}")]
    BadParam {
        /// The parameter.
        name: String,
        /// The value given.
        value: f64,
        /// Why it was refused.
        reason: String,
    },
    /// A drag constraint that cannot be imposed.
    #[error("drag constraint refused: {0}")]
    BadDrag(String),
    /// The simulation blew up: non-finite or exploding state.
    #[error("diverged at step {step} (t = {time:.4} s): {reason}")]
    Diverged {
        /// Steps taken before the failure.
        step: u64,
        /// Simulated time at the failure.
        time: f64,
        /// What was detected.
        reason: String,
    },
    /// Work that would need more memory than the machine has, refused before it starts.
    #[error(transparent)]
    TooLarge(#[from] crate::memory::TooLarge),
    /// A numerical routine failed (factorisation, eigen solve...).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A scene value the method reads is outside its parameter's range (worded as the scene's own
    /// checks are: file, dotted key, reason).
    #[error("{file}: `{key}`: {reason}")]
    SceneValue {
        /// The scene's file.
        file: String,
        /// Dotted key path.
        key: String,
        /// Why it was refused.
        reason: String,
    },
}
