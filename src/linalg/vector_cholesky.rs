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
//! are 16-bit and the solution a fixed-size array, so the gathers need no bounds checks (on one
//! thread; the halves' gathers on two are checked); larger systems take 32-bit indices and checked
//! gathers. The loops are compiled for AVX2 + FMA where the
//! CPU has them ([`super::isa`]). A solve reads the factor twice and allocates nothing.
//!
//! On the creature's Laplacian, streaming the backward pass forwards and gathering without bounds checks or
//! separate multiplies measured faster than before, and the whole solve faster than faer's own with
//! three columns, simplicial or supernodal; geometric nested dissection gives more fill there, and a
//! slower solve; more or fewer sums, and a backward pass scattering from the rows (one copy of the
//! factor instead of two), were each no faster or slower (`BENCHMARKS.md`, *Design measurements
//! quoted from module docs*).
//!
//! **Two threads.** The minimum-degree order is relabelled, with the same factor, so that the
//! unknowns come as two independent halves of the elimination tree and then their common ancestors
//! ([`super::tree_split`]), from [`LEAST_SPLIT`] unknowns on. With more than one thread
//! ([`crate::threads`]) each substitution solves the halves at once and the top alone
//! ([`super::substitution`]); each unknown is summed in the same order as on one thread, so the
//! solution is the same to the bit.

use faer::perm::PermRef;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Par, Side};

use super::LinalgError;
use super::padded::Padded;
use super::substitution::{Compressed, Factor, substitute};
use super::tree_split;

/// Systems of fewer unknowns are not split into halves: a solve of them is too short to share.
const LEAST_SPLIT: usize = 4096;

/// Systems of at most this many unknowns get 16-bit indices and a fixed-size solution array.
const SHORT: usize = 1 << 16;

/// The factor and the right side and solution.
#[derive(Clone, PartialEq)]
enum Lines {
    /// At most [`SHORT`] unknowns (the array's tail past them unused).
    Short { factor: Factor<u16>, x: Box<[Padded; SHORT]> },
    /// More.
    Long { factor: Factor<u32>, x: Vec<Padded> },
}

impl std::fmt::Debug for Lines {
    /// The index width and sizes (not the 65,536-entry array).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (width, entries) = match self {
            Lines::Short { factor, .. } => (16, factor.entries()),
            Lines::Long { factor, .. } => (32, factor.entries()),
        };
        write!(f, "Lines {{ index_bits: {width}, entries_below_diagonal: {entries} }}")
    }
}

/// The factor and a right side of 3-vectors, solved in place.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorCholesky {
    order: Vec<usize>,
    lines: Lines,
    inverse_diagonal: Vec<f64>,
    /// Per half, what each top row takes from it (`−Σ_j L_ij x_j`), during a solve.
    from_halves: [Vec<Padded>; 2],
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
        let symbolic_in = |ordering| {
            factorize_symbolic_cholesky(matrix.symbolic(), Side::Upper, ordering, params)
                .map_err(|e| LinalgError::Symbolic(format!("{e:?}")))
        };
        let mut symbolic = symbolic_in(SymmetricOrdering::Amd)?;
        let mut halves = None;
        let split = if n >= LEAST_SPLIT { elimination_split(&symbolic) } else { None };
        if let (Some(split), Some(amd)) = (split, symbolic.perm()) {
            let forward: Vec<usize> = split.order.iter().map(|&k| amd.arrays().0[k]).collect();
            let mut inverse = vec![0; n];
            forward.iter().enumerate().for_each(|(k, &i)| inverse[i] = k);
            symbolic = symbolic_in(SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n)))?;
            halves = Some(split.halves);
        }
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
        for j in 0..n {
            let entries = start[j]..start[j + 1];
            if entries.is_empty() || row[start[j]] != j {
                return Err(LinalgError::Symbolic(format!("column {j} of the factor does not start at its diagonal")));
            }
            inverse_diagonal.push(1.0 / values[start[j]]);
            for p in start[j] + 1..start[j + 1] {
                columns.index.push(row[p] as u32);
                columns.value.push(values[p]);
            }
            columns.start.push(columns.index.len());
        }
        let factor = Factor::new(columns, halves);
        let top = factor.halves().map_or(0, |[_, b]| n - b);
        let lines = if n <= short.min(SHORT) {
            let x = vec![Padded::ZERO; SHORT]
                .into_boxed_slice()
                .try_into()
                .map_err(|_| LinalgError::Symbolic("the solution array does not have its fixed size".into()))?;
            Lines::Short { factor: factor.narrow(), x }
        } else {
            Lines::Long { factor, x: vec![Padded::ZERO; n] }
        };
        Ok(Self { order, lines, inverse_diagonal, from_halves: [vec![Padded::ZERO; top], vec![Padded::ZERO; top]] })
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
            Lines::Short { factor, .. } => factor.entries(),
            Lines::Long { factor, .. } => factor.entries(),
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

    /// Solve `A x = b` in place (the halves on two threads where more than one is set).
    pub fn solve(&mut self) {
        let parallel = crate::threads::threads() > 1;
        let Self { inverse_diagonal, from_halves, lines, .. } = self;
        match lines {
            Lines::Short { factor, x } => substitute(factor, inverse_diagonal, &mut **x, from_halves, parallel),
            Lines::Long { factor, x } => substitute(factor, inverse_diagonal, &mut x[..], from_halves, parallel),
        }
    }

    /// The ends of the elimination tree's two halves, which a solve may run apart, if it was split:
    /// unknowns `0..a` and `a..b`, then their common ancestors (the top).
    pub fn halves(&self) -> Option<[usize; 2]> {
        match &self.lines {
            Lines::Short { factor, .. } => factor.halves(),
            Lines::Long { factor, .. } => factor.halves(),
        }
    }
}

