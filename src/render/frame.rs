//! Plain data describing one picture: camera, lit meshes, coloured lines and point markers.
//!
//! Nothing here touches the GPU; a [`Frame`] can be built, inspected and tested anywhere.
//! All colours are **linear** RGBA in `[0, 1]`.

use glam::{Mat4, Vec3};

use super::RenderError;

/// A perspective camera looking from `eye` at `target`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Position of the eye in world space.
    pub eye: Vec3,
    /// Point the camera looks at (drawn at the centre of the picture).
    pub target: Vec3,
    /// Approximate up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Distance to the near clipping plane (> 0).
    pub near: f32,
    /// Distance to the far clipping plane (> near).
    pub far: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self::look_at(Vec3::new(2.5, 2.0, 3.0), Vec3::ZERO)
    }
}

impl Camera {
    /// A camera at `eye` looking at `target` with +Y up, 45° field of view, near 0.01, far 100.
    pub fn look_at(eye: Vec3, target: Vec3) -> Self {
        Self { eye, target, up: Vec3::Y, fov_y_deg: 45.0, near: 0.01, far: 100.0 }
    }

    /// World-to-camera matrix (right-handed, camera looks down its -Z).
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.eye, self.target, self.up)
    }

    /// Perspective projection for the given width/height ratio, mapping depth to wgpu's `0..1`.
    ///
    /// A non-positive or non-finite `aspect` is treated as 1.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        Mat4::perspective_rh(self.fov_y_deg.to_radians(), aspect, self.near, self.far)
    }

    /// Combined `projection * view` matrix: world space to clip space.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// This camera moved (same viewing direction, up vector and field of view) so that the box
    /// `[lo, hi]` fills a picture of width/height ratio `aspect` with `margin` to spare.
    ///
    /// With `f`, `r`, `u` the forward, right and true-up vectors and `(x, y, z)` the coordinates of a
    /// box corner relative to the box centre along `r`, `u`, `f`, an eye at `centre + a·r + b·u − D·f`
    /// sees the corner at depth `z + D` and horizontal clip coordinate `(x − a) / ((z + D)·tan(fov_y/2)·aspect)`.
    /// Keeping it within `±(1 − margin)` for every corner, with `s = (1 − margin)·tan(fov_y/2)·aspect`,
    /// asks `D ≥ max(U − a/s, L + a/s)` where `U = max(x/s − z)` and `L = max(−x/s − z)`; the least such
    /// distance is `D_x = (U + L)/2`, at `a = s·(U − L)/2`. The same holds vertically (`b`, `D_y`). The
    /// camera takes `D = max(D_x, D_y)` with both shifts, so the tighter axis touches the margin on both
    /// sides and the other fits inside. Since perspective maps the box to the hull of its projected
    /// corners, every point of the box is then inside the picture. `D` is also kept large enough that
    /// the nearest corner lies in front of the eye (by 5% of the half-diagonal); the near plane sits
    /// halfway to it and the far plane at least twice as far as the farthest corner.
    ///
    /// `margin` is a fraction of the half-width and half-height in `[0, 1)`. A non-positive or
    /// non-finite `aspect` is treated as 1, as in [`Camera::projection`].
    pub fn fitted(&self, lo: Vec3, hi: Vec3, aspect: f32, margin: f32) -> Result<Camera, RenderError> {
        let bad = |reason: String| Err(RenderError::BadCamera(reason));
        if !(lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()) {
            return bad(format!("the box {lo} .. {hi} is not finite and ordered"));
        }
        if !(0.0..1.0).contains(&margin) {
            return bad(format!("the margin must lie in [0, 1), got {margin}"));
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return bad(format!("the field of view must lie in (0°, 180°), got {}°", self.fov_y_deg));
        }
        let f = self.forward();
        if f.cross(self.up).length() < 1e-6 * self.up.length() || !self.up.is_finite() {
            return bad(format!("the view direction {f} runs along the up vector {}", self.up));
        }
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let (r, u) = (self.right(), self.true_up());
        let tan = (1.0 - margin) * (self.fov_y_deg.to_radians() * 0.5).tan();
        let (sx, sy) = (tan * aspect, tan);
        let (centre, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        let corners = (0..8).map(|k| {
            let sign = Vec3::new([-1.0, 1.0][k & 1], [-1.0, 1.0][(k >> 1) & 1], [-1.0, 1.0][(k >> 2) & 1]);
            let q = sign * half;
            (q.dot(r), q.dot(u), q.dot(f))
        });
        let (mut ux, mut lx, mut uy, mut ly) = (f32::MIN, f32::MIN, f32::MIN, f32::MIN);
        let (mut z_min, mut z_max) = (f32::MAX, f32::MIN);
        for (x, y, z) in corners {
            ux = ux.max(x / sx - z);
            lx = lx.max(-x / sx - z);
            uy = uy.max(y / sy - z);
            ly = ly.max(-y / sy - z);
            z_min = z_min.min(z);
            z_max = z_max.max(z);
        }
        let clearance = 0.05 * half.length().max(1e-3);
        let distance = (0.5 * (ux + lx)).max(0.5 * (uy + ly)).max(clearance - z_min);
        let target = centre + r * (sx * 0.5 * (ux - lx)) + u * (sy * 0.5 * (uy - ly));
        Ok(Camera {
            eye: target - f * distance,
            target,
            near: 0.5 * (z_min + distance),
            far: self.far.max(2.0 * (z_max + distance)),
            ..*self
        })
    }

    /// Unit vector from the eye towards the target.
    pub fn forward(&self) -> Vec3 {
        (self.target - self.eye).normalize_or(Vec3::NEG_Z)
    }

    /// Unit vector pointing to the right of the picture.
    pub fn right(&self) -> Vec3 {
        self.forward().cross(self.up).normalize_or(Vec3::X)
    }

    /// Unit vector pointing to the top of the picture (orthogonal to `forward` and `right`).
    pub fn true_up(&self) -> Vec3 {
        self.right().cross(self.forward()).normalize_or(Vec3::Y)
    }
}

