//! Turning a scene and a solver state into a render [`Frame`]: the one place that decides how a
//! simulation looks, shared by the window, the headless `render` command and the evaluator.

use glam::{DQuat, DVec3, Vec3};

use super::gizmo;
use crate::collision::{Motion, Shape};
use crate::render::{Camera, Frame, Marker, MeshDraw};
use crate::scene::Setup;
use crate::solver::script::Rig;
use crate::solver::{Drag, DragId, DragKind};

/// Front (outside) colour of simulated surfaces, linear RGBA.
pub const FRONT: [f32; 4] = [0.85, 0.38, 0.12, 1.0];
/// Back (inside) colour of simulated surfaces.
pub const BACK: [f32; 4] = [0.10, 0.45, 0.50, 1.0];
/// Wireframe overlay colour.
pub const WIRE: [f32; 4] = [0.02, 0.02, 0.03, 1.0];
const COLLIDER: [f32; 4] = [0.55, 0.57, 0.62, 1.0];
/// The front of a plane collider.
const GROUND: [f32; 4] = [0.8, 0.8, 0.78, 1.0];
const ANCHOR: [f32; 4] = [0.15, 0.15, 0.9, 1.0];
const POSITION_DRAG: [f32; 4] = [0.95, 0.85, 0.1, 1.0];
const ORIENTATION_DRAG: [f32; 4] = [0.8, 0.1, 0.8, 1.0];
const GRID: [f32; 4] = [0.25, 0.27, 0.32, 0.6];
const BONE: [f32; 4] = [0.05, 0.6, 0.2, 1.0];
/// Colour of the reference ghost's wireframe.
pub const GHOST: [f32; 4] = [0.05, 0.25, 0.95, 1.0];
/// Radius of the rotate gizmo, in marker sizes.
const GIZMO_MARKERS: f32 = 9.0;
/// Rotate gizmos are drawn when there are at most this many orientation drags.
const MAX_GIZMOS: usize = 4;

/// Colliders are drawn this far inside their true surface (m), so that cloth resting on them
/// within the contact margin does not flicker through them.
const INSET: f64 = 0.0025;

/// How to draw.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ViewOptions {
    /// Overlay the simulated mesh's edges.
    pub wireframe: bool,
}

/// A collider's picture.
#[derive(Debug, Clone)]
enum ColliderDraw {
    /// A body that never moves, drawn where it is.
    Still(MeshDraw),
    /// A moving body: its geometry in the body frame, placed each frame by its scripted motion from
    /// `origin` and `orientation` (or, for a dynamic body, by the pose the solver reports).
    Moving { local: MeshDraw, origin: DVec3, orientation: DQuat, motion: Motion, dynamic: bool },
}

/// `local` moved to the pose `(centre, rotation)`.
fn placed(local: &MeshDraw, (centre, rotation): (DVec3, DQuat)) -> MeshDraw {
    let (c, r) = (centre.as_vec3(), rotation.as_quat());
    MeshDraw {
        positions: local.positions.iter().map(|&p| (r * Vec3::from(p) + c).to_array()).collect(),
        normals: local.normals.iter().map(|&n| (r * Vec3::from(n)).to_array()).collect(),
        ..local.clone()
    }
}

fn mesh_draw(positions: &[DVec3], triangles: &[[usize; 3]], front: [f32; 4], back: [f32; 4]) -> MeshDraw {
    MeshDraw::from_positions(positions.iter().map(|&p| f32x3(p)).collect(), triangles_u32(triangles), front, back)
}

/// The parts of a scene's picture that do not change while it runs, built once.
#[derive(Debug, Clone)]
pub struct SceneView {
    camera: Camera,
    triangles: Vec<[u32; 3]>,
    anchors: Vec<usize>,
    colliders: Vec<ColliderDraw>,
    grid_height: f32,
    grid_extent: f32,
    marker_size: f32,
    rig: Rig,
    edges: Vec<[usize; 2]>,
    /// The mesh at rest: drawn instead of positions of another mesh (the old scene's last snapshot
    /// in the frames between a scene switch and the new solver's first).
    rest: Vec<DVec3>,
}

/// A position as the renderer's `[f32; 3]`.
pub(super) fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

impl SceneView {
    /// Prepare the static geometry of `setup`: camera, colliders, ground grid, anchors.
    pub fn new(setup: &Setup) -> Self {
        let c = &setup.scene.camera;
        let mut camera = Camera::look_at(Vec3::from(c.eye.map(|x| x as f32)), Vec3::from(c.target.map(|x| x as f32)));
        camera.fov_y_deg = c.fov_deg as f32;
        let (lo, hi) = setup.mesh.bounding_box();
        let size = (hi - lo).max_element().max(1e-3);
        let mut grid_height = (lo.y - 0.35 * size) as f32;
        let mut colliders = Vec::new();
        for body in &setup.bodies {
            if let Shape::Plane { normal } = body.shape
                && normal.y > 0.99
                && !body.is_moving()
            {
                grid_height = body.origin.y as f32;
            }
            let Some(surface) = body.shape.drawn(INSET, 2.0 * size) else { continue };
            let front = if matches!(body.shape, Shape::Plane { .. }) { GROUND } else { COLLIDER };
            let local = mesh_draw(&surface.positions, &surface.triangles, front, COLLIDER);
            let dynamic = body.mass.is_some();
            colliders.push(if body.is_moving() || dynamic {
                let (origin, orientation, motion) = (body.origin, body.orientation, body.motion);
                ColliderDraw::Moving { local, origin, orientation, motion, dynamic }
            } else {
                ColliderDraw::Still(placed(&local, body.pose(0.0)))
            });
        }
        Self {
            camera,
            triangles: triangles_u32(setup.mesh.triangles()),
            anchors: setup.anchors.clone(),
            colliders,
            grid_height,
            grid_extent: (2.0 * size) as f32,
            marker_size: (0.012 * size) as f32,
            rig: Rig::new(&setup.scene.skeleton),
            edges: setup.mesh.topology().edges.iter().map(|e| e.v).collect(),
            rest: setup.mesh.positions().to_vec(),
        }
    }

