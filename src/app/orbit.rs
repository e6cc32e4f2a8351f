//! Orbit / pan / zoom camera control and screen-to-world rays.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

use crate::render::Camera;

/// A camera orbiting a target: yaw and pitch around it at a distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    /// Point looked at.
    pub target: Vec3,
    /// Distance from the target.
    pub distance: f32,
    /// Rotation about +y, radians.
    pub yaw: f32,
    /// Elevation, radians (clamped short of the poles).
    pub pitch: f32,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

const PITCH_LIMIT: f32 = 1.5;

impl Orbit {
    /// The orbit that reproduces `camera`.
    pub fn from_camera(camera: &Camera) -> Self {
        let d = camera.eye - camera.target;
        let distance = d.length().max(1e-3);
        Self {
            target: camera.target,
            distance,
            yaw: d.x.atan2(d.z),
            pitch: (d.y / distance).clamp(-1.0, 1.0).asin().clamp(-PITCH_LIMIT, PITCH_LIMIT),
            fov_y_deg: camera.fov_y_deg,
        }
    }

    /// The render camera.
    pub fn camera(&self) -> Camera {
        let dir = Vec3::new(self.pitch.cos() * self.yaw.sin(), self.pitch.sin(), self.pitch.cos() * self.yaw.cos());
        let mut c = Camera::look_at(self.target + dir * self.distance, self.target);
        c.fov_y_deg = self.fov_y_deg;
        c.near = (self.distance * 0.01).max(1e-4);
        c.far = self.distance * 100.0;
        c
    }

    /// Rotate by a pointer movement of `delta` pixels.
    pub fn rotate(&mut self, delta: Vec2) {
        self.yaw -= delta.x * 0.008;
        self.pitch = (self.pitch + delta.y * 0.008).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Pan by a pointer movement of `delta` pixels in a viewport `height` pixels tall.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let c = self.camera();
        let scale = 2.0 * self.distance * (c.fov_y_deg.to_radians() * 0.5).tan() / height.max(1.0);
        self.target += (-c.right() * delta.x + c.true_up() * delta.y) * scale;
    }

    /// Zoom by `steps` wheel notches (positive: closer).
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-3, 1e4);
    }
}

/// A ray in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start (the eye).
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
}

/// The ray through pixel `pixel` of a `size` viewport seen by `camera`.
pub fn pixel_ray(camera: &Camera, pixel: Vec2, size: Vec2) -> Ray {
    let ndc = Vec2::new(2.0 * pixel.x / size.x - 1.0, 1.0 - 2.0 * pixel.y / size.y);
    let inv: Mat4 = camera.view_proj(size.x / size.y).inverse();
    let far = inv * ndc.extend(1.0).extend(1.0);
    let far = far.xyz() / far.w;
    Ray { origin: camera.eye, direction: (far - camera.eye).normalize() }
}

/// Where `point` lands on a `size` viewport (pixels), or None behind the camera.
pub fn project(camera: &Camera, point: Vec3, size: Vec2) -> Option<Vec2> {
    let clip = camera.view_proj(size.x / size.y) * point.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let ndc = clip.xy() / clip.w;
    Some(Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y))
}

/// The vertex whose projection is nearest `pixel` and within `radius` pixels, preferring the one
/// closest to the eye among near ties (so the visible side of a fold wins).
pub fn pick_vertex(camera: &Camera, positions: &[Vec3], pixel: Vec2, size: Vec2, radius: f32) -> Option<usize> {
    positions
        .iter()
        .enumerate()
        .filter_map(|(i, &p)| {
            let s = project(camera, p, size)?;
            let d = s.distance(pixel);
            (d <= radius)
                .then(|| (i, d + 0.25 * radius * (p - camera.eye).length() / camera.eye.distance(camera.target)))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Intersection of `ray` with the plane through `point` facing the camera (normal = view direction).
pub fn view_plane_point(camera: &Camera, ray: &Ray, point: Vec3) -> Vec3 {
    let n = camera.forward();
    let denom = ray.direction.dot(n);
    if denom.abs() < 1e-6 {
        return point;
    }
    ray.origin + ray.direction * ((point - ray.origin).dot(n) / denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.5, 0.0))
    }

    #[test]
    fn orbit_round_trips_a_camera() {
        let c = cam();
        let o = Orbit::from_camera(&c);
        assert!((o.camera().eye - c.eye).length() < 1e-5);
        assert!((o.camera().target - c.target).length() < 1e-6);
    }

    #[test]
    fn pixel_ray_goes_through_projected_points() {
        let (c, size) = (cam(), Vec2::new(640.0, 400.0));
        let p = Vec3::new(0.3, 0.2, -0.4);
        let px = project(&c, p, size).unwrap();
        let ray = pixel_ray(&c, px, size);
        let closest = ray.origin + ray.direction * (p - ray.origin).dot(ray.direction);
        assert!((closest - p).length() < 1e-4, "{closest} vs {p}");
        let centre = project(&c, c.target, size).unwrap();
        assert!((centre - size / 2.0).length() < 1e-3);
    }

    #[test]
    fn picks_the_nearest_vertex_on_screen() {
        let (c, size) = (cam(), Vec2::new(640.0, 400.0));
        let pts = [Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let px = project(&c, pts[1], size).unwrap() + Vec2::new(2.0, -1.0);
        assert_eq!(pick_vertex(&c, &pts, px, size, 10.0), Some(1));
        assert_eq!(pick_vertex(&c, &pts, Vec2::new(1.0, 1.0), size, 10.0), None);
    }

    #[test]
    fn view_plane_keeps_depth_and_follows_the_pointer() {
        let (c, size) = (cam(), Vec2::new(640.0, 400.0));
        let anchor = Vec3::new(0.2, 0.4, 0.1);
        let px = project(&c, anchor, size).unwrap() + Vec2::new(30.0, 0.0);
        let hit = view_plane_point(&c, &pixel_ray(&c, px, size), anchor);
        assert!((hit - anchor).dot(c.forward()).abs() < 1e-5, "same depth");
        assert!((project(&c, hit, size).unwrap() - px).length() < 1e-2, "under the pointer");
    }

    #[test]
    fn pan_and_zoom_move_the_camera_sensibly() {
        let mut o = Orbit::from_camera(&cam());
        let d = o.distance;
        o.zoom(2.0);
        assert!(o.distance < d);
        let t = o.target;
        o.pan(Vec2::new(10.0, 0.0), 400.0);
        assert!((o.target - t).dot(o.camera().right()) < 0.0, "dragging right moves the scene right");
        o.rotate(Vec2::new(0.0, 1e6));
        assert!(o.pitch <= PITCH_LIMIT);
    }
}
