//! How a sparse Cholesky factor `L` of [`super::VectorCholesky`] is stored and solved with: its
//! strictly lower triangle by rows (the forward substitution) and by columns last first (the backward
//! one), each unknown a 3-vector in the four lanes of a [`Padded`].
//!
//! Both substitutions are gathers: `x_i ← (x_i − Σ_j L_ij x_j) / L_ii` over a line, in four
//! independent sums of fused multiply-adds (to hide their latency), compiled for AVX2 + FMA
//! ([`super::isa`]). Where the elimination tree has two independent halves followed by their common
//! ancestors, the top ([`super::tree_split`]), the top's rows are cut into what they take from each
//! half and the rest, and a solve goes in phases: forward, each half and what the top takes from it
//! (the two at once on two threads), then the top; backward, the top, then each half (at once). One
//! thread runs the same phases in turn, so that the solution does not depend on the thread count.

use std::ops::{Index, IndexMut, Range};

use super::isa::{Kernel, avx2};
use super::padded::Padded;
use super::shared::Shared;

/// The integer type of the factor's indices.
pub(super) trait FactorIndex: Copy + Default + std::fmt::Debug + PartialEq {
    /// From an index known to fit.
    fn narrow(i: u32) -> Self;
    /// As an index.
    fn get(self) -> usize;
}

impl FactorIndex for u16 {
    #[inline(always)]
    fn narrow(i: u32) -> Self {
        debug_assert!(i < 1 << 16, "{i} does not fit 16 bits");
        i as u16
    }
    #[inline(always)]
    fn get(self) -> usize {
        usize::from(self)
    }
}

impl FactorIndex for u32 {
    #[inline(always)]
    fn narrow(i: u32) -> Self {
        i
    }
    #[inline(always)]
    fn get(self) -> usize {
        self as usize
    }
}

/// The strictly lower triangle of `L` compressed by rows or by columns: per line, the columns (rows)
/// and values of its entries, the lines in the order a substitution visits them.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Compressed<I> {
    pub(super) start: Vec<usize>,
    pub(super) index: Vec<I>,
    pub(super) value: Vec<f64>,
}

impl Compressed<u32> {
    /// The indices of line `k`.
    pub(super) fn line(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        self.index[self.start[k]..self.start[k + 1]].iter().map(|&j| j as usize)
    }

    /// The same lines with their indices in `I` (each must fit).
    pub(super) fn narrow<I: FactorIndex>(self) -> Compressed<I> {
        let index = self.index.iter().map(|&i| I::narrow(i)).collect();
        Compressed { start: self.start, index, value: self.value }
    }

    /// The same lines, last first.
    pub(super) fn reversed(&self) -> Self {
        let mut out = Self { start: vec![0], ..Default::default() };
        for line in self.start.windows(2).rev() {
            out.index.extend_from_slice(&self.index[line[0]..line[1]]);
            out.value.extend_from_slice(&self.value[line[0]..line[1]]);
            out.start.push(out.index.len());
        }
        out
    }
}

/// The factor's lines: its rows (the forward substitution) and its columns last first (the backward
/// one). With halves, the top's rows keep only their entries in the top; what they take from each
/// half is in `from_halves` (one line per top row). Built only by [`Factor::new`], which checks that
/// the halves do not meet: what makes solving them on two threads at once sound.
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Factor<I> {
    rows: Compressed<I>,
    columns: Compressed<I>,
    from_halves: [Compressed<I>; 2],
    /// The ends of the two halves: unknowns `0..a` and `a..b`, then the top.
    halves: Option<[usize; 2]>,
}

