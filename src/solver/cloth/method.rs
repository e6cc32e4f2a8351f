//! `cloth` and `cloth-quad`: the implicit particle cloth stepped by backward Euler, linearised once
//! per step and solved by the filtered PCG, with anchors, drags and body contacts as constraints.

use std::time::Instant;

use glam::DVec3;

use super::contact::{ContactParams, Contacts};
use super::graph::SpringGraph;
use super::system::{ClothSystem, SpringParams, SpringState};
use crate::collision::Body;
use crate::linalg::filtered_pcg::{self, Constraint, PcgReport, Stop};
use crate::linalg::padded::PaddedMat3;
use crate::scene::{MeshSource, Setup};
use crate::solver::params::shared::{DENSITY, GRAVITY_Y};
use crate::solver::params::{self, Param, Redo};
use crate::solver::wind::Wind;
use crate::solver::{DragKind, DragSet, ParamSpec, ParamValue, Solver, SolverError, StepStats, check_finite};
use crate::solver::{Footprint, Method};

/// Registry entry of the triangle-mesh cloth (Noh & Jung).
pub const CLOTH: Method = Method {
    name: "cloth",
    summary: "implicit particle cloth on triangle meshes: stretch + buckling springs, valence weights, filtered PCG, contact with friction",
    build: |setup| Ok(Box::new(Cloth::new(setup, Variant::Triangles)?)),
    footprint: Footprint::PARTICLES,
};

/// Registry entry of Choi & Ko's original on a regular quad grid.
pub const CLOTH_QUAD: Method = Method {
    name: "cloth-quad",
    summary: "Choi & Ko's particle cloth on a regular grid (first and second neighbours); needs a `grid` mesh",
    build: |setup| Ok(Box::new(Cloth::new(setup, Variant::Quads)?)),
    footprint: Footprint::PARTICLES,
};

/// Which neighbour structure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Variant {
    /// Edge and diagonal neighbours of a triangle mesh, with valence weights.
    Triangles,
    /// First and second neighbours of a regular grid, no weights.
    Quads,
}

const fn spec(name: &'static str, label: &'static str, unit: &'static str, help: &'static str, max: f64) -> ParamSpec {
    ParamSpec::linear(name, label, unit, help, 0.0, max)
}

const K_S: ParamSpec =
    spec("k_s", "stretch stiffness k_s", "N/m", "Edge springs: resist stretch only (per spring).", 1e7)
        .in_scene("material.k_s");
const K_B: ParamSpec = spec(
    "k_b",
    "bending rigidity k_b",
    "N·m",
    "Diagonal springs: bending rigidity per unit width (a spring gets k_b × the width it stands for).",
    1e3,
)
.in_scene("material.k_b");
const C_B: ParamSpec = spec(
    "c_b",
    "buckling linear branch c_b",
    "N/m",
    "Diagonal springs near rest: c_b (|x| − L), used until buckling pushes harder; about k_s.",
    1e7,
)
.in_scene("material.c_b");
const K_D: ParamSpec =
    spec("k_d", "spring damping k_d", "N·s/m", "Damping of the relative velocity of every connected pair.", 1e3)
        .in_scene("material.k_d");
const MU_S: ParamSpec =
    spec("mu_s", "static friction μ_s", "", "A contact sticks while tangential force ≤ μ_s × normal force.", 10.0)
        .in_scene("material.mu_s");
const MU_K: ParamSpec =
    spec("mu_k", "kinetic friction μ_k", "", "A sliding contact feels μ_k × normal force against its motion.", 10.0)
        .in_scene("material.mu_k");
