//! The automatic model choice: a scene that gives `solver.accuracy` (a relative displacement-field
//! error) instead of a method gets the cheapest method and setting whose *estimated* error meets it.
//! "Model no more than a scene needs."
//!
//! Candidates are ordered by a measured cost (wall-clock seconds per simulated second, from a few
//! timed steps of each) and estimated in that order until one meets the target, so the expensive
//! ones are rarely touched. The estimates never run a reference:
//!
//! Accuracy is that of the scene's equilibrium under its loads, its tracks held at their targets at
//! time 0 (where a cheaper model's error lives; a fixed step adds time-discretisation error that is
//! not counted). A shell held only by tracks (a free part of the dancer) is judged as it runs: its
//! rigid modes kept, the tracked vertices held by drags.
//!
//! Each `[[parts]]` entry with a target (its own `accuracy`, else `solver.accuracy`) is chosen for
//! alone, on the scene cut down to that part ([`super::parts::split`]): the parts share no vertex and
//! no force, so the cheapest combination meeting every part's target is the cheapest model per part.
//!
//! - **Shells** (`rigid`, the modal methods with 1–64 modes, `rds` with 1–16 modes and its default
//!   derivative directions where the shell is anchored, `ds-implicit`): the candidate's static
//!   equilibrium (run to rest under critical damping of the lowest mode) is judged by
//!   [`super::quality::estimate`]: a few Newton iterations of the full discrete-shell equations,
//!   the distance they travel relative to the displacement they arrive at. `rigid` has error 1 (no
//!   displacement) and `ds-implicit` 0 (it solves the full equations, whose equilibrium does not
//!   depend on its step).
//! - **Cloth** (`cloth` at 40, 20 and 10 ms, PCG tolerance 1e-2 to 1e-4): the candidate's rest state is relaxed by
//!   [`RELAX_STEPS`] backward-Euler steps of 0.1 s with a tight PCG tolerance (nearly Newton steps on
//!   the static cloth equations); the distance travelled relative to the displacement is the
//!   estimate. It finds a candidate that stopped short of its equilibrium (the PCG's stopping rule
//!   lets a slowly settling cloth freeze); it cannot find another equilibrium (a different fold
//!   pattern), so path-dependent scenes are outside what it can judge.
//!
//! The family is the scene's `solver.method` when it names one (a cloth method: cloth), else shells.

use std::time::Instant;

use glam::DVec3;

use super::run::{Stop, distance, run_driven};
use super::script::Script;
use super::{DragSet, Solver, SolverError, quality, reduced, registry};
use crate::scene::Setup;

/// Mode counts tried by the modal methods.
pub const MODES: [usize; 7] = [1, 2, 4, 8, 16, 32, 64];
/// Mode counts tried by `rds`: its cost grows with the square of the modes (a derivative direction
/// per pair); at 16 it already costs 3× `ds-implicit` on the creature and 6× on the V-beam
/// (`eval auto-model`), so more are not tried.
pub const RDS_MODES: [usize; 5] = [1, 2, 4, 8, 16];
/// Cloth steps tried, s.
pub const CLOTH_STEPS: [f64; 3] = [0.04, 0.02, 0.01];
/// Cloth PCG tolerances tried.
pub const CLOTH_TOLERANCES: [f64; 3] = [1e-2, 1e-3, 1e-4];

/// What a scene is made of, which decides the candidates and the estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// A discrete shell (modal methods, the nonlinear shell).
    Shell,
    /// Cloth (the implicit particle cloth).
    Cloth,
}

impl Family {
    /// The family of a scene: cloth if its `solver.method` is a cloth method, else shell.
    pub fn of(setup: &Setup) -> Self {
        match setup.scene.solver.method.as_str() {
            "cloth" | "cloth-quad" | "pbd" | "xpbd" => Family::Cloth,
            _ => Family::Shell,
        }
    }
}

/// One candidate: a method and its setting, with its measured cost and (once estimated) error.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Registered method.
    pub method: &'static str,
    /// Mode count (modal methods).
    pub modes: Option<usize>,
    /// Time step (cloth), s.
    pub step: Option<f64>,
    /// Inner-solve tolerance (cloth's PCG).
    pub tolerance: Option<f64>,
    /// Wall-clock seconds per simulated second.
    pub cost: f64,
    /// Estimated relative error (NaN: not estimated, because a cheaper candidate met the target).
    pub estimate: f64,
    /// Why the candidate could not be built or run, if it could not (it is then passed over).
    pub failure: Option<String>,
}

