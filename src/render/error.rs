//! Errors raised while setting up the GPU, drawing a frame or writing an image.

use std::path::PathBuf;

/// Why rendering failed. Every message is one line and names what to fix where possible.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum RenderError {
    /// No adapter at all: not even a software rasterizer.
    #[error("no GPU adapter found (install mesa-vulkan-drivers for software rendering)")]
    NoAdapter,
    /// The adapter refused to create a device.
    #[error("could not create a GPU device: {0}")]
    RequestDevice(String),
    /// A render target size was zero or above the device limit.
    #[error("invalid render size {width}x{height}: {reason}")]
    BadSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
        /// Why it was refused.
        reason: String,
    },
    /// A mesh in the frame is inconsistent (index out of range, normals of the wrong length, ...).
    #[error("mesh {mesh} in frame: {reason}")]
    BadMesh {
        /// Index of the mesh in `Frame::meshes`.
        mesh: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A camera cannot be fitted to the given box (non-finite or inverted box, bad margin or field of
    /// A render target that would need more memory than the machine has.
    #[error(transparent)]
    TooLarge(#[from] crate::memory::TooLarge),
    /// view, or a viewing direction along the up vector).
    #[error("cannot fit the camera: {0}")]
    BadCamera(String),
    /// The frame has more vertices than 32-bit indices can address.
    #[error("frame has {0} vertices, more than 32-bit indices can address")]
    TooManyVertices(usize),
    /// The colour format cannot be used for this operation.
    #[error("unsupported colour format {format:?}: {reason}")]
    UnsupportedFormat {
        /// The offending format.
        format: wgpu::TextureFormat,
        /// Why it cannot be used.
        reason: String,
    },
    /// wgpu reported a validation or out-of-memory error.
    #[error("GPU error while {context}: {message}")]
    Gpu {
        /// What the renderer was doing.
        context: &'static str,
        /// wgpu's message on one line, down to the root cause.
        message: String,
    },
    /// Reading back a rendered image failed.
    #[error("could not read back the rendered image: {0}")]
    Map(String),
    /// Two images that should be compared have different sizes.
    #[error("image size mismatch: {a_width}x{a_height} vs {b_width}x{b_height}")]
    SizeMismatch {
        /// Width of the first image.
        a_width: u32,
        /// Height of the first image.
        a_height: u32,
        /// Width of the second image.
        b_width: u32,
        /// Height of the second image.
        b_height: u32,
    },
    /// Reading or writing an image file failed.
    #[error("{}: {reason}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

impl RenderError {
    /// A wgpu error as one line: wgpu's multi-line report ("Caused by: ...") flattened into its chain of
    /// causes, outermost first, ending with the root cause.
    pub(crate) fn gpu(context: &'static str, error: &wgpu::Error) -> Self {
        let flat = |s: String| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let mut parts: Vec<String> = Vec::new();
        if matches!(error, wgpu::Error::OutOfMemory { .. }) {
            parts.push("out of memory".into());
        }
        let mut cause = std::error::Error::source(error);
        while let Some(c) = cause {
            let part = flat(c.to_string());
            // Some causes repeat their own source in their message: keep each piece once.
            if !part.is_empty() && !parts.iter().any(|p| p.contains(&part)) {
                parts.push(part);
            }
            cause = c.source();
        }
        if parts.is_empty() {
            parts.push(flat(error.to_string()));
        }
        Self::Gpu { context, message: parts.join(": ") }
    }
}