/// The split of the elimination tree of `symbolic`'s simplicial factor, each unknown weighted by
/// its entries in the factor's row and column (what the two substitutions read for it).
fn elimination_split(
    symbolic: &faer::sparse::linalg::cholesky::SymbolicCholesky<usize>,
) -> Option<tree_split::TreeSplit> {
    let SymbolicCholeskyRaw::Simplicial(l) = symbolic.raw() else { return None };
    let (start, row) = (l.col_ptr(), l.row_idx());
    let n = start.len() - 1;
    let mut work = vec![1u64; n];
    let mut parent = vec![None; n];
    for j in 0..n {
        for &i in row[start[j]..start[j + 1]].iter().filter(|&&i| i > j) {
            work[i] += 1;
            work[j] += 1;
            parent[j] = Some(parent[j].map_or(i, |p: usize| p.min(i)));
        }
    }
    tree_split::split(&parent, &work)
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
    fn a_grid_splits_into_halves_solved_on_two_threads_as_on_one_to_the_bit() {
        // A 70 × 70 grid's Laplacian with diagonals, plus a shift: its elimination tree has halves.
        let side = 70;
        let id = |i: usize, j: usize| i * side + j;
        let mut entries = Vec::new();
        for (i, j) in (0..side).flat_map(|i| (0..side).map(move |j| (i, j))) {
            entries.push(Triplet::new(id(i, j), id(i, j), 6.5));
            for (di, dj) in [(0, 1), (1, 0), (1, 1)] {
                if i + di < side && j + dj < side {
                    entries.push(Triplet::new(id(i, j), id(i + di, j + dj), -1.0));
                }
            }
        }
        let n = side * side;
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &entries).unwrap();
        let b: Vec<DVec3> = (0..n).map(|i| DVec3::new((0.1 * i as f64).cos(), (i % 5) as f64, 1.0)).collect();
        let mut reference = crate::linalg::SparseCholesky::new(a.as_ref()).unwrap();
        reference.factor(a.as_ref()).unwrap();
        let mut chol = VectorCholesky::new(a.as_ref()).unwrap();
        assert!(chol.halves().is_some(), "a grid has halves");
        let Lines::Short { factor, .. } = &chol.lines else { panic!("16-bit indices") };
        let [first, second] = factor.halves().unwrap();
        assert!(first > n / 4 && second - first > n / 4 && n - second < n / 10, "{first} {second} of {n}");
        let mut solutions = Vec::new();
        for parallel in [false, true] {
            let order = chol.order().to_vec();
            chol.rhs_mut().iter_mut().zip(&order).for_each(|(x, &i)| *x = b[i].into());
            let VectorCholesky { inverse_diagonal, from_halves, lines: Lines::Short { factor, x }, .. } = &mut chol
            else {
                panic!("16-bit indices")
            };
            substitute(factor, inverse_diagonal, &mut **x, from_halves, parallel);
            for axis in 0..3 {
                let mut column: Vec<f64> = b.iter().map(|v| v[axis]).collect();
                reference.solve(&mut column).unwrap();
                for (got, &i) in chol.solution().iter().zip(&order) {
                    assert!((got.lane(axis) - column[i]).abs() < 1e-12 * column[i].abs().max(1.0));
                }
            }
            solutions.push(chol.solution().to_vec());
        }
        assert_eq!(solutions[0], solutions[1], "one thread and two, bit for bit");
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
