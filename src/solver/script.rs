//! Scripted constraints: a scene's tracks (and the skeleton they may follow) drive the same drag
//! constraints the mouse makes, through [`DragSet`], so every method that takes drags takes tracks.
//!
//! A track moves its vertices as one rigid frame: at time `t` the frame has rotation `R = exp([w]×)`
//! about the pivot `c` and translation `d`, and vertex `i` is asked to be at `c + d + R (X_i − c)`.
//!
//! - Keys interpolate linearly, translations and **rotation vectors alike**: the rotation is the
//!   vector written, so keys `0` and `2π x̂` turn a full turn and `3π/2 x̂` turns +270°, never the
//!   shorter way back. A looping track starts over after its last key.
//! - A track with positions (or following a joint) drives a position drag on every vertex.
//! - A track with rotations drives one [`FrameDrag`] on its whole selection (the selection turns as a
//!   whole; one orientation per vertex would over-determine a row that only has to turn as a whole)
//!   where the method has orientation drags, and otherwise position drags on every vertex at its
//!   place in the turned frame: the discrete shells follow the same twist as the modal methods.
//!
//! A joint-following track uses the joint's world frame relative to its frame at time 0 (the pose
//! the mesh was modelled in): `F(t) F(0)⁻¹`, whose rotation vector is chosen continuous in time
//! (`θ` grows past π instead of flipping to `−(2π − θ)`).

use glam::{DQuat, DVec3};

use super::{Drag, DragId, DragKind, FrameDrag, Solver, SolverError, StepStats};
use crate::scene::{Key, Setup, Skeleton};

/// Interpolate keys at `t` (clamped to the keys' span, or wrapped when `looping`): the translation
/// and the rotation vector the keys give (`None` where they give none), both linearly.
pub fn sample(keys: &[Key], t: f64, looping: bool) -> (Option<DVec3>, Option<DVec3>) {
    let (Some(first), Some(last)) = (keys.first(), keys.last()) else { return (None, None) };
    let span = last.time - first.time;
    let t = if looping && span > 0.0 && t > last.time { first.time + (t - first.time).rem_euclid(span) } else { t };
    let i = keys.partition_point(|k| k.time <= t);
    let (a, b, s) = match i {
        0 => (first, first, 0.0),
        i if i >= keys.len() => (last, last, 0.0),
        i => {
            let (a, b) = (&keys[i - 1], &keys[i]);
            (a, b, (t - a.time) / (b.time - a.time))
        }
    };
    let lerp = |p: [f64; 3], q: [f64; 3]| DVec3::from(p).lerp(DVec3::from(q), s);
    (a.position.zip(b.position).map(|(p, q)| lerp(p, q)), a.rotation.zip(b.rotation).map(|(p, q)| lerp(p, q)))
}

/// The rotation vector of `q` closest to `previous` among its equivalents `â (θ + 2πk)`, so that a
/// sequence of targets turns continuously through and past π.
pub fn unwrap_rotation(q: DQuat, previous: DVec3) -> DVec3 {
    let w = q.to_scaled_axis();
    let angle = w.length();
    let axis = if angle > 1e-12 {
        w / angle
    } else if previous.length() > 1e-12 {
        previous.normalize()
    } else {
        DVec3::X
    };
    (-3..=3)
        .map(|k| axis * (angle + std::f64::consts::TAU * f64::from(k)))
        .min_by(|a, b| (*a - previous).length_squared().total_cmp(&(*b - previous).length_squared()))
        .unwrap_or(w)
}

/// A skeleton ready for forward kinematics.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    joints: Vec<(Option<usize>, DVec3, Vec<Key>)>,
    names: Vec<String>,
    looping: bool,
}

impl Rig {
    /// From a validated skeleton (parents come before their children).
    pub fn new(skeleton: &Skeleton) -> Self {
        let names: Vec<String> = skeleton.joints.iter().map(|j| j.name.clone()).collect();
        let joints = skeleton
            .joints
            .iter()
            .map(|j| {
                let parent = j.parent.as_ref().and_then(|p| names.iter().position(|n| n == p));
                (parent, DVec3::from(j.offset), j.keys.clone())
            })
            .collect();
        Self { joints, names, looping: skeleton.looping }
    }

