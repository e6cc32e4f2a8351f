//! `rds` behind the [`Solver`] trait: backward Euler in the reduced coordinates, drags as stiff
//! springs, the basis rebuilt in the background when the shell, the mode count or the derivative
//! count changes.
//!
//! **A step.** With `c` the coordinates, `v` their velocities, the basis mass-orthonormal (the
//! reduced mass is `I`, held constant as in `mwts-rs`), Rayleigh damping `D = αI + βK₀` (`K₀` the
//! rest reduced stiffness) and `h` the step, `c⁺` minimises
//! `Φ(c⁺) = ½|c⁺ − c − hv|² + (h/2)(c⁺ − c)ᵀD(c⁺ − c) + h² Π(c⁺)`, where
//! `Π(c) = E(x(c)) − fᵀx(c) + Σ_k ½ κ_k |a_k(c) − t_k|²`: the full shell energy, the external
//! forces (gravity, point loads, wind held over the step) and the drags. Its stationary point is the
//! backward Euler step `c⁺ − c − hv + hD(c⁺ − c) = −h² ∇Π(c⁺)`; Newton with a backtracking line
//! search finds it (a few iterations a step; up to `solver.iterations`, twice that in a step taken
//! again, below), and `v⁺ = (c⁺ − c)/h`.
//!
//! **Energy bound.** Newton starts from the prediction `c + hv`. Where it stops short of converging
//! above `Φ(c)`, the step is taken again from `c` itself; the line search only lowers `Φ`, so such a
//! step ends with `Φ(c⁺) ≤ Φ(c)`, that is `Π(c⁺) + ½|v⁺ − v|² + (h/2)v⁺ᵀDv⁺ ≤ Π(c) + ½|v|²`
//! (`Π` under this step's loads and drag targets): the potential cannot climb above the total
//! energy the shell starts the step with. (A converged step is a stationary point of `Φ` and is
//! kept.) Without the retake, a grab that the basis cannot follow fed each unconverged step's
//! overshoot into the next (the strip's middle pulled 1 m by a jump: area ×100 after 18 steps,
//! where `ds-implicit` settles at ×1.3). A step whose energy passes [`ENERGY_LIMIT`] times the loads' work across the
//! body is reported as a divergence, as in the full shell's methods.
//!
//! **Basis.** The modes, the static responses to body loads (`solver.load_responses`, default 1)
//! and the derivative directions (`solver.derivatives`), [`super::basis`].
//!
//! **Drags** are stiff springs ([`super::springs`]); while position drags last, the static responses
//! to the dragged vertices join the basis, as in the modal methods. They are solved with the factor
//! of `K − σM` the basis was built with (the load responses and derivatives need it), handed to the
//! drags' [`DragFactor`]. A basis read from the cache ([`super::stored`]) comes without one: it is
//! made at the first drag, or ahead in the background once drags are expected
//! ([`Solver::expect_drags`]).
//!
//! **Cubature.** With `solver.cubature` above 0 the energy is summed over an optimised cubature
//! ([`super::cubature`]) fitted to the base basis after it is built (in the background like it);
//! a basis grown by drag responses keeps it. 0, the default, sums every element.

use std::time::{Duration, Instant};

use glam::DVec3;
use nalgebra::{DMatrix, DVector};

use super::basis::{self, ReducedBasis, default_derivatives};
use super::cubature;
use super::energy::{Cubature, ReducedShell};
use super::springs::{Spring, springs};
use super::stored::{self, Sizes};
use crate::scene::Setup;
use crate::solver::modal::cache::Cache;
use crate::solver::modal::method::{CONSTRAINT_DAMPING, MODES, Request, STEP, named};
use crate::solver::modal::ritz::{self, DragFactor, StaticResponse};
use crate::solver::newton::ITERATIONS_SPEC;
use crate::solver::params::shared::{DENSITY, GRAVITY_Y, K_AREA, K_BEND, K_LENGTH, RAYLEIGH_ALPHA, RAYLEIGH_BETA};
use crate::solver::params::{self, Param, Redo};
use crate::solver::supersede::{Background, Generation};
use crate::solver::wind::Wind;
use crate::solver::{DragSet, ParamSpec, ParamValue, Progress, Solver, SolverError, StepStats};
use crate::solver::{ENERGY_LIMIT, check_finite, energy_scale};
use crate::solver::{Footprint, Method};

