//! Two independent halves of a supernodal Cholesky factor's elimination tree and their top, so that
//! a substitution can run on two threads ([`super::supernodal_solve`]).
//!
//! The reasoning is [`super::tree_split`]'s, on supernodes: a supernode's pattern holds only
//! ancestors of its columns, so two disjoint sets of whole subtrees never meet in a row of `L`, and
//! only their common ancestors (the *top*) take from both. Here the unknowns are not relabelled
//! (faer keeps the caller's order), so halves are found only where they already are ranges. The top
//! is the chain from the root down to the first supernode with more than one child (or, under
//! several roots, empty); where the subtrees of that supernode's children tile the supernodes before
//! the chain (checked), they are dealt into a first and a second consecutive group, cut where their
//! work (values of `L`) balances best. The split is given up when
//! the halves differ by more than [`BALANCE`] or the top carries more than [`MAX_TOP`] of the work.
//! A nested-dissection order (the modal analysis's) has exactly this shape: the first separator is
//! the chain, its two sides the halves.

use std::ops::Range;

use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use super::tree_split::{BALANCE, MAX_TOP};

/// The supernodes and first columns of two independent halves and their top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct SupernodalSplit {
    /// The supernodes of the first half, of the second half, and of the top.
    pub(super) supernodes: [Range<usize>; 3],
    /// The first column of the second half and of the top.
    pub(super) columns: [usize; 2],
}

/// The split of `symbolic`'s tree, or `None` when it has no halves worth running apart.
pub(super) fn split(symbolic: &SymbolicSupernodalCholesky<usize>) -> Option<SupernodalSplit> {
    let count = symbolic.n_supernodes();
    let begin = symbolic.supernode_begin();
    let owner = |row: usize| begin.partition_point(|&b| b <= row) - 1;
    let work: Vec<u64> = symbolic.col_ptr_for_val().windows(2).map(|w| (w[1] - w[0]) as u64).collect();
    let (mut first, mut subtree) = ((0..count).collect::<Vec<_>>(), work.clone());
    let (mut children, mut roots) = (vec![Vec::new(); count], Vec::new());
    for s in 0..count {
        match symbolic.supernode(s).pattern().iter().min().map(|&r| owner(r)) {
            Some(p) if p > s => {
                children[p].push(s);
                first[p] = first[p].min(first[s]);
                subtree[p] += subtree[s];
            }
            Some(_) => return None,
            None => roots.push(s),
        }
    }
    // Down the chain from the root.
    let (mut level, mut top) = (roots, count);
    while let [s] = level[..] {
        if s + 1 != top {
            return None;
        }
        top = s;
        level = std::mem::take(&mut children[s]);
    }
    let tiled = level.first().is_some_and(|&c| first[c] == 0)
        && level.windows(2).all(|w| first[w[1]] == w[0] + 1)
        && level.last().is_some_and(|&c| c + 1 == top);
    if level.len() < 2 || !tiled {
        return None;
    }
    let halves: u64 = level.iter().map(|&c| subtree[c]).sum();
    let (mut before, mut best) = (0, None::<(u64, usize)>);
    for (i, &c) in level.iter().enumerate().skip(1) {
        before += subtree[level[i - 1]];
        let heavier = before.max(halves - before);
        if best.is_none_or(|(h, _)| heavier < h) {
            best = Some((heavier, first[c]));
        }
    }
    let (heavier, cut) = best?;
    let total: u64 = work.iter().sum();
    if heavier as f64 > BALANCE * halves as f64 || (total - halves) as f64 > MAX_TOP * total as f64 {
        return None;
    }
    let column = |s: usize| if s < count { begin[s] } else { symbolic.nrows() };
    Some(SupernodalSplit { supernodes: [0..cut, cut..top, top..count], columns: [column(cut), column(top)] })
}
