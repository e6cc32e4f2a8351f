//! Offscreen rendering to an [`RgbaImage`] and PNG files, for tests, reports and the command line.

use std::path::Path;
use std::sync::mpsc;

use image::RgbaImage;

use super::error::RenderError;
use super::frame::Frame;
use super::gpu::Gpu;
use super::renderer::Renderer;

/// Colour format of headless renders: 8-bit RGBA with hardware sRGB encoding.
pub const HEADLESS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Bytes per row of a `width`-pixel RGBA8 image once padded to wgpu's copy alignment (256 bytes).
pub fn padded_bytes_per_row(width: u32) -> u32 {
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    (width * 4).div_ceil(align) * align
}

/// An offscreen colour texture plus the buffer it is read back through.
#[derive(Debug)]
struct Offscreen {
    size: (u32, u32),
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback: wgpu::Buffer,
}

impl Offscreen {
    fn new(gpu: &Gpu, format: wgpu::TextureFormat, (width, height): (u32, u32)) -> Result<Self, RenderError> {
        gpu.check_size((width, height))?;
        gpu.scoped("creating the offscreen target", || Ok(Self::create(gpu, format, (width, height))))
    }

    fn create(gpu: &Gpu, format: wgpu::TextureFormat, (width, height): (u32, u32)) -> Self {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shellwarp offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shellwarp readback"),
            size: u64::from(padded_bytes_per_row(width)) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Self { size: (width, height), texture, view, readback }
    }

    fn read(&self, gpu: &Gpu) -> Result<RgbaImage, RenderError> {
        read_texture_with(gpu, &self.texture, &self.readback)
    }
}

/// Read an 8-bit RGBA or BGRA texture (with `COPY_SRC` usage) back into an image: a window's surface
/// texture for screenshots, or an offscreen target.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture) -> Result<RgbaImage, RenderError> {
    let readback = gpu.scoped("creating the readback buffer", || {
        Ok(gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shellwarp readback"),
            size: u64::from(padded_bytes_per_row(texture.width())) * u64::from(texture.height()),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        }))
    })?;
    read_texture_with(gpu, texture, &readback)
}

/// Copy `texture` into `readback`, wait, and strip the row padding (and swap BGRA to RGBA).
fn read_texture_with(gpu: &Gpu, texture: &wgpu::Texture, readback: &wgpu::Buffer) -> Result<RgbaImage, RenderError> {
    let bgra = readback_layout(texture.format())?;
    let (width, height) = (texture.width(), texture.height());
    let padded = padded_bytes_per_row(width);
    gpu.scoped("reading back the image", || {
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shellwarp readback") });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })?;

    let slice = readback.slice(..);
    let (sender, receiver) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        // The receiver outlives the poll below; a failed send only means nobody is waiting.
        let _ = sender.send(result);
    });
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Map(e.to_string()))?;
    receiver
        .recv()
        .map_err(|_| RenderError::Map("the map callback never ran".into()))?
        .map_err(|e| RenderError::Map(e.to_string()))?;

    let row_bytes = width as usize * 4;
    // Fallible: under an address-space limit the picture's memory is an error, not an abort.
    let mut pixels = Vec::new();
    pixels.try_reserve_exact(row_bytes * height as usize).map_err(|e| {
        RenderError::Map(format!(
            "no memory for the {width}x{height} picture ({} bytes): {e}",
            row_bytes * height as usize
        ))
    })?;
    {
        let data = slice.get_mapped_range().map_err(|e| RenderError::Map(e.to_string()))?;
        for row in data.chunks(padded as usize).take(height as usize) {
            pixels.extend_from_slice(&row[..row_bytes]);
        }
    }
    readback.unmap();
    if bgra {
        pixels.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
    }
    RgbaImage::from_raw(width, height, pixels)
        .ok_or_else(|| RenderError::Map("read back fewer bytes than the image needs".into()))
}

/// Whether `format` reads back as 4 bytes per pixel, and if so whether red and blue are swapped.
fn readback_layout(format: wgpu::TextureFormat) -> Result<bool, RenderError> {
    use wgpu::TextureFormat as F;
    match format {
        F::Rgba8UnormSrgb | F::Rgba8Unorm => Ok(false),
        F::Bgra8UnormSrgb | F::Bgra8Unorm => Ok(true),
        _ => Err(RenderError::UnsupportedFormat {
            format,
            reason: "headless rendering needs an 8-bit RGBA or BGRA format (use HEADLESS_FORMAT)".into(),
        }),
    }
}

