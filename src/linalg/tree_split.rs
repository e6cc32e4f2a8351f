//! Two independent halves of a Cholesky factor's elimination tree, so that a substitution can run
//! on two threads.
//!
//! In the factor `L` of a sparse SPD matrix, `L_ij ≠ 0` (`i > j`) only where `i` is an ancestor of
//! `j` in the elimination tree (`parent(j)` = the first row below the diagonal in column `j`). So two
//! disjoint sets of whole subtrees never meet in a row or a column of `L`: forward substitution can
//! solve both sets at once and then the rest (the *top*, their common ancestors), and backward
//! substitution the top first and then both sets at once. Any order that lists every unknown after
//! its descendants gives the same factor structure (an equivalent ordering: Liu 1990, "The role of
//! elimination trees in sparse factorization"), so relabelling the unknowns as `[first half][second
//! half][top]`, each part in its old order, keeps the fill and makes each part a range.
//!
//! The halves are found from the roots down: the heaviest subtree is opened (its root moves to the
//! top, its children take its place) until the subtrees, dealt largest first to the lighter half,
//! balance to within [`BALANCE`]; the split is given up if the top would carry more than [`MAX_TOP`]
//! of the work (a chain-like tree has no halves worth running apart).

/// The heavier half carries at most this fraction of the two halves' work.
pub const BALANCE: f64 = 0.55;

/// The most of the whole work the top may carry.
pub const MAX_TOP: f64 = 0.3;

/// A relabelling of a tree's nodes into two independent halves and their top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TreeSplit {
    /// The old node at each new position: the first half, the second half, then the top.
    pub order: Vec<usize>,
    /// The new positions `0..halves[0]` are the first half, `halves[0]..halves[1]` the second.
    pub halves: [usize; 2],
}

/// Split the tree with these parents (`None` for a root; every parent above its child) whose nodes
/// cost `work` each, or `None` when no split meets [`BALANCE`] with a top within [`MAX_TOP`].
pub fn split(parent: &[Option<usize>], work: &[u64]) -> Option<TreeSplit> {
    let n = parent.len();
    let mut subtree = work.to_vec();
    let mut children = vec![Vec::new(); n];
    for j in 0..n {
        if let Some(p) = parent[j] {
            subtree[p] += subtree[j];
            children[p].push(j);
        }
    }
    let total: u64 = work.iter().sum();
    let mut frontier: Vec<usize> = (0..n).filter(|&j| parent[j].is_none()).collect();
    let mut top = Vec::new();
    let mut top_work = 0;
    let bins = loop {
        frontier.sort_by_key(|&r| std::cmp::Reverse(subtree[r]));
        let mut bins = [(0u64, Vec::new()), (0u64, Vec::new())];
        for &root in &frontier {
            let lighter = usize::from(bins[1].0 < bins[0].0);
            bins[lighter].0 += subtree[root];
            bins[lighter].1.push(root);
        }
        let halves = bins[0].0 + bins[1].0;
        if halves > 0 && bins[0].0.max(bins[1].0) as f64 <= BALANCE * halves as f64 {
            break bins;
        }
        let heaviest = *frontier.first()?;
        top_work += work[heaviest];
        if top_work as f64 > MAX_TOP * total as f64 {
            return None;
        }
        top.push(heaviest);
        frontier.remove(0);
        frontier.extend_from_slice(&children[heaviest]);
    };
    let mut part = vec![2u8; n];
    for (label, (_, roots)) in bins.iter().enumerate() {
        let mut stack = roots.clone();
        while let Some(j) = stack.pop() {
            part[j] = label as u8;
            stack.extend_from_slice(&children[j]);
        }
    }
    let mut order = Vec::with_capacity(n);
    for label in 0..3 {
        order.extend((0..n).filter(|&j| part[j] == label));
    }
    let first = part.iter().filter(|&&p| p == 0).count();
    let second = first + part.iter().filter(|&&p| p == 1).count();
    Some(TreeSplit { order, halves: [first, second] })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_balanced_binary_tree_splits_below_its_root_and_every_node_follows_its_descendants() {
        // Nodes 0..6 in postorder: leaves 0, 1 under 2; leaves 3, 4 under 5; root 6.
        let parent = [Some(2), Some(2), Some(6), Some(5), Some(5), Some(6), None];
        let s = split(&parent, &[1; 7]).unwrap();
        assert_eq!(s.halves, [3, 6]);
        assert_eq!(s.order[6], 6, "the root is the top");
        let position: Vec<usize> = (0..7).map(|j| s.order.iter().position(|&o| o == j).unwrap()).collect();
        for (j, p) in parent.iter().enumerate() {
            if let Some(p) = p {
                assert!(position[*p] > position[j], "{j} before its parent {p}");
            }
        }
        // The halves are whole subtrees: {0, 1, 2} and {3, 4, 5} in some order.
        let mut first: Vec<usize> = s.order[..3].to_vec();
        first.sort();
        assert!(first == [0, 1, 2] || first == [3, 4, 5], "{first:?}");
    }

    #[test]
    fn a_chain_has_no_halves_and_a_lopsided_tree_opens_its_heavy_branch() {
        let chain: Vec<Option<usize>> = (0..10).map(|j| (j + 1 < 10).then_some(j + 1)).collect();
        assert_eq!(split(&chain, &[1; 10]), None);
        // Root 9 over a light leaf 0 and a heavy node 8, itself over two chains 1–4 (work 4) and
        // 5–7 (work 5): the split must open 9 and then 8, and deal the leaf to the lighter chain.
        let parent = [Some(9), Some(2), Some(3), Some(4), Some(8), Some(6), Some(7), Some(8), Some(9), None];
        let work = [1, 1, 1, 1, 1, 1, 1, 3, 1, 1];
        let s = split(&parent, &work).unwrap();
        assert_eq!(s.order[s.halves[1]..], [8, 9]);
        let mut halves = [s.order[..s.halves[0]].to_vec(), s.order[s.halves[0]..s.halves[1]].to_vec()];
        halves.sort_by_key(|h| h.len());
        assert_eq!(halves, [vec![5, 6, 7], vec![0, 1, 2, 3, 4]]);
    }
}