impl Factor<u32> {
    /// The factor whose strictly lower triangle has these `columns` (first to last), with `halves`
    /// if no row of one half has an entry in the other half's columns (an order that keeps the
    /// elimination tree guarantees it; if not, the factor has no halves).
    pub(super) fn new(columns: Compressed<u32>, halves: Option<[usize; 2]>) -> Self {
        let n = columns.start.len() - 1;
        let mut per_row = vec![0usize; n + 1];
        columns.index.iter().for_each(|&i| per_row[i as usize + 1] += 1);
        for i in 0..n {
            per_row[i + 1] += per_row[i];
        }
        let mut rows = Compressed { index: vec![0; per_row[n]], value: vec![0.0; per_row[n]], start: per_row.clone() };
        for j in 0..n {
            for p in columns.start[j]..columns.start[j + 1] {
                let slot = &mut per_row[columns.index[p] as usize];
                (rows.index[*slot], rows.value[*slot]) = (j as u32, columns.value[p]);
                *slot += 1;
            }
        }
        let half = |i: usize| halves.map_or(2, |[a, b]| usize::from(i >= a) + usize::from(i >= b));
        let meet = (0..n).any(|i| half(i) < 2 && rows.line(i).any(|j| half(j) != half(i)));
        debug_assert!(!meet, "the elimination tree's halves meet in the factor");
        let halves = halves.filter(|&[a, b]| !meet && a <= b && b <= n);
        let (rows, from_halves) = cut_top_rows(rows, halves.map_or(n, |[_, b]| b), half);
        // The backward pass visits the columns last to first: stored in that order, it streams the
        // factor forwards through memory as the forward pass does.
        Self { rows, columns: columns.reversed(), from_halves, halves }
    }

    /// The same lines with their indices in `I` (each must fit).
    pub(super) fn narrow<I: FactorIndex>(self) -> Factor<I> {
        let [first, second] = self.from_halves;
        Factor {
            rows: self.rows.narrow(),
            columns: self.columns.narrow(),
            from_halves: [first.narrow(), second.narrow()],
            halves: self.halves,
        }
    }
}

impl<I> Factor<I> {
    /// Unknowns.
    pub(super) fn dim(&self) -> usize {
        self.columns.start.len() - 1
    }

    /// Entries below the diagonal.
    pub(super) fn entries(&self) -> usize {
        self.columns.index.len()
    }

    /// The ends of the two halves (unknowns `0..a`, `a..b`), if it has them.
    pub(super) fn halves(&self) -> Option<[usize; 2]> {
        self.halves
    }
}

/// The rows from `top` on (of a factor with `n` rows) cut into their entries in the top, kept in
/// the rows, and those in each half (`half(j)` = 0 or 1; 2 for the top), one line per top row.
fn cut_top_rows(
    rows: Compressed<u32>,
    top: usize,
    half: impl Fn(usize) -> usize,
) -> (Compressed<u32>, [Compressed<u32>; 2]) {
    let n = rows.start.len() - 1;
    // Parts 0 and 1: from each half; part 2: kept.
    let mut parts: [Compressed<u32>; 3] = Default::default();
    parts.iter_mut().for_each(|c| c.start.push(0));
    for i in 0..n {
        for p in rows.start[i]..rows.start[i + 1] {
            let part = &mut parts[if i < top { 2 } else { half(rows.index[p] as usize) }];
            part.index.push(rows.index[p]);
            part.value.push(rows.value[p]);
        }
        let cut = if i < top { 2..3 } else { 0..3 };
        parts[cut].iter_mut().for_each(|c| c.start.push(c.index.len()));
    }
    let [first, second, kept] = parts;
    (kept, [first, second])
}

/// Both substitutions: forward by the rows, backward by the reversed columns. With halves, in
/// phases (module documentation): forward, each half and what the top's rows take from it (on two
/// threads if `parallel`), then the top; backward, the top, then each half. One thread runs the same
/// phases in turn, so that the solution does not depend on the thread count. `from_halves` holds one
/// entry per top row each.
pub(super) fn substitute<I, X>(
    factor: &Factor<I>,
    inverse_diagonal: &[f64],
    x: &mut X,
    from_halves: &mut [Vec<Padded>; 2],
    parallel: bool,
) where
    I: FactorIndex + Sync,
    X: ?Sized + IndexMut<usize, Output = Padded> + AsMut<[Padded]>,
{
    let n = factor.dim();
    assert_eq!(inverse_diagonal.len(), n, "one diagonal entry per unknown");
    let halves = factor.halves;
    let [first, second] = from_halves;
    match halves {
        Some([a, b]) if parallel => {
            // SAFETY: the halves never meet ([`Factor::new`] checks it, and the columns are the
            // rows' transpose): in either substitution, a thread writes only its own half's unknowns
            // and reads only those and the top's, and no thread writes the top's while the halves
            // are solved.
            #[allow(unsafe_code)]
            let shared = unsafe { Shared::new(x.as_mut()) };
            let pass = |factor, lines, reverse| {
                avx2(Substitute { factor, lines, inverse_diagonal, x: &mut shared.clone(), reverse });
            };
            let forward = |lines, from, out: &mut Vec<Padded>| {
                pass(&factor.rows, lines, false);
                avx2(Gather { factor: from, x: &shared, out });
            };
            rayon::join(
                || forward(0..a, &factor.from_halves[0], first),
                || forward(a..b, &factor.from_halves[1], second),
            );
            add_from_halves(&mut shared.clone(), b, first, second);
            pass(&factor.rows, b..n, false);
            // The columns are stored last first: the top's lines come first, then the second half's.
            pass(&factor.columns, 0..n - b, true);
            rayon::join(|| pass(&factor.columns, n - b..n - a, true), || pass(&factor.columns, n - a..n, true));
        }
        _ => {
            // The same phases one after another (each unknown summed as on two threads).
            let top = halves.map_or(n, |[_, b]| b);
            avx2(Substitute { factor: &factor.rows, lines: 0..top, inverse_diagonal, x: &mut *x, reverse: false });
            if halves.is_some() {
                avx2(Gather { factor: &factor.from_halves[0], x: &*x, out: first });
                avx2(Gather { factor: &factor.from_halves[1], x: &*x, out: second });
                add_from_halves(x, top, first, second);
            }
            avx2(Substitute { factor: &factor.rows, lines: top..n, inverse_diagonal, x: &mut *x, reverse: false });
            avx2(Substitute { factor: &factor.columns, lines: 0..n, inverse_diagonal, x, reverse: true });
        }
    }
}

