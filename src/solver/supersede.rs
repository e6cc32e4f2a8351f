//! Abandoning background work that a newer request, or its owner going away, has made pointless.
//!
//! Every parameter edit of a modal solver starts a new analysis, and only the latest one matters; a
//! quality readout's judgement (a few Newton iterations of the full shell, or a search for a remedy
//! that builds and settles several models) is pointless once the viewer has switched scene. Each
//! request takes a number from a shared [`Generation`] counter; a run whose number is no longer the
//! latest stops before it starts and at every progress report of the work (the work has no other
//! exit between its stages, so the stop unwinds out of it with a private payload that
//! [`unless_superseded`] catches; every other panic passes through untouched). Work that reports
//! no progress — a solver's step, whose Newton iterations may run for minutes at a user's setting —
//! can still be stopped: while a run is under way its ticket is the thread's, and [`checkpoint`]
//! (called once per Newton iteration, explicit substep and position-based substep) stops it there
//! the same way. The simulation thread runs each
//! step so, and the window supersedes a step whose result a reset or a switch would discard.

use std::cell::RefCell;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::time::Duration;

use super::SolverError;

/// A shared request counter: the newest ticket is the only current one.
#[derive(Debug, Clone, Default)]
pub struct Generation(Arc<AtomicU64>);

/// One request's number, checked against its [`Generation`].
#[derive(Debug, Clone)]
pub struct Ticket {
    generation: Generation,
    number: u64,
}

impl Generation {
    /// A new request; every earlier ticket becomes superseded.
    pub fn next(&self) -> Ticket {
        let number = self.0.fetch_add(1, Ordering::SeqCst) + 1;
        Ticket { generation: self.clone(), number }
    }

    /// Supersede every ticket issued so far (e.g. when the owner goes away).
    pub fn cancel_all(&self) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

impl Ticket {
    /// Whether no newer request has been made.
    pub fn is_current(&self) -> bool {
        self.generation.0.load(Ordering::SeqCst) == self.number
    }
}

/// A result computed on a background thread (a solver's new basis after an edit), stopped when a
/// newer request of the same [`Generation`] supersedes it, with its progress.
pub struct Background<T> {
    receiver: Receiver<Result<T, SolverError>>,
    progress: Arc<AtomicU32>,
    what: &'static str,
}

impl<T: Send + 'static> Background<T> {
    /// Start `work` (`what` it computes, for messages) on a thread named `name`, after waiting
    /// `settle` for further edits: a burst of edits costs one run, the last.
    pub fn start(
        name: &str,
        what: &'static str,
        generation: &Generation,
        settle: Duration,
        work: impl FnOnce(&dyn Fn(f32)) -> Result<T, SolverError> + Send + 'static,
    ) -> Self {
        let (tx, receiver) = mpsc::channel();
        let progress = Arc::new(AtomicU32::new(0));
        let (p, ticket) = (progress.clone(), generation.next());
        // If the thread cannot start, `tx` goes with it and the result reads as stopped.
        let _ = std::thread::Builder::new().name(name.into()).spawn(move || {
            std::thread::sleep(settle);
            let report = move |f: f32| p.store(f.to_bits(), Ordering::Relaxed);
            if let Some(result) = unless_superseded(&ticket, &report, work) {
                let _ = tx.send(result);
            }
        });
        Self { receiver, progress, what }
    }

    /// The result once it is ready; `None` while the work runs.
    pub fn ready(&self) -> Option<Result<T, SolverError>> {
        match self.receiver.try_recv() {
            Ok(result) => Some(result),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(self.stopped())),
        }
    }

    /// Wait for the result.
    pub fn wait(&self) -> Result<T, SolverError> {
        self.receiver.recv().unwrap_or_else(|_| Err(self.stopped()))
    }

    /// The completed fraction, in `[0, 1]`.
    pub fn fraction(&self) -> f32 {
        f32::from_bits(self.progress.load(Ordering::Relaxed))
    }

    fn stopped(&self) -> SolverError {
        SolverError::Numerical(format!("the background {} stopped", self.what))
    }
}