/// Registry entry: the reduced nonlinear discrete shell.
pub const RDS: Method = Method {
    name: "rds",
    summary: "reduced discrete shell: modes and modal derivatives through the rotation-strain reconstruction, \
              the full shell energy, implicit steps (1/30 s)",
    build: |setup| Ok(Box::new(Rds::new(setup)?)),
    footprint: Footprint::MODAL,
};

/// The derivative directions kept beside the modes.
const DERIVATIVES: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear(
        "derivatives",
        "derivatives",
        "",
        "Modal-derivative directions kept beside the modes after mass-PCA pruning (recomputed in the background).",
        0.0,
        1024.0,
    )
    .in_scene("solver.derivatives")
};

/// Whether the static responses to body loads join the modes.
const LOAD_RESPONSES: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear(
        "load_responses",
        "load responses",
        "",
        "1: the static responses to a uniform acceleration along each axis join the modes (a shell's sag under \
         its weight); 0: the modes alone (recomputed in the background).",
        0.0,
        1.0,
    )
    .in_scene("solver.load_responses")
};

/// The cubature's size.
const CUBATURE: ParamSpec = ParamSpec {
    integer: true,
    ..ParamSpec::linear(
        "cubature",
        "cubature",
        "",
        "Elements of the energy's optimised cubature (0: every element, exact; refitted in the background).",
        0.0,
        100_000.0,
    )
    .in_scene("solver.cubature")
};

/// The parameters (the wind's follow them).
const PARAMS: &[Param<Rds>] = &[
    Param::new(K_AREA, |m| m.request.stiffness.k_area, |m, v| m.request.stiffness.k_area = v, Redo::Modes),
    Param::new(K_LENGTH, |m| m.request.stiffness.k_length, |m, v| m.request.stiffness.k_length = v, Redo::Modes),
    Param::new(K_BEND, |m| m.request.stiffness.k_bend, |m, v| m.request.stiffness.k_bend = v, Redo::Modes),
    Param::new(DENSITY, |m| m.request.density, |m, v| m.request.density = v, Redo::Modes),
    Param::new(GRAVITY_Y, |m| m.gravity.y, |m, v| m.gravity.y = v, Redo::Forces),
    Param::new(RAYLEIGH_ALPHA, |m| m.settings.alpha, |m, v| m.settings.alpha = v, Redo::Nothing),
    Param::new(RAYLEIGH_BETA, |m| m.settings.beta, |m, v| m.settings.beta = v, Redo::Nothing),
    Param::new(MODES, |m| m.request.modes as f64, |m, v| m.request.modes = v as usize, Redo::Modes),
    Param::new(LOAD_RESPONSES, |m| f64::from(u8::from(m.sizes.loads)), |m, v| m.sizes.loads = v > 0.5, Redo::Modes),
    Param::new(DERIVATIVES, |m| m.sizes.derivatives as f64, |m, v| m.sizes.derivatives = v as usize, Redo::Modes),
    Param::new(CUBATURE, |m| m.sizes.cubature as f64, |m, v| m.sizes.cubature = v as usize, Redo::Modes),
    Param::new(STEP, |m| m.settings.step, |m, v| m.settings.step = v, Redo::Nothing),
    Param::new(
        ITERATIONS_SPEC,
        |m| m.settings.iterations as f64,
        |m, v| m.settings.iterations = v as usize,
        Redo::Nothing,
    ),
    Param::new(
        CONSTRAINT_DAMPING,
        |m| m.settings.constraint_damping,
        |m, v| m.settings.constraint_damping = v,
        Redo::Nothing,
    ),
];

/// The default relative compliance of drags: a hundred times tighter than the modal methods' 1e-2.
/// The compliance is measured against the linear response, and the full energy stiffens under large
/// pulls far beyond it: `tests/rds.rs` pulls the strip's tip 0.27 m and finds it met to 0.2 mm at
/// this setting.
const DRAG_DAMPING: f64 = 1e-4;

/// The seed of the poses the cubature's error is measured on (the training poses use another).
const UNSEEN_SEED: u64 = 0x5851_f42d_4c95_7f2d;

/// How long a background rebuild waits for further edits before it starts.
const SETTLE: Duration = Duration::from_millis(200);

/// The settings a step reads.
#[derive(Debug, Clone, Copy)]
struct Settings {
    step: f64,
    alpha: f64,
    beta: f64,
    constraint_damping: f64,
    iterations: usize,
}

