//! The window's wgpu surface: configuration (sRGB, vsync, read-back where offered), resizing, one
//! frame's drawing — the 3D scene in its viewport (4× MSAA where the adapter supports it) with the
//! egui panel on top — and saving what was drawn as PNG.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, anyhow};
use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

use crate::render::{Frame, Gpu, Renderer, read_texture, save_png};

/// The panel's output for one frame, ready to paint.
pub struct PanelPaint {
    /// Tessellated shapes.
    pub primitives: Vec<egui::ClippedPrimitive>,
    /// Font and image texture updates.
    pub textures: egui::TexturesDelta,
    /// egui's scale.
    pub pixels_per_point: f32,
}

/// The GPU side of the window.
pub struct WindowSurface {
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    egui: egui_wgpu::Renderer,
}

impl WindowSurface {
    /// Open a device for `window` and configure its surface.
    pub fn new(event_loop: &ActiveEventLoop, window: Arc<Window>) -> anyhow::Result<Self> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        )));
        let size = window.inner_size();
        let surface = instance.create_surface(window).context("creating the window surface")?;
        let gpu = Gpu::for_surface(instance, &surface)?;
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps.formats.iter().copied().find(wgpu::TextureFormat::is_srgb).or(caps.formats.first().copied());
        let format = format.ok_or_else(|| anyhow!("the window surface offers no colour format"))?;
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
            usage |= wgpu::TextureUsages::COPY_SRC;
        }
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        let renderer = Renderer::new(&gpu, format, 4)?;
        let egui = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        Ok(Self { surface, config, gpu, renderer, egui })
    }

    /// Size in physical pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.config.width, self.config.height)
    }

    /// Follow a window resize.
    pub fn resize(&mut self, width: u32, height: u32) {
        self.config.width = width.max(1);
        self.config.height = height.max(1);
        self.surface.configure(&self.gpu.device, &self.config);
    }

    /// Draw `frame` and the panel into the next surface texture, returned unpresented (so it can be
    /// read back first); `None` when the surface has no texture to give right now (try next frame).
    pub fn draw(&mut self, frame: &Frame, panel: PanelPaint) -> anyhow::Result<Option<wgpu::SurfaceTexture>> {
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                return Ok(None);
            }
            _ => return Ok(None),
        };
        let target = texture.texture.create_view(&Default::default());
        let size = self.size();
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.renderer.encode(&self.gpu, &mut encoder, frame, &target, size)?;
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: panel.pixels_per_point };
        for (id, deltas) in &panel.textures.set {
            for delta in deltas {
                self.egui.update_texture(&self.gpu.device, &self.gpu.queue, *id, delta);
            }
        }
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        let extra = self.egui.update_buffers(device, queue, &mut encoder, &panel.primitives, &screen);
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target,
                    resolve_target: None,
                    depth_slice: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            self.egui.render(&mut pass.forget_lifetime(), &panel.primitives, &screen);
        }
        self.gpu.queue.submit(extra.into_iter().chain([encoder.finish()]));
        for id in &panel.textures.free {
            self.egui.free_texture(id);
        }
        Ok(Some(texture))
    }

    /// Show a drawn texture.
    pub fn present(&self, texture: wgpu::SurfaceTexture) {
        self.gpu.queue.present(texture);
    }

    /// Save a drawn (not yet presented) texture as PNG.
    pub fn save(&self, texture: &wgpu::SurfaceTexture, out: &Path) -> anyhow::Result<()> {
        if !self.config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
            return Err(anyhow!("this window surface cannot be read back (no COPY_SRC), so no screenshot"));
        }
        let image = read_texture(&self.gpu, &texture.texture)?;
        save_png(&image, out).context("saving the screenshot")?; // the error names the file
        Ok(())
    }
}