    /// The camera the scene file asks for.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The frame for the simulated `positions` at simulated time `time` with these drags, seen by
    /// `camera`, and the colliders at the poses a solver reports ([`Solver::body_poses`], in the
    /// scene's order; empty: every collider by its scripted motion, which places moving ones, and
    /// dynamic ones where they start).
    ///
    /// [`Solver::body_poses`]: crate::solver::Solver::body_poses
    pub fn frame(
        &self,
        camera: Camera,
        positions: &[DVec3],
        time: f64,
        drags: &[(DragId, Drag)],
        options: ViewOptions,
        poses: &[(DVec3, DQuat)],
    ) -> Frame {
        let positions = if positions.len() == self.rest.len() { positions } else { &self.rest[..] };
        let mut frame = Frame::new(camera);
        let spacing = nice_spacing(self.grid_extent / 10.0);
        frame.ground_grid(self.grid_height, self.grid_extent, spacing, GRID);
        for (i, c) in self.colliders.iter().enumerate() {
            frame.meshes.push(match c {
                ColliderDraw::Still(draw) => draw.clone(),
                ColliderDraw::Moving { local, .. } if i < poses.len() => placed(local, poses[i]),
                ColliderDraw::Moving { local, origin, orientation, dynamic: true, .. } => {
                    placed(local, (*origin, *orientation))
                }
                ColliderDraw::Moving { local, origin, orientation, motion, .. } => {
                    let (centre, spin) = motion.pose(*origin, time);
                    placed(local, (centre, spin * *orientation))
                }
            });
        }
        let mut surface = MeshDraw::from_positions(
            positions.iter().map(|&p| f32x3(p)).collect(),
            self.triangles.clone(),
            FRONT,
            BACK,
        );
        if options.wireframe {
            surface = surface.with_wireframe(WIRE);
        }
        frame.meshes.push(surface);
        for &a in &self.anchors {
            frame.markers.push(Marker { position: f32x3(positions[a]), size: self.marker_size, color: ANCHOR });
        }
        for (a, b) in self.rig.bones(time) {
            frame.line(f32x3(a), f32x3(b), BONE);
            frame.markers.push(Marker { position: f32x3(b), size: self.marker_size, color: BONE });
        }
        let orientations = drags.iter().filter(|(_, d)| matches!(d.kind, DragKind::Orientation(_))).count();
        for (_, d) in drags {
            let p = positions.get(d.vertex).copied().unwrap_or_default();
            match d.kind {
                DragKind::Position(target) => {
                    frame.markers.push(Marker {
                        position: f32x3(target),
                        size: 2.0 * self.marker_size,
                        color: POSITION_DRAG,
                    });
                    frame.line(f32x3(p), f32x3(target), POSITION_DRAG);
                }
                DragKind::Orientation(rotation) => {
                    frame.markers.push(Marker {
                        position: f32x3(p),
                        size: 2.0 * self.marker_size,
                        color: ORIENTATION_DRAG,
                    });
                    // A few drags (the mouse's) show their rotation; many (a scripted track's ring) only mark.
                    if orientations <= MAX_GIZMOS {
                        gizmo::rotate_gizmo(&mut frame, p, rotation, f64::from(GIZMO_MARKERS * self.marker_size));
                    }
                }
            }
        }
        frame
    }
}

impl SceneView {
    /// Add the edges of a second state of the same mesh (a reference ghost) as lines.
    pub fn ghost_lines(&self, frame: &mut Frame, positions: &[DVec3]) {
        for &[a, b] in &self.edges {
            if let (Some(&p), Some(&q)) = (positions.get(a), positions.get(b)) {
                frame.line(f32x3(p), f32x3(q), GHOST);
            }
        }
    }
}

/// A box of half extents `half` with flat faces (four vertices of its own per face).
fn triangles_u32(t: &[[usize; 3]]) -> Vec<[u32; 3]> {
    t.iter().map(|t| t.map(|i| i as u32)).collect()
}

/// 1, 2 or 5 times a power of ten, near `x`.
fn nice_spacing(x: f32) -> f32 {
    let p = 10f32.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).min_by(|a, b| (a - x).abs().total_cmp(&(b - x).abs())).unwrap_or(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Between a scene switch and the new solver's first snapshot the window holds the new scene's
    /// view and the old scene's positions: the view draws its own mesh at rest (the soak found this
    /// panicking on an anchor index).
    #[test]
    fn positions_of_another_mesh_draw_this_mesh_at_rest() {
        let cantilever = crate::scene::load("cantilever", &[]).unwrap();
        let creature = crate::scene::load("creature", &[]).unwrap();
        let view = SceneView::new(&creature);
        let options = ViewOptions { wireframe: false };
        let frame = view.frame(view.camera(), cantilever.mesh.positions(), 0.0, &[], options, &[]);
        let shell = frame.meshes.iter().find(|m| m.positions.len() == creature.mesh.vertex_count()).unwrap();
        assert_eq!(shell.positions[7], f32x3(creature.mesh.positions()[7]));
        assert!(frame.meshes.iter().all(|m| m.triangles.iter().flatten().all(|&i| (i as usize) < m.positions.len())));
    }
}
