//! A scene of several parts (connected components of its mesh), each simulated by its own method and
//! settings (`[[parts]]`), behind one [`Solver`]: a part is built from the scene cut down to its
//! vertices (its own mesh, anchors, loads, colliders and tracks), the parts advance together, and the
//! positions, drags and statistics are gathered over the whole mesh.
//!
//! - Time: one step is the longest of the parts' steps; each part takes as many of its own steps as
//!   reach that time (to within half its step).
//! - Drags live in one set over the whole mesh; before a step they are handed to the part that owns
//!   their vertex (renumbered). Orientation drags are allowed if every part takes them.
//! - Parameters: the first part's list; setting one sets it in every part that has it.
//! - Models: a part with an accuracy target (its own `accuracy`, else `solver.accuracy`) gets the
//!   cheapest model that meets it, chosen on the part alone ([`super::auto`]).

use std::time::Instant;

use glam::DVec3;

use super::registry::find;
use super::{Drag, DragSet, FrameDrag, ParamValue, Progress, Solver, SolverError, StepStats, auto};
use crate::scene::Setup;

/// One part: its solver and the global index of each of its vertices.
struct Part {
    solver: Box<dyn Solver>,
    vertices: Vec<usize>,
    time: f64,
    /// Energy after its last step, J.
    energy: f64,
    /// Why its model was chosen (empty unless it had an accuracy target).
    why: Vec<String>,
}

/// A part before it is built: its vertices and the scene cut down to them.
#[derive(Debug, Clone)]
pub struct Piece {
    /// Global index of each of its vertices, sorted.
    pub vertices: Vec<usize>,
    /// The scene cut down to the part (its mesh, anchors, loads, colliders and tracks, renumbered),
    /// with `[solver]` replaced by the part's settings.
    pub setup: Setup,
}

/// The parts of a scene, as one solver.
pub struct Parts {
    parts: Vec<Part>,
    /// `(part, local index)` of every global vertex.
    owner: Vec<(usize, usize)>,
    positions: Vec<DVec3>,
    drags: DragSet,
    synced: Option<u64>,
    time: f64,
}

/// The scene cut down to `vertices` (sorted), with `[solver]` replaced by `settings`.
fn cut(setup: &Setup, vertices: &[usize], settings: crate::scene::SolverSettings) -> Result<Setup, SolverError> {
    let mut local = vec![usize::MAX; setup.mesh.vertex_count()];
    vertices.iter().enumerate().for_each(|(k, &v)| local[v] = k);
    let keep = |list: &[usize]| -> Vec<usize> {
        list.iter().filter(|&&v| local[v] != usize::MAX).map(|&v| local[v]).collect()
    };
    let mesh = setup.mesh.submesh(vertices).map_err(|e| SolverError::Numerical(e.to_string()))?;
    let mut scene = setup.scene.clone();
    scene.solver = settings;
    scene.parts.clear();
    // The tracks that reach this part, renumbered; the others are dropped (the driver of the whole
    // scene moves the drags, the part only needs to know it is held).
    let tracks: Vec<Vec<usize>> = setup.tracks.iter().map(|t| keep(t)).collect();
    let held: Vec<bool> = tracks.iter().map(|t| !t.is_empty()).collect();
    scene.tracks = scene.tracks.into_iter().zip(&held).filter(|(_, h)| **h).map(|(t, _)| t).collect();
    Ok(Setup {
        scene,
        origin: setup.origin.clone(),
        mesh,
        anchors: keep(&setup.anchors),
        loads: vertices.iter().map(|&v| setup.loads[v]).collect(),
        bodies: setup.bodies.clone(),
        tracks: tracks.into_iter().filter(|t| !t.is_empty()).collect(),
        parts: Vec::new(),
    })
}

/// The scene's parts, each cut down to its vertices with its own settings: the `[[parts]]` entries in
/// order, then one more with `[solver]` for the vertices of no part (if any).
pub fn split(setup: &Setup) -> Result<Vec<Piece>, SolverError> {
    let n = setup.mesh.vertex_count();
    let mut owned = vec![false; n];
    let mut groups: Vec<(Vec<usize>, crate::scene::SolverSettings)> = Vec::new();
    for (spec, vertices) in setup.scene.parts.iter().zip(&setup.parts) {
        vertices.iter().for_each(|&v| owned[v] = true);
        groups.push((vertices.clone(), spec.settings(&setup.scene.solver)));
    }
    let rest: Vec<usize> = (0..n).filter(|&v| !owned[v]).collect();
    if !rest.is_empty() {
        groups.push((rest, setup.scene.solver.clone()));
    }
    groups
        .into_iter()
        .map(|(vertices, settings)| Ok(Piece { setup: cut(setup, &vertices, settings)?, vertices }))
        .collect()
}