impl Candidate {
    fn new(method: &'static str, modes: Option<usize>) -> Self {
        Self { method, modes, step: None, tolerance: None, cost: f64::NAN, estimate: f64::NAN, failure: None }
    }

    /// `method` with its setting, e.g. `mwts, 8 modes`.
    pub fn label(&self) -> String {
        let mut label = self.method.to_string();
        if let Some(m) = self.modes {
            label += &format!(", {m} modes");
        }
        if let Some(h) = self.step {
            label += &format!(", h = {h} s");
        }
        if let Some(t) = self.tolerance {
            label += &format!(", tolerance {t}");
        }
        label
    }

    /// The scene with this candidate's method and setting (and no accuracy, so it builds directly).
    pub fn apply(&self, setup: &Setup) -> Setup {
        let mut s = setup.clone();
        s.scene.solver.accuracy = None;
        s.scene.solver.method = self.method.to_string();
        if let Some(m) = self.modes {
            s.scene.solver.modes = m;
        }
        if let Some(h) = self.step {
            s.scene.solver.step = Some(h);
        }
        if let Some(t) = self.tolerance {
            s.scene.solver.tolerance = t;
        }
        s
    }
}

/// The outcome of a choice: every candidate (cheapest first) and which one was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    /// The target relative error.
    pub accuracy: f64,
    /// The family searched.
    pub family: Family,
    /// The candidates, cheapest first.
    pub candidates: Vec<Candidate>,
    /// Index of the chosen one (the most accurate estimated if none meets the target).
    pub chosen: usize,
    /// Wall-clock seconds spent measuring the candidates' costs (what a brute force needs as well).
    pub costing: f64,
}

impl Choice {
    /// The chosen candidate.
    pub fn winner(&self) -> &Candidate {
        &self.candidates[self.chosen]
    }

    /// Why, in sentences: the choice, and the cheaper candidates it beat with their estimates.
    pub fn explain(&self) -> Vec<String> {
        let w = self.winner();
        let met = w.estimate <= self.accuracy;
        let mut lines = vec![format!(
            "accuracy {}: {} {} (estimated error {:.3}, cost {:.2e} s per simulated s)",
            self.accuracy,
            if met {
                "chose the cheapest model that meets it,"
            } else {
                "NO candidate meets it; chose the most accurate,"
            },
            w.label(),
            w.estimate,
            w.cost
        )];
        let rejected: Vec<String> = self.candidates[..self.chosen]
            .iter()
            .filter(|c| c.estimate.is_finite())
            .map(|c| format!("{} ({:.3})", c.label(), c.estimate))
            .collect();
        if !rejected.is_empty() {
            lines.push(format!("cheaper candidates estimated above the target: {}", rejected.join(", ")));
        }
        let failed: Vec<String> =
            self.candidates.iter().filter_map(|c| c.failure.as_ref().map(|f| format!("{} ({f})", c.label()))).collect();
        if !failed.is_empty() {
            lines.push(format!("passed over, could not be run: {}", failed.join(", ")));
        }
        lines
    }
}

/// Choose the method for `setup` (whose `solver.accuracy` may be unset: `accuracy` is the target).
pub fn choose(setup: &Setup, accuracy: f64) -> Result<Choice, SolverError> {
    let family = Family::of(setup);
    let candidates = match family {
        Family::Shell => shell_candidates(setup),
        Family::Cloth => CLOTH_STEPS
            .iter()
            .flat_map(|&h| {
                CLOTH_TOLERANCES.iter().map(move |&t| Candidate {
                    step: Some(h),
                    tolerance: Some(t),
                    ..Candidate::new("cloth", None)
                })
            })
            .collect(),
    };
    choose_among(setup, accuracy, candidates, &DragSet::default(), &|_| {})
}

/// The cheapest shell model that meets `accuracy` under the drags as they stand (their targets
/// held still), among a few steps up from `method` with `modes` modes: the same method with 2× and
/// 4× the modes, `mwts-rs` with 1×, 2× and 4× the modes (each up to 64), on an anchored shell `rds`
/// with 1× (from `rds`: 2× and 4×; up to 16), and `ds-implicit`. The remedy the viewer's readout
/// names when a model is not enough. The scene's tracks are replaced by `drags`. The fraction of
/// candidates judged goes to `progress` (where the search is stopped, [`super::supersede`]).
pub fn remedy(
    setup: &Setup,
    accuracy: f64,
    drags: &DragSet,
    (method, modes): (&str, usize),
    progress: &dyn Fn(f32),
) -> Result<Choice, SolverError> {
    let mut still = setup.clone();
    still.scene.tracks.clear();
    still.tracks.clear();
    let candidates = remedy_candidates(setup, method, modes);
    choose_among(&still, accuracy, candidates, drags, progress)
}

