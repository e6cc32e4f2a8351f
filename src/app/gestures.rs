//! Pointer gestures on the 3D view: orbit, pan, and drag constraints on picked vertices, turned into
//! simulation commands. Window-independent, so the mouse behaviour is unit-tested.
//!
//! A left press on a vertex adds a constraint (or takes hold of the one already on that vertex);
//! moving the pointer moves its target; releasing the button leaves it pinned where it was left, so
//! it is listed in the panel until removed there (or all at once with `C`).

use glam::{DQuat, DVec3, Vec2, Vec3};
use winit::event::MouseButton;

use super::orbit::{Orbit, pick_vertex, pixel_ray, view_plane_point};
use super::panel::DragMode;
use super::sim_thread::Command;
use crate::solver::{Drag, DragId, DragKind};

/// Pick radius around the pointer, pixels.
const PICK_RADIUS: f32 = 12.0;
/// Radians of rotation per pixel of pointer motion in a rotation drag.
const RADIANS_PER_PIXEL: f64 = 0.01;

/// What the pointer is over: the simulated state as last shown, seen through the orbit camera.
#[derive(Debug, Clone, Copy)]
pub struct ViewUnderPointer<'a> {
    /// The pointer, in pixels from the 3D viewport's top-left corner.
    pub pixel: Vec2,
    /// Size of the 3D viewport, pixels.
    pub viewport: Vec2,
    /// Vertex positions shown.
    pub positions: &'a [DVec3],
    /// Anchored vertices, sorted (they cannot be picked).
    pub anchors: &'a [usize],
    /// Constraints in force.
    pub drags: &'a [(DragId, Drag)],
}

/// An active pointer gesture.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Gesture {
    None,
    Orbit,
    Pan,
    /// Moving the target of a position constraint.
    Position {
        id: DragId,
        vertex: usize,
    },
    /// Turning an orientation constraint: `base` is its rotation when the press started at `start`.
    Rotation {
        id: DragId,
        start: Vec2,
        base: DVec3,
    },
}

/// The pointer state machine.
#[derive(Debug, Clone)]
pub struct Gestures {
    gesture: Gesture,
    next_drag: u64,
}

impl Default for Gestures {
    fn default() -> Self {
        // Ids far above the ones a solver hands out itself.
        Self { gesture: Gesture::None, next_drag: 1 << 32 }
    }
}

impl Gestures {
    /// A fresh id for a new constraint.
    pub fn new_drag_id(&mut self) -> DragId {
        self.next_drag += 1;
        DragId(self.next_drag)
    }

    /// Whether a constraint is being dragged.
    pub fn dragging(&self) -> bool {
        matches!(self.gesture, Gesture::Position { .. } | Gesture::Rotation { .. })
    }

    /// A button went down over the 3D view.
    pub fn press(
        &mut self,
        button: MouseButton,
        orbit: &Orbit,
        view: &ViewUnderPointer<'_>,
        mode: DragMode,
    ) -> Vec<Command> {
        let mut commands = Vec::new();
        self.gesture = match button {
            MouseButton::Left => self.grab(orbit, view, mode, &mut commands).unwrap_or(Gesture::Orbit),
            MouseButton::Right => Gesture::Orbit,
            MouseButton::Middle => Gesture::Pan,
            _ => Gesture::None,
        };
        commands
    }

    /// The button went up: the gesture ends; a dragged constraint stays where it was left.
    pub fn release(&mut self) {
        self.gesture = Gesture::None;
    }