/// A lit, two-sided triangle mesh.
///
/// Triangles wound counter-clockwise when seen from the side their normal points to show `front`;
/// the other side shows `back`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshDraw {
    /// Vertex positions in world space.
    pub positions: Vec<[f32; 3]>,
    /// One unit normal per vertex (see [`smooth_normals`]); same length as `positions`.
    pub normals: Vec<[f32; 3]>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Linear RGBA colour of the front side.
    pub front: [f32; 4],
    /// Linear RGBA colour of the back side.
    pub back: [f32; 4],
    /// Colour of an edge overlay drawn on top of the surface, if any.
    pub wireframe: Option<[f32; 4]>,
}

impl MeshDraw {
    /// A mesh with smooth, area-weighted vertex normals computed from `positions` and no wireframe.
    pub fn from_positions(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>, front: [f32; 4], back: [f32; 4]) -> Self {
        let normals = smooth_normals(&positions, &triangles);
        Self { positions, normals, triangles, front, back, wireframe: None }
    }

    /// The same mesh with an edge overlay of the given colour.
    pub fn with_wireframe(mut self, color: [f32; 4]) -> Self {
        self.wireframe = Some(color);
        self
    }
}

/// Smooth vertex normals: the sum of the (area-weighted) face normals around each vertex, normalised.
///
/// Triangles with an out-of-range index are ignored; a vertex with no usable triangle gets +Y.
pub fn smooth_normals(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for tri in triangles {
        let [a, b, c] = tri.map(|i| i as usize);
        let (Some(pa), Some(pb), Some(pc)) = (positions.get(a), positions.get(b), positions.get(c)) else {
            continue;
        };
        let (pa, pb, pc) = (Vec3::from(*pa), Vec3::from(*pb), Vec3::from(*pc));
        // The cross product's length is twice the area: this is the area weighting.
        let n = (pb - pa).cross(pc - pa);
        sums[a] += n;
        sums[b] += n;
        sums[c] += n;
    }
    sums.into_iter().map(|n| n.normalize_or(Vec3::Y).to_array()).collect()
}

/// A straight coloured line segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Start point in world space.
    pub start: [f32; 3],
    /// End point in world space.
    pub end: [f32; 3],
    /// Linear RGBA colour; alpha below 1 blends the line over what is behind it.
    pub color: [f32; 4],
}

