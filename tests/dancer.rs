//! The dancer (the modal-warping paper's Fig. 8): a keyframed skeleton carries four MWTS shells
//! (hat, tunic, two trouser legs), each a part with its own modes, held at the joints by tracks. Over
//! a minute of dancing nothing diverges and every part stays attached; the parts swing on their own
//! (their deviation from the joints' rigid motion), and the swing dies out once the skeleton stops.

use glam::DVec3;
use shellwarp::scene::{self, Setup};
use shellwarp::solver::script::Rig;
use shellwarp::solver::{self, Solver};

/// Per track: its joint's motion since time 0 applied to `x0` (rotation about the joint's origin plus
/// its translation), over the track's whole part.
struct Carried {
    joint: usize,
    part: Vec<usize>,
    held: Vec<usize>,
}

fn carried(setup: &Setup, rig: &Rig) -> Vec<Carried> {
    let (component, _) = setup.mesh.components();
    setup
        .scene
        .tracks
        .iter()
        .zip(&setup.tracks)
        .map(|(t, held)| Carried {
            joint: rig.index(t.joint.as_deref().unwrap()).unwrap(),
            part: (0..setup.mesh.vertex_count()).filter(|&v| component[v] == component[held[0]]).collect(),
            held: held.clone(),
        })
        .collect()
}

/// `x0` carried rigidly by joint `j` from time 0 to `t`.
fn rigidly(rig: &Rig, j: usize, t: f64, x0: DVec3) -> DVec3 {
    let (now, start) = (rig.frames(t)[j], rig.frames(0.0)[j]);
    now.1 + now.0 * start.0.inverse() * (x0 - start.1)
}

/// Largest distance of a held vertex from its target, m.
fn attachment_error(rig: &Rig, parts: &[Carried], rest: &[DVec3], x: &[DVec3], t: f64) -> f64 {
    parts
        .iter()
        .flat_map(|p| p.held.iter().map(move |&v| (x[v] - rigidly(rig, p.joint, t, rest[v])).length()))
        .fold(0.0, f64::max)
}

/// Root-mean-square deviation of every part from its equilibrium shape carried rigidly by its joint, m.
fn swing(rig: &Rig, parts: &[Carried], equilibrium: &[DVec3], x: &[DVec3], t: f64) -> f64 {
    let (sum, count) = parts.iter().fold((0.0, 0), |(s, c), p| {
        let d: f64 = p.part.iter().map(|&v| (x[v] - rigidly(rig, p.joint, t, equilibrium[v])).length_squared()).sum();
        (s + d, c + p.part.len())
    });
    (sum / count as f64).sqrt()
}

fn step_to(s: &mut dyn Solver, t: f64, time: &mut f64, each: &mut dyn FnMut(&[DVec3], f64)) {
    while *time < t - 1e-9 {
        *time = s.step().unwrap_or_else(|e| panic!("t = {time}: {e}")).sim_time;
        each(s.positions(), *time);
    }
}

#[test]
fn a_minute_of_dancing_keeps_every_part_attached_and_finite() {
    let setup = scene::load("dancer", &[]).unwrap();
    let rig = Rig::new(&setup.scene.skeleton);
    let parts = carried(&setup, &rig);
    assert_eq!(parts.len(), 4, "hat, tunic, two legs");
    let mut s = solver::build(&setup).unwrap();
    let rest = setup.mesh.positions().to_vec();
    let (mut time, mut worst) = (0.0, 0.0f64);
    step_to(s.as_mut(), 60.0, &mut time, &mut |x, t| {
        assert!(x.iter().all(|p| p.is_finite()), "t = {t}: NaN");
        worst = worst.max(attachment_error(&rig, &parts, &rest, x, t));
    });
    eprintln!("60 s: worst attachment error {:.2} mm", 1e3 * worst);
    // The drags are soft (compliance 1e-4 of the reduced system's scale): a held ring stays within 1 cm.
    assert!(worst < 0.01, "a part came loose by {:.1} mm", 1e3 * worst);
}

#[test]
fn the_parts_swing_while_the_skeleton_moves_and_settle_after_it_stops() {
    // One pass of the 4 s dance (not looped); the pose at its end is the pose at its start.
    let setup = scene::load("dancer", &["skeleton.loop=false".into()]).unwrap();
    let rig = Rig::new(&setup.scene.skeleton);
    let parts = carried(&setup, &rig);
    // The equilibrium under gravity with the skeleton still (every joint key removed).
    let mut still = setup.clone();
    still.scene.skeleton.joints.iter_mut().for_each(|j| j.keys.clear());
    let mut s = solver::build(&still).unwrap();
    let mut time = 0.0;
    step_to(s.as_mut(), 8.0, &mut time, &mut |_, _| {});
    let equilibrium = s.positions().to_vec();

    let mut s = solver::build(&setup).unwrap();
    let (mut time, mut during) = (0.0, 0.0f64);
    // The dance starts from the unloaded rest shape: its swing is counted once the dance has begun.
    step_to(s.as_mut(), 4.0, &mut time, &mut |x, t| {
        if t > 0.5 {
            during = during.max(swing(&rig, &parts, &equilibrium, x, t));
        }
    });
    let at_stop = swing(&rig, &parts, &equilibrium, s.positions(), time);
    step_to(s.as_mut(), 7.0, &mut time, &mut |_, _| {});
    let after = swing(&rig, &parts, &equilibrium, s.positions(), time);
    eprintln!(
        "swing: up to {:.1} mm while dancing, {:.2} mm as it stops, {:.3} mm 3 s later",
        1e3 * during,
        1e3 * at_stop,
        1e3 * after
    );
    assert!(during > 0.01, "the parts barely swing ({:.2} mm)", 1e3 * during);
    assert!(after * 10.0 <= at_stop, "the swing did not die out: {at_stop:.2e} → {after:.2e} m in 3 s");
}