    /// The pointer moved by `delta` pixels to `view.pixel`.
    pub fn moved(&mut self, delta: Vec2, orbit: &mut Orbit, view: &ViewUnderPointer<'_>) -> Vec<Command> {
        let camera = orbit.camera();
        match self.gesture {
            Gesture::None => Vec::new(),
            Gesture::Orbit => {
                orbit.rotate(delta);
                Vec::new()
            }
            Gesture::Pan => {
                orbit.pan(delta, view.viewport.y);
                Vec::new()
            }
            Gesture::Position { id, vertex } => {
                let Some(p) = view.positions.get(vertex) else { return Vec::new() };
                let ray = pixel_ray(&camera, view.pixel, view.viewport);
                let target = view_plane_point(&camera, &ray, p.as_vec3());
                vec![Command::MoveDrag(id, DragKind::Position(target.as_dvec3()))]
            }
            Gesture::Rotation { id, start, base } => {
                // Horizontal motion turns about the screen's up axis, vertical motion about its right axis.
                let d = (view.pixel - start).as_dvec2() * RADIANS_PER_PIXEL;
                let turn = camera.true_up().as_dvec3() * d.x + camera.right().as_dvec3() * d.y;
                vec![Command::MoveDrag(id, DragKind::Orientation(compose(turn, base)))]
            }
        }
    }

    /// Take hold of the vertex under the pointer: its existing constraint of the current kind, or a new one.
    fn grab(
        &mut self,
        orbit: &Orbit,
        view: &ViewUnderPointer<'_>,
        mode: DragMode,
        commands: &mut Vec<Command>,
    ) -> Option<Gesture> {
        let camera = orbit.camera();
        let points: Vec<Vec3> = view.positions.iter().map(|p| p.as_vec3()).collect();
        let vertex = pick_vertex(&camera, &points, view.pixel, view.viewport, PICK_RADIUS)?;
        if view.anchors.binary_search(&vertex).is_ok() {
            return None;
        }
        let same_kind = |k: DragKind| {
            matches!(
                (k, mode),
                (DragKind::Position(_), DragMode::Position) | (DragKind::Orientation(_), DragMode::Orientation)
            )
        };
        let existing = view.drags.iter().find(|(_, d)| d.vertex == vertex && same_kind(d.kind));
        let (id, kind) = match existing {
            Some(&(id, d)) => (id, d.kind),
            None => {
                let id = self.new_drag_id();
                let kind = match mode {
                    DragMode::Position => DragKind::Position(view.positions[vertex]),
                    DragMode::Orientation => DragKind::Orientation(DVec3::ZERO),
                };
                commands.push(Command::AddDrag(id, Drag { vertex, kind }));
                (id, kind)
            }
        };
        Some(match kind {
            DragKind::Position(_) => Gesture::Position { id, vertex },
            DragKind::Orientation(base) => Gesture::Rotation { id, start: view.pixel, base },
        })
    }
}

