//! A scene of parts runs each part as if it were a scene of its own: two copies of the clamped strip,
//! one by `lma` at 1/30 s and one by `mwts` at 1/60 s, give what each method gives on one strip;
//! drags reach the part that owns their vertex; parts that share a component are refused by name.

use glam::DVec3;
use shellwarp::scene::{self, SceneError};
use shellwarp::solver::{self, Drag, DragKind};

const TWO: [&str; 2] = ["placement.copies=2", "placement.copy_offset=[0, 0, 0.5]"];

fn parts_overrides() -> Vec<String> {
    let mut o: Vec<String> = TWO.iter().map(|s| s.to_string()).collect();
    o.push(
        "parts=[{ select = { box = { min = [-1, -1, -0.1], max = [1, 1, 0.1] } }, method = \"lma\" }, \
         { select = { box = { min = [-1, -1, 0.4], max = [1, 1, 0.6] } }, method = \"mwts\", step = 0.0166666666666667 }]"
            .into(),
    );
    o
}

#[test]
fn each_part_moves_as_its_method_does_on_its_own() {
    let setup = scene::load("cantilever", &parts_overrides()).unwrap();
    let n = 205;
    assert_eq!(setup.mesh.vertex_count(), 2 * n);
    assert_eq!(setup.parts, vec![(0..n).collect::<Vec<_>>(), (n..2 * n).collect()]);
    let mut all = solver::build(&setup).unwrap();
    // A drag on the second copy's tip goes to the mwts part, renumbered.
    let target = setup.mesh.positions()[2 * n - 3] + DVec3::new(0.0, 0.1, 0.0);
    all.drags_mut().add(Drag { vertex: 2 * n - 3, kind: DragKind::Position(target) }).unwrap();
    for _ in 0..30 {
        all.step().unwrap();
    }
    let single = |method: &str, step: &str| {
        let mut s = solver::build(
            &scene::load("cantilever", &[format!("solver.method={method}"), format!("solver.step={step}")]).unwrap(),
        )
        .unwrap();
        if method == "mwts" {
            let t = target - DVec3::new(0.0, 0.0, 0.5);
            s.drags_mut().add(Drag { vertex: n - 3, kind: DragKind::Position(t) }).unwrap();
        }
        let steps = if method == "mwts" { 60 } else { 30 };
        (0..steps).for_each(|_| {
            s.step().unwrap();
        });
        s.positions().to_vec()
    };
    let (lma, mwts) = (single("lma", "0.0333333333333333"), single("mwts", "0.0166666666666667"));
    let x = all.positions();
    let shift = DVec3::new(0.0, 0.0, 0.5);
    let worst_lma = (0..n).map(|v| (x[v] - lma[v]).length()).fold(0.0, f64::max);
    let worst_mwts = (0..n).map(|v| (x[n + v] - shift - mwts[v]).length()).fold(0.0, f64::max);
    assert!(
        worst_lma < 1e-9 && worst_mwts < 1e-6,
        "lma part off by {worst_lma:.2e} m, mwts part by {worst_mwts:.2e} m"
    );
    assert!((x[2 * n - 3] - target).length() < 0.01, "the drag reached the mwts part");
    assert!(all.notes().iter().any(|n| n.contains("part 1: mwts")), "{:?}", all.notes());
}

#[test]
fn parts_that_share_a_component_are_refused_by_name() {
    let mut o: Vec<String> = TWO.iter().map(|s| s.to_string()).collect();
    o.push("parts=[{ select = { indices = [0] } }, { select = { indices = [5] } }]".into());
    match scene::load("cantilever", &o) {
        Err(SceneError::Invalid { key, reason, .. }) => {
            assert_eq!(key, "parts[1].select");
            assert!(reason.contains("parts[0]"), "{reason}");
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
}