/// The candidates of [`remedy`] from `method` with `modes` modes, each setting once.
fn remedy_candidates(setup: &Setup, method: &str, modes: usize) -> Vec<Candidate> {
    let free = 3 * (setup.mesh.vertex_count() - setup.anchors.len());
    let mut candidates: Vec<Candidate> = Vec::new();
    let mut add = |method: &'static str, modes: usize| {
        let most = if method == "rds" { RDS_MODES[RDS_MODES.len() - 1] } else { MODES[MODES.len() - 1] };
        let c = Candidate::new(method, Some(modes.clamp(1, most)));
        // Compared by setting: an unmeasured cost is NaN, so whole candidates never compare equal.
        let known = candidates.iter().any(|k| (k.method, k.modes) == (c.method, c.modes));
        if c.modes.is_some_and(|m| m < free) && !known {
            candidates.push(c);
        }
    };
    if let Ok(m) = registry::find(method)
        && matches!(m.name, "lma" | "mwts" | "rds")
    {
        [2, 4].into_iter().for_each(|k| add(m.name, k * modes));
    }
    [1, 2, 4].into_iter().for_each(|k| add("mwts-rs", k * modes));
    // From `rds`, 1× is itself.
    if reduced::suits(setup) && method != "rds" {
        add("rds", modes);
    }
    candidates.push(Candidate::new("ds-implicit", None));
    candidates
}

/// Measure every candidate's cost, then estimate them cheapest first under `drags` until one meets
/// `accuracy`. A candidate that cannot be built or run (its precompute or a step fails) is passed
/// over, last in cost order, with why; if none can, the first failure is the error.
fn choose_among(
    setup: &Setup,
    accuracy: f64,
    mut candidates: Vec<Candidate>,
    drags: &DragSet,
    progress: &dyn Fn(f32),
) -> Result<Choice, SolverError> {
    let family = Family::of(setup);
    let mut first_failure = None;
    let mut fail = |c: &mut Candidate, e: SolverError| {
        c.failure = Some(e.to_string());
        first_failure.get_or_insert(e);
    };
    let clock = Instant::now();
    // Costing takes the first tenth of the progress, judging (up to every candidate) the rest.
    let n = candidates.len().max(1) as f32;
    for (i, c) in candidates.iter_mut().enumerate() {
        progress(0.1 * i as f32 / n);
        match cost(&c.apply(setup)) {
            Ok(x) => c.cost = x,
            Err(e) => fail(c, e),
        }
    }
    let costing = clock.elapsed().as_secs_f64();
    candidates.sort_by(|a, b| a.failure.is_some().cmp(&b.failure.is_some()).then(a.cost.total_cmp(&b.cost)));
    let mut chosen = None;
    for (i, c) in candidates.iter_mut().enumerate().filter(|(_, c)| c.failure.is_none()) {
        let part = |f: f32| progress(0.1 + 0.9 * (i as f32 + f) / n);
        let estimate = match family {
            Family::Cloth => cloth_estimate(setup, c, &part),
            Family::Shell => shell_estimate(setup, c, drags, &part),
        };
        match estimate {
            Ok(e) => c.estimate = e,
            Err(e) => fail(c, e),
        }
        if c.estimate <= accuracy {
            chosen = Some(i);
            break;
        }
    }
    progress(1.0);
    let most_accurate = (0..candidates.len())
        .filter(|&i| candidates[i].estimate.is_finite())
        .min_by(|&a, &b| candidates[a].estimate.total_cmp(&candidates[b].estimate));
    match (chosen.or(most_accurate), first_failure) {
        (Some(chosen), _) => Ok(Choice { accuracy, family, candidates, chosen, costing }),
        (None, Some(e)) => Err(e),
        (None, None) => Err(SolverError::Unsuitable { method: "auto", reason: "no candidate model".into() }),
    }
}

/// Choose for the scene's `solver.accuracy` and build the winner: the solver and why it was chosen.
pub fn build(setup: &Setup) -> Result<(Box<dyn Solver>, Vec<String>), SolverError> {
    let accuracy = setup.scene.solver.accuracy.unwrap_or(f64::NAN);
    let choice = choose(setup, accuracy)?;
    let mut winner = choice.winner().apply(setup);
    winner.scene.tracks.clear();
    Ok((registry::build_named(&winner)?, choice.explain()))
}

