//! Sparse Cholesky (faer `Llt`) with the symbolic analysis (fill-reducing ordering, elimination tree)
//! done once per pattern and the numeric factorisation per Newton step.

use faer::linalg::solvers::Solve;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::{MatMut, Side};

use super::LinalgError;

/// A reusable symbolic Cholesky factorisation of one sparsity pattern (reads the upper triangle).
#[derive(Debug, Clone)]
pub struct SparseCholesky {
    symbolic: SymbolicLlt<usize>,
    factor: Option<Llt<usize, f64>>,
}

impl SparseCholesky {
    /// Analyse the pattern of `matrix`.
    pub fn new(matrix: SparseColMatRef<'_, usize, f64>) -> Result<Self, LinalgError> {
        let symbolic = SymbolicLlt::try_new(matrix.symbolic(), Side::Upper)
            .map_err(|e| LinalgError::Symbolic(format!("{e:?}")))?;
        Ok(Self { symbolic, factor: None })
    }

    /// Factorise `matrix` (same pattern as at construction). Fails if it is not positive definite.
    pub fn factor(&mut self, matrix: SparseColMatRef<'_, usize, f64>) -> Result<(), LinalgError> {
        self.factor = None;
        let llt = Llt::try_new_with_symbolic(self.symbolic.clone(), matrix, Side::Upper)
            .map_err(|e| LinalgError::NotPositiveDefinite(format!("{e:?}")))?;
        self.factor = Some(llt);
        Ok(())
    }

    /// Solve `A x = b` in place with the last successful factorisation.
    pub fn solve(&self, b: &mut [f64]) -> Result<(), LinalgError> {
        let Some(llt) = &self.factor else {
            return Err(LinalgError::NotPositiveDefinite("no successful factorisation to solve with".into()));
        };
        let n = b.len();
        llt.solve_in_place(MatMut::from_column_major_slice_mut(b, n, 1));
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
        let mut block = vec![0.0; 36];
        for i in 0..6 {
            block[i * 6 + i] = 4.0;
            if i < 3 {
                block[i * 6 + i + 3] = 1.0;
                block[(i + 3) * 6 + i] = 1.0;
            }
        }
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
