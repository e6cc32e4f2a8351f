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
    /// Scratch: the second half's constraints and contacts while the halves are searched at once.
    later: (Vec<Constraint>, Vec<Active>),
}

/// What a search for contacts reads: the bodies where they are, the particles, the step.
struct Search<'a> {
    placed: &'a [Placed<'a>],
    params: ContactParams,
    x: &'a [DVec3],
    v: &'a [DVec3],
    held: &'a [bool],
    masses: &'a [f64],
    h: f64,
}

impl Contacts {
    /// No contacts, for `n` particles.
    pub fn new(n: usize) -> Self {
        Self { state: vec![ContactState::Free; n], active: Vec::new(), later: Default::default() }
    }

    /// Forget every contact.
    pub fn reset(&mut self) {
        self.state.fill(ContactState::Free);
        self.active.clear();
    }

    /// Find the contacts of particles at `x` with velocities `v` against `bodies` at time `t`, push their
    /// constraints, and add kinetic friction's impulse over the step of `h` to the step's right side
    /// `rhs`. Particles with `held[i]` are skipped. With `halves`, the two halves of the particles are
    /// searched at once ([`crate::threads::join`]) and their constraints pushed first half first: the
    /// same constraints in the same order as one search.
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
        halves: bool,
    ) {
        self.active.clear();
        if bodies.is_empty() {
            return;
        }
        let placed: Vec<Placed<'_>> = bodies.iter().map(|b| b.at(t)).collect();
        let search = Search { placed: &placed, params, x, v, held, masses, h };
        let Self { state, active, later } = self;
        if !halves {
            search.run(0, state, rhs, constraints, active);
            return;
        }
        let half = x.len() / 2;
        let (first_state, second_state) = state.split_at_mut(half);
        let (first_rhs, second_rhs) = rhs.split_at_mut(half);
        later.0.clear();
        later.1.clear();
        crate::threads::join(
            || search.run(0, first_state, first_rhs, constraints, active),
            || search.run(half, second_state, second_rhs, &mut later.0, &mut later.1),
        );
        constraints.append(&mut later.0);
        active.append(&mut later.1);
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

impl Search<'_> {
    /// The contacts of the particles `first..first + state.len()` (whose states and right sides are
    /// `state` and `rhs`), their constraints pushed to `constraints` and `active`.
    fn run(
        &self,
        first: usize,
        state: &mut [ContactState],
        rhs: &mut [DVec3],
        constraints: &mut Vec<Constraint>,
        active: &mut Vec<Active>,
    ) {
        let Self { placed, params, x, v, held, masses, h } = *self;
        for (k, (state, rhs)) in state.iter_mut().zip(rhs).enumerate() {
            let i = first + k;
            if held[i] {
                *state = ContactState::Free;
                continue;
            }
            let Some(c) = nearest(placed, x[i]) else { continue };
            let rel = v[i] - c.velocity;
            let vn = rel.dot(c.normal);
            let near = c.distance < params.margin || c.distance + h * vn < params.margin;
            *state = match (*state, near) {
                (_, false) => ContactState::Free,
                (ContactState::Released, true) if c.distance >= 0.0 && vn >= 0.0 => ContactState::Released,
                (ContactState::Free | ContactState::Released, true) if params.mu_s > 0.0 => ContactState::Stuck,
                // Without friction, locking would hand the particle the body's tangential velocity.
                (ContactState::Free | ContactState::Released, true) => ContactState::Sliding(0.0),
                (s, true) => s,
            };
            let target = (c.distance.clamp(0.0, params.margin) - c.distance) / h;
            let n = c.normal;
            match *state {
                ContactState::Free | ContactState::Released => {}
                ContactState::Stuck => {
                    let z = c.velocity + n * target - v[i];
                    constraints.push(Constraint { particle: i, filter: DMat3::ZERO, z });
                    active.push(Active { particle: i, normal: n, stopped: false });
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
                        *rhs -= tangential * (friction.min(limit) * h / speed);
                    }
                    active.push(Active { particle: i, normal: n, stopped });
                }
            }
        }
    }
}