const STEP: ParamSpec = ParamSpec {
    min: 1e-5,
    ..spec("step", "time step", "s", "Backward Euler step (the paper: 0.01 s).", 0.1).in_scene("solver.step")
};
const ITERATIONS: ParamSpec = ParamSpec {
    min: 1.0,
    integer: true,
    ..spec("iterations", "PCG iterations", "", "Cap on PCG iterations per step.", 1e5).in_scene("solver.iterations")
};
const TOLERANCE: ParamSpec = ParamSpec {
    min: 1e-14,
    ..spec("tolerance", "PCG tolerance", "", "Stop when the preconditioned residual falls by this factor.", 1.0)
        .in_scene("solver.tolerance")
};
const MARGIN: ParamSpec = ParamSpec {
    min: 1e-6,
    ..spec("margin", "contact margin", "m", "Distance to a body within which a particle is locked to it.", 1.0)
        .in_scene("solver.margin")
};

/// The parameters of both cloth methods, in panel order (the wind's follow them).
const PARAMS: &[Param<Cloth>] = &[
    Param::new(K_S, |c| c.system.params().k_s, |c, v| c.springs(|p| p.k_s = v), Redo::Nothing),
    Param::new(K_B, |c| c.system.params().k_b, |c, v| c.springs(|p| p.k_b = v), Redo::Nothing),
    Param::new(C_B, |c| c.system.params().c_b, |c, v| c.springs(|p| p.c_b = v), Redo::Nothing),
    Param::new(K_D, |c| c.system.params().k_d, |c, v| c.springs(|p| p.k_d = v), Redo::Nothing),
    Param::new(MU_S, |c| c.contact.mu_s, |c, v| c.contact.mu_s = v, Redo::Nothing),
    Param::new(MU_K, |c| c.contact.mu_k, |c, v| c.contact.mu_k = v, Redo::Nothing),
    Param::new(DENSITY, |c| c.density, Cloth::set_density, Redo::Nothing),
    Param::new(GRAVITY_Y, |c| c.gravity.y, |c, v| c.gravity.y = v, Redo::Nothing),
    Param::new(STEP, |c| c.h, |c, v| c.h = v, Redo::Nothing),
    Param::new(ITERATIONS, |c| f64::from(c.iterations), |c, v| c.iterations = v as u32, Redo::Nothing),
    Param::new(TOLERANCE, |c| c.tolerance, |c, v| c.tolerance = v, Redo::Nothing),
    Param::new(MARGIN, |c| c.contact.margin, |c, v| c.contact.margin = v, Redo::Nothing),
];
/// One step's linear system `A Δv = b` (with `A` applied by the [`ClothSystem`]'s
/// [`Operator`](filtered_pcg::Operator) product).
#[derive(Debug, Clone, Default)]
pub struct LinearStep {
    /// The right side `b`.
    pub rhs: Vec<DVec3>,
    /// Block-Jacobi inverse of `A`.
    pub preconditioner: Vec<PaddedMat3>,
    /// Anchors, drags and contacts.
    pub constraints: Vec<Constraint>,
    /// The PCG's [`Stop::floor`]: `Σ m̃ (0.1 m/s)²`, so that near rest the velocity error is bounded
    /// by the tolerance times 0.1 m/s (a typical speed of moving cloth) rather than chased to ever
    /// smaller absolute values.
    pub error_floor: f64,
}

impl LinearStep {
    /// Solve it with `system`'s product by the filtered PCG: `dv` the warm start and the result,
    /// `residual` its `b − A Δv`, `work` the iteration's vectors.
    pub fn solve(
        &self,
        system: &ClothSystem,
        dv: &mut [DVec3],
        stop: Stop,
        residual: &mut [DVec3],
        work: &mut filtered_pcg::Workspace,
    ) -> PcgReport {
        filtered_pcg::solve(system, &self.preconditioner, &self.constraints, &self.rhs, dv, stop, residual, work)
    }
}

/// The largest growth of a stretch spring's strain in one step that is accepted (see [`Cloth::advance`]).
const STRAIN_JUMP: f64 = 0.05;

/// How many times a step may be halved.
const MAX_HALVINGS: u32 = 4;

/// The reference speed of [`LinearStep::error_floor`], m/s.
const VELOCITY_FLOOR: f64 = 0.1;

/// Default contact margin, m.
const DEFAULT_MARGIN: f64 = 0.005;

