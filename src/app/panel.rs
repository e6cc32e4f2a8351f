//! The egui side panel: scene and method pickers, the solver's parameters (generated from the
//! [`ParamSpec`]s it publishes, so new solvers need no UI code), transport controls, statistics, a
//! live plot, and the list of drag constraints. It only returns [`UiAction`]s; it never touches a
//! solver, so it can be tested with egui_kittest on its own.

use std::collections::{BTreeMap, VecDeque};

use egui::{Color32, RichText};
use egui_plot::{Line, Plot};

use super::readout::ReadoutView;
use super::sim_thread::{Pacing, SimStatus, Snapshot};
use crate::solver::{DragId, DragKind, ParamSpec, registry};

/// What the user asked for this frame.
#[derive(Debug, Clone, PartialEq)]
pub enum UiAction {
    /// Set a solver parameter (already checked against its spec).
    SetParam(String, f64),
    /// Pause (true) or play (false).
    SetPaused(bool),
    /// Take one step.
    StepOnce,
    /// Back to the initial state.
    Reset,
    /// Change pacing.
    SetPacing(Pacing),
    /// Remove one drag constraint.
    RemoveDrag(DragId),
    /// Remove every drag constraint.
    ClearDrags,
    /// Load another scene (by built-in name).
    SwitchScene(String),
    /// Run the current scene with another method.
    SwitchMethod(String),
    /// Run a reference ghost with this method beside the current one (`None`: stop it).
    SetGhost(Option<String>),
    /// Save a screenshot.
    Screenshot,
}

/// What a mouse drag on the surface adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DragMode {
    /// A position constraint that follows the pointer in the view plane.
    #[default]
    Position,
    /// An orientation constraint rotated with the pointer.
    Orientation,
}

/// The panel's own state between frames.
#[derive(Debug, Clone)]
pub struct PanelState {
    /// Built-in scene names to offer.
    pub scenes: Vec<String>,
    /// Method names to offer.
    pub methods: Vec<String>,
    /// The scene shown.
    pub scene: String,
    /// Draw the mesh's edges.
    pub wireframe: bool,
    /// What a mouse drag adds.
    pub drag_mode: DragMode,
    /// Real time (1), slow motion (< 1), or as fast as possible (None).
    pub speed: Option<f64>,
    /// Text being edited, per parameter.
    edits: BTreeMap<&'static str, String>,
    /// Why the last entry of a parameter was refused.
    errors: BTreeMap<&'static str, String>,
    /// Recent (sim time, step ms, energy).
    history: VecDeque<[f64; 3]>,
    last_step: u64,
    /// Frames per second of the window, for display.
    pub fps: f64,
    /// What is being loaded in the background (scene or method switch), shown with a spinner.
    pub loading: Option<String>,
    /// A message for the user (a failed switch or screenshot), shown until dismissed.
    pub message: Option<String>,
}

const HISTORY: usize = 600;

/// The panel's width when the window opens, logical pixels.
pub const DEFAULT_WIDTH: f32 = 330.0;

impl PanelState {
    /// A panel offering these scenes and methods, showing `scene`.
    pub fn new(scenes: Vec<String>, methods: Vec<String>, scene: String) -> Self {
        Self {
            scenes,
            methods,
            scene,
            wireframe: false,
            drag_mode: DragMode::Position,
            speed: Some(1.0),
            edits: BTreeMap::new(),
            errors: BTreeMap::new(),
            history: VecDeque::new(),
            last_step: 0,
            fps: 0.0,
            loading: None,
            message: None,
        }
    }

    /// The refusal message currently shown for a parameter, if any.
    pub fn error(&self, name: &str) -> Option<&str> {
        self.errors.get(name).map(String::as_str)
    }

    /// Check typed text against a spec: the value, or the message to show.
    fn accept(spec: &ParamSpec, text: &str) -> Result<f64, String> {
        let value: f64 = text.trim().parse().map_err(|_| format!("`{}` is not a number", text.trim()))?;
        spec.check(value).map_err(|e| e.to_string())
    }