/// A small lit cube marking a point (anchors, drag handles, picks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Centre in world space.
    pub position: [f32; 3],
    /// Edge length of the cube in world units.
    pub size: f32,
    /// Linear RGBA colour.
    pub color: [f32; 4],
}

/// Everything needed to draw one picture.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The viewpoint.
    pub camera: Camera,
    /// Lit, two-sided triangle meshes.
    pub meshes: Vec<MeshDraw>,
    /// Coloured line segments (ground grid, gizmos, debug vectors).
    pub lines: Vec<Line>,
    /// Small cubes at points of interest.
    pub markers: Vec<Marker>,
    /// Linear RGBA clear colour.
    pub background: [f32; 4],
    /// Draw the scene into this sub-rectangle `[x, y, width, height]` (pixels) of the target, e.g. the
    /// part of a window not covered by a side panel; `None` is the whole target. The clear covers all.
    pub viewport: Option<[f32; 4]>,
}

impl Default for Frame {
    fn default() -> Self {
        Self::new(Camera::default())
    }
}

/// The default background: a light grey-blue (linear RGBA).
pub const DEFAULT_BACKGROUND: [f32; 4] = [0.55, 0.63, 0.76, 1.0];

impl Frame {
    /// An empty frame seen from `camera` on the [`DEFAULT_BACKGROUND`].
    pub fn new(camera: Camera) -> Self {
        Self {
            camera,
            meshes: Vec::new(),
            lines: Vec::new(),
            markers: Vec::new(),
            background: DEFAULT_BACKGROUND,
            viewport: None,
        }
    }

    /// Append one line segment.
    pub fn line(&mut self, start: [f32; 3], end: [f32; 3], color: [f32; 4]) -> &mut Self {
        self.lines.push(Line { start, end, color });
        self
    }

