//! The interactive viewer: a winit window whose surface the shared renderer draws into, an egui panel
//! on top, pointer gestures that pick and drag vertices, scene and method switches built in the
//! background, and the simulation on its own thread.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use glam::Vec2;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use super::gestures::{Gestures, ViewUnderPointer};
use super::ghost;
use super::loader::{self, Loaded, Loader, SceneSource};
use super::orbit::Orbit;
use super::panel::{self, PanelState, UiAction};
use super::scene_view::{SceneView, ViewOptions};
use super::sim_thread::{Command, Pacing, SimHandle, SimStatus, Snapshot};
use super::soak::{Poke, Soak, SoakOptions};
use super::surface::{PanelPaint, WindowSurface};
use crate::render::Camera;
use crate::scene::{self, Setup};
use crate::solver::{Drag, DragKind, METHODS, Solver};

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
    /// Scripted drags, sent through the same command channel as the mouse.
    pub drags: Vec<Drag>,
    /// With `screenshot_after`: also write the simulation state shown in the screenshot as JSON.
    pub state_out: Option<PathBuf>,
    /// Run a reference ghost with this method (refused if it cannot keep real time).
    pub ghost: Option<String>,
    /// Drive the window with a random script for a while, write its report, and exit.
    pub soak: Option<SoakOptions>,
}

/// The simulation state written by `state_out`: what the screenshot shows, as numbers, and how it
/// was projected (so a test can find a vertex's pixel).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ViewerState {
    /// Steps taken.
    pub steps: u64,
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Position-drag targets by vertex.
    pub position_drags: Vec<(usize, [f64; 3])>,
    /// Camera eye.
    pub eye: [f32; 3],
    /// Camera target (the camera's up is +y).
    pub target: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// The 3D viewport in the window, pixels: `[x, y, width, height]`.
    pub viewport: [f32; 4],
}

impl ViewerState {
    /// The camera the screenshot was taken with.
    pub fn camera(&self) -> Camera {
        let mut camera = Camera::look_at(self.eye.into(), self.target.into());
        camera.fov_y_deg = self.fov_y_deg;
        camera
    }
}

/// Open the window and run until it is closed (or the unattended screenshot is taken).
pub fn run(options: ViewerOptions) -> anyhow::Result<()> {
    let source = SceneSource { scene: options.scene.clone(), overrides: options.overrides.clone() };
    let loaded = loader::load(source.clone())?;
    let ghost = match &options.ghost {
        Some(method) => {
            let mut g = loader::load(source.with_method(method))?;
            ghost::check_pace(g.solver.as_mut()).map_err(anyhow::Error::msg)?;
            Some(g.solver)
        }
        None => None,
    };
    let event_loop = EventLoop::new().context("opening the display (is DISPLAY set? try xvfb-run)")?;
    let mut app = App { options, pending: Some((loaded, ghost)), running: None, error: None };
    event_loop.run_app(&mut app).context("running the event loop")?;
    app.error.map_or(Ok(()), Err)
}

