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
        panel: PanelState::new(vec![scene.into()], vec!["mwts".into(), "lma".into()], scene.into()),
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

fn value(s: &Snapshot, name: &str) -> Option<f64> {
    s.params.iter().find(|p| p.spec.name == name).map(|p| p.value)
}

#[test]
fn bending_stiffness_and_mode_count_typed_in_the_panel_reach_the_solver() {
    let (mut h, mut sim) = harness("cantilever");
    h.run();
    assert_eq!(h.state().snapshot.method, "mwts");
    type_into(&mut h, "k_B (bending)", "0.25");
    assert!(h.state().actions.contains(&UiAction::SetParam("k_bend".into(), 0.25)), "{:?}", h.state().actions);
    assert!(deliver(&mut h, &mut sim, |s| value(s, "k_bend") == Some(0.25)), "k_B never reached the solver");
    type_into(&mut h, "modes", "12");
    assert!(h.state().actions.contains(&UiAction::SetParam("modes".into(), 12.0)), "{:?}", h.state().actions);
    // The modes are recomputed in the background; the solver reports the new count at once.
    assert!(deliver(&mut h, &mut sim, |s| value(s, "modes") == Some(12.0)), "the mode count never reached the solver");
}

#[test]
fn invalid_value_is_refused_with_a_message() {
    let (mut h, _sim) = harness("cantilever");
    h.run();
    type_into(&mut h, "k_B (bending)", "-3");
    assert!(h.state().actions.iter().all(|a| !matches!(a, UiAction::SetParam(..))), "nothing sent");
    let err = h.state().panel.error("k_bend").expect("an error is recorded").to_string();
    assert!(err.contains("outside the allowed range"), "{err}");
    h.get_by_label_contains("outside the allowed range");
    type_into(&mut h, "modes", "2.5");
    assert!(h.state().panel.error("modes").is_some_and(|e| e.contains("whole number")));
    type_into(&mut h, "k_B (bending)", "abc");
    assert!(h.state().panel.error("k_bend").is_some_and(|e| e.contains("not a number")));
}
