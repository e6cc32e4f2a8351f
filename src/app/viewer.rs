//! The interactive viewer: a winit window whose surface the shared renderer draws into, an egui panel
//! on top, mouse picking and dragging, and the simulation on its own thread.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, anyhow};
use glam::{DVec3, Vec2, Vec3};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use super::orbit::{Orbit, pick_vertex, pixel_ray, view_plane_point};
use super::panel::{self, DragMode, PanelState, UiAction};
use super::scene_view::{SceneView, ViewOptions};
use super::sim_thread::{Command, Pacing, SimHandle};
use crate::render::{Gpu, Renderer, read_texture, save_png};
use crate::scene::{self, Setup};
use crate::solver::{self, Drag, DragId, DragKind, METHODS};

/// What to open and, for tests and scripts, what to do unattended.
#[derive(Debug, Clone, Default)]
pub struct ViewerOptions {
    /// Built-in scene name or scene file.
    pub scene: String,
    /// `key=value` scene overrides (including `solver.method=...`).
    pub overrides: Vec<String>,
    /// Window size in physical pixels.
    pub size: (u32, u32),
    /// Start paused.
    pub paused: bool,
    /// Save a screenshot after this many rendered frames, then exit.
    pub screenshot_after: Option<u64>,
    /// Where screenshots go (F12 and `screenshot_after`).
    pub out: PathBuf,
    /// A scripted drag sent through the same command channel as the mouse: vertex and target.
    pub drag: Option<(usize, DVec3)>,
    /// With `screenshot_after`: also write the simulation state shown in the screenshot as JSON.
    pub state_out: Option<PathBuf>,
}

/// The simulation state written by `state_out`: what the screenshot shows, as numbers.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ViewerState {
    /// Steps taken.
    pub steps: u64,
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Position-drag targets by vertex.
    pub position_drags: Vec<(usize, [f64; 3])>,
}

/// Open the window and run until it is closed (or the unattended screenshot is taken).
pub fn run(options: ViewerOptions) -> anyhow::Result<()> {
    let setup = scene::load(&options.scene, &options.overrides)?;
    let solver = solver::build(&setup).with_context(|| format!("building solver for {}", setup.origin.label))?;
    let event_loop = EventLoop::new().context("opening the display (is DISPLAY set? try xvfb-run)")?;
    let mut app = App { options, pending: Some((setup, solver)), running: None, error: None };
    event_loop.run_app(&mut app).context("running the event loop")?;
    app.error.map_or(Ok(()), Err)
}

struct App {
    options: ViewerOptions,
    pending: Option<(Setup, Box<dyn solver::Solver>)>,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

/// An active pointer gesture.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Gesture {
    None,
    Orbit,
    Pan,
    Drag { id: DragId, vertex: usize, start: Vec2, mode: DragMode },
}

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    sim: SimHandle,
    setup: Setup,
    view: SceneView,
    orbit: Orbit,
    panel: PanelState,
    pointer: Vec2,
    gesture: Gesture,
    next_drag: u64,
    frames: u64,
    last_frame: Instant,
    screenshot: bool,
    message: Option<String>,
    /// Width of the side panel in points (the 3D view is the rest of the window).
    panel_width: f32,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        let Some((setup, solver)) = self.pending.take() else { return };
        match Running::new(event_loop, &self.options, setup, solver) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else { return };
        if let Err(e) = r.handle(event_loop, &self.options, event) {
            self.error = Some(e);
            event_loop.exit();
        }
    }
}