fn shell_candidates(setup: &Setup) -> Vec<Candidate> {
    let free = 3 * (setup.mesh.vertex_count() - setup.anchors.len());
    let mut v = vec![Candidate::new("rigid", None)];
    for method in ["lma", "mwts", "mwts-rs"].into_iter().filter(|m| registry::find(m).is_ok()) {
        v.extend(MODES.iter().filter(|&&m| m < free).map(|&m| Candidate::new(method, Some(m))));
    }
    if reduced::suits(setup) {
        v.extend(RDS_MODES.iter().filter(|&&m| m < free).map(|&m| Candidate::new("rds", Some(m))));
    }
    v.push(Candidate::new("ds-implicit", None));
    v
}

/// Wall-clock seconds per simulated second: a few steps from rest, timed (at least 20 ms of work).
fn cost(setup: &Setup) -> Result<f64, SolverError> {
    let mut solver = registry::build_named(setup)?;
    let (mut wall, mut simulated, mut steps) = (0.0, 0.0, 0);
    while steps < 3 || (wall < 0.02 && steps < 200) {
        let start = Instant::now();
        let stats = solver.step()?;
        wall += start.elapsed().as_secs_f64();
        simulated = stats.sim_time;
        steps += 1;
    }
    Ok(wall / simulated)
}

/// The relative error estimate of a shell candidate under `drags` (see the module doc).
/// Settling takes the first half of the fraction reported to `progress`, the estimate the rest.
fn shell_estimate(setup: &Setup, c: &Candidate, drags: &DragSet, progress: &dyn Fn(f32)) -> Result<f64, SolverError> {
    match c.method {
        "rigid" => return Ok(1.0),
        "ds-implicit" => return Ok(0.0),
        _ => {}
    }
    let settled = settle(setup, c, drags, &|f| progress(0.5 * f))?;
    quality::estimate_reporting(setup, settled.positions(), settled.drags(), &|f| progress(0.5 + 0.5 * f))
}

/// The candidate's equilibrium under the scene's loads, its tracks held at their start: shells run to
/// rest under critical damping of their lowest mode (at most 40 time constants), cloth under its own
/// damping (at most 20 s).
pub fn at_rest(setup: &Setup, c: &Candidate) -> Result<Vec<DVec3>, SolverError> {
    Ok(settle(setup, c, &DragSet::default(), &|_| {})?.positions().to_vec())
}

/// [`at_rest`] under `drags` (those the candidate's method takes), returning the settled solver; the
/// fraction of the longest settling time simulated goes to `progress` before each step.
fn settle(
    setup: &Setup,
    c: &Candidate,
    drags: &DragSet,
    progress: &dyn Fn(f32),
) -> Result<Box<dyn Solver>, SolverError> {
    let rest = setup.mesh.positions().to_vec();
    let mut s = c.apply(setup);
    let stop = match Family::of(setup) {
        Family::Shell => {
            let omega = lowest_frequency(&held(setup))?;
            s.scene.solver.rayleigh_alpha = 2.0 * omega;
            s.scene.solver.rayleigh_beta = 0.0;
            Stop { max_time: 40.0 / omega, max_steps: 20_000, rest: 1e-7 }
        }
        Family::Cloth => Stop { max_time: 20.0, max_steps: 20_000, rest: 1e-6 },
    };
    let mut solver = start(&s, drags)?;
    let reached = run_driven(solver.as_mut(), &rest, stop, &mut |_, t| {
        progress((t / stop.max_time) as f32);
        Ok(())
    });
    match reached.outcome {
        super::run::Outcome::Diverged(e) => Err(e),
        _ => Ok(solver),
    }
}

/// The solver of `setup` at rest with `drags` (those its method takes) and the drags of its tracks
/// at their targets at time 0, held there (the tracks do not move on).
pub fn start(setup: &Setup, drags: &DragSet) -> Result<Box<dyn Solver>, SolverError> {
    let mut still = setup.clone();
    still.scene.tracks.clear();
    let mut solver = registry::build_named(&still)?;
    for (_, d) in drags.iter() {
        if matches!(d.kind, super::DragKind::Position(_)) || solver.drags().supports_orientation() {
            solver.drags_mut().add(*d)?;
        }
    }
    if solver.drags().supports_orientation() {
        for (_, f) in drags.frames() {
            solver.drags_mut().add_frame(f.clone())?;
        }
    }
    Script::new(setup).drive(solver.as_mut(), 0.0)?;
    Ok(solver)
}