/// The unwind payload that stops a superseded run at its next progress report.
struct Superseded;

/// Run `work` (which reports progress through the function it is given) unless `ticket` is
/// superseded before it starts or at one of its progress reports; reports of a current run are
/// forwarded to `progress`. `None` when the run was abandoned.
pub fn unless_superseded<T>(
    ticket: &Ticket,
    progress: &dyn Fn(f32),
    work: impl FnOnce(&dyn Fn(f32)) -> T,
) -> Option<T> {
    if !ticket.is_current() {
        return None;
    }
    let report = |fraction: f32| {
        if !ticket.is_current() {
            resume_unwind(Box::new(Superseded));
        }
        progress(fraction);
    };
    let outer = CURRENT.with(|c| c.replace(Some(ticket.clone())));
    let outcome = catch_unwind(AssertUnwindSafe(|| work(&report)));
    CURRENT.with(|c| *c.borrow_mut() = outer);
    match outcome {
        Ok(result) => Some(result),
        Err(payload) if payload.is::<Superseded>() => None,
        Err(payload) => resume_unwind(payload),
    }
}

/// The ticket of the run under way on this thread, if any: for work this run hands to another thread
/// ([`carrying`]).
pub fn current() -> Option<Ticket> {
    CURRENT.with(|c| c.borrow().clone())
}

/// `f()` with `ticket` as the ticket of this thread's run (the thread's own put back after, however
/// `f` ends): part of a run handed to another thread, such as a pool thread, stops at its
/// checkpoints as the run would, and the stop unwinds back through the join to the run's
/// [`unless_superseded`].
pub fn carrying<R>(ticket: Option<Ticket>, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Ticket>);
    impl Drop for Restore {
        fn drop(&mut self) {
            CURRENT.with(|c| *c.borrow_mut() = self.0.take());
        }
    }
    let _restore = Restore(CURRENT.with(|c| c.replace(ticket)));
    f()
}

/// [`crate::threads::awake`] for part of a run: `f` runs on a pool thread that carries this thread's
/// ticket ([`carrying`]), so it stops at its checkpoints as the run would. Every solver's step that
/// keeps the pool awake goes through here.
pub fn awake<R: Send>(joins: bool, f: impl FnOnce() -> R + Send) -> R {
    let ticket = current();
    crate::threads::awake(joins, || carrying(ticket, f))
}

thread_local! {
    /// The ticket of the run under way on this thread, if any.
    static CURRENT: RefCell<Option<Ticket>> = const { RefCell::new(None) };
}

