//! A sparse Cholesky factor of a scalar SPD matrix, solving for a 3-vector per unknown: the three
//! coordinates of a mesh's vertices share one scalar matrix (a graph Laplacian), so one pass over the
//! factor solves all three at once, in the four lanes of a [`Padded`].
//!
//! The factor is faer's simplicial `LLᵀ` of the matrix with its unknowns in faer's approximate
//! minimum degree order, and the right side and solution are kept in that order
//! ([`VectorCholesky::order`]), so a solve permutes nothing. Both substitutions are gathers —
//! forward by the rows of `L`, backward by its columns — so each unknown accumulates in registers
//! (four independent sums of fused multiply-adds, to hide their latency; each line's indices and
//! values walked in fours together) and is stored once, and both stream their copy of the factor
//! forwards through memory (the columns are stored last to first). Up to 65,536 unknowns the indices
//! are 16-bit and the solution a fixed-size array, so the gathers need no bounds checks; larger
//! systems take 32-bit indices and checked gathers. The loops are compiled for AVX2 + FMA where the
//! CPU has them ([`super::isa`]). A solve reads the factor twice and allocates nothing. On the
//! creature's Laplacian, streaming the backward pass forwards and gathering without bounds checks or
//! separate multiplies measured faster than before, and the whole solve faster than faer's own with
//! three columns, simplicial or supernodal; geometric nested dissection gives more fill there, and a
//! slower solve; more or fewer sums, and a backward pass scattering from the rows (one copy of the
//! factor instead of two), were each no faster or slower (`BENCHMARKS.md`, *Design measurements
//! quoted from module docs*).

use std::ops::IndexMut;

use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Par, Side};

use super::LinalgError;
use super::isa::{Kernel, avx2};
use super::padded::Padded;

/// Systems of at most this many unknowns get 16-bit indices and a fixed-size solution array.
const SHORT: usize = 1 << 16;

/// The integer type of the factor's indices.
trait FactorIndex: Copy + Default + std::fmt::Debug + PartialEq {
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
struct Compressed<I> {
    start: Vec<usize>,
    index: Vec<I>,
    value: Vec<f64>,
}

impl Compressed<u32> {
    /// The same lines with their indices in `I` (each must fit).
    fn narrow<I: FactorIndex>(self) -> Compressed<I> {
        let index = self.index.iter().map(|&i| I::narrow(i)).collect();
        Compressed { start: self.start, index, value: self.value }
    }

    /// The same lines, last first.
    fn reversed(&self) -> Self {
        let mut out = Self { start: vec![0], ..Default::default() };
        for line in self.start.windows(2).rev() {
            out.index.extend_from_slice(&self.index[line[0]..line[1]]);
            out.value.extend_from_slice(&self.value[line[0]..line[1]]);
            out.start.push(out.index.len());
        }
        out
    }
}

/// The rows and the reversed columns of the factor, and the right side and solution.
#[derive(Clone, PartialEq)]
enum Lines {
    /// At most [`SHORT`] unknowns (the array's tail past them unused).
    Short { rows: Compressed<u16>, columns: Compressed<u16>, x: Box<[Padded; SHORT]> },
    /// More.
    Long { rows: Compressed<u32>, columns: Compressed<u32>, x: Vec<Padded> },
}

impl std::fmt::Debug for Lines {
    /// The index width and sizes (not the 65,536-entry array).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (width, rows, columns) = match self {
            Lines::Short { rows, columns, .. } => (16, rows.index.len(), columns.index.len()),
            Lines::Long { rows, columns, .. } => (32, rows.index.len(), columns.index.len()),
        };
        write!(f, "Lines {{ index_bits: {width}, row_entries: {rows}, column_entries: {columns} }}")
    }
}

/// The factor and a right side of 3-vectors, solved in place.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorCholesky {
    order: Vec<usize>,
    lines: Lines,
    inverse_diagonal: Vec<f64>,
}

impl VectorCholesky {
    /// Order and factorise `matrix` (its upper triangle is read). Fails if it is not positive
    /// definite, or too large for 32-bit indices.
    pub fn new(matrix: SparseColMatRef<'_, usize, f64>) -> Result<Self, LinalgError> {
        Self::with_short_limit(matrix, SHORT)
    }

