//! How many threads the numerical work may use: one setting for every command.
//!
//! The count comes from `--threads N` (any subcommand), else the environment variable
//! `SHELLWARP_THREADS`, else every core the process may run on. It sizes rayon's global pool, in
//! which a sparse solve runs the two halves of its factor's elimination tree at once, or splits its
//! passes over the factor when it has no halves (the modal analysis's block solves,
//! [`crate::linalg::SparseCholesky::solve_many`]), `mwts-rs`'s step runs
//! the two halves of its triangle pass, of its reconstruction solve and of its placing ([`join`], inside the pool with
//! its threads awake: [`awake`]), `mwts`'s and `lma`'s the two halves of a large vertex pass, `pbd`'s and `xpbd`'s
//! step (on a pool thread) its sweeps' large colours in pieces ([`phases`]: one start of the threads
//! for all of a sweep's colours, each thread taking the next piece, a colour's once the last one's
//! have ended), its triangle scans in two halves and its self-collision hierarchy's refit in two
//! subtrees ([`join`]), the implicit cloth's step the two sides of its linearisation and its contact
//! search ([`join`]) and of its filtered PCG ([`pair`]: two workers for the whole solve, meeting by spinning three times
//! an iteration), and [`par`] hands the same count to faer for the eigen solver's dense
//! products. The evaluation's `--jobs` run one case per job, and the viewer's simulation thread steps
//! the solver; large steps of either share the pool's threads.
//!
//! faer's dense products group their work by thread count, so the modal analysis and the implicit
//! solves agree across thread counts to round-off, not to the bit (tested in `tests/threads.rs`: the
//! creature's eigenvalues to 1e-12, an implicit step of it to 1e-12).
//! The modal and implicit cloth steps' halves are summed in the same order on one thread as on two,
//! and the lanes of a position-based sweep's colour share no particle, so these kinds of step agree
//! to the bit (tested there too).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};

use faer::Par;

/// The environment variable read when `--threads` is not given.
pub const ENV: &str = "SHELLWARP_THREADS";

static THREADS: OnceLock<usize> = OnceLock::new();

/// Why a thread count was refused.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ThreadsError {
    /// Zero, or not a number.
    #[error("a thread count must be a whole number from 1 up, not `{0}`")]
    Invalid(String),
    /// The count was fixed earlier (by an earlier call, or by first use) to another value.
    #[error("the thread count is already {0}")]
    AlreadySet(usize),
}

/// Use `n` threads from now on (once, before the first heavy work; setting the same count again is
/// harmless).
pub fn set(n: usize) -> Result<(), ThreadsError> {
    if n == 0 {
        return Err(ThreadsError::Invalid(n.to_string()));
    }
    let current = *THREADS.get_or_init(|| start_pool(n));
    if current == n { Ok(()) } else { Err(ThreadsError::AlreadySet(current)) }
}

/// The thread count: the one set, else `SHELLWARP_THREADS`, else every available core.
pub fn threads() -> usize {
    *THREADS.get_or_init(|| start_pool(from_env().ok().flatten().unwrap_or_else(cores)))
}

/// The count `SHELLWARP_THREADS` asks for (`None` when unset).
pub fn from_env() -> Result<Option<usize>, ThreadsError> {
    match std::env::var(ENV) {
        Ok(v) => v.trim().parse::<usize>().ok().filter(|&n| n > 0).map(Some).ok_or(ThreadsError::Invalid(v)),
        Err(_) => Ok(None),
    }
}

/// faer's parallelism for the thread count.
pub fn par() -> Par {
    match threads() {
        1 => Par::Seq,
        n => Par::rayon(n),
    }
}

/// `f()` on a pool thread, when there are several and `f` joins (`joins`), with the pool's other
/// threads kept awake until it returns; else `f()` here. Each kept thread waits for the halves `f`'s
/// joins hand over by taking work as it comes (`rayon::yield_now`), and gives its core to other
/// processes while there is none. A join called from outside the pool would instead wake a pool
/// thread for the whole join and sleep until it is done, and a pool thread asleep between two joins
/// costs about as much to wake as the shorter of these stretches do (a position-based substep's
/// scans, search and sweeps; `mwts-rs`'s triangle pass and solve). Work already in the pool (a
/// modal analysis in the background) runs first: `f` waits for a pool thread to be free. A pool
/// thread has no thread-local state of the caller's: a solver's step comes here through the
/// solver layer's own `awake`, which hands its run's ticket to `f`.
pub fn awake<R: Send>(joins: bool, f: impl FnOnce() -> R + Send) -> R {
    if !joins || threads() == 1 {
        return f();
    }
    let done = AtomicBool::new(false);
    // Set however `f` ends (a panic, or a superseded run's stop), so that the keepers let the scope end.
    struct Done<'a>(&'a AtomicBool);
    impl Drop for Done<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Release);
        }
    }
    let keep = || {
        while !done.load(Ordering::Acquire) {
            if rayon::yield_now() != Some(rayon::Yield::Executed) {
                std::thread::yield_now();
            }
        }
    };
    rayon::scope(|s| {
        for _ in 1..threads() {
            s.spawn(|_| keep());
        }
        let _done = Done(&done);
        f()
    })
}