    /// Index of a joint by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Whether there are no joints.
    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    /// World frame (rotation, origin) of every joint at time `t`.
    pub fn frames(&self, t: f64) -> Vec<(DQuat, DVec3)> {
        let mut frames: Vec<(DQuat, DVec3)> = Vec::with_capacity(self.joints.len());
        for (parent, offset, keys) in &self.joints {
            let own = sample(keys, t, self.looping).1.map_or(DQuat::IDENTITY, DQuat::from_scaled_axis);
            let frame = match parent {
                Some(p) => {
                    let (r, o) = frames[*p];
                    (r * own, o + r * *offset)
                }
                None => (own, *offset),
            };
            frames.push(frame);
        }
        frames
    }

    /// Bone segments (parent origin, child origin) at time `t`, for drawing.
    pub fn bones(&self, t: f64) -> Vec<(DVec3, DVec3)> {
        let frames = self.frames(t);
        self.joints.iter().enumerate().filter_map(|(i, (p, _, _))| p.map(|p| (frames[p].1, frames[i].1))).collect()
    }
}

/// Where a track's frame comes from.
#[derive(Debug, Clone)]
enum Source {
    Keys(Vec<Key>),
    Joint(usize),
}

/// A track resolved against its mesh, with the handles of the drags it drives.
#[derive(Debug, Clone)]
struct Driven {
    vertices: Vec<usize>,
    pivot: DVec3,
    source: Source,
    looping: bool,
    positions: bool,
    rotations: bool,
    position_drags: Vec<DragId>,
    frame_drag: Option<DragId>,
    /// The last rotation target of a joint-following track, for continuity.
    previous: DVec3,
}

/// The scene's tracks and skeleton, driving a solver's drags.
#[derive(Debug, Clone)]
pub struct Script {
    rest: Vec<DVec3>,
    rig: Rig,
    tracks: Vec<Driven>,
}

impl Script {
    /// Resolve the scene's tracks (none: an empty script).
    pub fn new(setup: &Setup) -> Self {
        let rest = setup.mesh.positions().to_vec();
        let rig = Rig::new(&setup.scene.skeleton);
        let tracks = setup
            .scene
            .tracks
            .iter()
            .zip(&setup.tracks)
            .map(|(t, vertices)| {
                let centroid = vertices.iter().map(|&v| rest[v]).sum::<DVec3>() / vertices.len().max(1) as f64;
                let source = match t.joint.as_deref().and_then(|j| rig.index(j)) {
                    Some(j) => Source::Joint(j),
                    None => Source::Keys(t.keys.clone()),
                };
                let (positions, rotations) = match &source {
                    Source::Joint(_) => (true, true),
                    Source::Keys(k) => (
                        k.first().is_some_and(|k| k.position.is_some()),
                        k.first().is_some_and(|k| k.rotation.is_some()),
                    ),
                };
                Driven {
                    vertices: vertices.clone(),
                    pivot: t.pivot.map_or(centroid, DVec3::from),
                    source,
                    looping: t.looping,
                    positions,
                    rotations,
                    position_drags: Vec::new(),
                    frame_drag: None,
                    previous: DVec3::ZERO,
                }
            })
            .collect();
        Self { rest, rig, tracks }
    }

    /// Whether there is nothing to drive.
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    /// The skeleton.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// Track `k`'s frame at `t`: (pivot, translation, rotation vector).
    fn frame(&mut self, k: usize, t: f64) -> (DVec3, DVec3, DVec3) {
        let track = &self.tracks[k];
        match &track.source {
            Source::Keys(keys) => {
                let (d, w) = sample(keys, t, track.looping);
                (track.pivot, d.unwrap_or(DVec3::ZERO), w.unwrap_or(DVec3::ZERO))
            }
            Source::Joint(j) => {
                let (now, start) = (self.rig.frames(t)[*j], self.rig.frames(0.0)[*j]);
                let w = unwrap_rotation(now.0 * start.0.inverse(), track.previous);
                self.tracks[k].previous = w;
                (start.1, now.1 - start.1, w)
            }
        }
    }

    /// The targets of every track at `t`: per track, the place of each vertex in the track's frame
    /// and the frame's rotation vector (if the track has rotations).
    pub fn targets(&mut self, t: f64) -> Vec<(Vec<DVec3>, Option<DVec3>)> {
        (0..self.tracks.len())
            .map(|k| {
                let (c, d, w) = self.frame(k, t);
                let (track, r) = (&self.tracks[k], DQuat::from_scaled_axis(w));
                let positions = track.vertices.iter().map(|&v| c + d + r * (self.rest[v] - c)).collect();
                (positions, track.rotations.then_some(w))
            })
            .collect()
    }

