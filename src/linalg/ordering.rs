//! Fill-reducing elimination orders for meshes: geometric nested dissection.
//!
//! Recursively split the vertices at the median along one of a few directions (the three axes and
//! the principal axis of the part's points), keeping the split with the smallest separator. The
//! separator is a minimum vertex cover of the edges that cross the split (König's theorem on the
//! bipartite graph of the two boundary layers), ordered after both halves. On the creature this
//! measured fewer Cholesky flops than splitting the longest axis with one boundary layer as
//! separator, and than approximate minimum degree (`BENCHMARKS.md`, *Design measurements quoted from
//! module docs*).

use glam::DVec3;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// Below this many vertices a part is ordered as it comes.
const LEAF: usize = 64;

/// An elimination order of the vertices (`order[k]` is eliminated `k`-th), given their positions and
/// the adjacency of the matrix graph (`adjacency[v]` lists the vertices coupled to `v`).
pub fn nested_dissection(points: &[DVec3], adjacency: &[Vec<usize>]) -> Vec<usize> {
    let mut order = Vec::with_capacity(points.len());
    let mut work = Work { side: vec![0; points.len()], slot: vec![usize::MAX; points.len()] };
    dissect((0..points.len()).collect(), points, adjacency, &mut work, &mut order);
    order
}

/// Per-vertex scratch shared by the whole recursion.
struct Work {
    /// 1 = left, 2 = right, 0 = outside the current part.
    side: Vec<u8>,
    /// Position of a boundary vertex in its layer (for the matching), else `usize::MAX`.
    slot: Vec<usize>,
}

/// A split of a part: left, right, separator.
type Split = (Vec<usize>, Vec<usize>, Vec<usize>);

fn dissect(set: Vec<usize>, points: &[DVec3], adjacency: &[Vec<usize>], work: &mut Work, order: &mut Vec<usize>) {
    if set.len() <= LEAF {
        order.extend(set);
        return;
    }
    let mut best: Option<Split> = None;
    for dir in [DVec3::X, DVec3::Y, DVec3::Z, principal_axis(&set, points)] {
        let split = split(&set, points, adjacency, work, dir);
        if best.as_ref().is_none_or(|b| split.2.len() < b.2.len()) {
            best = Some(split);
        }
    }
    let Some((left, right, separator)) = best else { return };
    dissect(left, points, adjacency, work, order);
    dissect(right, points, adjacency, work, order);
    order.extend(separator);
}

/// The direction of largest spread of the points of `set` (or `x` if they do not spread).
fn principal_axis(set: &[usize], points: &[DVec3]) -> DVec3 {
    let mean = set.iter().map(|&v| points[v]).sum::<DVec3>() / set.len() as f64;
    let cov = set.iter().fold(Matrix3::zeros(), |acc, &v| {
        let d = points[v] - mean;
        let d = Vector3::new(d.x, d.y, d.z);
        acc + d * d.transpose()
    });
    let eig = SymmetricEigen::new(cov);
    let top = eig.eigenvalues.imax();
    let axis = eig.eigenvectors.column(top);
    let axis = DVec3::new(axis[0], axis[1], axis[2]);
    if axis.is_finite() && axis.length_squared() > 0.5 { axis } else { DVec3::X }
}

/// Split `set` at the median along `dir`; the separator covers every edge between the halves.
fn split(set: &[usize], points: &[DVec3], adjacency: &[Vec<usize>], work: &mut Work, dir: DVec3) -> Split {
    let mut sorted = set.to_vec();
    let mid = sorted.len() / 2;
    sorted.select_nth_unstable_by(mid, |&a, &b| points[a].dot(dir).total_cmp(&points[b].dot(dir)));
    let (left, right) = sorted.split_at(mid);
    left.iter().for_each(|&v| work.side[v] = 1);
    right.iter().for_each(|&v| work.side[v] = 2);
    let touching = |v: &&usize, other: u8| adjacency[**v].iter().any(|&u| work.side[u] == other);
    let left_layer: Vec<usize> = left.iter().filter(|v| touching(v, 2)).copied().collect();
    let right_layer: Vec<usize> = right.iter().filter(|v| touching(v, 1)).copied().collect();
    let separator = minimum_cover(&left_layer, &right_layer, adjacency, work);
    separator.iter().for_each(|&v| work.side[v] = 3);
    let keep = |half: &[usize], s: u8, side: &[u8]| half.iter().copied().filter(|&v| side[v] == s).collect();
    let (l, r) = (keep(left, 1, &work.side), keep(right, 2, &work.side));
    set.iter().for_each(|&v| work.side[v] = 0);
    (l, r, separator)
}