/// `setup` with every tracked vertex anchored as well: the shell held where its tracks hold it, for
/// what needs anchors (the lowest frequency of a part held only by tracks, a `ds-static` reference;
/// [`start`] still places the tracked vertices at their tracks' targets).
pub fn held(setup: &Setup) -> Setup {
    let mut s = setup.clone();
    s.anchors.extend(setup.tracks.iter().flatten());
    s.anchors.sort_unstable();
    s.anchors.dedup();
    s
}

/// The relative error estimate of a cloth candidate: from its rest state, [`RELAX_STEPS`] backward
/// Euler steps of 0.1 s with a tight PCG (nearly Newton steps on the static cloth equations, `M/h²`
/// keeping them regular); the distance they travel, relative to the displacement they arrive at.
fn cloth_estimate(setup: &Setup, c: &Candidate, progress: &dyn Fn(f32)) -> Result<f64, SolverError> {
    let mut solver = settle(setup, c, &DragSet::default(), progress)?;
    let x = solver.positions().to_vec();
    for (name, value) in [("step", 0.1), ("tolerance", 1e-8), ("iterations", 1e5)] {
        solver.set_param(name, value)?;
    }
    for _ in 0..RELAX_STEPS {
        solver.step()?;
    }
    let relaxed = solver.positions();
    Ok(distance(relaxed, &x) / distance(relaxed, setup.mesh.positions()))
}

/// Relaxation steps behind a cloth estimate.
pub const RELAX_STEPS: usize = 5;

