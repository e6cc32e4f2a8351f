//! Position-based cloth: `pbd` (Müller et al. 2007) and `xpbd` (Macklin, Müller & Chentanez 2016,
//! with the small substeps of Macklin et al. 2019), on any triangle mesh, behind the one [`Solver`].
//!
//! One step of `h` is `n` substeps of `h/n` (`pbd`: one). A substep: velocities take the external
//! forces (gravity, point loads, wind), positions are predicted `p = x + h v`; the colliders move
//! (scripted ones to their pose, dynamic ones by their velocity and gravity); contacts and
//! self-collision pairs are found; then `sweeps` Gauss–Seidel sweeps project every constraint in a
//! fixed order — stretch per boundary edge, then per interior edge each followed by its hinge's
//! bending (module `project`), the balloon's volume, contacts with bodies (and small bodies against the
//! cloth's triangles), self-collision — then friction against the bodies,
//! once, with the normal pushes of all the sweeps as its budget; and finally `v = (p − x)/h`, `x = p`,
//! and damping.
//!
//! - `pbd` projects `Δp_i = −k' w_i ∇_i C · C / Σ_j w_j |∇_j C|²` with the stiffness `k ∈ [0, 1]`
//!   corrected for the iteration count, `k' = 1 − (1 − k)^(1/n)`: the result still depends on the
//!   iteration count and the step, as the source warns (shown in the tests, not hidden).
//! - `xpbd` replaces `k` by a compliance `α` (inverse stiffness) with `α̃ = α/h²` and a multiplier `λ`
//!   per constraint, `Δλ = (−C − α̃λ)/(Σ w|∇C|² + α̃)`, `Δp_i = w_i ∇_i C Δλ`, so its stiffness is the
//!   physical one whatever the sweeps and substeps: `α = 1/k_s` for the edges (the cloth's
//!   springs) and `1/(k_b · 6|ē|²/(Ā₁ + Ā₂))` per hinge (the discrete shell's hinge energy with `k_b`
//!   as its stiffness), unless the scene gives compliances. An edge in compression (`C < 0`) has the
//!   compliance `α / compression` (`material.compression`, 1 by default): the implicit cloth's
//!   stretch springs take no compression (its buckling springs take it and soon give up), and edges
//!   as stiff in compression as in stretch keep a cloth of tiny bending stiffness from buckling into
//!   folds, so it crumples at the mesh's scale instead. With none at all the sheet collapses in its
//!   plane; the drape keeps 2%.
//!
//! Anchored and dragged particles have infinite mass (a dragged one is placed at its target).
//! Collisions: `contact`; self-collision: `self_collision`; bodies: `bodies`; the parameters: `params`.

#[cfg(target_arch = "x86_64")]
mod avx2_lanes;
mod batch;
mod bodies;
mod contact;
mod model;
mod narrow_phase;
mod near_least_area;
mod params;
mod project;
mod self_collision;
mod self_contact;
mod triangle_scan;
mod turned;

use std::time::Instant;

use glam::{DQuat, DVec3};

use self::batch::Rows;
use self::bodies::Rigid;
use self::contact::{SampleHit, Touch};
use self::model::Model;
use self::params::Settings;
use self::project::{Compliance, Multipliers, Stiffness};
use self::self_collision::{Flung, SelfCollision};
use crate::collision::Shape;
use crate::energy::constraints;
use crate::scene::Setup;
use crate::solver::wind::Wind;
use crate::solver::{DragKind, DragSet, ParamValue, Solver, SolverError, StepStats, check_finite};
use crate::solver::{Footprint, Method};

/// Cloths of at least this many triangles step with the pool's threads kept awake
/// ([`crate::solver::supersede::awake`]): about where their triangle scans and their sweeps' colours start to
/// run in halves (a smaller cloth would keep a thread spinning for nothing).
const PARALLEL_TRIANGLES: usize = 2048;

/// A self-collision search over `model`'s cloth at rest, with nothing found yet.
fn fresh_self_collision(model: &Model) -> SelfCollision {
    let edges = model.edges.iter().map(|e| e.v).collect();
    SelfCollision::new(&model.rest, &model.triangles, edges, model.mean_edge)
}

