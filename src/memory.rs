//! Memory budgets: work whose size the input chooses (a mesh file, `placement.copies`, a method on
//! a large mesh, a render target) is estimated before it starts and refused, with the estimate,
//! when it would need more memory than the machine has. Without this the allocator decides: an
//! allocation that fails aborts the process, and one that succeeds slowly drives the machine into
//! its out-of-memory killer.
//!
//! An estimate is a measured footprint times the size asked for (bytes a vertex, a pixel, a byte of
//! file), deliberately on the generous side: it refuses what cannot fit, not what merely might not.
//! The budget is the machine's physical memory (`MemTotal` in `/proc/meminfo`), or
//! `SHELLWARP_MEMORY` bytes when that is set (tests use it to reach the refusal cheaply), or what
//! [`limit_to`] set.
//!
//! Memory freed is not always memory given back: glibc keeps what a thread frees in that thread's
//! arena for reuse, and a long session that builds and drops solvers on several threads (loads,
//! background analyses, the quality readout) creeps upward by what the arenas hold. [`release_freed`]
//! hands the free pages of every arena back to the system; the simulation thread calls it when it
//! drops a solver (a scene or method switch).

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// Work refused because it would need more memory than the machine has.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} would need about {} of memory; this machine has {}", gigabytes(*.needed), gigabytes(*.available))]
pub struct TooLarge {
    /// What was asked for, e.g. "`mwts` with 16 modes on 4,000,000 vertices".
    pub what: String,
    /// The estimate, bytes.
    pub needed: u64,
    /// The budget, bytes.
    pub available: u64,
}

/// A budget set by [`limit_to`], zero for none.
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Set this process's budget to `bytes` (a harness running many cases in one process).
pub fn limit_to(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// The memory budget in bytes: the one set by [`limit_to`], else `SHELLWARP_MEMORY` if set, else the
/// machine's physical memory, else unlimited where none of these is known.
pub fn budget() -> u64 {
    let limit = LIMIT.load(Ordering::Relaxed);
    if limit > 0 {
        return limit;
    }
    if let Some(set) = std::env::var("SHELLWARP_MEMORY").ok().and_then(|v| v.trim().parse().ok()) {
        return set;
    }
    static TOTAL: OnceLock<u64> = OnceLock::new();
    *TOTAL.get_or_init(|| {
        let info = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
        info.lines()
            .find_map(|l| l.strip_prefix("MemTotal:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .map_or(u64::MAX, |kb| kb.saturating_mul(1024))
    })
}

/// Resident memory of this process, bytes (Linux; 0 elsewhere): what the soak and the fuzzer watch.
pub fn resident_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    statm.split_whitespace().nth(1).and_then(|p| p.parse::<u64>().ok()).unwrap_or(0) * 4096
}

/// The least memory any method needs a vertex of its mesh (the particle methods' footprint): what a
/// generated mesh is checked against before it is generated.
pub const LEAST_PER_VERTEX: u64 = 4_000;

/// Give the free pages the allocator holds back to the system (glibc's `malloc_trim`; nothing
/// elsewhere). Costs a walk over the heaps: for switches, not for every step.
#[allow(unsafe_code)]
pub fn release_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` takes no pointers, only releases pages glibc's heaps hold free, and locks
    // each arena it walks: safe to call from any thread at any time.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Refuse `needed` bytes of `what` if they exceed the [`budget`]; `what` is only formatted when refused.
pub fn check(needed: u64, what: impl FnOnce() -> String) -> Result<(), TooLarge> {
    let available = budget();
    if needed <= available { Ok(()) } else { Err(TooLarge { what: what(), needed, available }) }
}

/// `count × each` bytes, saturating (an estimate past `u64::MAX` is refused all the same).
pub fn times(count: impl TryInto<u64>, each: u64) -> u64 {
    count.try_into().unwrap_or(u64::MAX).saturating_mul(each)
}

/// Bytes as gigabytes with two decimals, megabytes below one gigabyte, bytes below one megabyte.
fn gigabytes(bytes: u64) -> String {
    match bytes {
        1_000_000_000.. => format!("{:.2} GB", bytes as f64 / 1e9),
        1_000_000.. => format!("{:.0} MB", bytes as f64 / 1e6),
        _ => format!("{bytes} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_budget_is_this_machines_memory_and_refuses_past_it() {
        if std::env::var_os("SHELLWARP_MEMORY").is_some() {
            return; // a budget set by hand is what it says
        }
        let total = budget();
        assert!(total > 100_000_000, "a machine with at least 100 MB: {total}");
        assert!(check(total, || "all of it".into()).is_ok());
        let refused = check(total + 1, || "a byte more".into()).unwrap_err();
        assert_eq!((refused.needed, refused.available), (total + 1, total));
        assert!(refused.to_string().starts_with("a byte more would need about"), "{refused}");
    }

    #[test]
    fn estimates_saturate_instead_of_wrapping() {
        assert_eq!(times(usize::MAX, 1024), u64::MAX);
        assert_eq!(times(3usize, 7), 21);
        assert_eq!(gigabytes(2_500_000_000), "2.50 GB");
        assert_eq!(gigabytes(12_000_000), "12 MB");
        assert_eq!(gigabytes(512), "512 bytes");
    }
}
