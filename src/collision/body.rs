//! A rigid body: a shape in its own frame and a scripted motion that places it in the world.

use glam::{DMat3, DQuat, DVec3};

use super::Shape;

/// A scripted rigid motion: `c(t) = c₀ + v t + A sin(2π f t)` and a constant spin `ω` about `c(t)`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Constant velocity `v`, m/s.
    pub velocity: DVec3,
    /// Oscillation amplitude `A`, m.
    pub amplitude: DVec3,
    /// Oscillation frequency `f`, Hz.
    pub frequency: f64,
    /// Angular velocity `ω` (axis × rad/s).
    pub spin: DVec3,
}

/// Where a point is relative to a body's surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Signed distance to the surface, m: negative inside the body.
    pub distance: f64,
    /// Unit outward surface normal at the closest surface point.
    pub normal: DVec3,
    /// Velocity of the body's material at the query point, m/s.
    pub velocity: DVec3,
}

/// A shape placed by a motion.
#[derive(Debug, Clone)]
pub struct Body {
    /// Geometry in the body frame.
    pub shape: Shape,
    /// Position of the body frame's origin at `t = 0`.
    pub origin: DVec3,
    /// Orientation of the body frame at `t = 0`.
    pub orientation: DQuat,
    /// How it moves.
    pub motion: Motion,
    /// A dynamic body's mass, kg (the position-based methods integrate it; others hold it still at
    /// its initial pose); `None`: the body follows its scripted motion.
    pub mass: Option<f64>,
}

impl Motion {
    /// Where this motion has taken a frame that started at `origin`, at time `t`: its origin and rotation.
    pub fn pose(&self, origin: DVec3, t: f64) -> (DVec3, DQuat) {
        let phase = std::f64::consts::TAU * self.frequency * t;
        let centre = origin + self.velocity * t + self.amplitude * phase.sin();
        (centre, DQuat::from_scaled_axis(self.spin * t))
    }
}

impl Body {
    /// A scripted body of this shape at `origin`, unrotated, following `motion`.
    pub fn scripted(shape: Shape, origin: DVec3, motion: Motion) -> Self {
        Self { shape, origin, orientation: DQuat::IDENTITY, motion, mass: None }
    }

    /// The body frame's origin and rotation at time `t` (a dynamic body: its initial pose).
    pub fn pose(&self, t: f64) -> (DVec3, DQuat) {
        if self.mass.is_some() {
            return (self.origin, self.orientation);
        }
        let (centre, spin) = self.motion.pose(self.origin, t);
        (centre, spin * self.orientation)
    }

    /// Velocity of the body frame's origin at time `t` (a dynamic body: zero, it is held).
    fn origin_velocity(&self, t: f64) -> DVec3 {
        if self.mass.is_some() {
            return DVec3::ZERO;
        }
        let m = &self.motion;
        let w = std::f64::consts::TAU * m.frequency;
        m.velocity + m.amplitude * (w * (w * t).cos())
    }

    /// Whether the body ever moves by its script.
    pub fn is_moving(&self) -> bool {
        self.mass.is_none()
            && (self.motion.velocity != DVec3::ZERO
                || self.motion.spin != DVec3::ZERO
                || (self.motion.amplitude != DVec3::ZERO && self.motion.frequency != 0.0))
    }

    /// Signed distance, outward normal and body velocity at world point `x` and time `t`.
    pub fn contact(&self, x: DVec3, t: f64) -> Contact {
        self.at(t).contact(x)
    }

    /// The body placed at time `t`, for many queries at that time.
    pub fn at(&self, t: f64) -> Placed<'_> {
        let (centre, rotation) = self.pose(t);
        let rotation = DMat3::from_quat(rotation);
        Placed { body: self, centre, rotation, inverse: rotation.transpose(), velocity: self.origin_velocity(t) }
    }
}

/// A [`Body`] at one instant: its pose and velocity computed once.
#[derive(Debug, Clone, Copy)]
pub struct Placed<'a> {
    body: &'a Body,
    centre: DVec3,
    rotation: DMat3,
    inverse: DMat3,
    velocity: DVec3,
}