/// The cloth solver.
#[derive(Debug, Clone)]
pub struct Cloth {
    method: &'static str,
    system: ClothSystem,
    contacts: Contacts,
    bodies: Vec<Body>,
    contact: ContactParams,
    rest: Vec<DVec3>,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    /// Last step's velocity change (PCG warm start).
    dv: Vec<DVec3>,
    /// The step being solved (its buffers reused from step to step).
    work: LinearStep,
    /// `Some((h, g))` when `work`'s right side and preconditioner, and the system's matrix, already hold
    /// the springs linearised at the current state for a step of `h` under gravity `g`: a step ends by
    /// linearising the next at the state it reached (which measures that state), and the next step
    /// of the same `h` starts from it. Anything else that changes the springs' linearisation (a
    /// parameter, a reset, a step taken back) clears it.
    ahead: Option<(f64, DVec3)>,
    /// The last solve's residual `b − A Δv`.
    residual: Vec<DVec3>,
    /// The solves' vectors.
    pcg: filtered_pcg::Workspace,
    /// Which particles anchors or drags hold this step.
    held: Vec<bool>,
    anchored: Vec<bool>,
    gravity: DVec3,
    /// The scene's wind, on the mesh's triangles.
    wind: Wind,
    triangles: Vec<[usize; 3]>,
    density: f64,
    h: f64,
    iterations: u32,
    tolerance: f64,
    drags: DragSet,
    steps: u64,
    time: f64,
    energy_limit: f64,
}

impl Cloth {
    /// Change the spring parameters through `edit` (the system rebuilds what they change).
    fn springs(&mut self, edit: impl FnOnce(&mut SpringParams)) {
        let mut p = self.system.params();
        edit(&mut p);
        if p != self.system.params() {
            self.system.set_params(p);
        }
    }

    /// Change the density: the particles' masses scale with it.
    fn set_density(&mut self, density: f64) {
        self.system.scale_masses(density / self.density);
        self.density = density;
    }