impl Running {
    fn new(
        event_loop: &ActiveEventLoop,
        options: &ViewerOptions,
        setup: Setup,
        solver: Box<dyn solver::Solver>,
    ) -> anyhow::Result<Self> {
        let (w, h) = options.size;
        let attributes = Window::default_attributes()
            .with_title(format!("shellwarp — {}", setup.scene.name))
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).context("creating the window")?);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        )));
        let surface = instance.create_surface(window.clone()).context("creating the window surface")?;
        let gpu = Gpu::for_surface(instance, &surface)?;
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps.formats.iter().copied().find(wgpu::TextureFormat::is_srgb).or(caps.formats.first().copied());
        let format = format.ok_or_else(|| anyhow!("the window surface offers no colour format"))?;
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
            usage |= wgpu::TextureUsages::COPY_SRC;
        }
        let size = window.inner_size();
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
        let ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            None,
        );
        let egui_renderer = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        let sim = SimHandle::spawn(solver, options.paused, Pacing::Scaled(1.0));
        let view = SceneView::new(&setup);
        let orbit = Orbit::from_camera(&view.camera());
        let panel = PanelState::new(
            scene::builtin_names().into_iter().map(String::from).collect(),
            METHODS.iter().map(|m| m.name.to_string()).collect(),
            setup.scene.name.clone(),
        );
        let mut running = Self {
            window,
            surface,
            config,
            gpu,
            renderer,
            egui_state,
            egui_renderer,
            sim,
            setup,
            view,
            orbit,
            panel,
            pointer: Vec2::ZERO,
            gesture: Gesture::None,
            next_drag: 1 << 32,
            frames: 0,
            last_frame: Instant::now(),
            screenshot: false,
            message: None,
            panel_width: 0.0,
        };
        if let Some((vertex, target)) = options.drag {
            let id = running.new_drag_id();
            running.sim.send(Command::AddDrag(id, Drag { vertex, kind: DragKind::Position(target) }));
        }
        Ok(running)
    }

    fn new_drag_id(&mut self) -> DragId {
        self.next_drag += 1;
        DragId(self.next_drag)
    }

    fn handle(
        &mut self,
        event_loop: &ActiveEventLoop,
        options: &ViewerOptions,
        event: WindowEvent,
    ) -> anyhow::Result<()> {
        let consumed = self.egui_state.on_window_event(&self.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                self.config.width = size.width.max(1);
                self.config.height = size.height.max(1);
                self.surface.configure(&self.gpu.device, &self.config);
            }
            WindowEvent::RedrawRequested if self.redraw(options)? => event_loop.exit(),
            WindowEvent::KeyboardInput { event, .. } if !consumed && event.state == ElementState::Pressed => {
                self.key(event_loop, &event.logical_key);
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let delta = p - self.pointer;
                self.pointer = p;
                self.pointer_moved(delta);
            }
            WindowEvent::MouseInput { state, button, .. } => self.button(state, button, consumed),
            WindowEvent::MouseWheel { delta, .. } if !consumed => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.orbit.zoom(steps);
            }
            _ => {}
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) {
        let paused = !matches!(self.sim.latest().status, super::sim_thread::SimStatus::Running);
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::Space) => self.sim.send(Command::SetPaused(!paused)),
            Key::Named(NamedKey::F12) => self.screenshot = true,
            Key::Named(NamedKey::ArrowLeft) => self.orbit.rotate(Vec2::new(-20.0, 0.0)),
            Key::Named(NamedKey::ArrowRight) => self.orbit.rotate(Vec2::new(20.0, 0.0)),
            Key::Named(NamedKey::ArrowUp) => self.orbit.rotate(Vec2::new(0.0, 20.0)),
            Key::Named(NamedKey::ArrowDown) => self.orbit.rotate(Vec2::new(0.0, -20.0)),
            Key::Character(c) => match c.as_str() {
                "s" | "S" => self.sim.send(Command::StepOnce),
                "r" | "R" => self.sim.send(Command::Reset),
                "w" | "W" => self.panel.wireframe = !self.panel.wireframe,
                "+" | "=" => self.orbit.zoom(1.0),
                "-" => self.orbit.zoom(-1.0),
                _ => {}
            },
            _ => {}
        }
    }

    /// The part of the window right of the panel, in pixels: `[x, y, width, height]`.
    fn viewport_rect(&self) -> [f32; 4] {
        let (w, h) = (self.config.width as f32, self.config.height as f32);
        let x = (self.panel_width * self.window.scale_factor() as f32).clamp(0.0, w - 1.0);
        [x, 0.0, w - x, h]
    }

    /// Size of the 3D viewport.
    fn viewport(&self) -> Vec2 {
        let [_, _, w, h] = self.viewport_rect();
        Vec2::new(w, h)
    }

    /// The pointer in viewport coordinates.
    fn viewport_pointer(&self) -> Vec2 {
        self.pointer - Vec2::new(self.viewport_rect()[0], 0.0)
    }

    fn button(&mut self, state: ElementState, button: MouseButton, consumed: bool) {
        if state == ElementState::Released {
            if let Gesture::Drag { id, .. } = self.gesture {
                self.sim.send(Command::RemoveDrag(id));
            }
            self.gesture = Gesture::None;
            return;
        }
        if consumed {
            return;
        }
        self.gesture = match button {
            MouseButton::Left => self.start_drag().unwrap_or(Gesture::Orbit),
            MouseButton::Right => Gesture::Orbit,
            MouseButton::Middle => Gesture::Pan,
            _ => Gesture::None,
        };
    }

    /// Pick the vertex under the pointer and add a constraint on it.
    fn start_drag(&mut self) -> Option<Gesture> {
        let camera = self.orbit.camera();
        let positions: Vec<Vec3> = self.sim.latest().positions.iter().map(|p| p.as_vec3()).collect();
        let vertex = pick_vertex(&camera, &positions, self.viewport_pointer(), self.viewport(), 12.0)?;
        if self.setup.anchors.binary_search(&vertex).is_ok() {
            return None;
        }
        let id = self.new_drag_id();
        let mode = self.panel.drag_mode;
        let kind = match mode {
            DragMode::Position => DragKind::Position(positions[vertex].as_dvec3()),
            DragMode::Orientation => DragKind::Orientation(DVec3::ZERO),
        };
        self.sim.send(Command::AddDrag(id, Drag { vertex, kind }));
        Some(Gesture::Drag { id, vertex, start: self.pointer, mode })
    }

    fn pointer_moved(&mut self, delta: Vec2) {
        let camera = self.orbit.camera();
        match self.gesture {
            Gesture::None => {}
            Gesture::Orbit => self.orbit.rotate(delta),
            Gesture::Pan => self.orbit.pan(delta, self.viewport().y),
            Gesture::Drag { id, vertex, mode: DragMode::Position, .. } => {
                let Some(p) = self.sim.latest().positions.get(vertex).map(|p| p.as_vec3()) else { return };
                let ray = pixel_ray(&camera, self.viewport_pointer(), self.viewport());
                let target = view_plane_point(&camera, &ray, p);
                self.sim.send(Command::MoveDrag(id, DragKind::Position(target.as_dvec3())));
            }
            Gesture::Drag { id, start, mode: DragMode::Orientation, .. } => {
                // Rotate about the screen axes: horizontal motion turns about "up", vertical about "right".
                let d = (self.pointer - start) * 0.01;
                let w = camera.true_up() * d.x + camera.right() * d.y;
                self.sim.send(Command::MoveDrag(id, DragKind::Orientation(w.as_dvec3())));
            }
        }
    }

    fn apply(&mut self, action: UiAction) -> anyhow::Result<()> {
        if let Some(c) = action.command() {
            self.sim.send(c);
            return Ok(());
        }
        let overrides = match &action {
            UiAction::SwitchScene(name) => {
                self.message = None;
                let setup = scene::load(name, &[])?;
                return self.switch(setup);
            }
            UiAction::SwitchMethod(m) => vec![format!("solver.method={m}")],
            UiAction::Screenshot => {
                self.screenshot = true;
                return Ok(());
            }
            _ => return Ok(()),
        };
        let setup = scene::load(&self.panel.scene, &overrides)?;
        self.switch(setup)
    }

    fn switch(&mut self, setup: Setup) -> anyhow::Result<()> {
        let solver = solver::build(&setup)?;
        self.sim.send(Command::Replace(solver));
        self.view = SceneView::new(&setup);
        self.orbit = Orbit::from_camera(&self.view.camera());
        self.window.set_title(&format!("shellwarp — {}", setup.scene.name));
        self.setup = setup;
        Ok(())
    }

    /// Draw one frame; returns true when the unattended screenshot is done and the app should exit.
    fn redraw(&mut self, options: &ViewerOptions) -> anyhow::Result<bool> {
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f64();
        self.last_frame = now;
        self.panel.fps = if dt > 0.0 { 0.9 * self.panel.fps + 0.1 / dt } else { self.panel.fps };
        let snapshot = self.sim.latest().clone();

        // The panel first, so its actions apply before the scene is drawn.
        let raw = self.egui_state.take_egui_input(&self.window);
        let mut actions = Vec::new();
        let message = self.message.clone();
        let panel = &mut self.panel;
        let mut panel_width = self.panel_width;
        let output = self.egui_state.egui_ctx().clone().run_ui(raw, |ui| {
            let shown = egui::Panel::left("controls").resizable(true).default_size(330.0).show(ui, |ui| {
                if let Some(m) = &message {
                    ui.colored_label(egui::Color32::from_rgb(220, 60, 40), m);
                }
                actions = panel::show(ui, panel, &snapshot);
            });
            panel_width = shown.response.rect.width();
        });
        self.panel_width = panel_width;
        for a in actions {
            if let Err(e) = self.apply(a) {
                self.message = Some(format!("{e:#}"));
            }
        }
        self.egui_state.handle_platform_output(&self.window, output.platform_output);
        let ctx = self.egui_state.egui_ctx().clone();
        let paint = ctx.tessellate(output.shapes, output.pixels_per_point);

        let frame_texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                self.window.request_redraw();
                return Ok(false);
            }
            _ => {
                self.window.request_redraw();
                return Ok(false);
            }
        };
        let target = frame_texture.texture.create_view(&Default::default());
        let size = (self.config.width, self.config.height);
        let mut frame = self.view.frame(
            self.orbit.camera(),
            &snapshot.positions,
            snapshot.stats.sim_time,
            &snapshot.drags,
            ViewOptions { wireframe: self.panel.wireframe },
        );
        frame.viewport = Some(self.viewport_rect());
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.renderer.encode(&self.gpu, &mut encoder, &frame, &target, size)?;
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: output.pixels_per_point };
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.egui_renderer.update_texture(&self.gpu.device, &self.gpu.queue, *id, delta);
            }
        }
        let extra = self.egui_renderer.update_buffers(&self.gpu.device, &self.gpu.queue, &mut encoder, &paint, &screen);
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
            self.egui_renderer.render(&mut pass.forget_lifetime(), &paint, &screen);
        }
        self.gpu.queue.submit(extra.into_iter().chain([encoder.finish()]));
        for id in &output.textures_delta.free {
            self.egui_renderer.free_texture(id);
        }
        self.frames += 1;
        let unattended = options.screenshot_after.is_some_and(|n| self.frames >= n);
        if self.screenshot || unattended {
            self.screenshot = false;
            self.save_screenshot(&frame_texture.texture, &options.out)?;
        }
        if let (true, Some(path)) = (unattended, &options.state_out) {
            let state = ViewerState {
                steps: snapshot.steps,
                positions: snapshot.positions.iter().map(|p| p.to_array()).collect(),
                position_drags: snapshot
                    .drags
                    .iter()
                    .filter_map(|(_, d)| match d.kind {
                        DragKind::Position(t) => Some((d.vertex, t.to_array())),
                        DragKind::Orientation(_) => None,
                    })
                    .collect(),
            };
            std::fs::write(path, serde_json::to_string(&state)?)
                .with_context(|| format!("writing {}", path.display()))?;
        }
        self.gpu.queue.present(frame_texture);
        self.window.request_redraw();
        Ok(unattended)
    }

    fn save_screenshot(&self, texture: &wgpu::Texture, out: &PathBuf) -> anyhow::Result<()> {
        if !self.config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
            return Err(anyhow!("this window surface cannot be read back (no COPY_SRC), so no screenshot"));
        }
        let image = read_texture(&self.gpu, texture)?;
        save_png(&image, out).with_context(|| format!("saving {}", out.display()))?;
        Ok(())
    }
}