    /// Set the drags of every track to its targets at `t`, adding them the first time (or again if
    /// they were removed, e.g. by the user): position drags where the track has positions, one frame
    /// drag for its rotation where the method has orientation drags, else position drags in the
    /// turned frame.
    pub fn drive(&mut self, solver: &mut dyn Solver, t: f64) -> Result<(), SolverError> {
        let targets = self.targets(t);
        let method = solver.method();
        for (k, (positions, rotation)) in targets.into_iter().enumerate() {
            let track = &mut self.tracks[k];
            let named = |e: SolverError| match e {
                SolverError::BadDrag(reason) => {
                    SolverError::BadDrag(format!("tracks[{k}]: {reason} (method `{method}`)"))
                }
                e => e,
            };
            let drags = solver.drags_mut();
            let framed = rotation.is_some() && drags.supports_orientation();
            if track.positions || (rotation.is_some() && !framed) {
                for (i, (&v, &p)) in track.vertices.iter().zip(&positions).enumerate() {
                    set(drags, &mut track.position_drags, i, Drag { vertex: v, kind: DragKind::Position(p) })
                        .map_err(named)?;
                }
            }
            if let (Some(w), true) = (rotation, framed) {
                let retargeted = track.frame_drag.is_some_and(|id| drags.retarget_frame(id, w).is_ok());
                if !retargeted {
                    let frame = FrameDrag { vertices: track.vertices.clone(), rotation: w };
                    track.frame_drag = Some(drags.add_frame(frame).map_err(named)?);
                }
            }
        }
        Ok(())
    }

    /// Forget the rotation history (after a reset the targets start again from time 0).
    pub fn rewind(&mut self) {
        self.tracks.iter_mut().for_each(|t| t.previous = DVec3::ZERO);
    }
}

/// Retarget drag `i` of `ids`, or add it (again) if it does not exist.
fn set(drags: &mut super::DragSet, ids: &mut Vec<DragId>, i: usize, drag: Drag) -> Result<(), SolverError> {
    if let Some(&id) = ids.get(i)
        && drags.retarget(id, drag.kind).is_ok()
    {
        return Ok(());
    }
    let id = drags.add(drag)?;
    if i < ids.len() {
        ids[i] = id;
    } else {
        ids.push(id);
    }
    Ok(())
}

/// A solver driven by a script (before each step the tracks' drags are set to their targets at the
/// end of the step), with notes on how it was chosen ([`super::auto`]) ahead of its own.
pub struct Scripted {
    inner: Box<dyn Solver>,
    script: Script,
    time: f64,
    why: Vec<String>,
}

/// `inner` driven by `setup`'s tracks, with `why` it was chosen to tell the user; `inner` itself when
/// there is neither.
pub fn drive(inner: Box<dyn Solver>, setup: &Setup, why: Vec<String>) -> Result<Box<dyn Solver>, SolverError> {
    let script = Script::new(setup);
    if script.is_empty() && why.is_empty() {
        return Ok(inner);
    }
    Ok(Box::new(Scripted::new(inner, script, why)?))
}

impl Scripted {
    /// Wrap `inner`, placing the drags at their time-0 targets (fails if the method refuses a track).
    pub fn new(mut inner: Box<dyn Solver>, mut script: Script, why: Vec<String>) -> Result<Self, SolverError> {
        script.drive(inner.as_mut(), 0.0)?;
        Ok(Self { inner, script, time: 0.0, why })
    }
}