    /// Build from a realised scene (material `k_s`, `k_b`, `c_b`, `k_d`, `mu_s`, `mu_k`, `density`;
    /// solver `step` (default 0.01 s), `iterations`, `tolerance`, `margin`).
    pub fn new(setup: &Setup, variant: Variant) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        let m = &setup.scene.material;
        let s = &setup.scene.solver;
        let method = match variant {
            Variant::Triangles => CLOTH.name,
            Variant::Quads => CLOTH_QUAD.name,
        };
        let graph = match (variant, &setup.scene.mesh) {
            (Variant::Triangles, _) => SpringGraph::triangle_mesh(&setup.mesh, m.density),
            (Variant::Quads, MeshSource::Grid { segments, .. }) => {
                let p = setup.mesh.positions();
                let [nx, nz] = *segments;
                let (dx, dz) = ((p[nz + 1] - p[0]).length(), (p[1] - p[0]).length());
                SpringGraph::quad_grid(p, [nx, nz], [dx, dz], m.density)
            }
            (Variant::Quads, _) => {
                return Err(SolverError::Unsuitable { method, reason: "it needs a regular `grid` mesh".into() });
            }
        };
        let params = SpringParams { k_s: m.k_s, k_b: m.k_b, c_b: m.c_b, k_d: m.k_d };
        let contact = ContactParams { margin: s.margin.unwrap_or(DEFAULT_MARGIN), mu_s: m.mu_s, mu_k: m.mu_k };
        let h = s.step.unwrap_or(0.01);
        let iterations = s.iterations as u32;
        let tolerance = s.tolerance;
        let density = m.density;
        let rest = setup.mesh.positions().to_vec();
        let n = rest.len();
        let total_mass: f64 = graph.masses.iter().sum();
        let (lo, hi) = setup.mesh.bounding_box();
        let size = (hi - lo).length();
        // Energies a million times what gravity could release over ten times the cloth's size mean divergence.
        let energy_limit = 1e6 * (total_mass * setup.gravity().length().max(9.81) * 10.0 * size).max(1e-3);
        Ok(Self {
            method,
            system: ClothSystem::new(graph, params),
            contacts: Contacts::new(n),
            bodies: setup.bodies.clone(),
            contact,
            x: rest.clone(),
            v: vec![DVec3::ZERO; n],
            dv: vec![DVec3::ZERO; n],
            work: LinearStep::default(),
            ahead: None,
            residual: vec![DVec3::ZERO; n],
            pcg: filtered_pcg::Workspace::default(),
            held: vec![false; n],
            rest,
            anchored: setup.anchored_mask(),
            gravity: setup.gravity(),
            wind: Wind::of(setup)?,
            triangles: setup.mesh.triangles().to_vec(),
            density,
            h,
            iterations,
            tolerance,
            drags: DragSet::new(n, false),
            steps: 0,
            time: 0.0,
            energy_limit,
        })
    }

    /// Current velocities, m/s.
    pub fn velocities(&self) -> &[DVec3] {
        &self.v
    }

    /// Kinetic energy `½ Σ m |v|²` with the particles' true masses, J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.v.iter().zip(&self.system.graph().masses).map(|(v, m)| m * v.length_squared()).sum::<f64>()
    }

    /// The spring system, linearised at the state of the last [`Cloth::linearise`].
    pub fn system(&self) -> &ClothSystem {
        &self.system
    }

    /// Linearise the next step at the current state: forces, constraints (anchors, drags, contacts,
    /// with the contact states advanced to this step) and the right side. [`Solver::step`] solves it.
    pub fn linearise(&mut self) -> LinearStep {
        let mut step = LinearStep::default();
        self.linearise_into(self.h, &mut step, false);
        step
    }

    /// Linearise a step of `h` into `step`, reusing its buffers; with `springs_ahead`, the springs' part
    /// is already in `step` (see [`Cloth::ahead`]).
    fn linearise_into(&mut self, h: f64, step: &mut LinearStep, springs_ahead: bool) {
        let n = self.x.len();
        step.constraints.clear();
        if !springs_ahead {
            self.ahead = None;
            step.rhs.resize(n, DVec3::ZERO);
            step.preconditioner.resize(n, PaddedMat3::default());
            self.system.linearise((&self.x, &self.v), self.gravity, h, &mut step.rhs, &mut step.preconditioner);
        }
        if !self.wind.is_calm() {
            // The wind at the start of the step, held over it (explicitly, like the loads).
            let mut f = vec![DVec3::ZERO; n];
            self.wind.add_forces(self.time, &self.x, &self.v, &self.triangles, &mut f);
            self.system.add_forces(&f, h, &mut step.rhs);
        }
        self.hold(h, &mut step.constraints);
        self.contacts.constrain(
            &self.bodies,
            self.contact,
            (&self.x, &self.v, &self.held),
            (self.time, h),
            self.system.scaled_masses(),
            &mut step.rhs,
            &mut step.constraints,
            self.system.parallel(),
        );
        step.error_floor = self.system.scaled_masses().iter().sum::<f64>() * VELOCITY_FLOOR * VELOCITY_FLOOR;
    }

    /// Advance by `h`: one linearised backward Euler step, or — if a stretch spring's strain grew by
    /// more than [`STRAIN_JUMP`] in it, which means the linearisation at the start missed the
    /// geometry (a fast particle stopped by a contact while its neighbours sweep past it) — two steps
    /// of `h/2`, up to [`MAX_HALVINGS`] times (Baraff & Witkin 1998, §5). Returns the solves' report
    /// and the springs' energy at the end.
    fn advance(&mut self, h: f64, halvings: u32) -> (PcgReport, f64) {
        let saved = (halvings < MAX_HALVINGS)
            .then(|| (self.x.clone(), self.v.clone(), self.dv.clone(), self.contacts.clone(), self.time));
        let (report, springs) = self.single_step(h);
        let Some((x, v, dv, contacts, time)) = saved else { return (report, springs.energy) };
        if springs.strain_jump <= STRAIN_JUMP {
            return (report, springs.energy);
        }
        (self.x, self.v, self.contacts, self.time, self.ahead) = (x, v, contacts, time, None);
        self.dv = dv.iter().map(|d| *d * 0.5).collect();
        let (first, _) = self.advance(0.5 * h, halvings + 1);
        let (second, energy) = self.advance(0.5 * h, halvings + 1);
        let report = PcgReport {
            iterations: report.iterations + first.iterations + second.iterations,
            residual: first.residual.max(second.residual),
            relative_residual: first.relative_residual.max(second.relative_residual),
            converged: first.converged && second.converged,
        };
        (report, energy)
    }

    /// One linearised backward Euler step of `h`, solved by the filtered PCG; the springs at its end,
    /// measured by linearising the next step of `h` there.
    fn single_step(&mut self, h: f64) -> (PcgReport, SpringState) {
        let mut step = std::mem::take(&mut self.work);
        self.linearise_into(h, &mut step, self.ahead == Some((h, self.gravity)));
        let stop = Stop { tolerance: self.tolerance, floor: step.error_floor, max_iterations: self.iterations };
        let report = step.solve(&self.system, &mut self.dv, stop, &mut self.residual, &mut self.pcg);
        self.work = step;
        self.contacts.update(self.contact, &self.residual, h);
        for ((x, v), dv) in self.x.iter_mut().zip(&mut self.v).zip(&self.dv) {
            *v += *dv;
            *x += *v * h;
        }
        self.time += h;
        let work = &mut self.work;
        let springs =
            self.system.linearise((&self.x, &self.v), self.gravity, h, &mut work.rhs, &mut work.preconditioner);
        self.ahead = Some((h, self.gravity));
        (report, springs)
    }

    /// Anchors and drags (reached at the end of a step of `h`) as constraints; marks held particles.
    fn hold(&mut self, h: f64, constraints: &mut Vec<Constraint>) {
        let held = &mut self.held;
        held.copy_from_slice(&self.anchored);
        for (i, _) in self.anchored.iter().enumerate().filter(|(_, a)| **a) {
            constraints.push(Constraint { particle: i, filter: glam::DMat3::ZERO, z: -self.v[i] });
        }
        for (_, d) in self.drags.iter() {
            if let DragKind::Position(target) = d.kind {
                let i = d.vertex;
                if !held[i] {
                    held[i] = true;
                    let z = (target - self.x[i]) / h - self.v[i];
                    constraints.push(Constraint { particle: i, filter: glam::DMat3::ZERO, z });
                }
            }
        }
    }
}