/// Stop the run under way on this thread here if its ticket has been superseded (outside
/// [`unless_superseded`], nothing happens).
pub fn checkpoint() {
    if CURRENT.with(|c| c.borrow().as_ref().is_some_and(|t| !t.is_current())) {
        resume_unwind(Box::new(Superseded));
    }
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;

    #[test]
    fn a_checkpoint_stops_a_superseded_run_and_does_nothing_outside_one() {
        checkpoint(); // no run under way
        let generation = Generation::default();
        let ticket = generation.next();
        let passed = Cell::new(0);
        let result = unless_superseded(&ticket, &|_| {}, |_| {
            for i in 0..10 {
                checkpoint();
                passed.set(passed.get() + 1);
                if i == 3 {
                    generation.cancel_all();
                }
            }
        });
        assert_eq!((result, passed.get()), (None, 4));
        checkpoint(); // the thread's ticket went with the run
    }

    /// A run's part handed to another thread with its ticket stops there, and the stop reaches the
    /// run; without the ticket the other thread's checkpoints do nothing.
    #[test]
    fn a_part_of_a_run_on_another_thread_stops_at_its_checkpoints() {
        let generation = Generation::default();
        let ticket = generation.next();
        let passed = std::sync::atomic::AtomicU32::new(0);
        let on_another = |carried: bool| {
            let ticket = current().filter(|_| carried);
            std::thread::scope(|s| {
                let part = s.spawn(|| {
                    carrying(ticket, || {
                        for _ in 0..10 {
                            checkpoint();
                            passed.fetch_add(1, Ordering::SeqCst);
                            generation.cancel_all();
                        }
                    })
                });
                part.join().unwrap_or_else(|payload| resume_unwind(payload));
            });
        };
        assert_eq!(unless_superseded(&ticket, &|_| {}, |_| on_another(false)), Some(()));
        assert_eq!(passed.swap(0, Ordering::SeqCst), 10, "no ticket there: nothing stops");
        let ticket = generation.next();
        assert_eq!(unless_superseded(&ticket, &|_| {}, |_| on_another(true)), None);
        assert_eq!(passed.load(Ordering::SeqCst), 1, "stopped at the first checkpoint after the cancel");
        assert!(current().is_none(), "the thread's own ticket is back");
    }

    #[test]
    fn work_kept_awake_on_the_pool_stops_at_its_checkpoints() {
        let generation = Generation::default();
        let ticket = generation.next();
        let passed = std::sync::atomic::AtomicU32::new(0);
        let pooled = std::sync::atomic::AtomicBool::new(false);
        let stopped = unless_superseded(&ticket, &|_| {}, |_| {
            awake(true, || {
                pooled.store(rayon::current_thread_index().is_some(), Ordering::SeqCst);
                for _ in 0..10 {
                    checkpoint();
                    passed.fetch_add(1, Ordering::SeqCst);
                    generation.cancel_all();
                }
            })
        });
        assert_eq!(stopped, None);
        assert_eq!(passed.load(Ordering::SeqCst), 1, "stopped at the first checkpoint after the cancel");
        // With several threads the work ran on a pool thread, which had no ticket of its own.
        assert_eq!(pooled.load(Ordering::SeqCst), crate::threads::threads() > 1);
        assert!(current().is_none(), "the thread's own ticket is back");
    }

    #[test]
    fn a_current_run_completes_and_forwards_progress() {
        let generation = Generation::default();
        let ticket = generation.next();
        let seen = Cell::new(0.0);
        let result = unless_superseded(&ticket, &|f| seen.set(f), |report| {
            report(0.5);
            42
        });
        assert_eq!(result, Some(42));
        assert_eq!(seen.get(), 0.5);
    }

    #[test]
    fn a_run_superseded_before_it_starts_never_runs() {
        let generation = Generation::default();
        let old = generation.next();
        let _new = generation.next();
        let ran = Cell::new(false);
        assert_eq!(unless_superseded(&old, &|_| {}, |_| ran.set(true)), None);
        assert!(!ran.get());
    }

    #[test]
    fn a_run_superseded_while_running_stops_at_its_next_report() {
        let generation = Generation::default();
        let ticket = generation.next();
        let (stage, forwarded) = (Cell::new(0), Cell::new(0));
        let result = unless_superseded(&ticket, &|_| forwarded.set(forwarded.get() + 1), |report| {
            stage.set(1);
            report(0.1);
            generation.cancel_all(); // a newer request arrives mid-run
            stage.set(2);
            report(0.3);
            stage.set(3); // the expensive rest never runs
            report(0.9);
        });
        assert_eq!(result, None);
        assert_eq!(stage.get(), 2, "stopped at the first report after being superseded");
        assert_eq!(forwarded.get(), 1, "only the report of the current run was forwarded");
    }

    #[test]
    fn other_panics_are_not_swallowed() {
        let ticket = Generation::default().next();
        let caught = catch_unwind(AssertUnwindSafe(|| unless_superseded(&ticket, &|_| {}, |_| panic!("real bug"))));
        assert!(caught.is_err());
    }
}