    fn record(&mut self, snap: &Snapshot) {
        if snap.steps < self.last_step {
            self.history.clear();
        }
        if snap.steps != self.last_step {
            self.history.push_back([snap.stats.sim_time, snap.stats.wall_seconds * 1e3, snap.stats.energy]);
            if self.history.len() > HISTORY {
                self.history.pop_front();
            }
        }
        self.last_step = snap.steps;
    }
}

/// Red, for errors.
const ERROR: Color32 = Color32::from_rgb(220, 60, 40);

/// Draw the panel for `snap`; returns what the user asked for.
pub fn show(ui: &mut egui::Ui, state: &mut PanelState, snap: &Snapshot) -> Vec<UiAction> {
    let mut actions = Vec::new();
    state.record(snap);
    egui::ScrollArea::vertical().show(ui, |ui| {
        notices(ui, state);
        pickers(ui, state, snap, &mut actions);
        ui.separator();
        transport(ui, state, snap, &mut actions);
        ui.separator();
        parameters(ui, state, snap, &mut actions);
        ui.separator();
        statistics(ui, state, snap);
        ui.separator();
        drags(ui, state, snap, &mut actions);
    });
    actions
}

/// The background load in progress and the latest message.
fn notices(ui: &mut egui::Ui, state: &mut PanelState) {
    if let Some(what) = &state.loading {
        ui.horizontal(|ui| {
            ui.spinner().on_hover_text("The scene is built on a background thread; the view keeps running");
            ui.label(what);
        });
    }
    if let Some(m) = &state.message {
        ui.colored_label(ERROR, m);
        if ui.small_button("Dismiss").on_hover_text("Hide this message").clicked() {
            state.message = None;
        }
    }
}

fn pickers(ui: &mut egui::Ui, state: &mut PanelState, snap: &Snapshot, actions: &mut Vec<UiAction>) {
    egui::Grid::new("pickers").num_columns(2).show(ui, |ui| {
        let label = ui.label("Scene").on_hover_text("Scene to simulate");
        let mut scene = state.scene.clone();
        egui::ComboBox::from_id_salt("scene")
            .selected_text(&scene)
            .show_ui(ui, |ui| {
                for s in &state.scenes {
                    ui.selectable_value(&mut scene, s.clone(), s)
                        .on_hover_text(format!("Load the built-in scene `{s}`"));
                }
            })
            .response
            .labelled_by(label.id)
            .on_hover_text("Switch to a built-in scene (loaded in the background)");
        if scene != state.scene {
            state.scene = scene.clone();
            actions.push(UiAction::SwitchScene(scene));
        }
        ui.end_row();
        let label = ui.label("Method").on_hover_text("Simulation method for this scene");
        let mut method = snap.method.to_string();
        egui::ComboBox::from_id_salt("method")
            .selected_text(&method)
            .show_ui(ui, |ui| {
                for m in &state.methods {
                    let summary = registry::find(m).map_or("", |x| x.summary);
                    ui.selectable_value(&mut method, m.clone(), m).on_hover_text(summary);
                }
            })
            .response
            .labelled_by(label.id)
            .on_hover_text("Run this scene with another method (built in the background)");
        if method != snap.method {
            actions.push(UiAction::SwitchMethod(method));
        }
        ui.end_row();
        let label = ui.label("Ghost").on_hover_text("A reference method drawn as a wireframe over this one");
        let shown = snap.ghost.as_ref().map(|g| g.method.to_string());
        let mut ghost = shown.clone();
        egui::ComboBox::from_id_salt("ghost")
            .selected_text(ghost.as_deref().unwrap_or("none"))
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut ghost, None, "none").on_hover_text("No reference ghost");
                for m in &state.methods {
                    let summary = registry::find(m).map_or("", |x| x.summary);
                    ui.selectable_value(&mut ghost, Some(m.clone()), m).on_hover_text(summary);
                }
            })
            .response
            .labelled_by(label.id)
            .on_hover_text(
                "Run another method on the same scene and drags, drawn as a blue wireframe, with the live \
                 relative displacement error against it (refused if it cannot keep real time)",
            );
        if ghost != shown {
            actions.push(UiAction::SetGhost(ghost));
        }
        ui.end_row();
    });
    if let Some(g) = &snap.ghost {
        ui.label(format!("error vs ghost {}: {:.2}%", g.method, 100.0 * g.error)).on_hover_text(
            "‖x − x_ghost‖ / ‖x_ghost − X‖ over all vertices, at the same simulated time: what this method \
             gives up against the ghost",
        );
        if let Some(m) = &g.message {
            ui.colored_label(ERROR, m);
        }
    }
}