/// Where `x` is relative to the body it is closest to (by signed distance in `total_cmp`'s order, the
/// first of equals: what `min_by` with it picks); `None` without bodies. A plain loop: as an
/// iterator's `min_by`, its running minimum went through memory at every body.
#[inline(always)]
fn nearest(bodies: &[Placed<'_>], x: DVec3) -> Option<Contact> {
    let mut best: Option<(&Placed<'_>, f64, DVec3)> = None;
    for body in bodies {
        let (distance, normal) = body.surface(x);
        if best.is_none_or(|(_, least, _)| distance.total_cmp(&least).is_lt()) {
            best = Some((body, distance, normal));
        }
    }
    let (body, distance, normal) = best?;
    Some(Contact { distance, normal, velocity: body.velocity_at(x) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::{Motion, Shape};

    #[test]
    fn the_halves_searched_apart_give_the_contacts_of_one_search() {
        // Particles around a moving, spinning ball over a floor, near and far, arriving and leaving,
        // in every state: the same constraints in the same order, states and right side, searched
        // whole and in two halves.
        let ball = Motion { velocity: DVec3::new(0.2, 0.0, 0.0), spin: DVec3::new(0.0, 3.0, 0.0), ..Motion::default() };
        let bodies = [
            Body::scripted(Shape::Sphere { radius: 0.25 }, DVec3::new(0.0, 0.3, 0.0), ball),
            Body::scripted(Shape::Plane { normal: DVec3::Y }, DVec3::ZERO, Motion::default()),
        ];
        let n = 301;
        let x: Vec<DVec3> = (0..n)
            .map(|i| {
                let (a, b) = (0.37 * i as f64, 0.11 * i as f64);
                DVec3::new(a.cos() * b.sin(), b.cos(), a.sin() * b.sin()) * (0.2 + 0.002 * (i % 70) as f64)
                    + DVec3::new(0.0, 0.3 - 0.001 * (i % 3) as f64, 0.0)
            })
            .collect();
        let v: Vec<DVec3> = (0..n).map(|i| DVec3::new((0.9 * i as f64).sin(), -0.5, 0.3) * 0.4).collect();
        let held: Vec<bool> = (0..n).map(|i| i % 17 == 0).collect();
        let masses = vec![1e-3; n];
        let params = ContactParams { margin: 0.01, mu_s: 0.5, mu_k: 0.4 };
        let states = [ContactState::Free, ContactState::Stuck, ContactState::Sliding(0.02), ContactState::Released];
        let searched: Vec<_> = [false, true]
            .map(|halves| {
                let mut contacts = Contacts::new(n);
                contacts.state.iter_mut().enumerate().for_each(|(i, s)| *s = states[i % 4]);
                let (mut rhs, mut constraints) = (vec![DVec3::ONE; n], Vec::new());
                contacts.constrain(
                    &bodies,
                    params,
                    (&x, &v, &held),
                    (0.1, 0.01),
                    &masses,
                    &mut rhs,
                    &mut constraints,
                    halves,
                );
                let active: Vec<(usize, DVec3, bool)> =
                    contacts.active.iter().map(|a| (a.particle, a.normal, a.stopped)).collect();
                (contacts.state, rhs, constraints, active)
            })
            .into_iter()
            .collect();
        let (whole, halves) = (&searched[0], &searched[1]);
        let kinds = |s: &[ContactState], k: fn(&ContactState) -> bool| s.iter().filter(|s| k(s)).count();
        let (stuck, sliding) = (
            kinds(&whole.0, |s| *s == ContactState::Stuck),
            kinds(&whole.0, |s| matches!(s, ContactState::Sliding(_))),
        );
        assert!(
            stuck > 10 && sliding > 10 && whole.2.len() < n / 2,
            "{stuck} stuck, {sliding} sliding, {} constrained",
            whole.2.len()
        );
        assert!(whole.1.iter().any(|r| *r != DVec3::ONE), "friction acted");
        assert_eq!(whole, halves);
    }

    #[test]
    fn the_nearest_body_is_the_one_min_by_picks_ties_and_all() {
        // A ball, and two floors at the same place moving apart (equal distances, different
        // velocities): the loop and `min_by` with `total_cmp` pick the same body everywhere.
        let floor = |vx: f64| Motion { velocity: DVec3::new(vx, 0.0, 0.0), ..Motion::default() };
        let bodies = [
            Body::scripted(Shape::Sphere { radius: 0.3 }, DVec3::new(0.0, 0.5, 0.0), Motion::default()),
            Body::scripted(Shape::Plane { normal: DVec3::Y }, DVec3::ZERO, floor(1.0)),
            Body::scripted(Shape::Plane { normal: DVec3::Y }, DVec3::ZERO, floor(-1.0)),
        ];
        let placed: Vec<Placed<'_>> = bodies.iter().map(|b| b.at(0.2)).collect();
        let mut floors = 0;
        for i in 0..400 {
            let x = DVec3::new((0.7 * i as f64).sin(), 0.9 * (0.3 * i as f64).cos() + 0.3, 0.1 * (i % 9) as f64);
            let (body, (distance, normal)) =
                placed.iter().map(|b| (b, b.surface(x))).min_by(|a, b| a.1.0.total_cmp(&b.1.0)).unwrap();
            let c = nearest(&placed, x).unwrap();
            assert_eq!((c.distance, c.normal, c.velocity), (distance, normal, body.velocity_at(x)), "{x}");
            floors += usize::from(c.velocity.x == 1.0);
        }
        assert!(floors > 50, "the first of the tied floors, {floors} times");
    }
}