/// The key of a refused `solver.*` value as the scene gives it: `parts[i].*` when part `i` sets it.
fn own_key(setup: &Setup, i: usize, key: String) -> String {
    let part = setup.scene.parts.get(i).and_then(|p| toml::Value::try_from(p).ok());
    match (key.strip_prefix("solver."), part) {
        (Some(field), Some(part)) if part.get(field).is_some() => format!("parts[{i}].{field}"),
        _ => key,
    }
}

/// A piece's solver: the model its accuracy target chooses, with why, or the method it names.
fn build(piece: &Setup) -> Result<(Box<dyn Solver>, Vec<String>), SolverError> {
    match piece.scene.solver.accuracy {
        Some(_) => auto::build(piece),
        None => Ok((find(&piece.scene.solver.method)?.construct(piece)?, Vec::new())),
    }
}

impl Parts {
    /// Build every part (and one more, with `[solver]`, for the vertices of no part).
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        let n = setup.mesh.vertex_count();
        let mut owner = vec![(0, 0); n];
        let pieces = split(setup)?;
        let mut parts = Vec::with_capacity(pieces.len());
        for (i, Piece { vertices, setup: sub }) in pieces.into_iter().enumerate() {
            let (solver, why) = build(&sub).map_err(|e| match e {
                SolverError::Unsuitable { method, reason } => {
                    SolverError::Unsuitable { method, reason: format!("part {i}: {reason}") }
                }
                SolverError::SceneValue { file, key, reason } => {
                    SolverError::SceneValue { file, key: own_key(setup, i, key), reason }
                }
                e => e,
            })?;
            vertices.iter().enumerate().for_each(|(k, &v)| owner[v] = (i, k));
            parts.push(Part { solver, vertices, time: 0.0, energy: 0.0, why });
        }
        // Orientation drags only if every part takes them: probe each with one at rest.
        let mut orientation = true;
        for p in &mut parts {
            let probe = Drag { vertex: 0, kind: super::DragKind::Orientation(DVec3::ZERO) };
            match p.solver.drags_mut().add(probe) {
                Ok(id) => {
                    p.solver.drags_mut().remove(id)?;
                }
                Err(_) => orientation = false,
            }
        }
        let mut all = Self {
            parts,
            owner,
            positions: setup.mesh.positions().to_vec(),
            drags: DragSet::new(n, orientation),
            synced: None,
            time: 0.0,
        };
        all.gather();
        Ok(all)
    }

    fn gather(&mut self) {
        for p in &self.parts {
            for (k, &v) in p.vertices.iter().enumerate() {
                self.positions[v] = p.solver.positions()[k];
            }
        }
    }

    /// Hand the drags to the parts that own their vertices, if they changed.
    fn sync_drags(&mut self) -> Result<(), SolverError> {
        if self.synced == Some(self.drags.revision()) {
            return Ok(());
        }
        self.parts.iter_mut().for_each(|p| p.solver.drags_mut().clear());
        for (_, d) in self.drags.iter() {
            let (part, local) = self.owner[d.vertex];
            self.parts[part].solver.drags_mut().add(Drag { vertex: local, kind: d.kind })?;
        }
        // A frame spanning several parts turns each part's share of it.
        for (_, f) in self.drags.frames() {
            let mut shares: Vec<Vec<usize>> = vec![Vec::new(); self.parts.len()];
            f.vertices.iter().map(|&v| self.owner[v]).for_each(|(part, local)| shares[part].push(local));
            for (part, vertices) in shares.into_iter().enumerate().filter(|(_, v)| !v.is_empty()) {
                self.parts[part].solver.drags_mut().add_frame(FrameDrag { vertices, rotation: f.rotation })?;
            }
        }
        self.synced = Some(self.drags.revision());
        Ok(())
    }
}