/// `f()` on a pool thread when there are several (the caller waits), else here: for a loop of many
/// short steps (`shellwarp sim`). Each step's [`awake`] then runs in place, where from outside the
/// pool it would hand its work to a pool thread and wait to be woken at the end; and between steps
/// the pool's other threads, just released, are still spinning rather than asleep. On two cores
/// here that took the drape's median step from 0.49 to 0.44 ms. A panic in `f` reaches the caller.
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if threads() == 1 || rayon::current_thread_index().is_some() { f() } else { rayon::scope(|_| f()) }
}

/// `(a(), b())`, at once on two pool threads when there are several (`rayon::join`), else in turn.
pub fn join<RA: Send, RB: Send>(a: impl FnOnce() -> RA + Send, b: impl FnOnce() -> RB + Send) -> (RA, RB) {
    if threads() > 1 { rayon::join(a, b) } else { (a(), b()) }
}

/// The sums of the two halves of one pass, `a()[i] + b()[i]` (run by [`join`]): the halves are the
/// same on one thread and on several, and so, added in this one order, are the sums.
pub fn join_sum(a: impl FnOnce() -> Vec<f64> + Send, b: impl FnOnce() -> Vec<f64> + Send) -> Vec<f64> {
    let (mut one, two) = join(a, b);
    one.iter_mut().zip(&two).for_each(|(x, y)| *x += y);
    one
}

/// `f(first, part)` over the two halves of `items` at once when there are several threads and each
/// half has at least `least` items (`first`: where `part` begins in `items`), else over the whole.
pub fn halves<T: Send>(items: &mut [T], least: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    let half = items.len() / 2;
    if threads() > 1 && half >= least.max(1) {
        let (first, second) = items.split_at_mut(half);
        join(|| f(0, first), || f(half, second));
    } else {
        f(0, items);
    }
}

/// Whether any of `0..n` passes `test`, its two halves tested at once as [`halves`] does.
pub fn any(n: usize, least: usize, test: impl Fn(usize) -> bool + Sync) -> bool {
    let half = n / 2;
    if threads() > 1 && half >= least.max(1) {
        let (a, b) = join(|| (0..half).any(&test), || (half..n).any(&test));
        a || b
    } else {
        (0..n).any(test)
    }
}

/// Run `tasks`, each with its phase (phases ascending), on the pool's threads at once: the tasks of a
/// phase in any order and on any thread, each once, and a phase's only after every task of the
/// phase before it has ended (its writes seen). Each thread takes the next task in order and, if the
/// phase before has tasks still running, waits for them (spinning: they are running, so not for
/// long). No task waits for one not yet taken, so the phases cannot stall, even when no other thread
/// is free to help and the calling thread runs them all in order (as it does on one thread). One
/// start of the threads for all the phases, instead of a join each.
pub fn phases<T: Send>(tasks: Vec<(usize, T)>, run: impl Fn(T) + Sync) {
    if threads() == 1 || tasks.len() < 2 {
        tasks.into_iter().for_each(|(_, task)| run(task));
        return;
    }
    // Phases numbered densely, and how many tasks each has.
    let mut phase = Vec::with_capacity(tasks.len());
    let mut sizes: Vec<usize> = Vec::new();
    for (k, (p, _)) in tasks.iter().enumerate() {
        if k == 0 || *p != tasks[k - 1].0 {
            sizes.push(0);
        }
        *sizes.last_mut().expect("pushed") += 1;
        phase.push(sizes.len() - 1);
    }
    let slots: Vec<Mutex<Option<T>>> = tasks.into_iter().map(|(_, task)| Mutex::new(Some(task))).collect();
    let (next, ended) = (AtomicUsize::new(0), sizes.iter().map(|_| AtomicUsize::new(0)).collect::<Vec<_>>());
    // Counts a task as ended however it ends, so that a panic reaches the caller instead of leaving
    // the other threads waiting.
    struct Ended<'a>(&'a AtomicUsize);
    impl Drop for Ended<'_> {
        fn drop(&mut self) {
            self.0.fetch_add(1, Ordering::Release);
        }
    }
    let worker = || {
        loop {
            let k = next.fetch_add(1, Ordering::Relaxed);
            let Some(slot) = slots.get(k) else { break };
            let p = phase[k];
            if p > 0 {
                let mut spins = 0u32;
                while ended[p - 1].load(Ordering::Acquire) < sizes[p - 1] {
                    spins = spins.wrapping_add(1);
                    if spins.is_multiple_of(4096) {
                        std::thread::yield_now();
                    } else {
                        std::hint::spin_loop();
                    }
                }
            }
            let _ended = Ended(&ended[p]);
            let task = slot.lock().unwrap_or_else(PoisonError::into_inner).take();
            if let Some(task) = task {
                run(task);
            }
        }
    };
    rayon::scope(|s| {
        for _ in 1..threads() {
            s.spawn(|_| worker());
        }
        worker();
    });
}