/// `ω₁` of the anchored shell, rad/s (from a one-mode analysis).
pub fn lowest_frequency(setup: &Setup) -> Result<f64, SolverError> {
    Ok(super::modal::compute::analyse_scene(setup, 1)?.basis.eigenvalues[0].sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cantilever() -> Setup {
        crate::scene::load("cantilever", &[]).unwrap()
    }

    #[test]
    fn stricter_targets_choose_more_accurate_models_and_the_choice_is_explained() {
        let setup = cantilever();
        let loose = choose(&setup, 0.5).unwrap();
        let strict = choose(&setup, 0.05).unwrap();
        let exact = choose(&setup, 1e-9).unwrap();
        assert!(loose.winner().estimate <= 0.5 && strict.winner().estimate <= 0.05);
        // Costs are measured, so the order of near-equal candidates varies from run to run: when the
        // cheapest one meets both targets, both choose it.
        assert!(strict.winner().estimate <= loose.winner().estimate, "{:?} vs {:?}", strict.winner(), loose.winner());
        assert!(
            loose.candidates[..loose.chosen].iter().all(|c| c.estimate > 0.5),
            "the loose choice is the cheapest meeting it"
        );
        // Only the full equations meet a target below any reduced model's error.
        assert_eq!(exact.winner().method, "ds-implicit");
        // Candidates are estimated cheapest first, up to the winner and no further.
        assert!(strict.candidates[..strict.chosen].iter().all(|c| c.estimate > 0.05));
        assert!(strict.candidates[strict.chosen + 1..].iter().all(|c| c.estimate.is_nan()));
        let mut s = setup.clone();
        s.scene.solver.accuracy = Some(0.05);
        let built = crate::solver::build(&s).unwrap();
        assert_eq!(built.method(), strict.winner().method);
        assert!(built.notes()[0].starts_with("accuracy 0.05: chose"), "{:?}", built.notes());
    }

    #[test]
    fn a_candidate_that_cannot_be_built_is_passed_over_with_why() {
        let setup = cantilever();
        let none = DragSet::default();
        let too_many = Candidate::new("mwts", Some(100_000));
        let choice =
            choose_among(&setup, 0.5, vec![too_many.clone(), Candidate::new("ds-implicit", None)], &none, &|_| {})
                .unwrap();
        assert_eq!(choice.winner().method, "ds-implicit");
        let failed = choice.candidates.last().unwrap();
        assert!(failed.failure.as_deref().is_some_and(|f| f.contains("`solver.modes`: 100000")), "{failed:?}");
        assert!(choice.explain().iter().any(|l| l.starts_with("passed over, could not be run: mwts, 100000 modes")));
        // Nothing that can run: its failure is the error.
        assert!(matches!(
            choose_among(&setup, 0.5, vec![too_many], &none, &|_| {}),
            Err(SolverError::SceneValue { .. })
        ));
    }

    #[test]
    fn a_search_reports_its_progress_as_it_goes_and_stops_when_superseded() {
        use std::cell::RefCell;

        use crate::solver::supersede::{Generation, unless_superseded};

        let setup = cantilever();
        let none = DragSet::default();
        let candidates = || vec![Candidate::new("mwts", Some(4)), Candidate::new("ds-implicit", None)];
        // In full: fractions from 0 to 1, never back, many of them (each settling step reports).
        let seen = RefCell::new(Vec::new());
        let choice = choose_among(&setup, 1e-9, candidates(), &none, &|f| seen.borrow_mut().push(f)).unwrap();
        assert_eq!(choice.winner().method, "ds-implicit");
        let seen = seen.into_inner();
        assert!(seen.len() > 20, "{} reports", seen.len());
        assert!(seen.windows(2).all(|w| w[0] <= w[1]) && seen.iter().all(|f| (0.0..=1.0).contains(f)), "{seen:?}");
        assert_eq!(seen.last(), Some(&1.0));
        // Superseded at its fifth report (while it settles the first candidate): it stops there.
        let generation = Generation::default();
        let ticket = generation.next();
        let reports = RefCell::new(0);
        let stopped = unless_superseded(
            &ticket,
            &|_| {
                *reports.borrow_mut() += 1;
                if *reports.borrow() == 5 {
                    generation.cancel_all();
                }
            },
            |report| choose_among(&setup, 1e-9, candidates(), &none, report),
        );
        assert!(stopped.is_none());
        assert_eq!(reports.into_inner(), 5, "no work reported after the stop");
    }

    #[test]
    fn rds_is_chosen_where_the_modal_methods_fall_short() {
        // The V-beam under 40 g sags by a third of its length: `mwts-rs`'s quadratic energy is 6% off
        // there at any mode count (`eval auto-model`), `rds` keeps the whole shell energy.
        let setup = crate::scene::load("v-beam", &["gravity=[0, -400, 0]".into()]).unwrap();
        let candidates = vec![Candidate::new("mwts-rs", Some(8)), Candidate::new("rds", Some(8))];
        let choice = choose_among(&setup, 0.05, candidates, &DragSet::default(), &|_| {}).unwrap();
        let estimate = |method: &str| choice.candidates.iter().find(|c| c.method == method).unwrap().estimate;
        assert_eq!(choice.winner().method, "rds", "{:?}", choice.candidates);
        assert!(estimate("rds") < 0.05, "{:?}", choice.candidates);
        // Either `mwts-rs` was cheaper and estimated above the target, or it was never estimated.
        assert!(estimate("mwts-rs") > 0.05 || estimate("mwts-rs").is_nan(), "{:?}", choice.candidates);
        // Every shell choice has `rds` among its candidates, up to 16 modes.
        let all = shell_candidates(&setup);
        assert!(RDS_MODES.iter().all(|&m| all.iter().any(|c| (c.method, c.modes) == ("rds", Some(m)))));
    }

    #[test]
    fn a_remedy_tries_each_setting_once_up_to_each_method_s_largest() {
        let settings = |method, modes| -> Vec<(&str, Option<usize>)> {
            remedy_candidates(&cantilever(), method, modes).iter().map(|c| (c.method, c.modes)).collect()
        };
        // From 32 modes, 2× and 4× are both capped at 64; `rds` at 16.
        assert_eq!(
            settings("mwts", 32),
            [
                ("mwts", Some(64)),
                ("mwts-rs", Some(32)),
                ("mwts-rs", Some(64)),
                ("rds", Some(16)),
                ("ds-implicit", None)
            ]
        );
        assert_eq!(
            settings("rds", 8),
            [
                ("rds", Some(16)),
                ("mwts-rs", Some(8)),
                ("mwts-rs", Some(16)),
                ("mwts-rs", Some(32)),
                ("ds-implicit", None)
            ]
        );
        // A shell held by nothing gets no `rds`.
        let mut free = cantilever();
        free.anchors.clear();
        assert!(remedy_candidates(&free, "mwts", 4).iter().all(|c| c.method != "rds"));
        assert!(shell_candidates(&free).iter().all(|c| c.method != "rds"));
    }

    #[test]
    fn the_family_follows_the_scene_method() {
        assert_eq!(Family::of(&cantilever()), Family::Shell);
        assert_eq!(Family::of(&crate::scene::load("drape", &[]).unwrap()), Family::Cloth);
    }
}