/// Refuse a cloth that starts deep inside a collider that stands still (deeper than a tenth
/// of its size): its projection out would launch it at metres per step, crumple it onto itself and
/// make every self-collision query meet every particle (a mutated pile scene with its strip half in
/// the ground took 6 s a step).
fn starts_outside(setup: &Setup, size: f64) -> Result<(), String> {
    let anchored: std::collections::HashSet<usize> = setup.anchors.iter().copied().collect();
    for (i, body) in setup.bodies.iter().enumerate().filter(|(_, b)| b.mass.is_none() && !b.is_moving()) {
        let free = setup.mesh.positions().iter().enumerate().filter(|(v, _)| !anchored.contains(v));
        let deepest = free.map(|(v, &x)| (v, body.contact(x, 0.0).distance)).min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((v, d)) = deepest.filter(|&(_, d)| d < -0.1 * size) {
            return Err(format!(
                "vertex {v} starts {:.3} m inside colliders[{i}] (more than a tenth of the cloth's size): \
                 move the cloth out (placement.translate)",
                -d
            ));
        }
    }
    Ok(())
}

/// Registry entry of position-based dynamics.
pub const PBD: Method = Method {
    name: "pbd",
    summary: "position-based cloth (Müller et al. 2007): stretch, dihedral bending, k ∈ [0, 1] per iteration, contacts, self-collision, balloons, dynamic bodies",
    build: |setup| Ok(Box::new(Pbd::new(setup, Variant::Pbd)?)),
    footprint: Footprint::PARTICLES,
};

/// Registry entry of extended position-based dynamics.
pub const XPBD: Method = Method {
    name: "xpbd",
    summary: "extended position-based cloth (Macklin et al. 2016, 2019): compliance instead of stiffness, small substeps; contacts, self-collision, balloons, dynamic bodies",
    build: |setup| Ok(Box::new(Pbd::new(setup, Variant::Xpbd)?)),
    footprint: Footprint::PARTICLES,
};

/// Which projection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// Stiffness per iteration (Müller et al. 2007).
    Pbd,
    /// Compliance with multipliers (Macklin et al. 2016).
    Xpbd,
}

/// The position-based cloth.
#[derive(Clone)]
pub struct Pbd {
    variant: Variant,
    model: Model,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    p: Vec<DVec3>,
    w: Vec<f64>,
    /// Gravity and point loads on each particle (set each frame), N.
    weights: Vec<DVec3>,
    /// Those plus the wind's force, when there is wind, N.
    forces: Vec<DVec3>,
    bodies: Vec<Rigid>,
    initial_bodies: Vec<Rigid>,
    self_collision: Option<SelfCollision>,
    wind: Wind,
    drags: DragSet,
    settings: Settings,
    /// Twice each rest area, also packed for the scan of which triangles start a substep near the
    /// least area; and those triangles (scratch).
    double_areas: Vec<f64>,
    areas: near_least_area::Areas,
    shrunk: Vec<u32>,
    // Scratch.
    rows: Rows,
    /// The substep's start as rows, for self-collision's test of its flat patches and the least
    /// area's of the triangles near it.
    start_rows: Rows,
    multipliers: Multipliers,
    gradient: Vec<DVec3>,
    touches: Vec<Touch>,
    samples: Vec<SampleHit>,
    near: Vec<(usize, usize)>,
    time: f64,
    steps: u64,
    energy_limit: f64,
}