/// How long the first of a [`pair`] waits for a thread to take the second's part before doing it
/// itself, in spins.
const PAIR_WAIT: u32 = 1 << 12;

/// One worker of a [`pair`]: the halves of the work it does and the barrier it shares.
pub struct Pair<'a> {
    halves: &'static [usize],
    state: Option<&'a PairState>,
    round: usize,
}

/// What the two workers of a [`pair`] share.
#[derive(Default)]
struct PairState {
    /// Whether the second part has been taken (by a thread, or by the first worker doing both).
    claimed: AtomicBool,
    /// How many times the workers have arrived at a barrier, together.
    arrived: AtomicUsize,
    /// Whether a worker has stopped early (a panic, or a superseded run's stop).
    abandoned: AtomicBool,
}

impl Pair<'_> {
    /// A worker alone, doing both halves.
    pub fn alone() -> Self {
        Pair { halves: &[0, 1], state: None, round: 0 }
    }

    /// The halves of the work this worker does: `[0, 1]` alone, else `[0]` or `[1]`.
    pub fn halves(&self) -> &'static [usize] {
        self.halves
    }

    /// Wait for the other worker to reach its matching call (nothing alone). Both must call it as
    /// many times. If the other stopped early, this one stops too (a panic).
    pub fn sync(&mut self) {
        let Some(state) = self.state else { return };
        self.round += 1;
        state.arrived.fetch_add(1, Ordering::AcqRel);
        let mut spins = 0u32;
        while state.arrived.load(Ordering::Acquire) < 2 * self.round {
            assert!(!state.abandoned.load(Ordering::Acquire), "the other worker of a pair stopped");
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(4096) {
                std::thread::yield_now();
            } else {
                std::hint::spin_loop();
            }
        }
    }
}

/// Marks the pair abandoned if its worker unwinds.
struct Abandon<'a>(&'a AtomicBool);

impl Drop for Abandon<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::Release);
        }
    }
}

/// `work` by two workers at once, each doing one half and meeting the other at [`Pair::sync`], when
/// there are several threads and a second one takes its part soon; else by one worker doing both
/// halves (its syncs do nothing). Returns what the worker of the first half (or the only one)
/// returns. For short phases that would cost more to start as joins than to run: the workers meet
/// by spinning, a fraction of a microsecond, and each keeps its half's data in its own core's
/// cache. Call it on a pool thread kept [`awake`], or the second part may find no thread soon.
pub fn pair<R: Send>(work: impl Fn(&mut Pair) -> R + Sync) -> R {
    let alone = || work(&mut Pair::alone());
    if threads() == 1 {
        return alone();
    }
    let state = PairState::default();
    let claim = || state.claimed.compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire).is_ok();
    let first = || {
        let mut spins = 0;
        while !state.claimed.load(Ordering::Acquire) && spins < PAIR_WAIT {
            std::hint::spin_loop();
            spins += 1;
        }
        if claim() {
            return alone();
        }
        let _abandon = Abandon(&state.abandoned);
        work(&mut Pair { halves: &[0], state: Some(&state), round: 0 })
    };
    let second = || {
        if claim() {
            let _abandon = Abandon(&state.abandoned);
            work(&mut Pair { halves: &[1], state: Some(&state), round: 0 });
        }
    };
    rayon::join(first, second).0
}

