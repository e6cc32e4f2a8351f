//! Turning a scene and a solver state into a render [`Frame`]: the one place that decides how a
//! simulation looks, shared by the window, the headless `render` command and the evaluator.

use glam::{DVec3, Vec3};

use super::gizmo;
use crate::collision::{Motion, Shape};
use crate::mesh::generate;
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
    /// A moving body: its geometry in the body frame, placed by its motion from `origin` each frame.
    Moving { local: MeshDraw, origin: DVec3, motion: Motion },
}

/// `local` moved to the pose at time `t` of a frame that `motion` takes from `origin`.
fn placed(local: &MeshDraw, origin: DVec3, motion: &Motion, t: f64) -> MeshDraw {
    let (centre, rotation) = motion.pose(origin, t);
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
            let local = match &body.shape {
                Shape::Sphere { radius } => match generate::icosphere(radius - INSET, 12) {
                    Ok(ball) => mesh_draw(ball.positions(), ball.triangles(), COLLIDER, COLLIDER),
                    Err(_) => continue,
                },
                Shape::Plane { normal } => {
                    if normal.y > 0.99 && !body.is_moving() {
                        grid_height = body.origin.y as f32;
                    }
                    let (t, b) = normal.any_orthonormal_pair();
                    let e = 2.0 * size;
                    let corners =
                        [-t * e - b * e, t * e - b * e, t * e + b * e, -t * e + b * e].map(|c| c - *normal * INSET);
                    let tris =
                        if t.cross(b).dot(*normal) > 0.0 { [[0, 1, 2], [0, 2, 3]] } else { [[0, 2, 1], [0, 3, 2]] };
                    mesh_draw(&corners, &tris, [0.8, 0.8, 0.78, 1.0], COLLIDER)
                }
                Shape::Mesh(mesh) => {
                    let mut draw = mesh_draw(mesh.positions(), mesh.triangles(), COLLIDER, COLLIDER);
                    for (p, n) in draw.positions.iter_mut().zip(&draw.normals) {
                        *p = (Vec3::from(*p) - Vec3::from(*n) * INSET as f32).to_array();
                    }
                    draw
                }
            };
            colliders.push(if body.is_moving() {
                ColliderDraw::Moving { local, origin: body.origin, motion: body.motion }
            } else {
                ColliderDraw::Still(placed(&local, body.origin, &body.motion, 0.0))
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
        }
    }

    /// The camera the scene file asks for.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The frame for the simulated `positions` at simulated time `time` (which places moving
    /// colliders) with these drags, seen by `camera`.
    pub fn frame(
        &self,
        camera: Camera,
        positions: &[DVec3],
        time: f64,
        drags: &[(DragId, Drag)],
        options: ViewOptions,
    ) -> Frame {
        let mut frame = Frame::new(camera);
        let spacing = nice_spacing(self.grid_extent / 10.0);
        frame.ground_grid(self.grid_height, self.grid_extent, spacing, GRID);
        for c in &self.colliders {
            frame.meshes.push(match c {
                ColliderDraw::Still(draw) => draw.clone(),
                ColliderDraw::Moving { local, origin, motion } => placed(local, *origin, motion, time),
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

fn triangles_u32(t: &[[usize; 3]]) -> Vec<[u32; 3]> {
    t.iter().map(|t| t.map(|i| i as u32)).collect()
}

/// 1, 2 or 5 times a power of ten, near `x`.
fn nice_spacing(x: f32) -> f32 {
    let p = 10f32.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).min_by(|a, b| (a - x).abs().total_cmp(&(b - x).abs())).unwrap_or(p)
}