impl Placed<'_> {
    /// Signed distance, outward normal and body velocity at world point `x`.
    pub fn contact(&self, x: DVec3) -> Contact {
        let (distance, normal) = self.surface(x);
        Contact { distance, normal, velocity: self.velocity_at(x) }
    }

    /// Signed distance and outward normal (world frame) at world point `x`.
    #[inline]
    pub fn surface(&self, x: DVec3) -> (f64, DVec3) {
        let (distance, normal) = self.body.shape.surface(self.inverse * (x - self.centre));
        (distance, self.rotation * normal)
    }

    /// Velocity of the body's material at world point `x`.
    #[inline]
    pub fn velocity_at(&self, x: DVec3) -> DVec3 {
        if self.body.mass.is_some() {
            return DVec3::ZERO;
        }
        self.velocity + self.body.motion.spin.cross(x - self.centre)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spinning_moving_sphere_reports_distance_normal_and_surface_velocity() {
        let body = Body::scripted(
            Shape::Sphere { radius: 0.5 },
            DVec3::new(0.0, 1.0, 0.0),
            Motion { velocity: DVec3::X, spin: DVec3::new(0.0, 2.0, 0.0), ..Motion::default() },
        );
        let t = 0.5;
        let x = DVec3::new(0.5 + 0.8, 1.0, 0.0); // 0.8 from the centre, which is at x = 0.5 now
        let c = body.contact(x, t);
        assert!((c.distance - 0.3).abs() < 1e-12);
        assert!((c.normal - DVec3::X).length() < 1e-12);
        // v = ċ + ω × r = (1, 0, 0) + (0, 2, 0) × (0.8, 0, 0) = (1, 0, −1.6).
        assert!((c.velocity - DVec3::new(1.0, 0.0, -1.6)).length() < 1e-12);
        // The surface velocity is the time derivative of a point fixed in the body.
        let p0 = DVec3::new(0.3, 0.2, -0.1);
        let world = |t: f64| {
            let (c, r) = body.pose(t);
            c + r * p0
        };
        let e = 1e-6;
        let fd = (world(t + e) - world(t - e)) / (2.0 * e);
        assert!((body.contact(world(t), t).velocity - fd).length() < 1e-8);
    }

    #[test]
    fn oscillating_plane_moves_its_surface() {
        let body = Body::scripted(
            Shape::Plane { normal: DVec3::Y },
            DVec3::ZERO,
            Motion { amplitude: DVec3::new(0.0, 0.1, 0.0), frequency: 1.0, ..Motion::default() },
        );
        let c = body.contact(DVec3::new(3.0, 0.2, 1.0), 0.25); // the plane is at y = 0.1
        assert!((c.distance - 0.1).abs() < 1e-12);
        assert!(c.velocity.length() < 1e-9, "at the top of its swing: {:?}", c.velocity);
        assert!(body.is_moving());
    }

    #[test]
    fn a_turned_box_reports_distances_and_normals_of_its_faces_edges_and_inside() {
        let turn = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let body = Body {
            orientation: turn,
            ..Body::scripted(Shape::Cuboid { half: DVec3::new(1.0, 0.5, 0.25) }, DVec3::Y, Motion::default())
        };
        // The long axis (body x) now lies along world −z.
        let face = body.contact(DVec3::new(0.0, 1.0, -1.5), 0.0);
        assert!((face.distance - 0.5).abs() < 1e-12 && (face.normal - DVec3::NEG_Z).length() < 1e-12, "{face:?}");
        let inside = body.contact(DVec3::new(0.0, 1.4, 0.0), 0.0);
        assert!((inside.distance + 0.1).abs() < 1e-12 && (inside.normal - DVec3::Y).length() < 1e-12, "{inside:?}");
        let edge = body.contact(DVec3::new(0.0, 2.5, -2.0), 0.0);
        assert!((edge.distance - 2f64.sqrt()).abs() < 1e-12, "{edge:?}");
    }
}
