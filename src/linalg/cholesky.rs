//! Sparse Cholesky (faer's supernodal `LLᵀ`) with the symbolic analysis (fill-reducing ordering,
//! elimination tree, supernodes) done once per pattern and the numeric factorisation per use.
//!
//! The ordering is faer's approximate minimum degree by default, or one supplied by the caller
//! (e.g. [`super::ordering::nested_dissection`] expanded to DOFs). The factorisation runs on the
//! calling thread (faer's own parallel factorisation measured hardly faster than one thread on a
//! large shell: `BENCHMARKS.md`, *Design measurements quoted from module docs*). A supernodal factor
//! is solved with by [`super::supernodal_solve`], eight or four right sides a pass over the factor.
//! Where its elimination tree has two independent halves ([`super::supernodal_split`]) a large pass
//! runs them at once on two threads of [`crate::threads`], or in turn on one; otherwise several large
//! passes are split over the threads, and a single pass (up to eight columns) runs on one thread.
//! Each column's solution is the same to the bit however the columns are batched and on however
//! many threads. A factor faer keeps column by column (small or very sparse matrices) is solved with
//! by faer.

use dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::Perm;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{Conj, MatMut, Par, Side};

use super::LinalgError;
use super::supernodal_solve::{Lanes, Part, backward, forward};
use super::supernodal_split::SupernodalSplit;

/// Unknowns × right sides of a pass (four or eight, however few columns are asked for) from which
/// the halves of a split factor run on two threads, and unknowns × columns from which the passes of
/// a factor without halves are split over the threads: below it the hand-over costs more than it
/// saves.
const PARALLEL_SOLVE: usize = 1 << 16;

