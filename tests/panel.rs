//! The egui panel, driven with egui_kittest: typed parameter values reach the solver through the
//! same command channel the viewer uses (a new mode count is computed in the background, reported,
//! then used), invalid values are refused with a message, and every control explains itself on hover.

use std::time::{Duration, Instant};

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use glam::DVec3;
use shellwarp::app::panel::{self, PanelState, UiAction};
use shellwarp::app::sim_thread::{Command, Pacing, SimHandle, SimStatus, Snapshot};
use shellwarp::solver::{Drag, DragId, DragKind, Progress};

struct Ui {
    panel: PanelState,
    snapshot: Snapshot,
    actions: Vec<UiAction>,
}

fn harness(scene: &str) -> (Harness<'static, Ui>, SimHandle) {
    let setup = shellwarp::scene::load(scene, &[]).unwrap();
    let solver = shellwarp::solver::build(&setup).unwrap();
    let mut sim = SimHandle::spawn(solver, true, Pacing::Scaled(1.0));
    let ui = Ui {
        panel: PanelState::new(vec![scene.into()], vec!["mwts".into(), "lma".into()], scene.into()),
        snapshot: sim.latest().clone(),
        actions: Vec::new(),
    };
    let h = Harness::builder().with_size(egui::vec2(panel::DEFAULT_WIDTH, 1000.0)).build_ui_state(
        |ui, s: &mut Ui| {
            let a = panel::show(ui, &mut s.panel, &s.snapshot);
            s.actions.extend(a);
        },
        ui,
    );
    (h, sim)
}

