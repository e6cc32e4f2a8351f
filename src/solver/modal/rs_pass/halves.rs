//! The two halves of the per-triangle pass ([`super`], module documentation *Two halves*): which
//! triangles go in which half, and where each half scatters its right side. Cut along the
//! reconstruction solve's halves of the unknowns (`0..a`, `a..b`, joined by no edge; their top
//! `b..`), each half writes its own unknowns in place and the second adds to the top through a
//! scratch; cut by number, the top is every unknown.

use super::{LANES, SPLIT, chunks};
use crate::linalg::padded::Padded;

/// The triangles in pass order, `None` where a chunk is padded, the first chunk of the second half,
/// and the ends of the unknowns' halves if the pass is cut along them (module documentation, *Two
/// halves*).
#[allow(clippy::type_complexity)]
pub(super) fn cut(
    moving: &[[usize; 3]],
    unknowns: &[u32],
    halves: Option<[usize; 2]>,
) -> (Vec<Option<[usize; 3]>>, usize, Option<[usize; 2]>) {
    let count = chunks(moving.len());
    let by_number = || {
        let half = if moving.len() >= SPLIT { count / 2 } else { count };
        (moving.iter().copied().map(Some).collect::<Vec<_>>(), half, None)
    };
    let Some([a, b]) = halves.filter(|_| moving.len() >= SPLIT) else { return by_number() };
    // Per triangle, which halves of the unknowns its corners are in (bit 0: the first, bit 1: the
    // second), then its group: 0 or 1, the half it has a corner in; 2, the top's only; 3, both
    // halves' (which their having no edge in common rules out; then it is cut by number).
    let side = |t: &[usize; 3]| {
        let of = |v: usize| match unknowns[v] as usize {
            u if u < a => 1,
            u if u < b => 2,
            _ => 0,
        };
        [2, 0, 1, 3][t.iter().fold(0, |sides, &v| sides | of(v))]
    };
    let sides: Vec<usize> = moving.iter().map(side).collect();
    if sides.contains(&3) {
        return by_number();
    }
    let count = |k| sides.iter().filter(|&&s| s == k).count();
    let top_with = usize::from(count(0) > count(1));
    let group = |k: usize| {
        (moving.iter().zip(&sides)).filter(move |(_, s)| **s == k || (**s == 2 && k == top_with)).map(|(t, _)| Some(*t))
    };
    let mut order: Vec<Option<[usize; 3]>> = group(0).collect();
    let half = chunks(order.len());
    order.resize(half * LANES, None);
    order.extend(group(1));
    (order, half, halves)
}

/// Where one half of a pass scatters the right side: its own unknowns and the top's, each a slice
/// with the unknown at its start (the top's from the first unknown past its own).
pub(super) struct Target<'a> {
    /// Its own unknowns, from the one at the slice's start.
    pub(super) own: (&'a mut [Padded], usize),
    /// The top's unknowns (or what of them it adds, in a scratch), from the one at its start.
    pub(super) top: (&'a mut [Padded], usize),
}

impl Target<'_> {
    /// Unknown `u`'s entry, if it is one of this target's.
    #[inline(always)]
    pub(super) fn get_mut(&mut self, u: u32) -> Option<&mut Padded> {
        let u = u as usize;
        let (part, start) =
            if u >= self.top.1 { (&mut *self.top.0, self.top.1) } else { (&mut *self.own.0, self.own.1) };
        u.checked_sub(start).and_then(|i| part.get_mut(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_is_cut_by_number_where_the_unknowns_have_no_halves_or_a_triangle_spans_both() {
        // 5,000 triangles in a strip, vertex k the unknown k: halves 0..4000 and 4000..4980 (the
        // rest the top). One triangle joining both halves, or no halves at all, cuts by number.
        let moving: Vec<[usize; 3]> = (0..5000).map(|t| [t, t + 1, t + 2]).collect();
        let unknowns: Vec<u32> = (0..5002).map(|v| v as u32).collect();
        let (order, half, halves) = cut(&moving, &unknowns, Some([4000, 4980]));
        assert_eq!(halves, None, "triangles 3998 and 3999 have corners in both halves");
        assert_eq!((order.len(), half), (5000, chunks(5000) / 2));
        assert!(order.iter().zip(&moving).all(|(o, t)| *o == Some(*t)));
        assert_eq!(cut(&moving, &unknowns, None).1, chunks(5000) / 2);
        assert_eq!(cut(&moving[..SPLIT - 1], &unknowns, None).1, chunks(SPLIT - 1), "small: whole");
        // Without the crossing triangles the cut follows the halves, the top's triangles (from
        // 4980 on) with the smaller group.
        let apart: Vec<[usize; 3]> = moving.iter().copied().filter(|t| t[0] + 2 < 4000 || t[0] >= 4000).collect();
        let (order, half, halves) = cut(&apart, &unknowns, Some([4000, 4980]));
        assert_eq!(halves, Some([4000, 4980]));
        let first: Vec<[usize; 3]> = order[..half * LANES].iter().flatten().copied().collect();
        assert!(first.iter().all(|t| t[0] < 4000) && first.len() == 3998, "{}", first.len());
        assert!(order[half * LANES..].iter().all(|t| t.is_some_and(|t| t[0] >= 4000)));
    }
}
