//! The renderer: draws a [`Frame`] into any texture view (window surface or offscreen texture).

use super::error::RenderError;
use super::frame::Frame;
use super::geometry::Geometry;
use super::gpu::Gpu;
use super::pipelines::{DEPTH_FORMAT, Globals, Pipelines};

/// Draws [`Frame`]s with two pipelines (lit two-sided triangles, lines) into views of one colour format.
///
/// GPU buffers, the depth buffer and the multisampled colour buffer are kept between frames and only
/// recreated when they become too small or the size changes.
#[derive(Debug)]
pub struct Renderer {
    color_format: wgpu::TextureFormat,
    sample_count: u32,
    pipelines: Pipelines,
    globals: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    lit_vertices: GrowBuffer,
    lit_indices: GrowBuffer,
    line_vertices: GrowBuffer,
    targets: Option<Targets>,
    geometry: Geometry,
}

/// Size-dependent attachments.
#[derive(Debug)]
struct Targets {
    size: (u32, u32),
    depth: wgpu::TextureView,
    msaa: Option<wgpu::TextureView>,
}

impl Renderer {
    /// A renderer for target views of `color_format`.
    ///
    /// `sample_count` is a request: 1 disables multisampling; anything above 1 asks for 4× MSAA, used
    /// when the adapter supports it for `color_format` (otherwise 1). See [`Renderer::sample_count`].
    pub fn new(gpu: &Gpu, color_format: wgpu::TextureFormat, sample_count: u32) -> Result<Self, RenderError> {
        let renderable = gpu
            .adapter
            .get_texture_format_features(color_format)
            .allowed_usages
            .contains(wgpu::TextureUsages::RENDER_ATTACHMENT);
        if color_format.has_depth_aspect() || color_format.has_stencil_aspect() || !renderable {
            return Err(RenderError::UnsupportedFormat {
                format: color_format,
                reason: "it is not a renderable colour format on this device".into(),
            });
        }
        let sample_count = if sample_count > 1
            && gpu.supports_sample_count(color_format, 4)
            && gpu.supports_sample_count(DEPTH_FORMAT, 4)
        {
            4
        } else {
            1
        };
        let device = &gpu.device;
        let (pipelines, globals, bind_group) = gpu.scoped("creating pipelines", || {
            let pipelines = Pipelines::new(device, color_format, sample_count);
            let globals = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("shellwarp globals"),
                size: size_of::<Globals>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shellwarp globals"),
                layout: &pipelines.bind_group_layout,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: globals.as_entire_binding() }],
            });
            Ok((pipelines, globals, bind_group))
        })?;
        Ok(Self {
            color_format,
            sample_count,
            pipelines,
            globals,
            bind_group,
            lit_vertices: GrowBuffer::new("shellwarp lit vertices", wgpu::BufferUsages::VERTEX),
            lit_indices: GrowBuffer::new("shellwarp lit indices", wgpu::BufferUsages::INDEX),
            line_vertices: GrowBuffer::new("shellwarp line vertices", wgpu::BufferUsages::VERTEX),
            targets: None,
            geometry: Geometry::default(),
        })
    }

    /// The colour format of the views this renderer draws into.
    pub fn color_format(&self) -> wgpu::TextureFormat {
        self.color_format
    }

    /// Samples per pixel actually used (1 or 4).
    pub fn sample_count(&self) -> u32 {
        self.sample_count
    }

    /// Draw `frame` into `target` (a view of a `size` texture in [`Renderer::color_format`]) and submit.
    ///
    /// wgpu validation and out-of-memory errors (e.g. a view of the wrong format, a target too large
    /// for memory) are returned instead of panicking.
    pub fn render(
        &mut self,
        gpu: &Gpu,
        frame: &Frame,
        target: &wgpu::TextureView,
        size: (u32, u32),
    ) -> Result<(), RenderError> {
        let result = gpu.scoped("rendering a frame", || {
            let mut encoder =
                gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shellwarp frame") });
            self.encode(gpu, &mut encoder, frame, target, size)?;
            gpu.queue.submit([encoder.finish()]);
            Ok(())
        });
        if result.is_err() {
            // Attachments that failed to allocate are invalid: make them afresh next time.
            self.targets = None;
        }
        result
    }

    /// Record the drawing of `frame` into `encoder` without submitting, so callers can add more passes
    /// (e.g. a GUI) to the same command buffer. Buffer uploads go through `gpu.queue` and happen first,
    /// so call this at most once per submission (a second call would overwrite the first's buffers).
    pub fn encode(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame,
        target: &wgpu::TextureView,
        size: (u32, u32),
    ) -> Result<(), RenderError> {
        gpu.check_size(size)?;
        self.geometry.build(frame)?;
        self.ensure_targets(gpu, size);
        let (device, queue) = (&gpu.device, &gpu.queue);
        let full = [0.0, 0.0, size.0 as f32, size.1 as f32];
        let [vx, vy, vw, vh] = frame
            .viewport
            .map(|[x, y, w, h]| {
                let (x, y) = (x.clamp(0.0, full[2] - 1.0), y.clamp(0.0, full[3] - 1.0));
                [x, y, w.clamp(1.0, full[2] - x), h.clamp(1.0, full[3] - y)]
            })
            .unwrap_or(full);
        let aspect = vw / vh;
        let globals = Globals::new(&frame.camera, aspect, !self.color_format.is_srgb());
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        let lit_v = self.lit_vertices.upload(device, queue, bytemuck::cast_slice(&self.geometry.lit_vertices));
        let lit_i = self.lit_indices.upload(device, queue, bytemuck::cast_slice(&self.geometry.lit_indices));
        let line_v = self.line_vertices.upload(device, queue, bytemuck::cast_slice(&self.geometry.line_vertices));

        let Some(targets) = &self.targets else {
            return Err(RenderError::Gpu { context: "rendering a frame", message: "render targets missing".into() });
        };
        let (view, resolve_target, store) = match &targets.msaa {
            Some(msaa) => (msaa, Some(target), wgpu::StoreOp::Discard),
            None => (target, None, wgpu::StoreOp::Store),
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shellwarp frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear_color(frame.background, self.color_format.is_srgb())),
                    store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_viewport(vx, vy, vw, vh, 0.0, 1.0);
        if let (Some(vertices), Some(indices)) = (lit_v, lit_i) {
            pass.set_pipeline(&self.pipelines.lit);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..self.geometry.lit_indices.len() as u32, 0, 0..1);
        }
        if let Some(vertices) = line_v {
            pass.set_pipeline(&self.pipelines.line);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.draw(0..self.geometry.line_vertices.len() as u32, 0..1);
        }
        Ok(())
    }

    /// (Re)create the depth and MSAA buffers when the size changed.
    fn ensure_targets(&mut self, gpu: &Gpu, size: (u32, u32)) {
        if self.targets.as_ref().is_some_and(|t| t.size == size) {
            return;
        }
        let make = |label: &str, format: wgpu::TextureFormat| {
            gpu.device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: self.sample_count,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let depth = make("shellwarp depth", DEPTH_FORMAT);
        let msaa = (self.sample_count > 1).then(|| make("shellwarp msaa colour", self.color_format));
        self.targets = Some(Targets { size, depth, msaa });
    }
}