fn transport(ui: &mut egui::Ui, state: &mut PanelState, snap: &Snapshot, actions: &mut Vec<UiAction>) {
    ui.horizontal(|ui| {
        let paused = !matches!(snap.status, SimStatus::Running);
        let play = ui.button(if paused { "Play" } else { "Pause" }).on_hover_text("Play or pause (Space)");
        if play.clicked() {
            actions.push(UiAction::SetPaused(!paused));
        }
        if ui.button("Step").on_hover_text("Advance one step and pause (S)").clicked() {
            actions.push(UiAction::StepOnce);
        }
        if ui.button("Reset").on_hover_text("Back to the rest state (R)").clicked() {
            actions.push(UiAction::Reset);
        }
        if ui.button("Screenshot").on_hover_text("Save a PNG of the window (F12)").clicked() {
            actions.push(UiAction::Screenshot);
        }
    });
    ui.horizontal(|ui| {
        ui.checkbox(&mut state.wireframe, "Wireframe").on_hover_text("Overlay the mesh's edges (W)");
        ui.label("Drag adds").on_hover_text("What a left-drag on the surface adds");
        ui.radio_value(&mut state.drag_mode, DragMode::Position, "position")
            .on_hover_text("The picked vertex follows the pointer in the view plane");
        ui.radio_value(&mut state.drag_mode, DragMode::Orientation, "rotation")
            .on_hover_text("The picked vertex turns with the pointer about the screen axes (rotate gizmo)");
    });
    ui.horizontal(|ui| {
        let before = state.speed;
        ui.label("Pace").on_hover_text("Simulated time per wall-clock time");
        ui.radio_value(&mut state.speed, Some(1.0), "real time")
            .on_hover_text("One simulated second per wall-clock second");
        ui.radio_value(&mut state.speed, Some(0.25), "slow x0.25")
            .on_hover_text("Slow motion: a quarter simulated second per wall-clock second");
        ui.radio_value(&mut state.speed, None, "fast").on_hover_text("Step as fast as possible");
        if state.speed != before {
            actions.push(UiAction::SetPacing(state.speed.map_or(Pacing::AsFastAsPossible, Pacing::Scaled)));
        }
    });
    if let SimStatus::Stuck(seconds) = snap.status {
        ui.colored_label(ERROR, format!("Stuck: `{}` has not returned from its step for {seconds:.0} s.", snap.method));
        let reset = ui.button("Reset on a new thread");
        let help = "Rebuild the scene and run it on a new simulation thread (R); the stuck one is left to \
                    end when its step returns. A method switch does the same.";
        if reset.on_hover_text(help).clicked() {
            actions.push(UiAction::Reset);
        }
    }
    if let SimStatus::Diverged(reason) = &snap.status {
        ui.colored_label(ERROR, format!("Diverged: {reason}"));
        let reset = ui.button("Reset after divergence");
        if reset.on_hover_text("Back to the rest state and run again (R)").clicked() {
            actions.push(UiAction::Reset);
        }
    }
    if let Some(p) = &snap.progress {
        ui.add(egui::ProgressBar::new(p.fraction).text(&p.label).show_percentage())
            .on_hover_text("Background work; the simulation keeps running on the previous state meanwhile");
    }
    if let Some(e) = &snap.last_error {
        ui.colored_label(ERROR, e);
    }
}

