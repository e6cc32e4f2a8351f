//! The egui panel, driven with egui_kittest: typed parameter values reach the solver through the
//! same command channel the viewer uses, and invalid values are refused with a message.

use std::time::{Duration, Instant};

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use shellwarp::app::panel::{self, PanelState, UiAction};
use shellwarp::app::sim_thread::{Pacing, SimHandle, Snapshot};

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
        panel: PanelState::new(vec![scene.into()], vec!["rigid".into()], scene.into()),
        snapshot: sim.latest().clone(),
        actions: Vec::new(),
    };
    let h = Harness::builder().with_size(egui::vec2(420.0, 900.0)).build_ui_state(
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

#[test]
fn typed_parameter_reaches_the_solver() {
    let (mut h, mut sim) = harness("cantilever");
    h.run();
    type_into(&mut h, "time step", "0.01");
    assert!(h.state().actions.contains(&UiAction::SetParam("step".into(), 0.01)), "actions: {:?}", h.state().actions);
    let reached = deliver(&mut h, &mut sim, |s| s.params.iter().any(|p| p.spec.name == "step" && p.value == 0.01));
    assert!(reached, "the solver's parameter never changed");
}

#[test]
fn invalid_value_is_refused_with_a_message() {
    let (mut h, _sim) = harness("cantilever");
    h.run();
    type_into(&mut h, "time step", "-3");
    assert!(h.state().actions.iter().all(|a| !matches!(a, UiAction::SetParam(..))), "nothing sent");
    let err = h.state().panel.error("step").expect("an error is recorded").to_string();
    assert!(err.contains("outside the allowed range"), "{err}");
    h.get_by_label_contains("outside the allowed range");
    type_into(&mut h, "time step", "abc");
    assert!(h.state().panel.error("step").is_some_and(|e| e.contains("not a number")));
}