impl Solver for Cloth {
    fn method(&self) -> &'static str {
        self.method
    }

    fn time_step(&self) -> f64 {
        self.h
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        // Keeps the pool's threads awake for the passes' joins.
        let (report, spring_energy) =
            crate::solver::supersede::awake(self.system.parallel(), || self.advance(self.h, 0));
        self.steps += 1;
        let energy = spring_energy + self.system.particle_energy(&self.x, &self.v, &self.rest, self.gravity);
        check_finite(self.steps, self.time, &self.x, energy, self.energy_limit)?;
        Ok(StepStats::solved(start, self.time, energy, &report))
    }

    fn positions(&self) -> &[DVec3] {
        &self.x
    }

    fn reset(&mut self) {
        self.x.clone_from(&self.rest);
        self.v.fill(DVec3::ZERO);
        self.dv.fill(DVec3::ZERO);
        self.contacts.reset();
        self.ahead = None;
        self.steps = 0;
        self.time = 0.0;
    }

    fn params(&self) -> Vec<ParamValue> {
        [params::values(PARAMS, self), self.wind.params()].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        // The wind's forces come after the springs' part; every other parameter may change it.
        if !self.wind.set_param(name, value)? {
            self.ahead = None;
            params::set(PARAMS, self, name, value)?;
        }
        Ok(())
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }
}