/// Send the panel's actions to the sim thread and wait until a snapshot satisfies `done`.
fn deliver(h: &mut Harness<'static, Ui>, sim: &mut SimHandle, done: impl Fn(&Snapshot) -> bool) -> bool {
    for a in h.state_mut().actions.drain(..) {
        if let Some(c) = a.command() {
            sim.send(c);
        }
    }
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(10) {
        let snap = sim.latest().clone();
        let ok = done(&snap);
        h.state_mut().snapshot = snap;
        if ok {
            h.run();
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    false
}

fn type_into(h: &mut Harness<'static, Ui>, label: &str, text: &str) {
    let field = h.get_by_role_and_label(Role::TextInput, label);
    field.focus();
    h.run();
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
    h.run();
    let field = h.get_by_role_and_label(Role::TextInput, label);
    field.type_text(text);
    h.run();
    h.key_press(egui::Key::Enter);
    h.run();
}

fn value(s: &Snapshot, name: &str) -> Option<f64> {
    s.params.iter().find(|p| p.spec.name == name).map(|p| p.value)
}

fn active_modes(s: &Snapshot) -> Option<f64> {
    s.info.iter().find(|(k, _)| *k == "active modes").map(|(_, v)| *v)
}

#[test]
fn bending_stiffness_and_mode_count_typed_in_the_panel_reach_the_solver() {
    let (mut h, mut sim) = harness("cantilever");
    h.run();
    assert_eq!(h.state().snapshot.method, "mwts");
    assert_eq!(active_modes(&h.state().snapshot), Some(8.0));
    type_into(&mut h, "bending stiffness k_B", "0.25");
    assert!(h.state().actions.contains(&UiAction::SetParam("k_bend".into(), 0.25)), "{:?}", h.state().actions);
    assert!(deliver(&mut h, &mut sim, |s| value(s, "k_bend") == Some(0.25)), "k_B never reached the solver");
    type_into(&mut h, "modes", "12");
    assert!(h.state().actions.contains(&UiAction::SetParam("modes".into(), 12.0)), "{:?}", h.state().actions);
    // The new basis is computed in the background: reported as progress while the old one stays in use...
    let computing = |s: &Snapshot| {
        value(s, "modes") == Some(12.0)
            && s.progress.as_ref().is_some_and(|p| p.label.contains("12 modes"))
            && active_modes(s) == Some(8.0)
    };
    assert!(deliver(&mut h, &mut sim, computing), "no progress reported for the new mode count");
    h.get_by_label_contains("active modes 8");
    // ...then it becomes the active one (the simulation is paused: background work still completes).
    let done = |s: &Snapshot| active_modes(s) == Some(12.0) && s.progress.is_none();
    assert!(deliver(&mut h, &mut sim, done), "the 12-mode basis never became active");
    h.get_by_label_contains("active modes 12");
    // And the simulation steps with it.
    sim.send(Command::StepOnce);
    assert!(deliver(&mut h, &mut sim, |s| s.steps == 1 && active_modes(s) == Some(12.0)), "no step on the new basis");
}

/// Every control of the panel, in every state it can show, describes itself on hover (egui exposes
/// hover text as the accessible description).
#[test]
fn every_control_has_hover_text() {
    let (mut h, _sim) = harness("cantilever");
    let state = h.state_mut();
    state.snapshot.status = SimStatus::Diverged("test".into());
    state.snapshot.progress = Some(Progress { label: "computing".into(), fraction: 0.5 });
    state.snapshot.drags = vec![(DragId(1), Drag { vertex: 3, kind: DragKind::Position(DVec3::ZERO) })];
    state.panel.loading = Some("loading".into());
    state.panel.message = Some("message".into());
    h.run_steps(4); // the spinner keeps repainting
    let roles = [Role::Button, Role::ComboBox, Role::RadioButton, Role::CheckBox, Role::TextInput];
    let mut seen = 0;
    for role in roles.into_iter().chain([Role::ProgressIndicator]) {
        for node in h.query_all_by_role(role) {
            let ak = node.accesskit_node();
            let name = ak.label().or(ak.value()).unwrap_or_default();
            assert!(ak.description().is_some_and(|d| !d.is_empty()), "{role:?} `{name}` has no hover text");
            seen += 1;
        }
    }
    // Play, Step, Reset, Screenshot, Reset after divergence, Dismiss, Remove all, Remove; two combos;
    // five radios; a checkbox; fourteen parameter fields; a progress bar and a spinner.
    assert!(seen >= 28, "only {seen} controls found");
}

#[test]
fn invalid_value_is_refused_with_a_message() {
    let (mut h, _sim) = harness("cantilever");
    h.run();
    type_into(&mut h, "bending stiffness k_B", "-3");
    assert!(h.state().actions.iter().all(|a| !matches!(a, UiAction::SetParam(..))), "nothing sent");
    let err = h.state().panel.error("k_bend").expect("an error is recorded").to_string();
    assert!(err.contains("outside the allowed range"), "{err}");
    h.get_by_label_contains("outside the allowed range");
    type_into(&mut h, "modes", "2.5");
    assert!(h.state().panel.error("modes").is_some_and(|e| e.contains("whole number")));
    type_into(&mut h, "bending stiffness k_B", "abc");
    assert!(h.state().panel.error("k_bend").is_some_and(|e| e.contains("not a number")));
}

#[test]
fn parameter_fields_are_wide_enough_for_their_values() {
    let (mut h, _sim) = harness("cantilever");
    h.run();
    let fields: Vec<_> = h.query_all_by_role(Role::TextInput).collect();
    // MWTS's ten and the wind's four.
    assert_eq!(fields.len(), 14);
    for field in fields {
        let ak = field.accesskit_node();
        // "-9.81" or "1000" need about 40 points in the default font, plus the frame's margins.
        assert!(field.rect().width() >= 70.0, "`{:?}` is {} points wide", ak.label(), field.rect().width());
    }
}

#[test]
fn the_ghost_switch_asks_for_a_ghost_and_shows_its_error() {
    let (mut h, _sim) = harness("cantilever");
    h.run();
    h.get_by_label("Ghost").click();
    h.run();
    h.get_by_role_and_label(Role::Button, "lma").click();
    h.run();
    assert!(h.state().actions.contains(&UiAction::SetGhost(Some("lma".into()))), "{:?}", h.state().actions);
    // Once a ghost runs, its live error is shown, and choosing `none` stops it.
    let view = shellwarp::app::ghost::GhostView { method: "lma", positions: Vec::new(), error: 0.0375, message: None };
    h.state_mut().snapshot.ghost = Some(view);
    h.state_mut().actions.clear();
    h.run();
    h.get_by_label_contains("error vs ghost lma: 3.75%");
    h.get_by_label("Ghost").click();
    h.run();
    h.get_by_role_and_label(Role::Button, "none").click();
    h.run();
    assert!(h.state().actions.contains(&UiAction::SetGhost(None)), "{:?}", h.state().actions);
    assert!(matches!(UiAction::SetGhost(None).command(), Some(Command::SetGhost(None))));
}
