//! How many threads the numerical work may use: one setting for every command.
//!
//! The count comes from `--threads N` (any subcommand), else the environment variable
//! `SHELLWARP_THREADS`, else every core the process may run on. It sizes rayon's global pool, in
//! which a sparse solve runs the two halves of its factor's elimination tree at once, or splits its
//! passes over the factor when it has no halves (the modal analysis's block solves,
//! [`crate::linalg::SparseCholesky::solve_many`]), `mwts-rs`'s step runs
//! the two halves of its triangle pass and of its reconstruction solve ([`join`], inside the pool:
//! [`in_pool`]), `mwts`'s and `lma`'s the two halves of a large vertex pass, and [`par`] hands the
//! same count to faer for the eigen solver's dense products. The evaluation's `--jobs` run one case per job, and the
//! viewer's simulation thread steps the solver; large modal steps of either share the pool's threads.
//!
//! faer's dense products group their work by thread count, so the modal analysis and the implicit
//! solves agree across thread counts to round-off, not to the bit (tested in `tests/threads.rs`: the
//! creature's eigenvalues to 1e-12, an implicit step of it to 1e-12).
//! The modal steps' halves are summed in the same order on one thread as on two, so their steps
//! agree to the bit (tested there too).

use std::sync::OnceLock;

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

/// Run `f` on one of the pool's threads when there are several and `f` joins (`joins`), else
/// here, so that the joins inside it hand their second half to another pool thread directly. A join
/// called from outside the pool instead wakes a pool thread for the whole join and sleeps until it
/// is done: on two cores, one wake-up more per join, and three threads on two cores. Work already in
/// the pool (a modal analysis in the background) runs first: `f` waits for a pool thread to be free.
pub fn in_pool<R: Send>(joins: bool, f: impl FnOnce() -> R + Send) -> R {
    if joins && threads() > 1 && rayon::current_thread_index().is_none() { rayon::scope(|_| f()) } else { f() }
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

    #[test]
    fn zero_threads_is_refused_and_a_second_different_count_is_reported() {
        assert_eq!(set(0), Err(ThreadsError::Invalid("0".into())));
        let n = threads();
        assert_eq!(set(n), Ok(()));
        assert_eq!(set(n + 1), Err(ThreadsError::AlreadySet(n)));
        assert_eq!(matches!(par(), Par::Seq), n == 1);
    }
}