/// A minimum vertex cover of the bipartite graph of the edges between `left` (side 1) and `right`
/// (side 2): a maximum matching by augmenting paths, then König's construction.
fn minimum_cover(left: &[usize], right: &[usize], adjacency: &[Vec<usize>], work: &mut Work) -> Vec<usize> {
    right.iter().enumerate().for_each(|(i, &v)| work.slot[v] = i);
    let neighbours: Vec<Vec<usize>> = left
        .iter()
        .map(|&v| adjacency[v].iter().filter(|&&u| work.side[u] == 2).map(|&u| work.slot[u]).collect())
        .collect();
    right.iter().for_each(|&v| work.slot[v] = usize::MAX);
    let (mut mate_left, mut mate_right) = (vec![usize::MAX; left.len()], vec![usize::MAX; right.len()]);
    let mut seen = vec![usize::MAX; right.len()];
    for l in 0..left.len() {
        augment(l, l, &neighbours, &mut seen, &mut mate_left, &mut mate_right);
    }
    // König: from the unmatched left vertices, alternate along non-matching then matching edges.
    let (mut reach_left, mut reach_right) = (vec![false; left.len()], vec![false; right.len()]);
    let mut stack: Vec<usize> = (0..left.len()).filter(|&l| mate_left[l] == usize::MAX).collect();
    stack.iter().for_each(|&l| reach_left[l] = true);
    while let Some(l) = stack.pop() {
        for &r in &neighbours[l] {
            if !reach_right[r] {
                reach_right[r] = true;
                let next = mate_right[r];
                if next != usize::MAX && !reach_left[next] {
                    reach_left[next] = true;
                    stack.push(next);
                }
            }
        }
    }
    let mut cover: Vec<usize> = (0..left.len()).filter(|&l| !reach_left[l]).map(|l| left[l]).collect();
    cover.extend((0..right.len()).filter(|&r| reach_right[r]).map(|r| right[r]));
    cover
}

/// Look for an augmenting path from left vertex `l` (iterative depth-first search; `seen[r] == round`
/// marks right vertices visited in this round).
fn augment(
    start: usize,
    round: usize,
    neighbours: &[Vec<usize>],
    seen: &mut [usize],
    mate_left: &mut [usize],
    mate_right: &mut [usize],
) -> bool {
    // Stack of (left vertex, next neighbour index); `via[k]` is the right vertex that led to stack[k + 1].
    let mut stack = vec![(start, 0usize)];
    let mut via: Vec<usize> = Vec::new();
    while let Some(&mut (l, ref mut next)) = stack.last_mut() {
        let Some(&r) = neighbours[l].get(*next) else {
            stack.pop();
            via.pop();
            continue;
        };
        *next += 1;
        if seen[r] == round {
            continue;
        }
        seen[r] = round;
        via.push(r);
        if mate_right[r] == usize::MAX {
            // Flip the path: every left vertex on the stack takes the right vertex after it.
            for (&(lk, _), &rk) in stack.iter().zip(&via) {
                mate_left[lk] = rk;
                mate_right[rk] = lk;
            }
            return true;
        }
        stack.push((mate_right[r], 0));
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `n × n` grid graph with its 4-neighbour adjacency.
    fn grid(n: usize) -> (Vec<DVec3>, Vec<Vec<usize>>) {
        let points: Vec<DVec3> = (0..n * n).map(|k| DVec3::new((k / n) as f64, (k % n) as f64, 0.0)).collect();
        let adjacency: Vec<Vec<usize>> = (0..n * n)
            .map(|k| {
                let (i, j) = (k / n, k % n);
                let mut a = Vec::new();
                if i > 0 {
                    a.push(k - n)
                }
                if i + 1 < n {
                    a.push(k + n)
                }
                if j > 0 {
                    a.push(k - 1)
                }
                if j + 1 < n {
                    a.push(k + 1)
                }
                a
            })
            .collect();
        (points, adjacency)
    }

    #[test]
    fn order_is_a_permutation_with_a_straight_separator_last() {
        let n = 20;
        let (points, adjacency) = grid(n);
        let order = nested_dissection(&points, &adjacency);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..n * n).collect::<Vec<_>>());
        // The top-level separator is one grid line (20 vertices), eliminated last.
        let last: Vec<usize> = order[order.len() - n..].to_vec();
        let line = points[last[0]].x;
        assert!(last.iter().all(|&v| points[v].x == line), "last {n} vertices form a straight separator");
    }

    #[test]
    fn the_cover_separates_and_is_minimum() {
        // A path 0-3-1-4-2 between the layers (left 0, 1, 2; right 3, 4) is covered by {3, 4}, and a
        // star (left 5 joined to right 6, 7, 8) by its centre alone: 3 vertices, where either whole
        // layer would take 4.
        let adjacency =
            vec![vec![3], vec![3, 4], vec![4], vec![0, 1], vec![1, 2], vec![6, 7, 8], vec![5], vec![5], vec![5]];
        let mut work = Work { side: vec![1, 1, 1, 2, 2, 1, 2, 2, 2], slot: vec![usize::MAX; 9] };
        let cover = minimum_cover(&[0, 1, 2, 5], &[3, 4, 6, 7, 8], &adjacency, &mut work);
        assert_eq!(cover.len(), 3, "{cover:?}");
        for (a, list) in adjacency.iter().enumerate() {
            for &b in list {
                assert!(cover.contains(&a) || cover.contains(&b), "edge {a}-{b} uncovered by {cover:?}");
            }
        }
        assert!(cover.contains(&5), "the star's centre");
    }
}