impl Solver for Scripted {
    fn method(&self) -> &'static str {
        self.inner.method()
    }
    fn time_step(&self) -> f64 {
        self.inner.time_step()
    }
    fn step(&mut self) -> Result<StepStats, SolverError> {
        let h = self.inner.time_step();
        self.script.drive(self.inner.as_mut(), self.time + h)?;
        let stats = self.inner.step()?;
        self.time = stats.sim_time;
        Ok(stats)
    }
    fn positions(&self) -> &[DVec3] {
        self.inner.positions()
    }
    fn reset(&mut self) {
        self.inner.reset();
        self.time = 0.0;
        self.script.rewind();
        // The drags were accepted before, so they are again.
        let _ = self.script.drive(self.inner.as_mut(), 0.0);
    }
    fn params(&self) -> Vec<super::ParamValue> {
        self.inner.params()
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        self.inner.set_param(name, value)
    }
    fn drags(&self) -> &super::DragSet {
        self.inner.drags()
    }
    fn drags_mut(&mut self) -> &mut super::DragSet {
        self.inner.drags_mut()
    }
    fn progress(&self) -> Option<super::Progress> {
        self.inner.progress()
    }
    fn poll(&mut self) -> Result<(), SolverError> {
        self.inner.poll()
    }
    fn expect_drags(&mut self) {
        self.inner.expect_drags();
    }
    fn info(&self) -> Vec<(&'static str, f64)> {
        self.inner.info()
    }
    fn body_poses(&self) -> Vec<(DVec3, DQuat)> {
        self.inner.body_poses()
    }
    fn notes(&self) -> Vec<String> {
        self.why.iter().cloned().chain(self.inner.notes()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: f64, position: Option<[f64; 3]>, rotation: Option<[f64; 3]>) -> Key {
        Key { time, position, rotation }
    }

    #[test]
    fn keys_interpolate_linearly_clamp_and_loop() {
        let keys = [key(0.0, Some([0.0; 3]), Some([0.0; 3])), key(2.0, Some([2.0, 0.0, 0.0]), Some([0.0, 0.0, 1.0]))];
        let (p, r) = sample(&keys, 0.5, false);
        assert!((p.unwrap() - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
        assert!((r.unwrap() - DVec3::new(0.0, 0.0, 0.25)).length() < 1e-15, "rotation vectors interpolate linearly");
        assert_eq!(sample(&keys, 5.0, false).0, Some(DVec3::new(2.0, 0.0, 0.0)), "held after the last key");
        let looped = sample(&keys, 2.5, true).0.unwrap();
        assert!((looped - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12, "wraps to t = 0.5");
        assert_eq!(sample(&keys, 1.0, false).0.map(|p| p.x), Some(1.0));
    }

    #[test]
    fn rotation_keys_are_the_turns_written_not_the_shortest_arcs() {
        let tau = std::f64::consts::TAU;
        // 0 → 2π: halfway is a half turn (the shortest arc between the keys' rotations is no turn at all).
        let full = [key(0.0, None, Some([0.0; 3])), key(1.0, None, Some([tau, 0.0, 0.0]))];
        assert!((sample(&full, 0.5, false).1.unwrap() - DVec3::X * 0.5 * tau).length() < 1e-15);
        // 0 → 3π/2: a quarter of the way is +67.5°, not −22.5° (the short way to −90°).
        let most = [key(0.0, None, Some([0.0; 3])), key(1.0, None, Some([0.75 * tau, 0.0, 0.0]))];
        let w = sample(&most, 0.25, false).1.unwrap();
        assert!((w.x - 0.1875 * tau).abs() < 1e-15, "{w}");
    }

    #[test]
    fn rotation_targets_continue_past_pi_instead_of_flipping() {
        let mut previous = DVec3::ZERO;
        for k in 1..=72 {
            let angle = f64::from(k) * 5f64.to_radians();
            let w = unwrap_rotation(DQuat::from_rotation_x(angle), previous);
            assert!((w - DVec3::X * angle).length() < 1e-9, "{angle}: {w}");
            previous = w;
        }
    }

    #[test]
    fn forward_kinematics_composes_parent_frames() {
        use crate::scene::Joint;
        let quarter = [0.0, 0.0, std::f64::consts::FRAC_PI_2];
        let skeleton = Skeleton {
            joints: vec![
                Joint {
                    name: "root".into(),
                    parent: None,
                    offset: [0.0, 1.0, 0.0],
                    keys: vec![key(0.0, None, Some([0.0; 3])), key(1.0, None, Some(quarter))],
                },
                Joint { name: "tip".into(), parent: Some("root".into()), offset: [1.0, 0.0, 0.0], keys: vec![] },
            ],
            looping: false,
        };
        let rig = Rig::new(&skeleton);
        assert!((rig.frames(0.0)[1].1 - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-12);
        // A quarter turn of the root about z carries the child from +x to +y of it.
        assert!((rig.frames(1.0)[1].1 - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-12);
        assert_eq!(rig.bones(1.0).len(), 1);
    }
}