impl Pbd {
    /// Build from a scene.
    pub fn new(setup: &Setup, variant: Variant) -> Result<Self, SolverError> {
        let model = Model::new(setup)?;
        let m = &setup.scene.material;
        let s = &setup.scene.solver;
        let method = if variant == Variant::Pbd { PBD.name } else { XPBD.name };
        if let Some(k) = m.k_pressure
            && !model.is_closed()
        {
            return Err(SolverError::Unsuitable {
                method,
                reason: format!("material.k_pressure = {k} needs a closed mesh, and this mesh is not closed"),
            });
        }
        let settings = Settings::new(variant, setup, model.mean_edge)?;
        let n = model.rest.len();
        let bodies: Vec<Rigid> = setup.bodies.iter().map(Rigid::new).collect();
        let size = {
            let (lo, hi) = setup.mesh.bounding_box();
            (hi - lo).length().max(1e-3)
        };
        starts_outside(setup, size).map_err(|reason| SolverError::Unsuitable { method, reason })?;
        let double_areas: Vec<f64> =
            model.triangles.iter().map(|t| 2.0 * crate::mesh::area_of(&model.rest, t)).collect();
        let total_mass: f64 =
            model.areas.iter().sum::<f64>() * m.density + setup.bodies.iter().filter_map(|b| b.mass).sum::<f64>();
        let mut solver = Self {
            variant,
            x: model.rest.clone(),
            v: vec![DVec3::ZERO; n],
            p: model.rest.clone(),
            w: vec![0.0; n],
            weights: vec![DVec3::ZERO; n],
            forces: vec![DVec3::ZERO; n],
            initial_bodies: bodies.clone(),
            bodies,
            self_collision: s.self_collision.then(|| fresh_self_collision(&model)),
            wind: Wind::of(setup)?,
            drags: DragSet::new(n, false),
            settings,
            areas: near_least_area::Areas::new(&model.triangles, &double_areas),
            double_areas,
            shrunk: Vec::new(),
            rows: Rows::default(),
            start_rows: Rows::default(),
            multipliers: Multipliers::new(&model),
            gradient: vec![DVec3::ZERO; n],
            touches: Vec::new(),
            samples: Vec::new(),
            near: Vec::new(),
            time: 0.0,
            steps: 0,
            energy_limit: 1e6 * (total_mass * setup.gravity().length().max(9.81) * 10.0 * size).max(1e-3),
            model,
        };
        solver.update_masses();
        Ok(solver)
    }