/// A basis with its reduced shell and rest stiffness.
struct Built {
    /// The modes and their derivative directions.
    base: ReducedBasis,
    /// The basis in use: `base`, and while position drags last the static responses to them.
    basis: ReducedBasis,
    shell: ReducedShell,
    /// The rest reduced stiffness `K₀ = Jᵀ K J` at `c = 0`.
    rest: DMatrix<f64>,
}

/// A basis built for the solver, with the factored stiffness it was built with if it was built
/// here (not read from the cache): handed to the solver's [`DragFactor`] for the drags' static
/// responses.
type Rebuilt = (Built, Option<StaticResponse>);

impl Built {
    /// The basis (read from the cache, else built from the modes, themselves cached or computed),
    /// the reduced shell, its cubature of at most `sizes.cubature` elements (none for 0; cached
    /// likewise). Built afresh, it comes with the factor it was built with, for the drags.
    fn of(request: &Request, sizes: Sizes, progress: &dyn Fn(f32)) -> Result<Rebuilt, SolverError> {
        let masses = request.masses();
        let problem = request.problem(&masses);
        let cache = &request.cache;
        let (base, factor) = match stored::load_basis(cache, &problem, sizes) {
            Some(base) => (base, None),
            None => {
                let (analysis, factor) = request.run_factored(&|f| progress(0.5 * f))?;
                let (loads, derivatives) = (sizes.loads, sizes.derivatives);
                let built =
                    basis::build(&problem, &analysis, factor, loads, derivatives, &|f| progress(0.5 + 0.3 * f))?;
                stored::store_basis(cache, &problem, sizes, &built.0);
                built
            }
        };
        let mut shell = ReducedShell::new(&request.mesh, &request.anchors, request.stiffness, &base)?;
        if sizes.cubature > 0 {
            let fitted = match stored::load_cubature(cache, &problem, sizes, shell.element_count()) {
                Some(fitted) => fitted,
                None => {
                    let rest = request.mesh.positions();
                    let fitted = cubature::fit(&mut shell, &base, rest, sizes.cubature, &|f| progress(0.8 + 0.2 * f));
                    stored::store_cubature(cache, &problem, sizes, &fitted);
                    fitted
                }
            };
            shell.set_cubature(Some(fitted));
        }
        let built = Self::around(request, base.clone(), base, shell);
        progress(1.0);
        Ok((built, factor.map(StaticResponse::of)))
    }

    /// The reduced shell of `basis` (`base` with any drag responses), its energy summed by
    /// `cubature` (fitted to `base`) if given.
    fn with(
        request: &Request,
        base: ReducedBasis,
        basis: ReducedBasis,
        cubature: Option<Cubature>,
    ) -> Result<Self, SolverError> {
        let mut shell = ReducedShell::new(&request.mesh, &request.anchors, request.stiffness, &basis)?;
        shell.set_cubature(cubature);
        Ok(Self::around(request, base, basis, shell))
    }

    /// The built basis around `shell` (the reduced shell of `basis`), with its rest stiffness.
    fn around(request: &Request, base: ReducedBasis, basis: ReducedBasis, mut shell: ReducedShell) -> Self {
        let zero = vec![0.0; basis.len()];
        let j = shell.jacobian(&zero);
        let rest = shell.projected_hessian(request.mesh.positions(), &j);
        Self { base, basis, shell, rest }
    }
}

/// The reduced discrete shell.
pub struct Rds {
    request: Request,
    sizes: Sizes,
    built: Built,
    settings: Settings,
    loads: Vec<DVec3>,
    gravity: DVec3,
    wind: Wind,
    c: Vec<f64>,
    v: Vec<f64>,
    positions: Vec<DVec3>,
    previous: Vec<DVec3>,
    drags: DragSet,
    steps: u64,
    pending: Option<Background<Rebuilt>>,
    /// The drags' factor of `K − σM`: the one the basis was built with, else made at the first drag
    /// or ahead in the background once drags are expected.
    factor: DragFactor,
    generation: Generation,
    /// The groups of dragged vertices whose responses are in the basis, and the drag revision the
    /// basis was last fitted to.
    groups: Vec<Vec<usize>>,
    drag_revision: Option<u64>,
}

