//! Drawing shells with wgpu.
//!
//! The renderer knows nothing about solvers or scenes. Callers describe a picture as plain data — a
//! [`Frame`] with a [`Camera`], lit two-sided [`MeshDraw`]s, coloured [`Line`]s and [`Marker`] cubes —
//! and a [`Renderer`] draws it into **any** `wgpu::TextureView`: a window's surface texture or the
//! offscreen texture behind [`render_to_image`]. Both paths share every line of drawing code.
//!
//! ```no_run
//! use shellwarp::render::{Camera, Frame, Headless, MeshDraw, save_png};
//!
//! # fn main() -> Result<(), shellwarp::render::RenderError> {
//! let mut frame = Frame::new(Camera::look_at(glam::Vec3::new(2.0, 1.5, 2.5), glam::Vec3::ZERO));
//! frame.ground_grid(0.0, 2.0, 0.25, [0.1, 0.1, 0.15, 0.35]);
//! let positions = vec![[-1.0, 0.5, -1.0], [-1.0, 0.5, 1.0], [1.0, 0.5, 1.0], [1.0, 0.5, -1.0]];
//! let quad = MeshDraw::from_positions(positions, vec![[0, 1, 2], [0, 2, 3]], [0.9, 0.4, 0.1, 1.0], [0.1, 0.5, 0.5, 1.0]);
//! frame.meshes.push(quad.with_wireframe([0.05, 0.05, 0.05, 1.0]));
//! let mut headless = Headless::new(640, 480)?;
//! let image = headless.render(&frame)?;
//! save_png(&image, "quad.png")?;
//! # Ok(())
//! # }
//! ```

mod compare;
mod error;
mod frame;
mod geometry;
mod gpu;
mod headless;
mod pipelines;
mod renderer;

pub use compare::{DEFAULT_PIXEL_THRESHOLD, ImageDiff, compare_images, compare_images_with_threshold};
pub use error::RenderError;
pub use frame::{Camera, DEFAULT_BACKGROUND, Frame, Line, Marker, MeshDraw, smooth_normals};
pub use gpu::Gpu;
pub use headless::{
    HEADLESS_FORMAT, Headless, load_png, padded_bytes_per_row, read_texture, render_to_image, save_png,
};
pub use renderer::{Renderer, linear_to_srgb};