    fn method_name(&self) -> &'static str {
        match self.variant {
            Variant::Pbd => PBD.name,
            Variant::Xpbd => XPBD.name,
        }
    }

    /// Inverse masses (anchored and dragged particles have none), and each particle's weight with its
    /// point load.
    fn update_masses(&mut self) {
        for (i, w) in self.w.iter_mut().enumerate() {
            let m = self.model.areas[i] * self.settings.density;
            *w = if self.model.anchored[i] || m <= 0.0 { 0.0 } else { 1.0 / m };
            self.weights[i] = self.settings.gravity * m + self.model.loads[i];
        }
        for (_, d) in self.drags.iter() {
            self.w[d.vertex] = 0.0;
        }
    }

    /// A particle deeper inside a scripted collider than an edge is long has gone through it: the
    /// substeps are too few for the speeds (a fine strip hitting the ground, say). The state stays
    /// finite, so this is reported as the divergence it is instead of crumpling on.
    fn check_penetration(&self) -> Result<(), SolverError> {
        let depth = self.model.mean_edge;
        for (b, body) in self.bodies.iter().enumerate().filter(|(_, b)| !b.is_dynamic()) {
            let inside = (0..self.x.len()).filter(|&i| self.w[i] > 0.0).find_map(|i| {
                let d = body.surface(self.x[i]).0;
                (d < -depth).then_some((i, d))
            });
            if let Some((i, d)) = inside {
                return Err(SolverError::Diverged {
                    step: self.steps,
                    time: self.time,
                    reason: format!(
                        "particle {i} is {:.1} mm inside collider {b}, more than an edge ({:.1} mm): too few \
                         substeps for its speed",
                        -1e3 * d,
                        1e3 * depth
                    ),
                });
            }
        }
        Ok(())
    }

    /// One substep of `h` ending at time `t`; refused when the cloth is flying apart ([`Flung`]).
    fn substep(&mut self, h: f64, t: f64) -> Result<(), Flung> {
        // External forces, prediction.
        let forces = if self.wind.is_calm() {
            &self.weights
        } else {
            self.forces.copy_from_slice(&self.weights);
            self.wind.add_forces(t - h, &self.x, &self.v, &self.model.triangles, &mut self.forces);
            &self.forces
        };
        let (x, v, p) = (&self.x, &mut self.v, &mut self.p);
        for ((((v, p), x), f), &w) in v.iter_mut().zip(p.iter_mut()).zip(x).zip(forces).zip(&self.w) {
            *v += *f * (w * h);
            *p = if w > 0.0 { *x + *v * h } else { *x };
        }
        for (_, d) in self.drags.iter() {
            if let DragKind::Position(target) = d.kind {
                self.p[d.vertex] = target;
            }
        }
        for b in &mut self.bodies {
            b.predict(t, h, self.settings.gravity);
        }
        if self.settings.least_area > 0.0 || self.self_collision.is_some() {
            self.start_rows.fill(&self.x, &self.w);
        }
        if self.settings.least_area > 0.0 {
            self.areas.under(self.start_rows.indexed(), 2.0 * self.settings.least_area, &mut self.shrunk);
        }
        self.rows.fill(&self.p, &self.w);
        self.detect(h)?;
        let (alpha_stretch, alpha_bend) = self.settings.compliances();
        let sweeps = self.settings.sweeps as f64;
        let correction = |k: f64| 1.0 - (1.0 - k).powf(1.0 / sweeps);
        for sweep in 0..self.settings.sweeps {
            let (first, last) = (sweep == 0, sweep + 1 == self.settings.sweeps);
            if !first {
                self.rows.fill(&self.p, &self.w);
            }
            let (rows, m, lambda) = (&mut self.rows, &self.model, &mut self.multipliers);
            match self.variant {
                Variant::Pbd => {
                    let (stretch, bend) =
                        (correction(self.settings.stiffness.0), correction(self.settings.stiffness.1));
                    let bend = (bend > 0.0).then_some((0.0, Stiffness(bend)));
                    // PBD's rule does not read the multipliers: none is kept.
                    project::sweep(m, rows, lambda, (true, true), (0.0, Stiffness(stretch)), bend);
                }
                Variant::Xpbd => {
                    let (stretch, bend) = (alpha_stretch / (h * h), alpha_bend / (h * h));
                    let bend = bend.is_finite().then_some((bend, Compliance::SYMMETRIC));
                    // An edge free in compression still gets a (very large) finite compliance: its
                    // multiplier relaxes to zero instead of dividing by infinity.
                    let compressed = 1.0 / self.settings.compression.max(1e-12);
                    project::sweep(m, rows, lambda, (first, last), (stretch, Compliance { compressed }), bend);
                }
            }
            self.rows.read(&mut self.p);
            let (p, w) = (&mut self.p, &self.w);
            if let (Some(v0), true) = (self.model.six_volume, self.settings.k_pressure > 0.0) {
                project::volume(&self.model.triangles, p, w, self.settings.k_pressure * v0, &mut self.gradient);
            }
            self.collide(h);
        }
        for touch in self.touches.iter().filter(|t| t.pushed > 0.0) {
            let i = touch.particle;
            let body = &mut self.bodies[touch.body];
            contact::particle_friction(&mut self.p[i], self.x[i], self.w[i], body, touch.pushed, h, self.settings.mu);
        }
        if self.settings.least_area > 0.0 {
            project::least_area(
                &self.model.triangles,
                &self.shrunk,
                &self.x,
                &mut self.p,
                &self.w,
                &self.double_areas,
                self.settings.least_area,
            );
        }
        // The last word goes to self-collision: the cloth must not end the substep through itself.
        if let Some(sc) = &self.self_collision {
            sc.project(&mut self.p, &self.w, &self.model.triangles, self.settings.thickness);
        }
        // Velocities from positions; friction; damping.
        let keep = (1.0 - self.settings.damping * h).max(0.0);
        // Damping waits for the self-contacts to settle, if there are any.
        let settling = self.self_collision.as_ref().filter(|sc| sc.active() > 0);
        let now = if settling.is_some() { 1.0 } else { keep };
        let scale = now / h;
        for (((v, x), p), &w) in self.v.iter_mut().zip(self.x.iter_mut()).zip(&self.p).zip(&self.w) {
            *v = if w > 0.0 { (*p - *x) * scale } else { DVec3::ZERO };
            *x = *p;
        }
        if let Some(sc) = settling {
            sc.settle(&self.x, &mut self.v, &self.w, &self.model.triangles, self.settings.thickness);
            self.v.iter_mut().for_each(|v| *v *= keep);
        }
        for b in &mut self.bodies {
            b.finish(h);
            b.damp(keep);
        }
        Ok(())
    }

    /// Find this substep's contacts: particles near bodies, small bodies near triangles, and the
    /// self-collision pairs (whose test of the flat patches reads the predicted positions from the
    /// sweep's rows, so they are filled first). Refused when the cloth is flying apart ([`Flung`]).
    fn detect(&mut self, h: f64) -> Result<(), Flung> {
        self.touches.clear();
        self.samples.clear();
        self.near.clear();
        let reach = |v: DVec3| self.settings.thickness + v.length() * h + 0.5 * self.model.mean_edge;
        // No bodies, no pass over the particles (1.3% of the 10,000-particle hanging sheet's frame).
        if !self.bodies.is_empty() {
            for i in 0..self.x.len() {
                if self.w[i] == 0.0 {
                    continue;
                }
                for (b, body) in self.bodies.iter().enumerate() {
                    if body.surface(self.p[i]).0 < reach(self.v[i] - body.velocity_at(self.p[i])) {
                        self.touches.push(Touch { particle: i, body: b, pushed: 0.0 });
                    }
                }
            }
        }
        // Small bodies against triangles: the triangles near a ball or a box.
        let spacing = 0.5 * self.model.mean_edge;
        for (b, body) in self.bodies.iter().enumerate() {
            let Some(radius) = body.body.shape.bounding_radius() else { continue };
            let margin = radius + self.settings.thickness + body.velocity.length() * h + self.model.mean_edge;
            let samples = body.samples(spacing);
            for (t, tri) in self.model.triangles.iter().enumerate() {
                let centroid = tri.iter().map(|&i| self.p[i]).sum::<DVec3>() / 3.0;
                let size = tri.iter().map(|&i| (self.p[i] - centroid).length()).fold(0.0, f64::max);
                if (centroid - body.centre).length() > margin + size {
                    continue;
                }
                self.near.push((b, t));
                let [a, bb, c] = tri.map(|i| self.x[i]);
                let normal = (bb - a).cross(c - a);
                for s in &samples {
                    // The side each sample starts on, relative to the triangle's start position.
                    let side = if (*s - a).dot(normal) >= 0.0 { 1.0 } else { -1.0 };
                    let local = body.rotation.inverse() * (*s - body.centre);
                    self.samples.push(SampleHit { body: b, local, triangle: t, side });
                }
            }
        }
        if let Some(sc) = &mut self.self_collision {
            let rows = [self.start_rows.indexed(), self.rows.indexed()];
            sc.find([&self.x, &self.p], rows, &self.model.triangles, self.settings.thickness)?;
        }
        Ok(())
    }

    /// One sweep over the contacts and self-collision pairs (of a substep of `h`).
    fn collide(&mut self, h: f64) {
        for touch in &mut self.touches {
            let i = touch.particle;
            let body = &mut self.bodies[touch.body];
            touch.pushed += contact::push_particle(&mut self.p[i], self.w[i], body, self.settings.thickness);
        }
        for &(b, t) in &self.near {
            if let Shape::Sphere { radius } = self.bodies[b].body.shape {
                let tri = self.model.triangles[t];
                contact::push_sphere(&mut self.bodies[b], radius, &mut self.p, &self.w, tri, self.settings.thickness);
            }
        }
        for hit in &self.samples {
            let tri = self.model.triangles[hit.triangle];
            contact::push_sample(&mut self.bodies[hit.body], hit, &mut self.p, &self.w, tri, self.settings.thickness);
        }
        // Dynamic bodies against the scripted colliders (the ground).
        for b in 0..self.bodies.len() {
            if !self.bodies[b].is_dynamic() {
                continue;
            }
            for g in 0..self.bodies.len() {
                if g != b && !self.bodies[g].is_dynamic() {
                    let (body, ground) = if b < g {
                        let (l, r) = self.bodies.split_at_mut(g);
                        (&mut l[b], &r[0])
                    } else {
                        let (l, r) = self.bodies.split_at_mut(b);
                        (&mut r[0], &l[g])
                    };
                    contact::push_body(body, ground, h, self.settings.mu);
                }
            }
        }
        if let Some(sc) = &self.self_collision {
            sc.project(&mut self.p, &self.w, &self.model.triangles, self.settings.thickness);
        }
    }

    /// Kinetic + gravitational (relative to rest) + stretch energy, J; and the largest strain of an
    /// edge (both from one pass over the edges).
    fn energy_and_strain(&self) -> (f64, f64) {
        let mut e = 0.0;
        for i in 0..self.x.len() {
            let m = self.model.areas[i] * self.settings.density;
            e += 0.5 * m * self.v[i].length_squared() - m * self.settings.gravity.dot(self.x[i] - self.model.rest[i]);
        }
        let k = match self.variant {
            Variant::Xpbd => 1.0 / self.settings.compliances().0,
            Variant::Pbd => self.settings.k_s,
        };
        let mut strain = 0.0f64;
        for edge in &self.model.edges {
            let c = constraints::stretch(self.x[edge.v[0]], self.x[edge.v[1]], edge.rest).0;
            e += 0.5 * k * c * c;
            strain = strain.max(c.abs() / edge.rest);
        }
        (e + self.bodies.iter().map(Rigid::kinetic_energy).sum::<f64>(), strain)
    }

    /// Total linear momentum of the cloth, kg·m/s.
    pub fn cloth_momentum(&self) -> DVec3 {
        self.v.iter().zip(&self.model.areas).map(|(v, a)| *v * (a * self.settings.density)).sum()
    }

    /// Linear momentum of collider `i` (zero for a scripted one), kg·m/s.
    pub fn body_momentum(&self, i: usize) -> DVec3 {
        self.bodies.get(i).map_or(DVec3::ZERO, Rigid::momentum)
    }
}