impl Rds {
    /// Build from a scene (computing or loading the modes and the basis synchronously), caching
    /// them in the default location ([`Cache::from_env`]).
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        Self::with_cache(setup, Cache::from_env())
    }

    /// Build from a scene, caching the modes, the basis and the cubature in `cache`.
    pub fn with_cache(setup: &Setup, cache: Cache) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS), setup)?;
        if !super::suits(setup) {
            return Err(SolverError::Unsuitable {
                method: RDS.name,
                reason:
                    "it needs anchors: the modal derivatives solve with the rest stiffness, singular for a free shell"
                        .into(),
            });
        }
        let s = &setup.scene.solver;
        let request = Request::of(setup, cache);
        // In range: checked above.
        let sizes = Sizes {
            loads: s.load_responses.is_none_or(|l| l > 0),
            derivatives: s.derivatives.map_or_else(|| default_derivatives(s.modes), |d| d.max(0) as usize),
            cubature: s.cubature.map_or(0, |c| c.max(0) as usize),
        };
        let (built, response) = Built::of(&request, sizes, &|_| {}).map_err(|e| named(e, RDS.name))?;
        let r = built.basis.len();
        let mut rds = Self {
            request,
            sizes,
            built,
            settings: Settings {
                step: s.step.unwrap_or(1.0 / 30.0),
                alpha: s.rayleigh_alpha,
                beta: s.rayleigh_beta,
                constraint_damping: s.constraint_damping.unwrap_or(DRAG_DAMPING),
                iterations: s.iterations,
            },
            loads: setup.loads.clone(),
            gravity: setup.gravity(),
            wind: Wind::of(setup)?,
            c: vec![0.0; r],
            v: vec![0.0; r],
            positions: setup.mesh.positions().to_vec(),
            previous: setup.mesh.positions().to_vec(),
            drags: DragSet::new(setup.mesh.vertex_count(), true),
            steps: 0,
            pending: None,
            factor: DragFactor::default(),
            generation: Generation::default(),
            groups: Vec::new(),
            drag_revision: None,
        };
        rds.factor.renew(response, rds.request.drag_factor());
        Ok(rds)
    }

    /// The basis in use.
    pub fn basis(&self) -> &ReducedBasis {
        &self.built.basis
    }

    /// The cubature in use (`None`: every element).
    pub fn cubature(&self) -> Option<&Cubature> {
        self.built.shell.cubature()
    }

    /// The cubature's relative force errors on `count` poses it was not fitted to
    /// ([`cubature::relative_errors`]); `None` without a cubature.
    pub fn cubature_errors(&mut self, count: usize) -> Option<Vec<f64>> {
        let fitted = self.built.shell.cubature()?.clone();
        let rest = self.request.mesh.positions();
        let built = &mut self.built;
        Some(cubature::relative_errors(&mut built.shell, &built.basis, rest, &fitted, count, UNSEEN_SEED))
    }

    /// The external forces of the coming step: the scene's `base` (gravity and point loads) and the
    /// wind on the shell as the last step left it, N.
    fn forces(&self, base: Vec<DVec3>) -> Vec<DVec3> {
        if self.wind.is_calm() {
            return base;
        }
        let h = self.settings.step;
        let v: Vec<DVec3> = self.positions.iter().zip(&self.previous).map(|(a, b)| (*a - *b) / h).collect();
        self.wind.forces(self.steps as f64 * h, (&self.positions, &v), self.request.mesh.triangles(), &base)
    }

    /// The step's objective at `c` (module documentation), with the positions it leaves in `x`.
    fn objective(&mut self, s: &Step, c: &DVector<f64>, x: &mut [DVec3]) -> f64 {
        self.built.shell.positions(c.as_slice(), x);
        let rest = self.request.mesh.positions();
        let work: f64 = x.iter().zip(rest).zip(&s.forces).map(|((x, x0), f)| (*x - *x0).dot(*f)).sum();
        let springs: f64 = s.springs.iter().map(|k| k.energy(c, x)).sum();
        let (dy, dc) = (c - &s.predicted, c - &s.start);
        let h = self.settings.step;
        0.5 * dy.norm_squared()
            + 0.5 * h * dc.dot(&(&s.damping * &dc))
            + h * h * (self.built.shell.energy(x) - work + springs)
    }

    /// One backward Euler step by Newton's method from the inertial prediction; returns
    /// (iterations, converged). A step that stops short of converging above the objective where the
    /// shell stood is taken again from there (module documentation, *energy bound*).
    fn solve(&mut self, s: &Step) -> Result<(u32, bool), SolverError> {
        let mut x = self.positions.clone();
        let value = self.objective(s, &s.predicted, &mut x);
        if !value.is_finite() {
            let time = (self.steps + 1) as f64 * self.settings.step;
            let reason = "the step's energy is not finite".to_string();
            return Err(SolverError::Diverged { step: self.steps + 1, time, reason });
        }
        let mut newton = self.newton(s, (s.predicted.clone(), x, value))?;
        if !newton.converged {
            let mut x = self.positions.clone();
            let standing = self.objective(s, &s.start, &mut x);
            if standing < newton.value {
                let again = self.newton(s, (s.start.clone(), x, standing))?;
                newton = Newton { iterations: newton.iterations + again.iterations, ..again };
            }
        }
        self.finish(&newton.c, &newton.x, s);
        Ok((newton.iterations, newton.converged))
    }

    /// Newton's method on the step's objective from `(c, x(c), Φ(c))`, with a backtracking line
    /// search, for at most `solver.iterations` iterations.
    fn newton(
        &mut self,
        s: &Step,
        (mut c, mut x, mut value): (DVector<f64>, Vec<DVec3>, f64),
    ) -> Result<Newton, SolverError> {
        let h = self.settings.step;
        let r = self.c.len();
        let mut trial = x.clone();
        let mut gradient = vec![DVec3::ZERO; x.len()];
        let inertia = DMatrix::identity(r, r) + &s.damping * h;
        // The stiffness (the Jacobian, the projected Hessian and the load stiffness) is kept from
        // one iteration to the next while full steps are taken: the force is exact at every
        // iteration, so a stale stiffness changes how fast the iteration converges, not where.
        let mut kept: Option<(DMatrix<f64>, DMatrix<f64>)> = None;
        for iteration in 1..=self.settings.iterations as u32 {
            self.built.shell.gradient(&x, &mut gradient);
            let mut force: Vec<DVec3> = s.forces.iter().zip(&gradient).map(|(f, g)| *f - *g).collect();
            s.springs.iter().for_each(|k| k.add_force(&x, &mut force));
            let (pulled, (j, elastic)) = match kept.take() {
                Some(kept) => (self.built.shell.force(c.as_slice(), &force), kept),
                None => {
                    let (pulled, load) = self.built.shell.pull_back(c.as_slice(), &force);
                    let j = self.built.shell.jacobian(c.as_slice());
                    let elastic = self.built.shell.projected_hessian(&x, &j) - load;
                    (pulled, (j, elastic))
                }
            };
            let mut stiffness = elastic.clone();
            let mut g = -pulled;
            for k in &s.springs {
                k.add_stiffness(&self.built.shell, &j, &c, &mut g, &mut stiffness);
            }
            let grad = (&c - &s.predicted) + &s.damping * (&c - &s.start) * h + g * (h * h);
            let system = &inertia + stiffness * (h * h);
            let system = (&system + system.transpose()) * 0.5;
            let dc = descent(&system, &grad)?;
            let slope = grad.dot(&dc);
            let mut step = 1.0;
            let accepted = loop {
                let candidate = &c + &dc * step;
                let next = self.objective(s, &candidate, &mut trial);
                if next.is_finite() && next <= value + 1e-4 * step * slope.min(0.0) {
                    value = next;
                    break Some(candidate);
                }
                step *= 0.5;
                if step < 1e-6 {
                    break None;
                }
            };
            let Some(next) = accepted else {
                // No decrease left at round-off: the stationary point.
                return Ok(Newton { c, x, value, iterations: iteration, converged: true });
            };
            let moved = (&next - &c).norm();
            if step == 1.0 && iteration % 4 != 0 {
                kept = Some((j, elastic));
            }
            c = next;
            std::mem::swap(&mut x, &mut trial);
            if moved <= 1e-10 * (c.norm() + (&c - &s.start).norm()) + 1e-300 {
                return Ok(Newton { c, x, value, iterations: iteration, converged: true });
            }
        }
        Ok(Newton { c, x, value, iterations: self.settings.iterations as u32, converged: false })
    }

    fn finish(&mut self, c: &DVector<f64>, x: &[DVec3], s: &Step) {
        let h = self.settings.step;
        self.v = ((c - &s.start) / h).as_slice().to_vec();
        self.c = c.as_slice().to_vec();
        self.previous.copy_from_slice(&self.positions);
        self.positions.copy_from_slice(x);
    }

    fn recompute(&mut self) {
        let request = self.request.clone();
        let sizes = self.sizes;
        let work = move |report: &dyn Fn(f32)| Built::of(&request, sizes, report);
        self.pending = Some(Background::start("shellwarp-rds-basis", "basis", &self.generation, SETTLE, work));
    }

    fn poll_pending(&mut self) -> Result<(), SolverError> {
        match self.pending.as_ref().and_then(Background::ready) {
            Some(result) => self.swap(result),
            None => Ok(()),
        }
    }

    /// Whether the drags' factor is at hand or being made ([`Solver::expect_drags`]).
    pub fn drags_prepared(&self) -> bool {
        self.factor.prepared()
    }

    /// Block until a background rebuild (if any) has finished and swap it in (deterministic runs).
    pub fn wait_for_basis(&mut self) -> Result<(), SolverError> {
        match self.pending.as_ref().map(Background::wait) {
            Some(result) => self.swap(result),
            None => Ok(()),
        }
    }

    /// Swap in a basis rebuilt in the background; the drags' responses are refitted to it at the
    /// next step.
    fn swap(&mut self, result: Result<Rebuilt, SolverError>) -> Result<(), SolverError> {
        self.pending = None;
        let (built, response) = result.map_err(|e| named(e, RDS.name))?;
        (self.groups, self.drag_revision) = (Vec::new(), None);
        self.carry(built);
        self.factor.renew(response, self.request.drag_factor());
        Ok(())
    }

    /// Fit the basis to the position drags, as the modal methods do ([`ritz`]): the static
    /// responses to forces at the dragged vertices join it while they are dragged, so a local pull
    /// is followed by the shell's own local deformation rather than by large amplitudes of global
    /// modes.
    fn follow_drags(&mut self) -> Result<(), SolverError> {
        if self.drag_revision == Some(self.drags.revision()) {
            return Ok(());
        }
        self.drag_revision = Some(self.drags.revision());
        let groups = ritz::dragged_groups(&self.drags);
        if groups == self.groups {
            return Ok(());
        }
        let base = self.built.base.clone();
        let basis = if groups.is_empty() {
            base.clone()
        } else {
            let response = self.factor.get(self.request.drag_factor())?;
            let mesh = &self.request.mesh;
            let augmented = response.augment(&base.modal(mesh), mesh, &groups)?;
            let shapes = (0..augmented.modes()).map(|j| augmented.shape(j)).collect();
            ReducedBasis { modes: base.modes, loads: base.loads, stiffness: augmented.eigenvalues.clone(), shapes }
        };
        let cubature = self.built.shell.cubature().cloned();
        let built = Built::with(&self.request, base, basis, cubature)?;
        self.carry(built);
        self.groups = groups;
        Ok(())
    }

    /// Carry the state over to a new basis: the coordinates whose positions (and velocities) are
    /// closest to the current ones in the mass norm.
    fn carry(&mut self, mut built: Built) {
        let masses = self.request.masses();
        let rest = self.request.mesh.positions();
        let h = self.settings.step;
        let start: Vec<f64> = (built.basis.shapes.iter())
            .map(|s| s.iter().enumerate().map(|(v, b)| masses[v] * b.dot(self.positions[v] - rest[v])).sum())
            .collect();
        let velocity: Vec<DVec3> = self.positions.iter().zip(&self.previous).map(|(a, b)| (*a - *b) / h).collect();
        (self.c, self.v) = built.shell.fit(&masses, &self.positions, &velocity, start);
        self.built = built;
        self.built.shell.positions(&self.c, &mut self.positions);
        self.previous.copy_from_slice(&self.positions);
    }
}

