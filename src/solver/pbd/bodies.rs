//! The scene's colliders as position-based dynamics moves them: scripted ones follow their motion;
//! dynamic ones (a mass given) are rigid bodies integrated with the cloth (Müller et al. 2020,
//! "Detailed rigid body simulation with extended position based dynamics"): predicted by their
//! velocity and gravity each substep, corrected by contacts with the cloth through their generalised
//! inverse mass, and given the velocity their corrected pose implies. A correction of a cloth vertex
//! against a body moves the body by the opposite impulse at the contact — `m_i Δp_i / h` — so momentum
//! passes between them.

use glam::{DMat3, DQuat, DVec3};

use crate::collision::{Body, Shape};

/// Points along one edge of a box at most: a box more than this many half cloth edges long is sampled
/// more coarsely along its edges (its faces still push every particle) instead of asking for memory
/// in proportion to its size (a box of a kilometre on a centimetre cloth once asked for 2 TB).
pub const MAX_EDGE_SAMPLES: usize = 1024;

/// One collider's state.
#[derive(Debug, Clone)]
pub struct Rigid {
    /// The scene's body (shape, script, mass).
    pub body: Body,
    /// Centre and orientation now (the substep's predicted pose while it is solved).
    pub centre: DVec3,
    /// Orientation.
    pub rotation: DQuat,
    /// Centre and orientation at the start of the substep.
    previous: (DVec3, DQuat),
    /// Linear velocity, m/s.
    pub velocity: DVec3,
    /// Angular velocity, rad/s.
    pub spin: DVec3,
    /// `1/m` (0: scripted, moved by nobody but its script).
    pub inverse_mass: f64,
    /// Inverse inertia in the body frame (principal axes), `1/(kg m²)`.
    inverse_inertia: DVec3,
}

impl Rigid {
    /// The collider at time 0.
    pub fn new(body: &Body) -> Self {
        let (centre, rotation) = body.pose(0.0);
        let (inverse_mass, inverse_inertia) = match body.mass.and_then(|m| Some((m, body.shape.inertia(m)?))) {
            Some((m, inertia)) => (1.0 / m, DVec3::ONE / inertia),
            None => (0.0, DVec3::ZERO),
        };
        let (velocity, spin) =
            if body.mass.is_some() { (body.motion.velocity, body.motion.spin) } else { (DVec3::ZERO, DVec3::ZERO) };
        Self {
            body: body.clone(),
            centre,
            rotation,
            previous: (centre, rotation),
            velocity,
            spin,
            inverse_mass,
            inverse_inertia,
        }
    }

    /// Whether the cloth can push it.
    pub fn is_dynamic(&self) -> bool {
        self.inverse_mass > 0.0
    }

    /// Start a substep ending at time `t`: a scripted body takes its pose at `t`; a dynamic one is
    /// predicted by its velocity (with gravity) over `h`.
    pub fn predict(&mut self, t: f64, h: f64, gravity: DVec3) {
        self.previous = (self.centre, self.rotation);
        if !self.is_dynamic() {
            (self.centre, self.rotation) = self.body.pose(t);
            let (c0, _) = self.body.pose(t - h);
            self.velocity = (self.centre - c0) / h;
            self.spin = self.body.motion.spin;
            return;
        }
        self.velocity += gravity * h;
        self.centre += self.velocity * h;
        self.rotation = integrate(self.rotation, self.spin * h);
    }

    /// End a substep of `h`: a dynamic body's velocities from its corrected pose.
    pub fn finish(&mut self, h: f64) {
        if !self.is_dynamic() {
            return;
        }
        self.velocity = (self.centre - self.previous.0) / h;
        let d = self.rotation * self.previous.1.inverse();
        let d = if d.w < 0.0 { -d } else { d };
        self.spin = DVec3::new(d.x, d.y, d.z) * (2.0 / h);
    }

    /// Where the body point now at world `x` was at the start of the substep.
    pub fn previous_point(&self, x: DVec3) -> DVec3 {
        let local = self.rotation.inverse() * (x - self.centre);
        self.previous.0 + self.previous.1 * local
    }

