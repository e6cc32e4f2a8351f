//! Sparse Cholesky (faer's supernodal `LLᵀ`) with the symbolic analysis (fill-reducing ordering,
//! elimination tree, supernodes) done once per pattern and the numeric factorisation per use.
//!
//! The ordering is faer's approximate minimum degree by default, or one supplied by the caller
//! (e.g. [`super::ordering::nested_dissection`] expanded to DOFs). The factorisation runs on the
//! calling thread; a solve with several right sides splits its columns over the threads of
//! [`crate::threads`] (faer's blocked kernels then group the columns differently, so a column may
//! differ in its last bits from a solve on one thread). faer's own parallel factorisation measured
//! hardly faster than one thread on a large shell (`BENCHMARKS.md`, *Design measurements quoted from
//! module docs*).

use dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::Perm;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Conj, MatMut, Par, Side};

use super::LinalgError;

/// Right sides (unknowns × columns) from which a solve with several columns is split over threads:
/// below it the hand-over costs more than it saves.
const PARALLEL_SOLVE: usize = 1 << 16;

/// A reusable symbolic Cholesky factorisation of one sparsity pattern (reads the upper triangle).
#[derive(Debug)]
pub struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    factored: bool,
}

impl SparseCholesky {
    /// Analyse the pattern of `matrix` with an approximate-minimum-degree ordering.
    pub fn new(matrix: SparseColMatRef<'_, usize, f64>) -> Result<Self, LinalgError> {
        Self::analyse(matrix, SymmetricOrdering::Amd)
    }

    /// Analyse the pattern of `matrix` eliminating the unknowns in `order` (`order[k]` is
    /// eliminated `k`-th; a permutation of `0..n`).
    pub fn with_order(matrix: SparseColMatRef<'_, usize, f64>, order: &[usize]) -> Result<Self, LinalgError> {
        let n = matrix.nrows();
        let mut inverse = vec![usize::MAX; n];
        for (k, &i) in order.iter().enumerate() {
            if i >= n || inverse[i] != usize::MAX {
                return Err(LinalgError::Symbolic(format!("elimination order is not a permutation of 0..{n}")));
            }
            inverse[i] = k;
        }
        if order.len() != n {
            return Err(LinalgError::Symbolic(format!(
                "elimination order has {} entries for {n} unknowns",
                order.len()
            )));
        }
        let perm = Perm::new_checked(order.to_vec().into_boxed_slice(), inverse.into_boxed_slice(), n);
        Self::analyse(matrix, SymmetricOrdering::Custom(perm.as_ref()))
    }

    fn analyse(
        matrix: SparseColMatRef<'_, usize, f64>,
        ordering: SymmetricOrdering<'_, usize>,
    ) -> Result<Self, LinalgError> {
        let symbolic =
            factorize_symbolic_cholesky(matrix.symbolic(), Side::Upper, ordering, CholeskySymbolicParams::default())
                .map_err(|e| LinalgError::Symbolic(format!("{e:?}")))?;
        Ok(Self { values: vec![0.0; symbolic.len_val()], symbolic, factored: false })
    }

    /// Factorise `matrix` (same pattern as at construction). Fails if it is not positive definite.
    pub fn factor(&mut self, matrix: SparseColMatRef<'_, usize, f64>) -> Result<(), LinalgError> {
        self.factored = false;
        let need = self.symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
        let mut scratch =
            MemBuffer::try_new(need).map_err(|_| LinalgError::NotPositiveDefinite("out of memory".into()))?;
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.values,
                matrix,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut scratch),
                Default::default(),
            )
            .map_err(|e| LinalgError::NotPositiveDefinite(format!("{e:?}")))?;
        self.factored = true;
        Ok(())
    }

    /// Solve `A x = b` in place with the last successful factorisation.
    pub fn solve(&self, b: &mut [f64]) -> Result<(), LinalgError> {
        self.solve_many(b, 1)
    }

    /// Solve `A X = B` in place for `columns` right-hand sides stored column after column in `b`
    /// (one pass over the factor for all of them).
    pub fn solve_many(&self, b: &mut [f64], columns: usize) -> Result<(), LinalgError> {
        if !self.factored {
            return Err(LinalgError::NotPositiveDefinite("no successful factorisation to solve with".into()));
        }
        let n = self.symbolic.nrows();
        if columns == 0 || b.len() != n * columns {
            return Err(LinalgError::BadRhs { len: b.len(), rows: n, columns });
        }
        // Columns are independent: with several threads each solves its share, one pass over the
        // factor apiece.
        let threads = crate::threads::threads().min(columns);
        if threads > 1 && n * columns >= PARALLEL_SOLVE {
            use rayon::prelude::*;
            let per = columns.div_ceil(threads);
            return b.par_chunks_mut(n * per).try_for_each(|part| self.solve_serial(part, part.len() / n));
        }
        self.solve_serial(b, columns)
    }

    /// [`SparseCholesky::solve_many`] on the calling thread.
    fn solve_serial(&self, b: &mut [f64], columns: usize) -> Result<(), LinalgError> {
        let n = self.symbolic.nrows();
        let need = self.symbolic.solve_in_place_scratch::<f64>(columns, Par::Seq);
        let mut scratch =
            MemBuffer::try_new(need).map_err(|_| LinalgError::NotPositiveDefinite("out of memory".into()))?;
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(b, n, columns),
            Par::Seq,
            MemStack::new(&mut scratch),
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{BlockAssembler, DofMap};

    #[test]
    fn solves_a_small_spd_system_and_refuses_an_indefinite_one() {
        let dofs = DofMap::all(2);
        let mut a = BlockAssembler::new(&dofs, [&[0usize, 1][..]]).unwrap();
        // Lower blocks (0, 0), (1, 0), (1, 1) of [[4I, I], [I, 4I]].
        let block = [glam::DMat3::IDENTITY * 4.0, glam::DMat3::IDENTITY, glam::DMat3::IDENTITY * 4.0];
        a.begin();
        a.add_element(0, &block).unwrap();
        a.finish();
        let mut chol = SparseCholesky::new(a.matrix()).unwrap();
        chol.factor(a.matrix()).unwrap();
        let mut b = vec![5.0, 5.0, 5.0, 5.0, 5.0, 5.0];
        chol.solve(&mut b).unwrap();
        assert!(b.iter().all(|x| (x - 1.0).abs() < 1e-14), "{b:?}");
        a.add_diagonal(&[-10.0; 6]);
        assert!(chol.factor(a.matrix()).is_err());
        assert!(chol.solve(&mut b).is_err());
    }
}