/// A reusable symbolic Cholesky factorisation of one sparsity pattern (reads the upper triangle).
#[derive(Debug)]
pub struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
    /// Two independent halves of the supernodal factor's tree, if it has them.
    split: Option<SupernodalSplit>,
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
        let split = match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(supernodal) => super::supernodal_split::split(supernodal),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        };
        Ok(Self { values: vec![0.0; symbolic.len_val()], symbolic, split, factored: false })
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
    /// (one pass over the factor for each eight of them, or four for the last few).
    pub fn solve_many(&self, b: &mut [f64], columns: usize) -> Result<(), LinalgError> {
        if !self.factored {
            return Err(LinalgError::NotPositiveDefinite("no successful factorisation to solve with".into()));
        }
        let n = self.symbolic.nrows();
        if columns == 0 || b.len() != n * columns {
            return Err(LinalgError::BadRhs { len: b.len(), rows: n, columns });
        }
        if n == 0 {
            return Ok(());
        }
        let SymbolicCholeskyRaw::Supernodal(supernodal) = self.symbolic.raw() else {
            return self.solve_simplicial(b, columns);
        };
        let solve = |part: &mut [f64]| match part.len() / n {
            ..=4 => self.pass::<4>(supernodal, part),
            _ => self.pass::<8>(supernodal, part),
        };
        // With halves, each pass runs them on two threads; without, the passes are split over them.
        let threads = crate::threads::threads().min(columns.div_ceil(8));
        if threads > 1 && n * columns >= PARALLEL_SOLVE && self.split.is_none() {
            use rayon::prelude::*;
            b.par_chunks_mut(8 * n).for_each(solve);
        } else {
            b.chunks_mut(8 * n).for_each(solve);
        }
        Ok(())
    }

    /// One pass over the factor for the (at most `W`) columns of `part`: permuted into the factor's
    /// order with their values side by side, solved, and put back.
    fn pass<const W: usize>(&self, supernodal: &SymbolicSupernodalCholesky<usize>, part: &mut [f64]) {
        let n = self.symbolic.nrows();
        let order = self.symbolic.perm().map(|p| p.arrays().0);
        let row = |i: usize| order.map_or(i, |o| o[i]);
        let width = part.len() / n;
        let mut x = vec![Lanes::<W>::default(); n];
        for (i, xi) in x.iter_mut().enumerate() {
            (0..width).for_each(|c| xi.0[c] = part[c * n + row(i)]);
        }
        self.substitute(supernodal, &mut x);
        for (i, xi) in x.iter().enumerate() {
            (0..width).for_each(|c| part[c * n + row(i)] = xi.0[c]);
        }
    }

    /// Solve `L Lᵀ x = y` in place (`y` in the factor's order): with halves, in phases (forward: the
    /// halves, what the top takes from each added to it, the top; backward: the top, then the
    /// halves), the halves at once on two threads or in turn on one, with the same sums either way.
    fn substitute<const W: usize>(&self, supernodal: &SymbolicSupernodalCholesky<usize>, x: &mut [Lanes<W>]) {
        let (n, values) = (x.len(), &self.values[..]);
        let Some(SupernodalSplit { supernodes: [first, second, top], columns: [middle, high] }) = self.split.clone()
        else {
            forward(
                supernodal,
                values,
                Part { supernodes: 0..supernodal.n_supernodes(), base: 0, x, outside: n },
                &mut [],
            );
            let all = Part { supernodes: 0..supernodal.n_supernodes(), base: 0, x, outside: n };
            return backward(supernodal, values, all, &[]);
        };
        // At once on two threads where there are several ([`crate::threads::join`]) and the pass is
        // large enough to be worth the hand-over.
        let both = |a: &mut (dyn FnMut() + Send), b: &mut (dyn FnMut() + Send)| {
            if n * W >= PARALLEL_SOLVE {
                crate::threads::join(a, b);
            } else {
                a();
                b();
            }
        };
        let (low, rest) = x.split_at_mut(middle);
        let (mid, upper) = rest.split_at_mut(high - middle);
        let mut taken = [vec![Lanes::<W>::default(); n - high], vec![Lanes::<W>::default(); n - high]];
        let [taken_low, taken_mid] = &mut taken;
        both(
            &mut || {
                forward(
                    supernodal,
                    values,
                    Part { supernodes: first.clone(), base: 0, x: &mut *low, outside: high },
                    &mut taken_low[..],
                )
            },
            &mut || {
                forward(
                    supernodal,
                    values,
                    Part { supernodes: second.clone(), base: middle, x: &mut *mid, outside: high },
                    &mut taken_mid[..],
                )
            },
        );
        for t in &taken {
            upper.iter_mut().zip(t).for_each(|(u, t)| *u = u.plus(*t));
        }
        forward(supernodal, values, Part { supernodes: top.clone(), base: high, x: upper, outside: n }, &mut []);
        backward(supernodal, values, Part { supernodes: top, base: high, x: upper, outside: n }, &[]);
        let upper = &*upper;
        both(
            &mut || {
                backward(
                    supernodal,
                    values,
                    Part { supernodes: first.clone(), base: 0, x: &mut *low, outside: high },
                    upper,
                )
            },
            &mut || {
                backward(
                    supernodal,
                    values,
                    Part { supernodes: second.clone(), base: middle, x: &mut *mid, outside: high },
                    upper,
                )
            },
        );
    }

    /// [`SparseCholesky::solve_many`] for a factor faer stored column by column (small or very
    /// sparse matrices), by faer's own solve.
    fn solve_simplicial(&self, b: &mut [f64], columns: usize) -> Result<(), LinalgError> {
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

    /// A cubic grid's weighted Laplacian plus a mass, `side³` unknowns, as faer's upper triangle
    /// (diagonally dominant, so positive definite; in three dimensions the factor fills enough for
    /// faer to store it by supernodes).
    fn grid(side: usize) -> faer::sparse::SparseColMat<usize, f64> {
        blocks(side, 1)
    }

    /// `count` unconnected copies of [`grid`] on the diagonal, the unknowns of one after another.
    fn blocks(side: usize, count: usize) -> faer::sparse::SparseColMat<usize, f64> {
        let n = side.pow(3);
        let mut entries = Vec::new();
        for block in 0..count {
            let id = |i: usize, j: usize, k: usize| block * n + (i * side + j) * side + k;
            for (i, j, k) in (0..side).flat_map(|i| (0..side).flat_map(move |j| (0..side).map(move |k| (i, j, k)))) {
                let here = id(i, j, k);
                entries.push(faer::sparse::Triplet::new(here, here, 6.01 + 0.001 * (i + 2 * j + 3 * k) as f64));
                for (step, weight) in [((1, 0, 0), 1.0), ((0, 1, 0), 0.9 + 0.002 * i as f64), ((0, 0, 1), 0.8)] {
                    let (a, b, c) = (i + step.0, j + step.1, k + step.2);
                    if a < side && b < side && c < side {
                        entries.push(faer::sparse::Triplet::new(here, id(a, b, c), -weight));
                    }
                }
            }
        }
        faer::sparse::SparseColMat::try_new_from_triplets(count * n, count * n, &entries).unwrap()
    }

    /// Solve `a` with `chol` for 1 to 9 right sides: as faer does (to round-off), and each column the
    /// same to the bit however the columns are batched.
    fn agrees_with_faer(chol: &SparseCholesky, n: usize) {
        let mut random = crate::linalg::random::Rng(7);
        for columns in [1, 3, 4, 5, 9] {
            let b: Vec<f64> = (0..n * columns).map(|_| random.uniform()).collect();
            let (mut ours, mut faers) = (b.clone(), b.clone());
            chol.solve_many(&mut ours, columns).unwrap();
            chol.solve_simplicial(&mut faers, columns).unwrap();
            let scale = faers.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = ours.iter().zip(&faers).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(worst < 1e-13 * scale, "{columns} columns: {worst:.2e} of {scale:.2e}");
            for c in 0..columns {
                let mut alone = b[c * n..(c + 1) * n].to_vec();
                chol.solve(&mut alone).unwrap();
                assert_eq!(alone, ours[c * n..(c + 1) * n], "{columns} columns: column {c} batched differs");
            }
        }
    }

    #[test]
    fn the_supernodal_solve_agrees_with_faers_for_any_number_of_right_sides() {
        let side: usize = 14;
        let a = grid(side);
        let mut chol = SparseCholesky::new(a.as_ref()).unwrap();
        chol.factor(a.as_ref()).unwrap();
        assert!(matches!(chol.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)), "the test must reach the kernel");
        agrees_with_faer(&chol, side.pow(3));
    }

    #[test]
    fn a_factor_with_two_halves_is_solved_in_phases_as_faer_solves_it() {
        // Dissected once: the planes before the middle one, those after it (from the far end, so that
        // each half's plane next to the middle comes last), then the middle plane (the separator):
        // two halves that never meet, and their top.
        let side: usize = 15;
        let plane = |i: usize| (i * side * side..(i + 1) * side * side).collect::<Vec<_>>();
        let order: Vec<usize> = (0..7).chain((8..side).rev()).chain([7]).flat_map(plane).collect();
        let a = grid(side);
        let mut chol = SparseCholesky::with_order(a.as_ref(), &order).unwrap();
        chol.factor(a.as_ref()).unwrap();
        let split = chol.split.clone().expect("a dissected grid has halves");
        let [low, high] = split.columns;
        let plane_size = side * side;
        assert!((5 * plane_size..=7 * plane_size).contains(&low), "{split:?}");
        assert!((low..side.pow(3) - plane_size).contains(&high), "{split:?}");
        agrees_with_faer(&chol, side.pow(3));
        // The plain natural order has no halves (a chain).
        let plain = SparseCholesky::with_order(a.as_ref(), &(0..side.pow(3)).collect::<Vec<_>>()).unwrap();
        assert_eq!(plain.split, None);
    }

    #[test]
    fn a_factor_of_two_unconnected_blocks_has_them_as_halves_and_no_top() {
        // Two roots: each block's chain is a half, and nothing takes from both.
        let (side, n) = (12, 12usize.pow(3));
        let a = blocks(side, 2);
        let mut chol = SparseCholesky::with_order(a.as_ref(), &(0..2 * n).collect::<Vec<_>>()).unwrap();
        chol.factor(a.as_ref()).unwrap();
        let split = chol.split.clone().expect("two blocks are two halves");
        assert_eq!(split.columns, [n, 2 * n], "{split:?}");
        assert!(split.supernodes[2].is_empty(), "no top: {split:?}");
        agrees_with_faer(&chol, 2 * n);
    }
}