    /// Append a square grid in the plane `y`, centred on the origin, covering `[-half_extent, half_extent]`
    /// in x and z with lines every `spacing`.
    ///
    /// Adds `2 * (2n + 1)` lines with `n = floor(half_extent / spacing)`; nothing if either value is not positive.
    pub fn ground_grid(&mut self, y: f32, half_extent: f32, spacing: f32, color: [f32; 4]) -> &mut Self {
        if !(half_extent > 0.0 && spacing > 0.0 && half_extent.is_finite() && spacing.is_finite()) {
            return self;
        }
        // Guard against absurd line counts from a tiny spacing.
        let n = ((half_extent / spacing + 1e-4).floor() as i64).min(10_000);
        let h = half_extent;
        for k in -n..=n {
            let t = k as f32 * spacing;
            self.lines.push(Line { start: [t, y, -h], end: [t, y, h], color });
            self.lines.push(Line { start: [-h, y, t], end: [h, y, t], color });
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_projects_to_screen_centre() {
        let cam = Camera::look_at(Vec3::new(3.0, 2.0, -4.0), Vec3::new(0.5, 0.1, 0.2));
        let clip = cam.view_proj(1.5) * cam.target.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1e-5 && ndc.y.abs() < 1e-5, "{ndc}");
        assert!(ndc.z > 0.0 && ndc.z < 1.0, "depth {ndc}");
        // A point above the target is drawn above the centre.
        let clip = cam.view_proj(1.5) * (cam.target + Vec3::Y * 0.1).extend(1.0);
        assert!(clip.y / clip.w > 0.0);
    }

    /// Clip-space `(x, y)` of `p` seen by `cam` in a picture of ratio `aspect`, and its depth.
    fn project(cam: &Camera, aspect: f32, p: Vec3) -> (f32, f32, f32) {
        let clip = cam.view_proj(aspect) * p.extend(1.0);
        (clip.x / clip.w, clip.y / clip.w, clip.w)
    }

    #[test]
    fn a_fitted_camera_shows_the_whole_box_and_fills_one_axis() {
        let boxes = [
            (Vec3::new(-0.5, -0.05, -0.08), Vec3::new(0.5, 0.08, 0.08)),
            (Vec3::new(-0.5, -0.95, -0.1), Vec3::new(0.3, 0.0, 0.1)),
            (Vec3::new(2.0, 3.0, 4.0), Vec3::new(2.5, 3.0, 4.5)),
        ];
        let directions = [Vec3::new(0.9, 0.55, 1.0), Vec3::new(-1.0, 0.2, 0.1), Vec3::new(0.0, 2.0, 0.3)];
        for (lo, hi) in boxes {
            for from in directions {
                for (aspect, margin) in [(1.3, 0.06), (0.5, 0.0), (2.0, 0.2)] {
                    let mut start = Camera::look_at(from, Vec3::ZERO);
                    start.fov_y_deg = 30.0;
                    let cam = start.fitted(lo, hi, aspect, margin).unwrap();
                    assert!((cam.forward() - start.forward()).length() < 1e-5, "the direction is kept");
                    let (mut x_extent, mut y_extent) = ((f32::MAX, f32::MIN), (f32::MAX, f32::MIN));
                    for k in 0..8 {
                        let p = Vec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][(k >> 2) & 1]);
                        let (x, y, w) = project(&cam, aspect, p);
                        assert!(w > cam.near && w < cam.far, "corner {p} at depth {w}");
                        assert!(x.abs() <= 1.0 - margin + 1e-4 && y.abs() <= 1.0 - margin + 1e-4, "{p}: {x}, {y}");
                        x_extent = (x_extent.0.min(x), x_extent.1.max(x));
                        y_extent = (y_extent.0.min(y), y_extent.1.max(y));
                    }
                    let fills = |(a, b): (f32, f32)| (a + 1.0 - margin).abs() < 1e-3 && (b - 1.0 + margin).abs() < 1e-3;
                    assert!(fills(x_extent) || fills(y_extent), "{lo}..{hi} from {from}: {x_extent:?} {y_extent:?}");
                }
            }
        }
    }

    #[test]
    fn fitting_refuses_bad_boxes_margins_and_directions() {
        let cam = Camera::look_at(Vec3::new(1.0, 1.0, 1.0), Vec3::ZERO);
        let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
        assert!(cam.fitted(hi, lo, 1.0, 0.1).is_err());
        assert!(cam.fitted(Vec3::splat(f32::INFINITY), hi, 1.0, 0.1).is_err());
        assert!(cam.fitted(lo, hi, 1.0, 1.0).is_err());
        assert!(cam.fitted(lo, hi, 1.0, f32::NAN).is_err());
        assert!(Camera::look_at(Vec3::Y, Vec3::ZERO).fitted(lo, hi, 1.0, 0.1).is_err());
        assert!(Camera { fov_y_deg: 0.0, ..cam }.fitted(lo, hi, 1.0, 0.1).is_err());
        assert!(cam.fitted(lo, lo, 1.0, 0.1).is_ok(), "a point is framed too");
    }

    #[test]
    fn camera_basis_is_orthonormal() {
        let cam = Camera::default();
        let (f, r, u) = (cam.forward(), cam.right(), cam.true_up());
        assert!(f.dot(r).abs() < 1e-6 && f.dot(u).abs() < 1e-6 && r.dot(u).abs() < 1e-6);
        assert!(u.y > 0.0);
    }

    #[test]
    fn flat_quad_normals_point_up() {
        let positions = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
        let triangles = vec![[0, 1, 2], [0, 2, 3]];
        let mesh = MeshDraw::from_positions(positions, triangles, [1.0; 4], [0.0; 4]);
        for n in &mesh.normals {
            assert!((Vec3::from(*n) - Vec3::Y).length() < 1e-6, "{n:?}");
        }
    }

    #[test]
    fn normals_are_area_weighted_and_robust() {
        // Vertex 0 is shared by a big triangle facing +Z and a small one facing +X.
        let positions = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, -0.1]];
        let triangles = [[0, 1, 2], [0, 4, 3], [0, 1, 99]];
        let n = smooth_normals(&positions, &triangles);
        let n0 = Vec3::from(n[0]);
        assert!(n0.z > 0.9 && n0.x > 0.0, "{n0}");
        assert!((n0.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn grid_line_count() {
        let mut frame = Frame::default();
        frame.ground_grid(0.0, 2.0, 0.5, [0.0, 0.0, 0.0, 0.3]);
        assert_eq!(frame.lines.len(), 2 * 9);
        assert!(frame.lines.iter().all(|l| l.start[1] == 0.0 && l.end[1] == 0.0));
        frame.ground_grid(0.0, 1.0, 0.0, [0.0; 4]);
        assert_eq!(frame.lines.len(), 18);
    }
}