    /// [`VectorCholesky::new`], with 16-bit indices only up to `short` unknowns (at most [`SHORT`]).
    fn with_short_limit(matrix: SparseColMatRef<'_, usize, f64>, short: usize) -> Result<Self, LinalgError> {
        let n = matrix.nrows();
        if n >= u32::MAX as usize {
            return Err(LinalgError::Symbolic(format!("{n} unknowns need more than 32-bit indices")));
        }
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(matrix.symbolic(), Side::Upper, SymmetricOrdering::Amd, params)
            .map_err(|e| LinalgError::Symbolic(format!("{e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let need = symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
        let mut scratch = dyn_stack::MemBuffer::try_new(need)
            .map_err(|_| LinalgError::NotPositiveDefinite("out of memory".into()))?;
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut values,
                matrix,
                Side::Upper,
                Default::default(),
                Par::Seq,
                dyn_stack::MemStack::new(&mut scratch),
                Default::default(),
            )
            .map_err(|e| LinalgError::NotPositiveDefinite(format!("{e:?}")))?;
        let SymbolicCholeskyRaw::Simplicial(l) = symbolic.raw() else {
            return Err(LinalgError::Symbolic("the factor is not simplicial".into()));
        };
        let order = symbolic.perm().map_or_else(|| (0..n).collect(), |p| p.arrays().0.to_vec());
        let (start, row) = (l.col_ptr(), l.row_idx());
        let mut columns = Compressed { start: vec![0], ..Default::default() };
        let mut inverse_diagonal = Vec::with_capacity(n);
        let mut per_row = vec![0usize; n + 1];
        for j in 0..n {
            let entries = start[j]..start[j + 1];
            if entries.is_empty() || row[start[j]] != j {
                return Err(LinalgError::Symbolic(format!("column {j} of the factor does not start at its diagonal")));
            }
            inverse_diagonal.push(1.0 / values[start[j]]);
            for p in start[j] + 1..start[j + 1] {
                columns.index.push(row[p] as u32);
                columns.value.push(values[p]);
                per_row[row[p] + 1] += 1;
            }
            columns.start.push(columns.index.len());
        }
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
        // The backward pass visits the columns last to first: stored in that order, it streams the
        // factor forwards through memory as the forward pass does.
        let columns = columns.reversed();
        let lines = if n <= short.min(SHORT) {
            let x = vec![Padded::ZERO; SHORT]
                .into_boxed_slice()
                .try_into()
                .map_err(|_| LinalgError::Symbolic("the solution array does not have its fixed size".into()))?;
            Lines::Short { rows: rows.narrow(), columns: columns.narrow(), x }
        } else {
            Lines::Long { rows, columns, x: vec![Padded::ZERO; n] }
        };
        Ok(Self { order, lines, inverse_diagonal })
    }

    /// Number of unknowns.
    pub fn dim(&self) -> usize {
        self.inverse_diagonal.len()
    }

    /// The factor's order of the unknowns: its `k`-th unknown is the matrix's row `order()[k]`.
    /// [`VectorCholesky::rhs_mut`] and [`VectorCholesky::solution`] are in this order.
    pub fn order(&self) -> &[usize] {
        &self.order
    }

    /// Entries of the factor (with the diagonal).
    pub fn factor_entries(&self) -> usize {
        let below = match &self.lines {
            Lines::Short { rows, .. } => rows.index.len(),
            Lines::Long { rows, .. } => rows.index.len(),
        };
        below + self.dim()
    }

    /// The right side (one 3-vector per unknown, in the factor's [`VectorCholesky::order`]), to fill
    /// before [`VectorCholesky::solve`]; after it, the solution.
    pub fn rhs_mut(&mut self) -> &mut [Padded] {
        let n = self.dim();
        match &mut self.lines {
            Lines::Short { x, .. } => &mut x[..n],
            Lines::Long { x, .. } => x,
        }
    }

    /// The solution of the last [`VectorCholesky::solve`].
    pub fn solution(&self) -> &[Padded] {
        match &self.lines {
            Lines::Short { x, .. } => &x[..self.dim()],
            Lines::Long { x, .. } => x,
        }
    }

    /// Solve `A x = b` in place.
    pub fn solve(&mut self) {
        let inverse_diagonal = &self.inverse_diagonal;
        match &mut self.lines {
            Lines::Short { rows, columns, x } => substitute(rows, columns, inverse_diagonal, &mut **x),
            Lines::Long { rows, columns, x } => substitute(rows, columns, inverse_diagonal, &mut x[..]),
        }
    }
}

/// Both substitutions: forward by `rows`, backward by the reversed `columns`.
fn substitute<I: FactorIndex, X: ?Sized + IndexMut<usize, Output = Padded>>(
    rows: &Compressed<I>,
    columns: &Compressed<I>,
    inverse_diagonal: &[f64],
    x: &mut X,
) {
    avx2(Substitute { factor: rows, inverse_diagonal, x: &mut *x, reverse: false });
    avx2(Substitute { factor: columns, inverse_diagonal, x, reverse: true });
}

/// One substitution: `x_i ← (x_i − Σ_j L_ij x_j) / L_ii` over the entries of `factor`'s `k`-th line,
/// for `i = k` ascending (forward, by rows) or `i = n − 1 − k` descending (backward, by columns).
struct Substitute<'a, I, X: ?Sized> {
    factor: &'a Compressed<I>,
    inverse_diagonal: &'a [f64],
    x: &'a mut X,
    reverse: bool,
}

impl<I: FactorIndex, X: ?Sized + IndexMut<usize, Output = Padded>> Kernel for Substitute<'_, I, X> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        let Self { factor, inverse_diagonal, x, reverse } = self;
        let n = inverse_diagonal.len();
        for k in 0..n {
            let i = if reverse { n - 1 - k } else { k };
            let line = factor.start[k]..factor.start[k + 1];
            let (index, value) = (factor.index[line.clone()].chunks_exact(4), factor.value[line].chunks_exact(4));
            let (index_tail, value_tail) = (index.remainder(), value.remainder());
            let mut sums = [x[i], Padded::ZERO, Padded::ZERO, Padded::ZERO];
            for (four, values) in index.zip(value) {
                for ((&j, &l), s) in four.iter().zip(values).zip(&mut sums) {
                    *s = s.minus_scaled(x[j.get()], l);
                }
            }
            for (&j, &l) in index_tail.iter().zip(value_tail) {
                sums[0] = sums[0].minus_scaled(x[j.get()], l);
            }
            x[i] = ((sums[0] + sums[1]) + (sums[2] + sums[3])) * inverse_diagonal[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::{SparseColMat, Triplet};
    use glam::DVec3;

    #[test]
    fn solves_each_coordinate_as_faer_does_with_either_index_width_and_refuses_an_indefinite_matrix() {
        // A path graph's Laplacian plus a diagonal shift, with a few long-range couplings (fill-in).
        let n = 40;
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push(Triplet::new(i, i, 3.0 + 0.1 * i as f64));
            if i + 1 < n {
                entries.push(Triplet::new(i, i + 1, -1.0));
            }
            if i + 7 < n && i % 3 == 0 {
                entries.push(Triplet::new(i, i + 7, -0.5));
            }
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &entries).unwrap();
        let b: Vec<DVec3> = (0..n).map(|i| DVec3::new((0.3 * i as f64).sin(), 1.0, -(i as f64))).collect();
        let mut reference = crate::linalg::SparseCholesky::new(a.as_ref()).unwrap();
        reference.factor(a.as_ref()).unwrap();
        // 16-bit indices (any system this small) and 32-bit ones (forced): the same arithmetic.
        let mut solutions = Vec::new();
        for short in [SHORT, 0] {
            let mut chol = VectorCholesky::with_short_limit(a.as_ref(), short).unwrap();
            assert_eq!(matches!(chol.lines, Lines::Short { .. }), short > 0);
            assert!(chol.factor_entries() > 2 * n - 1, "fill-in: {}", chol.factor_entries());
            let order = chol.order().to_vec();
            chol.rhs_mut().iter_mut().zip(&order).for_each(|(x, &i)| *x = b[i].into());
            chol.solve();
            for axis in 0..3 {
                let mut column: Vec<f64> = b.iter().map(|v| v[axis]).collect();
                reference.solve(&mut column).unwrap();
                for (got, &i) in chol.solution().iter().zip(&order) {
                    let want = column[i];
                    let error = (got.lane(axis) - want).abs();
                    assert!(error < 1e-14 * want.abs().max(1.0), "{} vs {want}", got.lane(axis));
                }
            }
            assert_eq!(chol.solution().len(), n);
            assert!(chol.solution().iter().all(|x| x.lane(3) == 0.0), "the pad stays zero");
            solutions.push(chol.solution().to_vec());
        }
        assert_eq!(solutions[0], solutions[1], "both index widths, bit for bit");
        // An indefinite matrix is refused.
        let bad = SparseColMat::<usize, f64>::try_new_from_triplets(
            2,
            2,
            &[Triplet::new(0, 0, 1.0), Triplet::new(0, 1, 2.0), Triplet::new(1, 1, 1.0)],
        )
        .unwrap();
        assert!(VectorCholesky::new(bad.as_ref()).is_err());
    }

    #[test]
    fn the_largest_system_with_16_bit_indices_solves_as_with_32_bit_ones() {
        // A path graph's Laplacian plus a shift, with exactly 65,536 unknowns: the factor's last
        // indices are 65,535, the largest 16 bits hold. Its exact solution for b = A·x is x.
        let n = SHORT;
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push(Triplet::new(i, i, 2.5));
            if i + 1 < n {
                entries.push(Triplet::new(i, i + 1, -1.0));
            }
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &entries).unwrap();
        let want: Vec<DVec3> = (0..n).map(|i| DVec3::new((0.01 * i as f64).sin(), 1.0, (i % 7) as f64)).collect();
        let b: Vec<DVec3> = (0..n)
            .map(|i| {
                let side = |j: Option<usize>| j.and_then(|j| want.get(j)).copied().unwrap_or(DVec3::ZERO);
                want[i] * 2.5 - side(i.checked_sub(1)) - side(Some(i + 1))
            })
            .collect();
        let mut solutions = Vec::new();
        for short in [SHORT, 0] {
            let mut chol = VectorCholesky::with_short_limit(a.as_ref(), short).unwrap();
            assert_eq!(matches!(chol.lines, Lines::Short { .. }), short > 0, "{:?}", chol.lines);
            let order = chol.order().to_vec();
            chol.rhs_mut().iter_mut().zip(&order).for_each(|(x, &i)| *x = b[i].into());
            chol.solve();
            let worst = (chol.solution().iter().zip(&order))
                .map(|(got, &i)| (DVec3::from(*got) - want[i]).length())
                .fold(0.0, f64::max);
            assert!(worst < 1e-12, "{short}: off by {worst:.1e}");
            solutions.push(chol.solution().to_vec());
        }
        assert_eq!(solutions[0], solutions[1], "both index widths, bit for bit");
    }
}