impl Solver for Parts {
    fn method(&self) -> &'static str {
        self.parts[0].solver.method()
    }

    fn time_step(&self) -> f64 {
        self.parts.iter().map(|p| p.solver.time_step()).fold(0.0, f64::max)
    }

    fn step(&mut self) -> Result<StepStats, SolverError> {
        let start = Instant::now();
        self.sync_drags()?;
        let target = self.time + self.time_step();
        let mut stats = StepStats { sim_time: target, ..StepStats::default() };
        for p in &mut self.parts {
            while p.time < target - 0.5 * p.solver.time_step() {
                let s = p.solver.step()?;
                p.time = s.sim_time;
                p.energy = s.energy;
                stats.iterations += s.iterations;
                stats.converged &= s.converged;
                stats.residual = stats.residual.max(s.residual);
                stats.relative_residual = stats.relative_residual.max(s.relative_residual);
            }
            stats.energy += p.energy;
        }
        self.time = target;
        self.gather();
        stats.wall_seconds = start.elapsed().as_secs_f64();
        Ok(stats)
    }

    fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    fn reset(&mut self) {
        for p in &mut self.parts {
            p.solver.reset();
            p.time = 0.0;
            p.energy = 0.0;
        }
        self.time = 0.0;
        self.gather();
    }

    fn params(&self) -> Vec<ParamValue> {
        self.parts[0].solver.params()
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), SolverError> {
        let mut first_error = None;
        let mut set = false;
        for p in &mut self.parts {
            match p.solver.set_param(name, value) {
                Ok(()) => set = true,
                Err(e) => first_error = first_error.or(Some(e)),
            }
        }
        match (set, first_error) {
            (true, _) | (false, None) => Ok(()),
            (false, Some(e)) => Err(e),
        }
    }

    fn drags(&self) -> &DragSet {
        &self.drags
    }

    fn drags_mut(&mut self) -> &mut DragSet {
        &mut self.drags
    }

    fn progress(&self) -> Option<Progress> {
        self.parts.iter().find_map(|p| p.solver.progress())
    }

    fn poll(&mut self) -> Result<(), SolverError> {
        self.parts.iter_mut().try_for_each(|p| p.solver.poll())?;
        self.gather();
        Ok(())
    }

    fn expect_drags(&mut self) {
        self.parts.iter_mut().for_each(|p| p.solver.expect_drags());
    }

    fn info(&self) -> Vec<(&'static str, f64)> {
        let mut info = vec![("parts", self.parts.len() as f64)];
        info.extend(self.parts[0].solver.info());
        info
    }

    fn body_poses(&self) -> Vec<(DVec3, glam::DQuat)> {
        self.parts.iter().map(|p| p.solver.body_poses()).find(|b| !b.is_empty()).unwrap_or_default()
    }

    fn notes(&self) -> Vec<String> {
        self.parts
            .iter()
            .enumerate()
            .flat_map(|(i, p)| {
                let head = format!("part {i}: {} on {} vertices", p.solver.method(), p.vertices.len());
                let own = p.why.iter().cloned().chain(p.solver.notes());
                std::iter::once(head).chain(own.map(move |n| format!("part {i}: {n}")))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_takes_its_own_target_else_none_if_it_names_a_method_else_the_scenes() {
        let setup = crate::scene::load("dancer", &["solver.accuracy=0.1".into()]).unwrap();
        let (mut part, solver) = (setup.scene.parts[0].clone(), &setup.scene.solver);
        assert_eq!(part.settings(solver).accuracy, Some(0.1));
        part.method = Some("lma".into());
        assert_eq!(part.settings(solver).accuracy, None);
        part.accuracy = Some(0.2);
        let own = part.settings(solver);
        assert_eq!((own.accuracy, own.method.as_str()), (Some(0.2), "lma"), "the method names the family");
    }

    /// The dancer's legs are mirror images: with a loose and a tight target they get a reduced model
    /// and the full equations, each with why; the parts without a target keep the scene's method.
    #[test]
    fn each_part_gets_the_model_its_own_target_chooses() {
        let mut setup = crate::scene::load("dancer", &[]).unwrap();
        setup.scene.parts[2].accuracy = Some(0.5);
        setup.scene.parts[3].accuracy = Some(0.05);
        let targets: Vec<Option<f64>> = split(&setup).unwrap().iter().map(|p| p.setup.scene.solver.accuracy).collect();
        assert_eq!(targets, [None, None, Some(0.5), Some(0.05)]);
        let built = Parts::new(&setup).unwrap();
        let methods: Vec<&str> = built.parts.iter().map(|p| p.solver.method()).collect();
        assert_eq!(methods[..2], ["mwts", "mwts"]);
        assert!(matches!(methods[2], "lma" | "mwts" | "mwts-rs"), "{methods:?}");
        assert_eq!(methods[3], "ds-implicit", "only the full equations meet 5% on a leg");
        let notes = built.notes();
        for (k, target) in [(2, "0.5"), (3, "0.05")] {
            let head = format!("part {k}: accuracy {target}: chose the cheapest model that meets it");
            assert!(notes.iter().any(|n| n.starts_with(&head)), "{notes:?}");
        }
        assert!(built.parts[..2].iter().all(|p| p.why.is_empty()));
    }
}