/// The rotation vector of turning by `base`, then by `turn`.
fn compose(turn: DVec3, base: DVec3) -> DVec3 {
    (DQuat::from_scaled_axis(turn) * DQuat::from_scaled_axis(base)).to_scaled_axis()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::orbit::project;
    use crate::render::Camera;

    const SIZE: Vec2 = Vec2::new(640.0, 400.0);

    fn orbit() -> Orbit {
        Orbit::from_camera(&Camera::look_at(Vec3::new(0.0, 0.5, 2.0), Vec3::ZERO))
    }

    fn points() -> Vec<DVec3> {
        vec![DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0)]
    }

    fn over<'a>(vertex: usize, positions: &'a [DVec3], drags: &'a [(DragId, Drag)]) -> ViewUnderPointer<'a> {
        let pixel = project(&orbit().camera(), positions[vertex].as_vec3(), SIZE).unwrap();
        ViewUnderPointer { pixel, viewport: SIZE, positions, anchors: &[0], drags }
    }

    #[test]
    fn a_position_drag_follows_the_pointer_and_stays_pinned_after_release() {
        let (mut g, mut o, pts) = (Gestures::default(), orbit(), points());
        let view = over(2, &pts, &[]);
        let added = g.press(MouseButton::Left, &o, &view, DragMode::Position);
        let [Command::AddDrag(id, drag)] = added.as_slice() else { panic!("expected one AddDrag") };
        assert_eq!((drag.vertex, drag.kind), (2, DragKind::Position(pts[2])));
        let moved_to = ViewUnderPointer { pixel: view.pixel + Vec2::new(0.0, -40.0), ..view };
        let moves = g.moved(Vec2::new(0.0, -40.0), &mut o, &moved_to);
        let [Command::MoveDrag(mid, DragKind::Position(target))] = moves.as_slice() else { panic!("expected a move") };
        assert_eq!(mid, id);
        assert!(target.y > 0.05, "dragging up raises the target: {target}");
        let shown = project(&o.camera(), target.as_vec3(), SIZE).unwrap();
        assert!(shown.distance(moved_to.pixel) < 0.5, "the target is under the pointer");
        g.release();
        assert!(!g.dragging());
        assert!(g.moved(Vec2::ONE, &mut o, &moved_to).is_empty(), "released: nothing follows the pointer");
    }

    #[test]
    fn pressing_a_constrained_vertex_takes_hold_of_its_constraint() {
        let (mut g, o, pts) = (Gestures::default(), orbit(), points());
        let drags = [(DragId(7), Drag { vertex: 1, kind: DragKind::Position(DVec3::Y) })];
        assert!(g.press(MouseButton::Left, &o, &over(1, &pts, &drags), DragMode::Position).is_empty());
        assert!(g.dragging());
        let mut o2 = o;
        let moves = g.moved(Vec2::X, &mut o2, &over(1, &pts, &drags));
        assert!(matches!(moves.as_slice(), [Command::MoveDrag(DragId(7), _)]), "moves the existing constraint");
    }

    #[test]
    fn anchors_and_the_background_orbit_instead() {
        let (mut g, mut o, pts) = (Gestures::default(), orbit(), points());
        assert!(g.press(MouseButton::Left, &o, &over(0, &pts, &[]), DragMode::Position).is_empty());
        assert!(!g.dragging());
        let yaw = o.yaw;
        g.moved(Vec2::new(30.0, 0.0), &mut o, &over(0, &pts, &[]));
        assert_ne!(o.yaw, yaw, "an anchored vertex is not picked: the view orbits");
    }

    #[test]
    fn a_rotation_drag_turns_about_the_screen_axes_and_accumulates() {
        let (mut g, mut o, pts) = (Gestures::default(), orbit(), points());
        let view = over(2, &pts, &[]);
        let added = g.press(MouseButton::Left, &o, &view, DragMode::Orientation);
        let [Command::AddDrag(id, _)] = added.as_slice() else { panic!("expected one AddDrag") };
        let right = ViewUnderPointer { pixel: view.pixel + Vec2::new(50.0, 0.0), ..view };
        let moves = g.moved(Vec2::new(50.0, 0.0), &mut o, &right);
        let [Command::MoveDrag(_, DragKind::Orientation(w))] = moves.as_slice() else { panic!("expected a turn") };
        let up = o.camera().true_up().as_dvec3();
        assert!((*w - up * 0.5).length() < 1e-9, "50 px right = 0.5 rad about screen up: {w}");
        // Take hold again: the next turn starts from the current rotation.
        g.release();
        let drags = [(*id, Drag { vertex: 2, kind: DragKind::Orientation(*w) })];
        g.press(MouseButton::Left, &o, &over(2, &pts, &drags), DragMode::Orientation);
        let again = ViewUnderPointer { pixel: view.pixel + Vec2::new(50.0, 0.0), ..over(2, &pts, &drags) };
        let moves = g.moved(Vec2::new(50.0, 0.0), &mut o, &again);
        let [Command::MoveDrag(_, DragKind::Orientation(w2))] = moves.as_slice() else { panic!("expected a turn") };
        assert!((*w2 - up * 1.0).length() < 1e-9, "turns add up: {w2}");
    }
}