struct App {
    options: ViewerOptions,
    pending: Option<(Loaded, Option<Box<dyn Solver>>)>,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

struct Running {
    window: Arc<Window>,
    surface: WindowSurface,
    egui_state: egui_winit::State,
    sim: SimHandle,
    source: SceneSource,
    setup: Setup,
    view: SceneView,
    orbit: Orbit,
    panel: PanelState,
    loader: Loader,
    /// A ghost being built (and timed) in the background.
    ghost_loader: Loader,
    pointer: Vec2,
    gestures: Gestures,
    frames: u64,
    last_frame: Instant,
    screenshot: bool,
    /// Width of the side panel in points (the 3D view is the rest of the window).
    panel_width: f32,
    /// The soak driving the window, if any.
    soak: Option<Soak>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        let Some((loaded, ghost)) = self.pending.take() else { return };
        match Running::new(event_loop, &self.options, loaded, ghost) {
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

/// How long the solver may stay inside one call before the panel calls it stuck (a creature's
/// implicit discrete-shell step takes under 2 s).
pub const STUCK_AFTER: std::time::Duration = std::time::Duration::from_secs(5);

/// A scene's window title, static picture and camera orbit.
fn scene_parts(setup: &Setup) -> (String, SceneView, Orbit) {
    let view = SceneView::new(setup);
    let orbit = Orbit::from_camera(&view.camera());
    (format!("shellwarp — {}", setup.scene.name), view, orbit)
}

impl Running {
    fn new(
        event_loop: &ActiveEventLoop,
        options: &ViewerOptions,
        loaded: Loaded,
        ghost: Option<Box<dyn Solver>>,
    ) -> anyhow::Result<Self> {
        let Loaded { source, setup, solver } = loaded;
        let (title, view, orbit) = scene_parts(&setup);
        let (w, h) = options.size;
        let attributes =
            Window::default_attributes().with_title(title).with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).context("creating the window")?);
        let surface = WindowSurface::new(event_loop, window.clone())?;
        let egui_state = egui_winit::State::new(
            egui::Context::default(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            None,
        );
        let sim = SimHandle::spawn(solver, options.paused, Pacing::Scaled(1.0));
        sim.send(Command::Watch(Some(Box::new(setup.clone()))));
        if ghost.is_some() {
            sim.send(Command::SetGhost(ghost));
        }
        let panel = PanelState::new(
            scene::builtin_names().into_iter().map(String::from).collect(),
            METHODS.iter().map(|m| m.name.to_string()).collect(),
            source.scene.clone(),
        );
        let mut gestures = Gestures::default();
        for &drag in &options.drags {
            sim.send(Command::AddDrag(gestures.new_drag_id(), drag));
        }
        Ok(Self {
            window,
            surface,
            egui_state,
            sim,
            source,
            setup,
            view,
            orbit,
            panel,
            loader: Loader::default(),
            ghost_loader: Loader::default(),
            pointer: Vec2::ZERO,
            gestures,
            frames: 0,
            last_frame: Instant::now(),
            screenshot: false,
            panel_width: 0.0,
            soak: options.soak.clone().map(Soak::new),
        })
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
            WindowEvent::Resized(size) => self.surface.resize(size.width, size.height),
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
            WindowEvent::MouseInput { state: ElementState::Released, .. } => self.gestures.release(),
            WindowEvent::MouseInput { button, .. } if !consumed => self.pressed(button),
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
        let paused = !matches!(self.sim.latest().status, SimStatus::Running);
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
                "r" | "R" => self.apply(UiAction::Reset),
                "c" | "C" => self.sim.send(Command::ClearDrags),
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
        let (w, h) = self.surface.size();
        let (w, h) = (w as f32, h as f32);
        let x = (self.panel_width * self.window.scale_factor() as f32).clamp(0.0, w - 1.0);
        [x, 0.0, w - x, h]
    }

    /// The pointer in viewport coordinates and the viewport's size.
    fn pointer_in_viewport(&self) -> (Vec2, Vec2) {
        let [x, _, w, h] = self.viewport_rect();
        (self.pointer - Vec2::new(x, 0.0), Vec2::new(w, h))
    }

    fn pressed(&mut self, button: winit::event::MouseButton) {
        let mode = self.panel.drag_mode;
        self.gesture(|gestures, orbit, view| gestures.press(button, orbit, view, mode));
    }

    fn pointer_moved(&mut self, delta: Vec2) {
        self.gesture(|gestures, orbit, view| gestures.moved(delta, orbit, view));
    }

    /// Feed the gesture state machine what is under the pointer; send the commands it produces.
    fn gesture(&mut self, step: impl FnOnce(&mut Gestures, &mut Orbit, &ViewUnderPointer<'_>) -> Vec<Command>) {
        let (pixel, viewport) = self.pointer_in_viewport();
        let snap = self.sim.latest();
        let view = ViewUnderPointer {
            pixel,
            viewport,
            positions: &snap.positions,
            anchors: &self.setup.anchors,
            drags: &snap.drags,
        };
        let commands = step(&mut self.gestures, &mut self.orbit, &view);
        commands.into_iter().for_each(|c| self.sim.send(c));
    }

    fn apply(&mut self, action: UiAction) {
        match action {
            // A stuck solver cannot take a command: its scene is rebuilt and run on a new thread.
            UiAction::Reset if self.stuck().is_some() => self.loader.start(self.source.clone()),
            UiAction::SwitchScene(name) => self.loader.start(SceneSource { scene: name, overrides: Vec::new() }),
            UiAction::SwitchMethod(method) => self.loader.start(self.source.with_method(&method)),
            UiAction::SetGhost(Some(method)) => {
                self.ghost_loader.start_checked(self.source.with_method(&method), Some(ghost::check_pace));
            }
            UiAction::Screenshot => self.screenshot = true,
            other => {
                if let Some(c) = other.command() {
                    self.sim.send(c);
                }
            }
        }
    }

    /// Take over a scene built in the background, or report why it failed.
    fn finish_switch(&mut self) {
        match self.loader.poll() {
            None => {}
            Some(Ok(Loaded { source, setup, solver })) => {
                if self.stuck().is_some() {
                    let pacing = self.panel.speed.map_or(Pacing::AsFastAsPossible, Pacing::Scaled);
                    std::mem::replace(&mut self.sim, SimHandle::spawn(solver, false, pacing)).abandon();
                } else {
                    self.sim.send(Command::Replace(solver));
                }
                self.sim.send(Command::Watch(Some(Box::new(setup.clone()))));
                let title;
                (title, self.view, self.orbit) = scene_parts(&setup);
                self.window.set_title(&title);
                self.panel.scene.clone_from(&source.scene);
                self.panel.message = None;
                self.source = source;
                self.setup = setup;
            }
            Some(Err(e)) => {
                self.panel.message = Some(e.to_string());
                self.panel.scene.clone_from(&self.source.scene);
            }
        }
        match self.ghost_loader.poll() {
            // A ghost for a scene that has since been switched away is dropped.
            Some(Ok(g)) if g.source.scene == self.source.scene => self.sim.send(Command::SetGhost(Some(g.solver))),
            Some(Ok(_)) | None => {}
            Some(Err(e)) => self.panel.message = Some(e.to_string()),
        }
        self.panel.loading = self.loader.status().or_else(|| self.ghost_loader.status());
    }

    /// Run the panel for `snapshot`; returns what it drew.
    fn panel(&mut self, snapshot: &Snapshot) -> PanelPaint {
        let raw = self.egui_state.take_egui_input(&self.window);
        let mut actions = Vec::new();
        let panel = &mut self.panel;
        let mut panel_width = self.panel_width;
        let ctx = self.egui_state.egui_ctx().clone();
        let output = ctx.run_ui(raw, |ui| {
            let shown =
                egui::Panel::left("controls").resizable(true).default_size(panel::DEFAULT_WIDTH).show(ui, |ui| {
                    actions = panel::show(ui, panel, snapshot);
                });
            panel_width = shown.response.rect.width();
        });
        self.panel_width = panel_width;
        actions.into_iter().for_each(|a| self.apply(a));
        self.egui_state.handle_platform_output(&self.window, output.platform_output);
        PanelPaint {
            primitives: ctx.tessellate(output.shapes, output.pixels_per_point),
            textures: output.textures_delta,
            pixels_per_point: output.pixels_per_point,
        }
    }

    /// Draw one frame; returns true when the unattended screenshot is done and the app should exit.
    fn redraw(&mut self, options: &ViewerOptions) -> anyhow::Result<bool> {
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f64();
        self.last_frame = now;
        self.panel.fps = if dt > 0.0 { 0.9 * self.panel.fps + 0.1 / dt } else { self.panel.fps };
        self.finish_switch();
        let mut snapshot = self.sim.latest().clone();
        if let Some(seconds) = self.stuck() {
            snapshot.status = SimStatus::Stuck(seconds);
        }
        if let Some(report) = self.soak(&snapshot, dt * 1e3)? {
            return Ok(report);
        }
        // The panel first, so its actions apply before the scene is drawn.
        let paint = self.panel(&snapshot);
        let camera = self.orbit.camera();
        let options_view = ViewOptions { wireframe: self.panel.wireframe };
        let mut frame = self.view.frame(
            camera,
            &snapshot.positions,
            snapshot.stats.sim_time,
            &snapshot.drags,
            options_view,
            &snapshot.bodies,
        );
        if let Some(g) = &snapshot.ghost {
            self.view.ghost_lines(&mut frame, &g.positions);
        }
        frame.viewport = Some(self.viewport_rect());
        self.window.request_redraw();
        let Some(texture) = self.surface.draw(&frame, paint)? else { return Ok(false) };
        self.frames += 1;
        let unattended = options.screenshot_after.is_some_and(|n| self.frames >= n);
        if self.screenshot || unattended {
            self.screenshot = false;
            let saved = self.surface.save(&texture, &options.out);
            screenshot_outcome(saved, unattended, &mut self.panel)?;
        }
        if let (true, Some(path)) = (unattended, &options.state_out) {
            let state = viewer_state(&snapshot, &camera, self.viewport_rect());
            crate::atomic::write(path, serde_json::to_string(&state)?.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
        }
        self.surface.present(texture);
        Ok(unattended)
    }
}

impl Running {
    /// Seconds the solver has been inside one call, once that is past [`STUCK_AFTER`].
    fn stuck(&self) -> Option<f64> {
        self.sim.stuck_for().filter(|d| *d >= STUCK_AFTER).map(|d| d.as_secs_f64())
    }

    /// Let the soak act on this frame; `Some(true)` once it is over and its report written.
    fn soak(&mut self, snapshot: &Snapshot, frame_ms: f64) -> anyhow::Result<Option<bool>> {
        let Some(soak) = self.soak.as_mut() else { return Ok(None) };
        if soak.finished() {
            let path = soak.report_path().to_path_buf();
            let report = soak.report();
            crate::atomic::write(&path, serde_json::to_string_pretty(&report)?.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            return Ok(Some(true));
        }
        for poke in soak.tick(snapshot, frame_ms) {
            match poke {
                Poke::Ui(action) => self.apply(action),
                Poke::Sim(command) => self.sim.send(command),
            }
        }
        Ok(None)
    }
}

/// An unattended screenshot that fails ends the run with the error; an interactive one (F12, the
/// button) shows it in the panel and the viewer carries on.
fn screenshot_outcome(saved: anyhow::Result<()>, unattended: bool, panel: &mut PanelState) -> anyhow::Result<()> {
    match saved {
        Err(e) if unattended => Err(e),
        Err(e) => {
            panel.message = Some(format!("screenshot failed: {e:#}"));
            Ok(())
        }
        Ok(()) => Ok(()),
    }
}

fn viewer_state(snapshot: &Snapshot, camera: &Camera, viewport: [f32; 4]) -> ViewerState {
    ViewerState {
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
        eye: camera.eye.to_array(),
        target: camera.target.to_array(),
        fov_y_deg: camera.fov_y_deg,
        viewport,
    }
}

#[cfg(test)]
mod tests {
    use anyhow::anyhow;

    use super::*;

    #[test]
    fn a_failed_interactive_screenshot_is_shown_not_fatal() {
        let mut panel = PanelState::new(Vec::new(), Vec::new(), "s".into());
        let failed = || Err(anyhow!("saving /nope/x.png: No such file or directory"));
        assert!(screenshot_outcome(failed(), false, &mut panel).is_ok(), "the viewer keeps running");
        assert!(panel.message.as_deref().is_some_and(|m| m.contains("/nope/x.png")), "{:?}", panel.message);
        let mut quiet = PanelState::new(Vec::new(), Vec::new(), "s".into());
        assert!(screenshot_outcome(failed(), true, &mut quiet).is_err(), "an unattended run fails with it");
        assert!(screenshot_outcome(Ok(()), false, &mut quiet).is_ok() && quiet.message.is_none());
    }
}
