//! A rigid body: a shape in its own frame and a scripted motion that places it in the world.

use glam::{DMat3, DQuat, DVec3};

use super::MeshDistance;

/// A body's geometry in its own frame (origin at its centre or reference point).
#[derive(Debug, Clone)]
pub enum Shape {
    /// A ball of this radius centred on the origin.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// The half-space below the plane through the origin with this unit normal is solid.
    Plane {
        /// Unit outward normal.
        normal: DVec3,
    },
    /// A closed triangle mesh (solid inside).
    Mesh(Box<MeshDistance>),
}

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
    /// How it moves.
    pub motion: Motion,
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
    /// The body frame's origin and rotation at time `t`.
    pub fn pose(&self, t: f64) -> (DVec3, DQuat) {
        self.motion.pose(self.origin, t)
    }

    /// Velocity of the body frame's origin at time `t`.
    fn origin_velocity(&self, t: f64) -> DVec3 {
        let m = &self.motion;
        let w = std::f64::consts::TAU * m.frequency;
        m.velocity + m.amplitude * (w * (w * t).cos())
    }

    /// Whether the body ever moves.
    pub fn is_moving(&self) -> bool {
        self.motion.velocity != DVec3::ZERO
            || self.motion.spin != DVec3::ZERO
            || (self.motion.amplitude != DVec3::ZERO && self.motion.frequency != 0.0)
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
        let local = self.inverse * (x - self.centre);
        let (distance, normal) = match &self.body.shape {
            Shape::Sphere { radius } => {
                let r = local.length();
                let n = if r > 0.0 { local / r } else { DVec3::Y };
                (r - radius, n)
            }
            Shape::Plane { normal } => (local.dot(*normal), *normal),
            Shape::Mesh(mesh) => mesh.signed_distance(local),
        };
        (distance, self.rotation * normal)
    }

    /// Velocity of the body's material at world point `x`.
    #[inline]
    pub fn velocity_at(&self, x: DVec3) -> DVec3 {
        self.velocity + self.body.motion.spin.cross(x - self.centre)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spinning_moving_sphere_reports_distance_normal_and_surface_velocity() {
        let body = Body {
            shape: Shape::Sphere { radius: 0.5 },
            origin: DVec3::new(0.0, 1.0, 0.0),
            motion: Motion { velocity: DVec3::X, spin: DVec3::new(0.0, 2.0, 0.0), ..Motion::default() },
        };
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
        let body = Body {
            shape: Shape::Plane { normal: DVec3::Y },
            origin: DVec3::ZERO,
            motion: Motion { amplitude: DVec3::new(0.0, 0.1, 0.0), frequency: 1.0, ..Motion::default() },
        };
        let c = body.contact(DVec3::new(3.0, 0.2, 1.0), 0.25); // the plane is at y = 0.1
        assert!((c.distance - 0.1).abs() < 1e-12);
        assert!(c.velocity.length() < 1e-9, "at the top of its swing: {:?}", c.velocity);
        assert!(body.is_moving());
    }
}