fn parameters(ui: &mut egui::Ui, state: &mut PanelState, snap: &Snapshot, actions: &mut Vec<UiAction>) {
    ui.heading("Parameters");
    egui::Grid::new("params").num_columns(3).striped(true).show(ui, |ui| {
        for p in &snap.params {
            let spec = p.spec;
            let label = ui.label(spec.label).on_hover_text(format!("{} (`{}`)", spec.help, spec.name));
            let text = state.edits.entry(spec.name).or_insert_with(|| format_value(p.value));
            let field = egui::TextEdit::singleline(text).min_size(egui::vec2(FIELD_WIDTH, 0.0)).id_salt(spec.name);
            let edit = ui
                .add(field.desired_width(FIELD_WIDTH))
                .labelled_by(label.id)
                .on_hover_text(format!("{} - range [{}, {}] {}", spec.help, spec.min, spec.max, spec.unit));
            if edit.lost_focus() {
                // The field shows a rounded value: leaving it untouched must not "set" the rounding.
                let untouched = text.trim() == format_value(p.value);
                match PanelState::accept(&spec, text) {
                    Ok(v) => {
                        state.errors.remove(spec.name);
                        if !untouched && v != p.value {
                            actions.push(UiAction::SetParam(spec.name.to_string(), v));
                        }
                    }
                    Err(e) => {
                        state.errors.insert(spec.name, e);
                    }
                }
            } else if !edit.has_focus() && !state.errors.contains_key(spec.name) {
                *text = format_value(p.value);
            }
            ui.label(spec.unit);
            ui.end_row();
            if let Some(e) = state.errors.get(spec.name) {
                ui.label("");
                ui.colored_label(ERROR, RichText::new(e).small());
                ui.end_row();
            }
        }
    });
}

/// Width of a parameter's text field, in points: room for values like `-9.81` or `1e-9`.
const FIELD_WIDTH: f32 = 80.0;

/// A value with at most six significant digits, so it fits its field.
fn format_value(v: f64) -> String {
    fn trim(digits: &str) -> &str {
        if digits.contains('.') { digits.trim_end_matches('0').trim_end_matches('.') } else { digits }
    }
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        let text = format!("{v:.5e}");
        match text.split_once('e') {
            Some((mantissa, exponent)) => format!("{}e{exponent}", trim(mantissa)),
            None => text,
        }
    } else {
        let decimals = (5 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
        trim(&format!("{v:.decimals$}")).to_string()
    }
}

fn statistics(ui: &mut egui::Ui, state: &PanelState, snap: &Snapshot) {
    ui.heading("Statistics");
    ui.label(format!(
        "step {}   t = {:.3} s   wall {:.3} s   {:.0} fps",
        snap.steps, snap.stats.sim_time, snap.wall_time, state.fps
    ))
    .on_hover_text("Steps since reset, simulated time, wall-clock time spent running, window frame rate");
    ui.label(format!(
        "step time {:.3} ms   energy {:.4e} J   residual {:.2e}   iterations {}",
        snap.stats.wall_seconds * 1e3,
        snap.stats.energy,
        snap.stats.residual,
        snap.stats.iterations
    ));
    if !snap.info.is_empty() {
        let info: Vec<String> = snap.info.iter().map(|(k, v)| format!("{k} {v}")).collect();
        ui.label(info.join("   ")).on_hover_text("What the solver is using right now");
    }
    if let Some(r) = &snap.readout {
        readout(ui, r);
    }
    // Step time and energy have unrelated units and scales: one plot each, each with its own axis.
    history_plot(ui, state, "step_ms", "step time (ms)", 1);
    history_plot(ui, state, "energy", "energy (J)", 2);
}