    /// The points where a dynamic body may touch another collider: a sphere's point nearest to it (by
    /// that collider's surface normal at the centre), a box's corners; world frame.
    pub fn contact_points(&self, other: &Rigid) -> Vec<DVec3> {
        match self.body.shape {
            Shape::Sphere { radius } => {
                let (_, n) = other.surface(self.centre);
                vec![self.centre - n * radius]
            }
            Shape::Cuboid { half } => (0..8)
                .map(|i| {
                    let s = DVec3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    );
                    self.centre + self.rotation * (s * half)
                })
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Scale a dynamic body's velocities by `keep` (damping).
    pub fn damp(&mut self, keep: f64) {
        if self.is_dynamic() {
            self.velocity *= keep;
            self.spin *= keep;
        }
    }

    /// Signed distance and outward normal at world point `x`.
    #[inline(always)]
    pub fn surface(&self, x: DVec3) -> (f64, DVec3) {
        let (d, n) = self.body.shape.surface(self.rotation.inverse() * (x - self.centre));
        (d, self.rotation * n)
    }

    /// Velocity of the body's material at `x`.
    #[inline]
    pub fn velocity_at(&self, x: DVec3) -> DVec3 {
        self.velocity + self.spin.cross(x - self.centre)
    }

    /// World inverse inertia.
    fn inverse_inertia_world(&self) -> DMat3 {
        let r = DMat3::from_quat(self.rotation);
        r * DMat3::from_diagonal(self.inverse_inertia) * r.transpose()
    }

    /// Generalised inverse mass for a push along unit `n` at `x`: `1/m + (r × n)ᵀ I⁻¹ (r × n)`.
    pub fn inverse_mass_at(&self, x: DVec3, n: DVec3) -> f64 {
        if !self.is_dynamic() {
            return 0.0;
        }
        let rn = (x - self.centre).cross(n);
        self.inverse_mass + rn.dot(self.inverse_inertia_world() * rn)
    }

    /// Move the body by the positional impulse `p` (kg·m) applied at `x`.
    pub fn apply_position_impulse(&mut self, x: DVec3, p: DVec3) {
        if !self.is_dynamic() {
            return;
        }
        let dtheta = self.inverse_inertia_world() * (x - self.centre).cross(p);
        self.centre += p * self.inverse_mass;
        self.rotation = integrate(self.rotation, dtheta);
    }

    /// Linear momentum, kg·m/s (zero for a scripted body).
    pub fn momentum(&self) -> DVec3 {
        if self.is_dynamic() { self.velocity / self.inverse_mass } else { DVec3::ZERO }
    }

    /// Kinetic energy, J.
    pub fn kinetic_energy(&self) -> f64 {
        if !self.is_dynamic() {
            return 0.0;
        }
        let w_local = self.rotation.inverse() * self.spin;
        0.5 * self.velocity.length_squared() / self.inverse_mass
            + 0.5 * (w_local * w_local / self.inverse_inertia).element_sum()
    }

    /// The points a small body tests against cloth triangles, world frame: a box's corners and points
    /// along its edges at most `spacing` apart (at most [`MAX_EDGE_SAMPLES`] an edge); none for other
    /// shapes.
    pub fn samples(&self, spacing: f64) -> Vec<DVec3> {
        let Shape::Cuboid { half } = self.body.shape else { return Vec::new() };
        let corner = |i: usize| {
            DVec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            ) * half
        };
        let mut local: Vec<DVec3> = (0..8).map(corner).collect();
        for i in 0..8 {
            for bit in [1, 2, 4] {
                if i & bit == 0 {
                    let (a, b) = (corner(i), corner(i | bit));
                    let n = ((b - a).length() / spacing.max(1e-9)).ceil().min(MAX_EDGE_SAMPLES as f64) as usize;
                    local.extend((1..n).map(|k| a + (b - a) * (k as f64 / n as f64)));
                }
            }
        }
        local.into_iter().map(|p| self.centre + self.rotation * p).collect()
    }
}

/// `q` turned by the small rotation vector `w` (first order, renormalised).
fn integrate(q: DQuat, w: DVec3) -> DQuat {
    let dq = DQuat::from_xyzw(w.x, w.y, w.z, 0.0) * q;
    (q + dq * 0.5).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::Motion;

    /// Found by the fuzzer (`tests/fuzz.rs`): a scene's box mutated to a kilometre beside a fine cloth
    /// made the edge samples ask for 2 TB and abort the program.
    #[test]
    fn a_box_a_kilometre_wide_beside_a_fine_cloth_is_sampled_without_asking_for_terabytes() {
        let body = Body::scripted(Shape::Cuboid { half: DVec3::splat(1e3) }, DVec3::ZERO, Motion::default());
        let samples = Rigid::new(&body).samples(1e-4);
        assert_eq!(samples.len(), 8 + 12 * (MAX_EDGE_SAMPLES - 1));
        assert!(samples.iter().all(|p| p.abs().max_element() <= 1e3 + 1e-9));
        // A small box is sampled at the spacing asked for: corners and 3 points inside each edge.
        let small = Body::scripted(Shape::Cuboid { half: DVec3::splat(0.1) }, DVec3::ZERO, Motion::default());
        assert_eq!(Rigid::new(&small).samples(0.05).len(), 8 + 12 * 3);
    }
}
