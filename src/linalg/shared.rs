//! A slice that several threads write at once, each its own entries.
//!
//! Rust's borrows split a slice into ranges (`split_at_mut`); some parallel passes own entries that
//! are not ranges: the unknowns of one half of an elimination tree and the shared top, or the
//! particles on one side of a cloth while the springs among them are summed. [`Shared`] is a copyable
//! view of the slice for such a pass. Making one is `unsafe`: the caller promises that while the
//! views live no entry is written by one thread and read or written by another. Every access is
//! checked against the slice's length, and the view keeps the slice's borrow.

use std::marker::PhantomData;
use std::ops::{Index, IndexMut};

/// A view of `&mut [T]` that threads index at once, each only its own entries ([`Shared::new`]).
pub struct Shared<'a, T> {
    x: *mut T,
    len: usize,
    borrow: PhantomData<&'a mut [T]>,
}

impl<T> Clone for Shared<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Shared<'_, T> {}

impl<'a, T> Shared<'a, T> {
    /// The view of `x`, borrowed for as long as the view lives.
    ///
    /// # Safety
    /// While any copy of the view lives, no entry may be written through one thread's copy and read
    /// or written through another thread's at the same time.
    #[allow(unsafe_code)]
    pub unsafe fn new(x: &'a mut [T]) -> Self {
        Self { x: x.as_mut_ptr(), len: x.len(), borrow: PhantomData }
    }
}

impl<'a, T> Shared<'a, T> {
    /// The whole slice, to read.
    ///
    /// # Safety
    /// No thread may write any entry while the returned slice lives.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub unsafe fn whole(self) -> &'a [T] {
        // SAFETY: the view was made from a slice of this length, still borrowed; no writes meanwhile
        // (the caller's promise).
        unsafe { std::slice::from_raw_parts(self.x, self.len) }
    }

    /// The entries `rows`, to read and write.
    ///
    /// # Safety
    /// No other thread may read or write these entries while the returned slice lives, nor this
    /// thread through another view.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub unsafe fn rows(self, rows: std::ops::Range<usize>) -> &'a mut [T] {
        assert!(rows.start <= rows.end && rows.end <= self.len, "rows {rows:?} of {}", self.len);
        // SAFETY: in bounds; these entries are this thread's alone meanwhile (the caller's promise).
        unsafe { std::slice::from_raw_parts_mut(self.x.add(rows.start), rows.len()) }
    }
}

// SAFETY: the threads' accesses never overlap (the promise of `Shared::new`), so sending a view to a
// thread sends it only entries no other thread touches meanwhile.
#[allow(unsafe_code)]
unsafe impl<T: Send> Send for Shared<'_, T> {}
// SAFETY: as for `Send`.
#[allow(unsafe_code)]
unsafe impl<T: Send> Sync for Shared<'_, T> {}

impl<T> Index<usize> for Shared<'_, T> {
    type Output = T;
    #[inline(always)]
    #[allow(unsafe_code)]
    fn index(&self, j: usize) -> &T {
        assert!(j < self.len, "unknown {j} of {}", self.len);
        // SAFETY: in bounds, and no other thread writes it now (the promise of `Shared::new`).
        unsafe { &*self.x.add(j) }
    }
}

impl<T> IndexMut<usize> for Shared<'_, T> {
    #[inline(always)]
    #[allow(unsafe_code)]
    fn index_mut(&mut self, j: usize) -> &mut T {
        assert!(j < self.len, "unknown {j} of {}", self.len);
        // SAFETY: in bounds, and no other thread reads or writes it now (the promise of `Shared::new`).
        unsafe { &mut *self.x.add(j) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two threads write the even and the odd entries through copies of one view; every write lands.
    #[test]
    fn two_threads_write_their_own_entries() {
        let mut x = vec![0usize; 1001];
        // SAFETY: one thread writes the even entries, the other the odd ones; neither reads.
        #[allow(unsafe_code)]
        let shared = unsafe { Shared::new(&mut x) };
        let fill = |parity: usize| {
            let mut view = shared;
            (parity..1001).step_by(2).for_each(|j| view[j] = j + 1);
        };
        std::thread::scope(|s| {
            s.spawn(|| fill(0));
            s.spawn(|| fill(1));
        });
        assert!(x.iter().enumerate().all(|(j, v)| *v == j + 1));
    }

    #[test]
    #[should_panic(expected = "unknown 3 of 3")]
    fn an_index_past_the_end_is_refused() {
        let mut x = [1.0, 2.0, 3.0];
        // SAFETY: one thread.
        #[allow(unsafe_code)]
        let shared = unsafe { Shared::new(&mut x) };
        let _ = shared[3];
    }
}