/// The quality readout: area change, estimated error, and a warning with its remedy past the target.
fn readout(ui: &mut egui::Ui, r: &ReadoutView) {
    let estimate = match (r.estimate, &r.failure) {
        (_, Some(f)) => format!("estimate failed: {f}"),
        (Some(e), None) => format!("estimated error {:.1}%", 100.0 * e),
        (None, None) => "estimated error …".into(),
    };
    ui.label(format!("area change {:+.2}%   {estimate}", 100.0 * r.area_change)).on_hover_text(
        "Area change against rest, and the distance three Newton iterations of the full discrete shell \
         (drags pinned) move the shape, relative to its displacement: an estimate of the error, recomputed \
         in the background",
    );
    if let Some(w) = r.warning() {
        ui.colored_label(ui.visuals().warn_fg_color, w);
    }
}

/// One column of the history against simulated time, under its own title and y axis.
fn history_plot(ui: &mut egui::Ui, state: &PanelState, id: &str, title: &str, column: usize) {
    let points: Vec<[f64; 2]> = state.history.iter().map(|h| [h[0], h[column]]).collect();
    ui.label(RichText::new(format!("{title} over simulated time (s)")).small())
        .on_hover_text("The last 600 steps; drag or scroll to pan, Ctrl+scroll to zoom, double-click to fit");
    Plot::new(id).height(70.0).show(ui, |plot| {
        plot.line(Line::new(title, points));
    });
}

fn drags(ui: &mut egui::Ui, state: &PanelState, snap: &Snapshot, actions: &mut Vec<UiAction>) {
    ui.heading("Constraints");
    if snap.drags.is_empty() {
        let how = match state.drag_mode {
            DragMode::Position => "Left-drag the surface to pull a vertex; it stays pinned when released.",
            DragMode::Orientation => "Left-drag the surface to twist a vertex; it stays twisted when released.",
        };
        ui.label(how);
    } else if ui.small_button("Remove all").on_hover_text("Remove every constraint (C)").clicked() {
        actions.push(UiAction::ClearDrags);
    }
    for (id, d) in &snap.drags {
        ui.horizontal(|ui| {
            let what = match d.kind {
                DragKind::Position(p) => format!("vertex {} -> ({:.3}, {:.3}, {:.3})", d.vertex, p.x, p.y, p.z),
                DragKind::Orientation(w) => format!("vertex {} rotated {:.1} deg", d.vertex, w.length().to_degrees()),
            };
            ui.label(what);
            if ui.small_button("Remove").on_hover_text("Remove this constraint").clicked() {
                actions.push(UiAction::RemoveDrag(*id));
            }
        });
    }
}

impl UiAction {
    /// The simulation-thread command this action is, for actions that are one (the viewer handles
    /// scene and method switches, screenshots and nothing-to-send actions itself).
    pub fn command(&self) -> Option<super::sim_thread::Command> {
        use super::sim_thread::Command;
        Some(match self {
            UiAction::SetParam(name, value) => Command::SetParam(name.clone(), *value),
            UiAction::SetPaused(p) => Command::SetPaused(*p),
            UiAction::StepOnce => Command::StepOnce,
            UiAction::Reset => Command::Reset,
            UiAction::SetPacing(p) => Command::SetPacing(*p),
            UiAction::RemoveDrag(id) => Command::RemoveDrag(*id),
            UiAction::ClearDrags => Command::ClearDrags,
            UiAction::SetGhost(None) => Command::SetGhost(None),
            UiAction::SwitchScene(_)
            | UiAction::SwitchMethod(_)
            | UiAction::SetGhost(Some(_))
            | UiAction::Screenshot => {
                return None;
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::format_value;

    #[test]
    fn values_are_shown_short_and_whole() {
        let cases = [
            (1000.0, "1000"),
            (-9.81, "-9.81"),
            (1.0 / 30.0, "0.0333333"),
            (0.0, "0"),
            (2.0, "2"),
            (1e-9, "1e-9"),
            (2.5e6, "2.5e6"),
            (256.0, "256"),
        ];
        for (v, want) in cases {
            assert_eq!(format_value(v), want, "{v}");
        }
    }
}
