//! Scene and method switches built off the UI thread: loading a scene and building its solver (a
//! modal method may compute modes for seconds) run on a worker thread while the window keeps drawing
//! the running simulation; the viewer polls for the result each frame.

use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::time::Instant;

use crate::scene::{self, SceneError, Setup};
use crate::solver::{self, Solver, SolverError};

/// What a scene is rebuilt from: the name or path it was opened by and its `key=value` overrides
/// (including `solver.method=...`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneSource {
    /// Built-in scene name or scene file path.
    pub scene: String,
    /// Overrides applied on top of the file, in order.
    pub overrides: Vec<String>,
}

impl SceneSource {
    /// The same scene with the same overrides, run by `method`.
    pub fn with_method(&self, method: &str) -> Self {
        let mut overrides: Vec<String> =
            self.overrides.iter().filter(|o| !o.trim_start().starts_with("solver.method=")).cloned().collect();
        overrides.push(format!("solver.method={method}"));
        Self { scene: self.scene.clone(), overrides }
    }

    /// What to call it in messages: the scene and, if one is forced, the method.
    pub fn describe(&self) -> String {
        match self.overrides.iter().rev().find_map(|o| o.trim_start().strip_prefix("solver.method=")) {
            Some(method) => format!("{} ({method})", self.scene),
            None => self.scene.clone(),
        }
    }
}

/// Why a switch failed.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The solver could not be built.
    #[error("building the solver for {scene}: {source}")]
    Solver {
        /// The scene.
        scene: String,
        /// Why.
        source: SolverError,
    },
    /// The worker thread ended without an answer.
    #[error("loading {0} stopped unexpectedly")]
    Stopped(String),
    /// The solver was built but refused by the load's check (e.g. a ghost too slow for real time).
    #[error("{0}")]
    Refused(String),
}

/// A check a loaded solver must pass (run on the worker thread).
pub type Check = fn(&mut dyn Solver) -> Result<f64, String>;

/// A scene ready to be shown.
pub struct Loaded {
    /// Where it came from.
    pub source: SceneSource,
    /// The realised scene.
    pub setup: Setup,
    /// Its solver, ready to step.
    pub solver: Box<dyn Solver>,
}

/// Load a scene and build its solver (on the calling thread).
pub fn load(source: SceneSource) -> Result<Loaded, LoadError> {
    let setup = scene::load(&source.scene, &source.overrides)?;
    let solver =
        solver::build(&setup).map_err(|source| LoadError::Solver { scene: setup.origin.label.clone(), source })?;
    Ok(Loaded { source, setup, solver })
}

struct Job {
    what: String,
    started: Instant,
    receiver: Receiver<Result<Loaded, LoadError>>,
}

/// At most one switch in flight; a newer request replaces (and discards) an older one.
#[derive(Default)]
pub struct Loader {
    job: Option<Job>,
}

impl Loader {
    /// Start loading `source` on a worker thread.
    pub fn start(&mut self, source: SceneSource) {
        self.start_checked(source, None);
    }

    /// Start loading `source` on a worker thread, then run `check` on its solver there.
    pub fn start_checked(&mut self, source: SceneSource, check: Option<Check>) {
        let (tx, receiver) = mpsc::channel();
        let what = source.describe();
        // If the thread cannot start, `tx` goes with it and the next poll reports `Stopped`.
        let _ = std::thread::Builder::new().name("shellwarp-load".into()).spawn(move || {
            let result = load(source).and_then(|mut loaded| match check {
                Some(check) => check(loaded.solver.as_mut()).map(|_| loaded).map_err(LoadError::Refused),
                None => Ok(loaded),
            });
            let _ = tx.send(result);
        });
        self.job = Some(Job { what, started: Instant::now(), receiver });
    }

    /// The finished load, if it has finished.
    pub fn poll(&mut self) -> Option<Result<Loaded, LoadError>> {
        let job = self.job.as_ref()?;
        let result = match job.receiver.try_recv() {
            Ok(result) => result,
            Err(TryRecvError::Empty) => return None,
            Err(TryRecvError::Disconnected) => Err(LoadError::Stopped(job.what.clone())),
        };
        self.job = None;
        Some(result)
    }

    /// What is loading and for how long, for the panel.
    pub fn status(&self) -> Option<String> {
        self.job.as_ref().map(|j| format!("loading {} ... {:.1} s", j.what, j.started.elapsed().as_secs_f64()))
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn wait(loader: &mut Loader) -> Result<Loaded, LoadError> {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(60) {
            if let Some(r) = loader.poll() {
                return r;
            }
            assert!(loader.status().is_some_and(|s| s.contains("loading")), "progress is shown while loading");
            std::thread::sleep(Duration::from_millis(5));
        }
        panic!("the load never finished");
    }

    fn param(loaded: &Loaded, name: &str) -> Option<f64> {
        loaded.solver.params().iter().find(|p| p.spec.name == name).map(|p| p.value)
    }

    #[test]
    fn a_method_switch_keeps_the_scene_path_and_its_overrides() {
        let path = format!("{}/assets/scenes/cantilever.toml", env!("CARGO_MANIFEST_DIR"));
        let source = SceneSource {
            scene: path.clone(),
            overrides: vec!["solver.method=mwts".into(), "material.k_bend=0.3".into()],
        };
        let switched = source.with_method("lma");
        assert_eq!(switched.overrides, ["material.k_bend=0.3", "solver.method=lma"]);
        let mut loader = Loader::default();
        loader.start(switched.clone());
        let loaded = wait(&mut loader).unwrap();
        assert_eq!(loaded.solver.method(), "lma");
        assert_eq!(param(&loaded, "k_bend"), Some(0.3), "the override survived the switch");
        assert_eq!(loaded.source, switched);
        assert!(loader.status().is_none() && loader.poll().is_none(), "done");
    }

    #[test]
    fn a_failed_load_is_reported_not_fatal() {
        let mut loader = Loader::default();
        loader.start(SceneSource { scene: "no-such-scene".into(), overrides: Vec::new() });
        let err = wait(&mut loader).err().expect("an unknown scene fails");
        assert!(err.to_string().contains("no-such-scene"), "{err}");
    }

    #[test]
    fn a_newer_request_replaces_an_older_one() {
        let mut loader = Loader::default();
        loader.start(SceneSource { scene: "no-such-scene".into(), overrides: Vec::new() });
        loader.start(SceneSource { scene: "cantilever".into(), overrides: vec!["solver.method=lma".into()] });
        assert_eq!(wait(&mut loader).map(|l| l.solver.method()).ok(), Some("lma"));
    }
}