/// The clear colour for a target: sRGB targets take linear values, others need them encoded.
fn clear_color(c: [f32; 4], target_is_srgb: bool) -> wgpu::Color {
    let enc = |x: f32| if target_is_srgb { x } else { linear_to_srgb(x) };
    wgpu::Color { r: enc(c[0]) as f64, g: enc(c[1]) as f64, b: enc(c[2]) as f64, a: c[3] as f64 }
}

/// The sRGB transfer function for one channel in `[0, 1]`.
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// A GPU buffer that is reused while large enough and replaced by a bigger one when not.
#[derive(Debug)]
struct GrowBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buffer: Option<wgpu::Buffer>,
}

impl GrowBuffer {
    fn new(label: &'static str, usage: wgpu::BufferUsages) -> Self {
        Self { label, usage: usage | wgpu::BufferUsages::COPY_DST, buffer: None }
    }

    /// Copy `bytes` to the start of the buffer; `None` when there is nothing to draw.
    /// The returned buffer may be larger than `bytes`; callers draw only the counts they uploaded.
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) -> Option<&wgpu::Buffer> {
        if bytes.is_empty() {
            return None;
        }
        let needed = bytes.len() as u64;
        if self.buffer.as_ref().is_none_or(|b| b.size() < needed) {
            let size = needed.next_power_of_two().max(1024);
            self.buffer = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            }));
        }
        let buffer = self.buffer.as_ref()?;
        queue.write_buffer(buffer, 0, bytes);
        Some(buffer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_endpoints() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((linear_to_srgb(0.214) - 0.5).abs() < 2e-3);
    }
}
