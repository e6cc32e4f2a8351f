//! Cloth–body contact as constraints on the velocity change (Noh & Jung §4, after Baraff & Witkin).
//!
//! Each step, a particle whose distance `d` to a body is below the margin — or will be by the end of
//! the step at its current relative normal velocity — is constrained. Its relative normal velocity
//! after the step is set to `(clamp(d, 0, margin) − d)/h`: zero inside the margin (locking: it takes
//! the body's velocity), just enough to reach the margin when arriving from further out, and the
//! recovery of the penetration `−d` when it went inside. The state machine per particle:
//!
//! - **stuck** (static friction, and every new contact if `μ_s > 0`): all three components
//!   prescribed, `S = 0`.
//! - **sliding** (and every new contact if `μ_s = 0`, which could not hold a locked particle and must
//!   not hand it the body's tangential velocity): only the normal component prescribed, `S = I − n̂n̂ᵀ`; kinetic friction
//!   `μ_k N` opposes the relative tangential velocity (explicit, limited so that it can stop the
//!   particle within the step but never reverse it; when it stops it, the particle sticks again).
//! - **released**: after the constraint force pulled toward the body; free while it moves away.
//!
//! After the solve the constraint force `f_c = (A Δv − b)/h` decides the next state: a pull
//! (`f_c·n̂ < 0`) releases; a stuck particle whose tangential force exceeds `μ_s` times the normal
//! force starts sliding with normal force `N = f_c·n̂`.

use glam::{DMat3, DVec3};

use crate::collision::{Body, Contact, Placed};
use crate::energy::hinge::outer;
use crate::linalg::filtered_pcg::Constraint;

/// Contact state of one particle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ContactState {
    /// Not in contact.
    #[default]
    Free,
    /// Locked to the body (static friction).
    Stuck,
    /// Sliding on the body with this normal force (in the solve's scaled units).
    Sliding(f64),
    /// Let go after a pulling constraint force; free while it separates.
    Released,
}

/// Friction coefficients and margin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Contact margin, m.
    pub margin: f64,
    /// Static friction coefficient.
    pub mu_s: f64,
    /// Kinetic friction coefficient.
    pub mu_k: f64,
}

/// One active contact of this step.
#[derive(Debug, Clone, Copy)]
struct Active {
    particle: usize,
    normal: DVec3,
    /// Whether kinetic friction was limited to stopping the particle this step.
    stopped: bool,
}

/// The contact states of all particles.
#[derive(Debug, Clone)]
pub struct Contacts {
    state: Vec<ContactState>,
    active: Vec<Active>,
}

impl Contacts {
    /// No contacts, for `n` particles.
    pub fn new(n: usize) -> Self {
        Self { state: vec![ContactState::Free; n], active: Vec::new() }
    }

    /// Forget every contact.
    pub fn reset(&mut self) {
        self.state.fill(ContactState::Free);
        self.active.clear();
    }

    /// Find the contacts of particles at `x` with velocities `v` against `bodies` at time `t`, push their
    /// constraints, and add kinetic friction's impulse over the step of `h` to the step's right side
    /// `rhs`. Particles with `held[i]` are skipped.
    #[allow(clippy::too_many_arguments)]
    pub fn constrain(
        &mut self,
        bodies: &[Body],
        params: ContactParams,
        (x, v, held): (&[DVec3], &[DVec3], &[bool]),
        (t, h): (f64, f64),
        masses: &[f64],
        rhs: &mut [DVec3],
        constraints: &mut Vec<Constraint>,
    ) {
        self.active.clear();
        if bodies.is_empty() {
            return;
        }
        let placed: Vec<Placed<'_>> = bodies.iter().map(|b| b.at(t)).collect();
        for i in 0..x.len() {
            if held[i] {
                self.state[i] = ContactState::Free;
                continue;
            }
            let Some(c) = nearest(&placed, x[i]) else { continue };
            let rel = v[i] - c.velocity;
            let vn = rel.dot(c.normal);
            let near = c.distance < params.margin || c.distance + h * vn < params.margin;
            let state = match (self.state[i], near) {
                (_, false) => ContactState::Free,
                (ContactState::Released, true) if c.distance >= 0.0 && vn >= 0.0 => ContactState::Released,
                (ContactState::Free | ContactState::Released, true) if params.mu_s > 0.0 => ContactState::Stuck,
                // Without friction, locking would hand the particle the body's tangential velocity.
                (ContactState::Free | ContactState::Released, true) => ContactState::Sliding(0.0),
                (s, true) => s,
            };
            self.state[i] = state;
            let target = (c.distance.clamp(0.0, params.margin) - c.distance) / h;
            let n = c.normal;
            match state {
                ContactState::Free | ContactState::Released => {}
                ContactState::Stuck => {
                    let z = c.velocity + n * target - v[i];
                    constraints.push(Constraint { particle: i, filter: DMat3::ZERO, z });
                    self.active.push(Active { particle: i, normal: n, stopped: false });
                }
                ContactState::Sliding(normal_force) => {
                    let z = n * (c.velocity.dot(n) + target - v[i].dot(n));
                    constraints.push(Constraint { particle: i, filter: DMat3::IDENTITY - outer(n, n), z });
                    let tangential = rel - n * vn;
                    let speed = tangential.length();
                    let mut stopped = false;
                    if speed > 0.0 {
                        let limit = masses[i] * speed / h;
                        let friction = params.mu_k * normal_force.max(0.0);
                        stopped = friction >= limit;
                        rhs[i] -= tangential * (friction.min(limit) * h / speed);
                    }
                    self.active.push(Active { particle: i, normal: n, stopped });
                }
            }
        }
    }

    /// Decide the next states from the solve's residual `b − A Δv` (per particle), whose constrained
    /// part is minus the constraint impulse.
    pub fn update(&mut self, params: ContactParams, residual: &[DVec3], h: f64) {
        for a in &self.active {
            let f = -residual[a.particle] / h;
            let normal = f.dot(a.normal);
            let tangential = (f - a.normal * normal).length();
            self.state[a.particle] = match self.state[a.particle] {
                _ if normal < 0.0 => ContactState::Released,
                ContactState::Stuck if tangential > params.mu_s * normal => ContactState::Sliding(normal),
                ContactState::Sliding(_) if a.stopped => ContactState::Stuck,
                ContactState::Sliding(_) => ContactState::Sliding(normal),
                s => s,
            };
        }
    }
}

/// Where `x` is relative to the body it is closest to (by signed distance); `None` without bodies.
fn nearest(bodies: &[Placed<'_>], x: DVec3) -> Option<Contact> {
    let (body, (distance, normal)) = bodies.iter().map(|b| (b, b.surface(x))).min_by(|a, b| a.1.0.total_cmp(&b.1.0))?;
    Some(Contact { distance, normal, velocity: body.velocity_at(x) })
}
