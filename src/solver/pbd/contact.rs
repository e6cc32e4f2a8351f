//! Contacts between the cloth and the colliders, as inequality constraints solved with the others.
//!
//! - A particle stays `thickness` outside every body: `C = d(p) − h ≥ 0` along the body's outward
//!   normal. Against a dynamic body the correction is shared by the particle and the body in
//!   proportion to their (generalised) inverse masses, so the body receives the opposite impulse.
//! - A small body must not slip between cloth vertices: a sphere keeps its radius (plus `h`) from
//!   the closest point of every nearby triangle, and a box's corners and points along its edges keep
//!   `h` from every nearby triangle on the side they started on; the triangle's share of the
//!   correction goes to its vertices by their barycentric weights.
//! - Friction with each push of a particle: its slip over the substep relative to the body's surface
//!   is undone while within `μ_s` times the normal correction, and shortened by `μ_k` times it
//!   otherwise (Macklin et al. 2014's position-level Coulomb law); the body gets the opposite impulse.

use glam::DVec3;

use super::bodies::Rigid;
use crate::collision::closest::closest_on_triangle;

/// A particle touching (or about to touch) a body during a substep, and the normal correction it got.
#[derive(Debug, Clone, Copy)]
pub struct Touch {
    /// The particle.
    pub particle: usize,
    /// The body.
    pub body: usize,
    /// Accumulated normal correction over the substep, m.
    pub pushed: f64,
}

/// A body sample (a box's corner or edge point, in the body frame) against a cloth triangle, with the
/// side it started on.
#[derive(Debug, Clone, Copy)]
pub struct SampleHit {
    /// The body.
    pub body: usize,
    /// The sample in the body frame.
    pub local: DVec3,
    /// The triangle.
    pub triangle: usize,
    /// +1 above the triangle's front, −1 below.
    pub side: f64,
}

/// Push particle `p` (inverse mass `w`) out of `body` to `thickness`. Returns the normal correction.
pub fn push_particle(p: &mut DVec3, w: f64, body: &mut Rigid, thickness: f64) -> f64 {
    let (d, n) = body.surface(*p);
    let c = d - thickness;
    if c >= 0.0 {
        return 0.0;
    }
    let contact = *p - n * d;
    let wb = body.inverse_mass_at(contact, n);
    let lambda = -c / (w + wb);
    *p += n * (w * lambda);
    body.apply_position_impulse(contact, -n * lambda);
    w * lambda
}

/// Coulomb friction at the position level (Macklin et al. 2014), once per substep of `h` after its
/// sweeps, for particle `p` (inverse mass `w`, at `start` when the substep began) that `body` pushed
/// by `pushed` in all over them: its slip over the substep relative to the body's surface is undone
/// while within `μ_s · pushed`, and shortened by `μ_k · pushed` otherwise. (Per sweep, the budget
/// would be the sweep's own push, which the sweeps after the first hardly give: a cloth would creep
/// off a ball its friction holds.)
pub fn particle_friction(p: &mut DVec3, start: DVec3, w: f64, body: &mut Rigid, pushed: f64, h: f64, mu: (f64, f64)) {
    let (d, n) = body.surface(*p);
    let contact = *p - n * d;
    let slip = (*p - start) - body.velocity_at(contact) * h;
    let tangential = slip - n * slip.dot(n);
    let length = tangential.length();
    if length > 0.0 {
        let undo = coulomb(length, pushed, mu);
        let t = tangential / length;
        let wt = body.inverse_mass_at(contact, t);
        let share = undo / (w + wt);
        *p -= t * (w * share);
        body.apply_position_impulse(contact, t * share);
    }
}

/// Keep a sphere body `radius + thickness` away from triangle `t` (vertex inverse masses `w`).
pub fn push_sphere(body: &mut Rigid, radius: f64, p: &mut [DVec3], w: &[f64], t: [usize; 3], thickness: f64) {
    let (b, _) = closest_on_triangle(body.centre, t.map(|i| p[i]));
    let q = p[t[0]] * b[0] + p[t[1]] * b[1] + p[t[2]] * b[2];
    let d = body.centre - q;
    let dist = d.length();
    let c = dist - (radius + thickness);
    if c >= 0.0 || dist == 0.0 {
        return;
    }
    let n = d / dist;
    let wt: f64 = (0..3).map(|k| b[k] * b[k] * w[t[k]]).sum();
    let contact = body.centre - n * radius;
    let wb = body.inverse_mass_at(contact, n);
    if wt + wb == 0.0 {
        return;
    }
    let lambda = -c / (wt + wb);
    (0..3).for_each(|k| p[t[k]] -= n * (b[k] * w[t[k]] * lambda));
    body.apply_position_impulse(contact, n * lambda);
}

/// Keep a body sample `thickness` from its triangle on its side, where it lies over the triangle.
pub fn push_sample(body: &mut Rigid, hit: &SampleHit, p: &mut [DVec3], w: &[f64], t: [usize; 3], thickness: f64) {
    let s = body.centre + body.rotation * hit.local;
    let [a, b, c] = t.map(|i| p[i]);
    let normal = (b - a).cross(c - a);
    let len = normal.length();
    if len == 0.0 {
        return;
    }
    let n = normal / len * hit.side;
    let (bary, _) = closest_on_triangle(s, [a, b, c]);
    // Only over the triangle's interior (its edges and corners belong to its neighbours).
    if bary.iter().any(|&x| x <= 0.0) {
        return;
    }
    let cval = (s - a).dot(n) - thickness;
    if cval >= 0.0 {
        return;
    }
    let wt: f64 = (0..3).map(|k| bary[k] * bary[k] * w[t[k]]).sum();
    let wb = body.inverse_mass_at(s, n);
    if wt + wb == 0.0 {
        return;
    }
    let lambda = -cval / (wt + wb);
    (0..3).for_each(|k| p[t[k]] -= n * (bary[k] * w[t[k]] * lambda));
    body.apply_position_impulse(s, n * lambda);
}

/// Keep dynamic `body` out of the scripted collider `ground` (a plane, a still ball or mesh) at its
/// contact points, with the same position-level friction as the cloth's (so a ball rolls).
pub fn push_body(body: &mut Rigid, ground: &Rigid, h: f64, mu: (f64, f64)) {
    for point in body.contact_points(ground) {
        let (d, n) = ground.surface(point);
        if d >= 0.0 {
            continue;
        }
        let w = body.inverse_mass_at(point, n);
        if w == 0.0 {
            continue;
        }
        let lambda = -d / w;
        body.apply_position_impulse(point, n * lambda);
        let moved = point + n * (-d);
        let slip = (moved - body.previous_point(point)) - ground.velocity_at(point) * h;
        let tangential = slip - n * slip.dot(n);
        let length = tangential.length();
        if length > 0.0 {
            let undo = coulomb(length, -d, mu);
            let t = tangential / length;
            let wt = body.inverse_mass_at(moved, t);
            body.apply_position_impulse(moved, -t * (undo / wt));
        }
    }
}

/// How much of a tangential slip of `length` Coulomb friction undoes for a normal push of `pushed`:
/// all of it while within `μ_s · pushed` (sticking), else `μ_k · pushed` of it (sliding).
fn coulomb(length: f64, pushed: f64, (mu_s, mu_k): (f64, f64)) -> f64 {
    if length <= mu_s * pushed { length } else { (mu_k * pushed).min(length) }
}