/// What a step holds fixed.
struct Step {
    start: DVector<f64>,
    predicted: DVector<f64>,
    damping: DMatrix<f64>,
    forces: Vec<DVec3>,
    springs: Vec<Spring>,
}

/// Where Newton's method left a step: the coordinates, their shell, the objective there, the
/// iterations taken and whether it converged.
struct Newton {
    c: DVector<f64>,
    x: Vec<DVec3>,
    value: f64,
    iterations: u32,
    converged: bool,
}

/// `−S⁻¹ g` for the symmetric step matrix `S`, shifted towards positive definite if it is not.
fn descent(system: &DMatrix<f64>, grad: &DVector<f64>) -> Result<DVector<f64>, SolverError> {
    let scale = system.diagonal().abs().max().max(f64::MIN_POSITIVE);
    let mut shift = 0.0;
    for _ in 0..40 {
        let shifted = system + DMatrix::identity(system.nrows(), system.ncols()) * shift;
        if let Some(c) = shifted.cholesky() {
            return Ok(-c.solve(grad));
        }
        shift = if shift == 0.0 { 1e-8 * scale } else { shift * 10.0 };
    }
    Err(SolverError::Numerical("the reduced step matrix is not finite".into()))
}

impl Solver for Rds {
    fn method(&self) -> &'static str {
        RDS.name
    }

    fn time_step(&self) -> f64 {
        self.settings.step
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let wall = Instant::now();
        self.poll_pending()?;
        self.follow_drags()?;
        let h = self.settings.step;
        let r = self.c.len();
        let start = DVector::from_column_slice(&self.c);
        let velocity = DVector::from_column_slice(&self.v);
        let damping = DMatrix::identity(r, r) * self.settings.alpha + &self.built.rest * self.settings.beta;
        let scene = self.request.scene_forces(self.gravity, &self.loads);
        let limit = ENERGY_LIMIT * energy_scale(&scene, self.request.mesh.bounding_box());
        let step = Step {
            predicted: &start + &velocity * h,
            start,
            damping,
            forces: self.forces(scene),
            springs: springs(
                &self.drags,
                &self.built.shell.modal,
                &self.built.rest,
                h,
                self.settings.constraint_damping,
            ),
        };
        let (iterations, converged) = self.solve(&step)?;
        self.steps += 1;
        let time = self.steps as f64 * h;
        if !self.c.iter().chain(&self.v).all(|x| x.is_finite()) {
            let reason = "the reduced coordinates are not finite".to_string();
            return Err(SolverError::Diverged { step: self.steps, time, reason });
        }
        let kinetic = 0.5 * self.v.iter().map(|v| v * v).sum::<f64>();
        let energy = self.built.shell.energy(&self.positions) + kinetic;
        check_finite(self.steps, time, &[], energy, limit)?;
        Ok(StepStats {
            wall_seconds: wall.elapsed().as_secs_f64(),
            sim_time: time,
            energy,
            iterations,
            converged,
            ..StepStats::default()
        })
    }

    fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    fn reset(&mut self) {
        self.c.iter_mut().chain(self.v.iter_mut()).for_each(|x| *x = 0.0);
        self.positions.copy_from_slice(self.request.mesh.positions());
        self.previous.copy_from_slice(&self.positions);
        self.steps = 0;
    }

    fn params(&self) -> Vec<ParamValue> {
        [params::values(PARAMS, self), self.wind.params()].concat()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        if self.wind.set_param(name, value)? {
            return Ok(());
        }
        match params::set(PARAMS, self, name, value)? {
            Redo::Nothing | Redo::Forces => {}
            Redo::Modes => self.recompute(),
        }
        Ok(())
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }

    fn progress(&self) -> Option<Progress> {
        self.pending.as_ref().map(|p| Progress {
            label: match self.sizes.cubature {
                0 => format!("computing {} modes and {} derivatives", self.request.modes, self.sizes.derivatives),
                n => format!(
                    "computing {} modes, {} derivatives and a {n}-element cubature",
                    self.request.modes, self.sizes.derivatives
                ),
            },
            fraction: p.fraction(),
        })
    }

    fn poll(&mut self) -> Result<(), SolverError> {
        self.poll_pending()
    }

    fn expect_drags(&mut self) {
        self.factor.expect(self.request.drag_factor());
    }

    fn info(&self) -> Vec<(&'static str, f64)> {
        let (base, basis) = (&self.built.base, &self.built.basis);
        vec![
            ("active modes", base.modes as f64),
            ("load responses", base.loads as f64),
            ("derivative directions", (base.len() - base.first_order()) as f64),
            ("drag modes", (basis.len() - base.len()) as f64),
            ("cubature elements", self.cubature().map_or(0, |c| c.elements.len()) as f64),
            ("cubature training error", self.cubature().map_or(0.0, |c| c.training_error)),
        ]
    }
}

impl Drop for Rds {
    fn drop(&mut self) {
        self.generation.cancel_all();
    }
}