/// Every core this process may run on.
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Size rayon's global pool (if nothing has started it yet) and return `n`.
fn start_pool(n: usize) -> usize {
    // Fails only if the pool already runs (a library user started it): its size then stands, and
    // faer is told `n` all the same (a hint of how many tasks to make).
    let _ =
        rayon::ThreadPoolBuilder::new().num_threads(n).thread_name(|i| format!("shellwarp-work-{i}")).build_global();
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every task runs once, and each phase's only after the phase before has ended, on the pool's
    /// threads.
    #[test]
    fn phases_run_every_task_once_and_in_order() {
        let log = Mutex::new(Vec::new());
        let tasks: Vec<(usize, (usize, usize))> =
            [0, 0, 0, 2, 2, 5, 7, 7, 7, 7].iter().enumerate().map(|(k, &p)| (p, (p, k))).collect();
        phases(tasks, |(p, k)| {
            std::thread::sleep(std::time::Duration::from_micros(200 * (k as u64 % 3)));
            log.lock().unwrap().push((p, k));
        });
        let log = log.into_inner().unwrap();
        let mut ks: Vec<usize> = log.iter().map(|&(_, k)| k).collect();
        ks.sort_unstable();
        assert_eq!(ks, (0..10).collect::<Vec<_>>(), "each task once");
        assert!(log.windows(2).all(|w| w[0].0 <= w[1].0), "phases in order: {log:?}");
    }

    /// `awake` gives back what its work returns, and a panic in the work reaches the caller instead
    /// of leaving the kept threads waiting.
    #[test]
    fn work_kept_awake_returns_and_panics_through() {
        let (a, b) = awake(true, || join(|| 20, || 22));
        assert_eq!(a + b, 42);
        let caught = std::panic::catch_unwind(|| awake(true, || -> u32 { panic!("in the work") }));
        assert!(caught.is_err());
        assert_eq!(awake(true, || 7), 7, "the pool still works after the panic");
    }

    /// The two workers of a pair each do their half, and a sum that needs both halves' results after
    /// a sync sees them; on one thread one worker does both. A panic in one worker reaches the caller
    /// instead of leaving the other at its barrier.
    #[test]
    fn a_pair_does_both_halves_and_meets_at_its_syncs() {
        let (mut paired, mut attempts, start) = (0, 0, std::time::Instant::now());
        // 200 pairs, and more while none has had two workers (for up to 10 s: other tests may hold
        // the pool's threads).
        while attempts < 200 || (paired == 0 && threads() > 1 && start.elapsed().as_secs() < 10) {
            attempts += 1;
            let slots = [AtomicUsize::new(0), AtomicUsize::new(0)];
            let (total, workers) = awake(true, || {
                let workers = AtomicUsize::new(0);
                let total = pair(|p| {
                    workers.fetch_add(1, Ordering::Relaxed);
                    let mut sum = 0;
                    for round in 1..=50 {
                        p.halves().iter().for_each(|&h| slots[h].store(round * (h + 1), Ordering::Relaxed));
                        p.sync();
                        sum += slots[0].load(Ordering::Relaxed) + slots[1].load(Ordering::Relaxed);
                        p.sync();
                    }
                    sum
                });
                (total, workers.into_inner())
            });
            assert_eq!(total, 3 * 50 * 51 / 2);
            assert!(workers == 1 || (workers == 2 && threads() > 1), "{workers} workers");
            paired += usize::from(workers == 2);
        }
        // Kept awake, the pool's other thread takes the second half (at least sometimes).
        assert!(threads() == 1 || paired > 0, "no pair of {attempts} had two workers");
        let caught = std::panic::catch_unwind(|| {
            awake(true, || {
                pair(|p| {
                    if p.halves().contains(&1) {
                        panic!("in the second half");
                    }
                    p.sync();
                })
            })
        });
        assert!(caught.is_err());
    }

    /// `on_pool` runs its work on a pool thread (when there are several) and gives back its result; a
    /// panic in it reaches the caller.
    #[test]
    fn work_on_the_pool_returns_and_panics_through() {
        let index = on_pool(rayon::current_thread_index);
        assert_eq!(index.is_some(), threads() > 1);
        assert_eq!(on_pool(|| awake(true, || join(|| 20, || 22))), (20, 22));
        assert!(std::panic::catch_unwind(|| on_pool(|| -> u32 { panic!("in the work") })).is_err());
    }

    #[test]
    fn zero_threads_is_refused_and_a_second_different_count_is_reported() {
        assert_eq!(set(0), Err(ThreadsError::Invalid("0".into())));
        let n = threads();
        assert_eq!(set(n), Ok(()));
        assert_eq!(set(n + 1), Err(ThreadsError::AlreadySet(n)));
        assert_eq!(matches!(par(), Par::Seq), n == 1);
    }
}