impl Solver for Pbd {
    fn method(&self) -> &'static str {
        self.method_name()
    }

    fn time_step(&self) -> f64 {
        self.settings.step
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.update_masses();
        let h = self.settings.step / self.settings.substeps as f64;
        // On a pool thread with the others awake, so that the joins of the scans, the search and the
        // sweeps hand their halves to another one at once; the substeps' checkpoints stop as this
        // thread's run would.
        crate::solver::supersede::awake(self.model.triangles.len() >= PARALLEL_TRIANGLES, || {
            for k in 1..=self.settings.substeps {
                crate::solver::supersede::checkpoint();
                let t = self.time + h * k as f64;
                self.substep(h, t).map_err(|Flung { vertices }| {
                    let reason = format!(
                        "{vertices} particles moved farther than ten times the cloth's size, or to a non-finite \
                         place, in one substep"
                    );
                    SolverError::Diverged { step: self.steps + 1, time: t, reason }
                })?;
            }
            Ok::<(), SolverError>(())
        })?;
        self.time += self.settings.step;
        self.steps += 1;
        let (energy, strain) = self.energy_and_strain();
        check_finite(self.steps, self.time, &self.x, energy, self.energy_limit)?;
        self.check_penetration()?;
        Ok(StepStats {
            wall_seconds: start.elapsed().as_secs_f64(),
            sim_time: self.time,
            energy,
            residual: strain,
            iterations: (self.settings.sweeps * self.settings.substeps) as u32,
            ..StepStats::default()
        })
    }

    fn positions(&self) -> &[DVec3] {
        &self.x
    }

    fn reset(&mut self) {
        self.x.clone_from(&self.model.rest);
        self.v.fill(DVec3::ZERO);
        // The search's anchors and pairs belong to the last state (non-finite after a divergence,
        // which would keep the cloth from ever being searched again).
        if self.self_collision.is_some() {
            self.self_collision = Some(fresh_self_collision(&self.model));
        }
        self.bodies.clone_from(&self.initial_bodies);
        self.time = 0.0;
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        self.param_values()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        self.set(name, value)
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }

    fn body_poses(&self) -> Vec<(DVec3, DQuat)> {
        if self.bodies.iter().any(Rigid::is_dynamic) {
            self.bodies.iter().map(|b| (b.centre, b.rotation)).collect()
        } else {
            Vec::new()
        }
    }

    fn info(&self) -> Vec<(&'static str, f64)> {
        let mut info = vec![("contacts", self.touches.len() as f64)];
        if let Some(sc) = &self.self_collision {
            info.push(("self-collision pairs", (sc.pairs.len() + sc.edge_pairs.len()) as f64));
            info.push(("self-collision pairs in reach", sc.active() as f64));
            info.push(("self-collision searches", sc.searches as f64));
            info.push(("self-collision renewals", sc.renewals as f64));
        }
        info
    }
}