/// Render `frame` offscreen at `width`×`height` and read it back as an image.
///
/// `renderer` should have been created with [`HEADLESS_FORMAT`] (any 8-bit RGBA/BGRA format works).
/// Allocates a texture per call; use [`Headless`] for repeated renders of one size.
pub fn render_to_image(
    gpu: &Gpu,
    renderer: &mut Renderer,
    frame: &Frame,
    width: u32,
    height: u32,
) -> Result<RgbaImage, RenderError> {
    readback_layout(renderer.color_format())?;
    let offscreen = Offscreen::new(gpu, renderer.color_format(), (width, height))?;
    renderer.render(gpu, frame, &offscreen.view, (width, height))?;
    offscreen.read(gpu)
}

/// A GPU, a renderer and an offscreen target bundled for repeated renders of one size.
#[derive(Debug)]
pub struct Headless {
    gpu: Gpu,
    renderer: Renderer,
    offscreen: Option<Offscreen>,
    size: (u32, u32),
}

impl Headless {
    /// Open a headless GPU ([`Gpu::new_headless`]) and a 4× MSAA renderer (if supported) for `width`×`height`
    /// (refused with [`RenderError::BadSize`] if the GPU cannot make textures that large).
    pub fn new(width: u32, height: u32) -> Result<Self, RenderError> {
        let gpu = Gpu::new_headless()?;
        let renderer = Renderer::new(&gpu, HEADLESS_FORMAT, 4)?;
        let mut headless = Self { gpu, renderer, offscreen: None, size: (0, 0) };
        headless.resize(width, height)?;
        Ok(headless)
    }

    /// Change the output size (the offscreen texture is recreated on the next render).
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        self.gpu.check_size((width, height))?;
        if self.size != (width, height) {
            self.size = (width, height);
            self.offscreen = None;
        }
        Ok(())
    }

    /// Output size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The GPU in use.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The renderer in use.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// Render `frame` and read it back.
    pub fn render(&mut self, frame: &Frame) -> Result<RgbaImage, RenderError> {
        readback_layout(self.renderer.color_format())?;
        let offscreen = match self.offscreen.take() {
            Some(o) if o.size == self.size => o,
            _ => Offscreen::new(&self.gpu, self.renderer.color_format(), self.size)?,
        };
        self.renderer.render(&self.gpu, frame, &offscreen.view, self.size)?;
        let image = offscreen.read(&self.gpu)?;
        // Kept only after a successful render: a target that failed is made afresh next time.
        self.offscreen = Some(offscreen);
        Ok(image)
    }
}

/// Write `image` as a PNG at `path` atomically ([`crate::atomic`]): readers never see a half-written file.
pub fn save_png(image: &RgbaImage, path: impl AsRef<Path>) -> Result<(), RenderError> {
    let path = path.as_ref();
    let io = |reason: String| RenderError::Io { path: path.to_path_buf(), reason };
    let mut png = std::io::Cursor::new(Vec::new());
    image.write_to(&mut png, image::ImageFormat::Png).map_err(|e| io(format!("cannot encode PNG: {e}")))?;
    crate::atomic::write(path, png.get_ref()).map_err(|e| io(format!("cannot write PNG: {e}")))
}

/// Read a PNG (or any format the `image` crate was built with) as 8-bit RGBA.
pub fn load_png(path: impl AsRef<Path>) -> Result<RgbaImage, RenderError> {
    let path = path.as_ref();
    image::open(path)
        .map(|i| i.to_rgba8())
        .map_err(|e| RenderError::Io { path: path.to_path_buf(), reason: format!("cannot read image: {e}") })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_padded_to_256_bytes() {
        assert_eq!(padded_bytes_per_row(64), 256);
        assert_eq!(padded_bytes_per_row(65), 512);
        assert_eq!(padded_bytes_per_row(256), 1024);
        assert_eq!(padded_bytes_per_row(1), 256);
    }

    #[test]
    fn save_png_round_trips_and_reports_bad_paths() {
        let dir = std::env::temp_dir().join(format!("shellwarp-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let image = RgbaImage::from_pixel(3, 2, image::Rgba([1, 2, 3, 255]));
        save_png(&image, &path).unwrap();
        assert_eq!(load_png(&path).unwrap(), image);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary file left behind");
        let err = save_png(&image, dir.join("missing/t.png")).unwrap_err();
        assert!(err.to_string().contains("missing"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