/// `x_i += first_k + second_k` for the top's unknowns `i = top + k`: what their rows take from the
/// halves.
fn add_from_halves<X: ?Sized + IndexMut<usize, Output = Padded>>(
    x: &mut X,
    top: usize,
    first: &[Padded],
    second: &[Padded],
) {
    for (k, (a, b)) in first.iter().zip(second).enumerate() {
        x[top + k] = x[top + k] + *a + *b;
    }
}

/// One substitution: `x_i ← (x_i − Σ_j L_ij x_j) / L_ii` over the entries of `factor`'s `k`-th line,
/// for `k` in `lines`, `i = k` ascending (forward, by rows) or `i = n − 1 − k` descending (backward,
/// by columns).
struct Substitute<'a, I, X: ?Sized> {
    factor: &'a Compressed<I>,
    lines: Range<usize>,
    inverse_diagonal: &'a [f64],
    x: &'a mut X,
    reverse: bool,
}

impl<I: FactorIndex, X: ?Sized + IndexMut<usize, Output = Padded>> Kernel for Substitute<'_, I, X> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        let Self { factor, lines, inverse_diagonal, x, reverse } = self;
        let n = inverse_diagonal.len();
        for k in lines {
            let i = if reverse { n - 1 - k } else { k };
            x[i] = minus_line(factor, k, &*x, x[i]) * inverse_diagonal[i];
        }
    }
}

/// `out_k = −Σ_j L_ij x_j` over the entries of each line `k` of `factor`.
struct Gather<'a, I, X: ?Sized> {
    factor: &'a Compressed<I>,
    x: &'a X,
    out: &'a mut [Padded],
}

impl<I: FactorIndex, X: ?Sized + Index<usize, Output = Padded>> Kernel for Gather<'_, I, X> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        for (k, out) in self.out.iter_mut().enumerate() {
            *out = minus_line(self.factor, k, self.x, Padded::ZERO);
        }
    }
}

/// `start − Σ_j L_ij x_j` over the entries of line `k` of `factor`: four independent sums of fused
/// multiply-adds (to hide their latency), each line's indices and values walked in fours together.
#[inline(always)]
fn minus_line<I: FactorIndex, X: ?Sized + Index<usize, Output = Padded>>(
    factor: &Compressed<I>,
    k: usize,
    x: &X,
    start: Padded,
) -> Padded {
    let line = factor.start[k]..factor.start[k + 1];
    let (index, value) = (factor.index[line.clone()].chunks_exact(4), factor.value[line].chunks_exact(4));
    let (index_tail, value_tail) = (index.remainder(), value.remainder());
    let mut sums = [start, Padded::ZERO, Padded::ZERO, Padded::ZERO];
    for (four, values) in index.zip(value) {
        for ((&j, &l), s) in four.iter().zip(values).zip(&mut sums) {
            *s = s.minus_scaled(x[j.get()], l);
        }
    }
    for (&j, &l) in index_tail.iter().zip(value_tail) {
        sums[0] = sums[0].minus_scaled(x[j.get()], l);
    }
    (sums[0] + sums[1]) + (sums[2] + sums[3])
}
