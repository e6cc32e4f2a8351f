//! Symbolic pattern once, numeric assembly many times.
//!
//! The matrix is `3m × 3m` over the `m` free blocks of a [`DofMap`], stored in full (both triangles)
//! in faer's compressed sparse column format. Each block column `j` holds the sorted row blocks `R_j`;
//! its three scalar columns share that row pattern, so the entry `(3i + r, 3j + c)` of block `(i, j)`
//! sits at `base_j + c · 3|R_j| + 3·pos(i) + r`.
//!
//! The matrix is symmetric, so elements are accumulated only into its upper blocks (`i ≤ j`), in a
//! block-contiguous scratch array (block `(i, j)` column-major at `ubase_j + 9·pos(i)`, where the
//! upper rows `i ≤ j` are the first entries of the sorted `R_j`: one or two cache lines per block, half
//! the matrix's size). A final pass writes every block column in faer's layout, reading a lower block
//! `(i, j)`, `i > j`, as the transpose of `(j, i)`. Elements hand in their lower 3 × 3 blocks
//! (`p ≥ q`, see e.g. a discrete shell's `element_hessians`); each stores, per block, the
//! scratch offset of the upper global block it adds to and whether to add it transposed — computed
//! at construction — so numeric assembly is a sequential walk of 9-value additions with no searching.

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};

use super::{DofMap, LinalgError};
use glam::DMat3;

/// Flag in [`BlockAssembler::sources`] and [`BlockAssembler::slots`]: the block goes transposed.
const TRANSPOSED: u32 = 1 << 31;
/// A slot of a block that touches a removed vertex.
const SKIP: u32 = u32::MAX;

/// A sparse symmetric block matrix with a fixed pattern and per-element value slots.
///
/// Elements must be symmetric (Hessians, mass matrices): they are given by their lower blocks.
#[derive(Debug, Clone)]
pub struct BlockAssembler {
    matrix: SparseColMat<usize, f64>,
    /// Per element, per lower block `(p, q)` in packed order: the scratch offset of the upper global
    /// block it adds to (with [`TRANSPOSED`] if the global block `(i, j)` has `i > j`), or [`SKIP`].
    slots: Vec<u32>,
    /// Per element, its first slot (and one past the last element's).
    element_start: Vec<usize>,
    /// Block-contiguous accumulation buffer of the upper blocks.
    scratch: Vec<f64>,
    /// `(base_j, |R_j|)` of every block column.
    groups: Vec<(usize, usize)>,
    /// Per stored block, in storage order: the scratch offset it is read from — its own for `i ≤ j`,
    /// that of `(j, i)` with [`TRANSPOSED`] set for `i > j`.
    sources: Vec<u32>,
    diagonal: Vec<usize>,
}

impl BlockAssembler {
    /// Build the pattern of `stencils` (the vertex lists of the elements, in element order) restricted
    /// to the free vertices of `dofs`; pairs involving a removed vertex are dropped. Every free vertex
    /// gets its diagonal block even if no element touches it.
    pub fn new<'a>(dofs: &DofMap, stencils: impl IntoIterator<Item = &'a [usize]>) -> Result<Self, LinalgError> {
        let stencils: Vec<&[usize]> = stencils.into_iter().collect();
        let m = dofs.free_count();
        let mut rows: Vec<Vec<u32>> = (0..m).map(|j| vec![j as u32]).collect();
        for s in &stencils {
            for &v in s.iter() {
                if v >= dofs.vertex_count() {
                    return Err(LinalgError::BadStencil { vertex: v, count: dofs.vertex_count() });
                }
            }
            for &vj in s.iter() {
                let Some(j) = dofs.block(vj) else { continue };
                rows[j].extend(s.iter().filter_map(|&vi| dofs.block(vi)).map(|i| i as u32));
            }
        }
        let mut col_ptr = Vec::with_capacity(3 * m + 1);
        let (mut bases, mut upper_bases) = (Vec::with_capacity(m), Vec::with_capacity(m));
        let (mut nnz, mut upper) = (0usize, 0usize);
        col_ptr.push(0);
        for (j, r) in rows.iter_mut().enumerate() {
            r.sort_unstable();
            r.dedup();
            bases.push(nnz);
            upper_bases.push(upper);
            upper += 9 * r.partition_point(|&i| i as usize <= j);
            for _ in 0..3 {
                nnz += 3 * r.len();
                col_ptr.push(nnz);
            }
        }
        if nnz >= TRANSPOSED as usize {
            return Err(LinalgError::TooLarge(nnz));
        }
        let mut row_idx = Vec::with_capacity(nnz);
        for r in &rows {
            for _ in 0..3 {
                row_idx.extend(r.iter().flat_map(|&i| (0..3).map(move |k| 3 * i as usize + k)));
            }
        }
        let position = |i: usize, j: usize| {
            rows[j].binary_search(&(i as u32)).unwrap_or_else(|_| unreachable!("pattern has the pair"))
        };
        // Offset of entry (3i, 3j + c) in faer's layout, and in the block-contiguous scratch.
        let offset = |i: usize, j: usize, c: usize| -> usize { bases[j] + 3 * position(i, j) + c * 3 * rows[j].len() };
        // Offset of entry (3i, 3j + c), i ≤ j, in the scratch.
        let scratch_offset = |i: usize, j: usize, c: usize| -> usize { upper_bases[j] + 9 * position(i, j) + 3 * c };
        let mut slots = Vec::new();
        let mut element_start = Vec::with_capacity(stencils.len() + 1);
        for s in &stencils {
            element_start.push(slots.len());
            for (p, &vp) in s.iter().enumerate() {
                for &vq in &s[..=p] {
                    slots.push(match (dofs.block(vp), dofs.block(vq)) {
                        (Some(i), Some(j)) if i <= j => scratch_offset(i, j, 0) as u32,
                        (Some(i), Some(j)) => scratch_offset(j, i, 0) as u32 | TRANSPOSED,
                        _ => SKIP,
                    });
                }
            }
        }
        element_start.push(slots.len());
        let diagonal = (0..m).flat_map(|j| (0..3).map(move |c| (j, c))).map(|(j, c)| offset(j, j, c) + c).collect();
        let symbolic = SymbolicSparseColMat::new_checked(3 * m, 3 * m, col_ptr, None, row_idx);
        let matrix = SparseColMat::new(symbolic, vec![0.0; nnz]);
        let groups = bases.iter().zip(&rows).map(|(&b, r)| (b, r.len())).collect();
        let sources = rows
            .iter()
            .enumerate()
            .flat_map(|(j, r)| r.iter().map(move |&i| (i as usize, j)))
            .map(
                |(i, j)| {
                    if i <= j { scratch_offset(i, j, 0) as u32 } else { scratch_offset(j, i, 0) as u32 | TRANSPOSED }
                },
            )
            .collect();
        Ok(Self { matrix, slots, element_start, diagonal, scratch: vec![0.0; upper], groups, sources })
    }

    /// Number of rows (= columns).
    pub fn dim(&self) -> usize {
        self.matrix.nrows()
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.matrix.val().len()
    }

    /// Start an assembly: zero the accumulation buffer.
    pub fn begin(&mut self) {
        self.scratch.fill(0.0);
    }

    /// Add an element's Hessian, given by its lower 3 × 3 blocks `(p, q)`, `p ≥ q`, packed row-wise
    /// (`p(p + 1)/2 + q`, for `k` stencil vertices `k(k + 1)/2` of them). Between
    /// [`BlockAssembler::begin`] and [`BlockAssembler::finish`].
    pub fn add_element(&mut self, element: usize, lower: &[DMat3]) -> Result<(), LinalgError> {
        let (Some(&start), Some(&end)) = (self.element_start.get(element), self.element_start.get(element + 1)) else {
            return Err(LinalgError::BadBlock { element, len: lower.len() });
        };
        if lower.len() != end - start {
            return Err(LinalgError::BadBlock { element, len: lower.len() });
        }
        for (&slot, block) in self.slots[start..end].iter().zip(lower) {
            if slot == SKIP {
                continue;
            }
            let off = (slot & !TRANSPOSED) as usize;
            let values = if slot & TRANSPOSED == 0 { *block } else { block.transpose() }.to_cols_array();
            // A fixed-size view, so the nine additions unroll and vectorise.
            if let Some(Ok(dst)) = self.scratch.get_mut(off..off + 9).map(<&mut [f64; 9]>::try_from) {
                for k in 0..9 {
                    dst[k] += values[k];
                }
            }
        }
        Ok(())
    }

    /// End an assembly: move the accumulated blocks into the matrix (overwriting its values), the
    /// lower ones as transposes of the upper.
    pub fn finish(&mut self) {
        let vals = self.matrix.val_mut();
        for &(base, n) in &self.groups {
            let dst = &mut vals[base..base + 9 * n];
            for (k, &source) in self.sources[base / 9..base / 9 + n].iter().enumerate() {
                let from = (source & !TRANSPOSED) as usize;
                let src = &self.scratch[from..from + 9];
                for c in 0..3 {
                    let to = c * 3 * n + 3 * k;
                    if source & TRANSPOSED == 0 {
                        dst[to..to + 3].copy_from_slice(&src[3 * c..3 * c + 3]);
                    } else {
                        dst[to..to + 3].copy_from_slice(&[src[c], src[3 + c], src[6 + c]]);
                    }
                }
            }
        }
    }

    /// Add `d[k]` to the `k`-th diagonal entry (e.g. a lumped mass matrix scaled by `1/h²`).
    pub fn add_diagonal(&mut self, d: &[f64]) {
        let vals = self.matrix.val_mut();
        for (&i, &v) in self.diagonal.iter().zip(d) {
            vals[i] += v;
        }
    }

    /// The diagonal entries of the current values, in DOF order.
    pub fn diagonal(&self) -> Vec<f64> {
        let vals = self.matrix.val();
        self.diagonal.iter().map(|&i| vals[i]).collect()
    }

    /// Add `scale ×` values of another matrix with the same pattern (e.g. a stored rest stiffness).
    pub fn add_scaled(&mut self, values: &[f64], scale: f64) {
        self.matrix.val_mut().iter_mut().zip(values).for_each(|(a, b)| *a += scale * b);
    }

    /// For each free block, the other free blocks it is coupled to (the matrix graph over vertices).
    pub fn block_adjacency(&self) -> Vec<Vec<usize>> {
        let sym = self.matrix.symbolic();
        let (ptr, rows) = (sym.col_ptr(), sym.row_idx());
        (0..self.dim() / 3)
            .map(|b| {
                // The three scalar columns of a block share one row pattern: read the first, one row per block.
                (ptr[3 * b]..ptr[3 * b + 1])
                    .map(|p| rows[p])
                    .filter(|r| r % 3 == 0 && r / 3 != b)
                    .map(|r| r / 3)
                    .collect()
            })
            .collect()
    }

    /// The values (in the pattern's order).
    pub fn values(&self) -> &[f64] {
        self.matrix.val()
    }

    /// The assembled matrix.
    pub fn matrix(&self) -> SparseColMatRef<'_, usize, f64> {
        self.matrix.as_ref()
    }

    /// `out = A V` for the current values, or for `values` in this pattern if given, with the `r`
    /// vectors of `V` interleaved: entry `i` of vector `k` at `v[i r + k]`, and so in `out`. One pass
    /// over the matrix for all of them (`r` separate products would each stream the whole matrix).
    pub fn multiply(&self, values: Option<&[f64]>, v: &[f64], r: usize, out: &mut [f64]) {
        let vals = values.unwrap_or(self.matrix.val());
        let sym = self.matrix.symbolic();
        let (col_ptr, row_idx) = (sym.col_ptr(), sym.row_idx());
        out.fill(0.0);
        if r == 1 {
            // The common single product (one per iteration of a solver), without the slices.
            for (j, &vj) in v.iter().enumerate() {
                for k in col_ptr[j]..col_ptr[j + 1] {
                    out[row_idx[k]] += vals[k] * vj;
                }
            }
            return;
        }
        for (j, vj) in v.chunks_exact(r).enumerate() {
            for k in col_ptr[j]..col_ptr[j + 1] {
                let (a, i) = (vals[k], row_idx[k]);
                out[i * r..(i + 1) * r].iter_mut().zip(vj).for_each(|(o, x)| *o += a * x);
            }
        }
    }

    /// The matrix as a dense row-major array (tests and small problems only).
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let n = self.dim();
        let mut d = vec![vec![0.0; n]; n];
        let sym = self.matrix.symbolic();
        for j in 0..n {
            for k in sym.col_ptr()[j]..sym.col_ptr()[j + 1] {
                let row = &mut d[sym.row_idx()[k]];
                row[j] += self.matrix.val()[k];
            }
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scatters_blocks_into_the_right_entries_and_skips_removed_vertices() {
        // Two "edges" 0-1 and 1-2 on three vertices; vertex 2 removed.
        let dofs = DofMap::without(&[false, false, true]);
        let mut a = BlockAssembler::new(&dofs, [&[0usize, 1][..], &[1, 2][..]]).unwrap();
        assert_eq!(a.dim(), 6);
        assert_eq!(a.nnz(), 36);
        // A symmetric element block (entry (i, j) = ij + i + j, plus 7 on the diagonal).
        let block: Vec<f64> =
            (0..36).map(|t| ((t % 6) * (t / 6) + t % 6 + t / 6) as f64 + if t % 7 == 0 { 7.0 } else { 0.0 }).collect();
        // Its lower blocks (0, 0), (1, 0), (1, 1), column-major.
        let lower: Vec<DMat3> = [(0, 0), (1, 0), (1, 1)]
            .iter()
            .map(|&(p, q)| DMat3::from_cols_array(&std::array::from_fn(|t| block[(3 * q + t / 3) * 6 + 3 * p + t % 3])))
            .collect();
        a.begin();
        a.add_element(0, &lower).unwrap();
        a.add_element(1, &lower).unwrap();
        a.finish();
        let d = a.to_dense();
        assert!((0..6).all(|i| (0..6).all(|j| d[i][j] == d[j][i])), "exactly symmetric");
        for i in 0..6 {
            for j in 0..6 {
                // Element 1 maps its vertex 1 (local 0) to block 1 and drops local vertex 1.
                // Blocks are column-major: entry (i, j) is block[j * 6 + i].
                let extra = if i >= 3 && j >= 3 { block[(j - 3) * 6 + (i - 3)] } else { 0.0 };
                assert_eq!(d[i][j], block[j * 6 + i] + extra, "entry ({i}, {j})");
            }
        }
        let before = a.diagonal();
        assert!((0..6).all(|i| before[i] == d[i][i]), "diagonal() reads the diagonal");
        a.add_diagonal(&[1.0; 6]);
        assert!(a.diagonal().iter().zip(&before).all(|(d, b)| *d == b + 1.0));
        assert_eq!(a.to_dense()[4][4], block[4 * 6 + 4] + block[7] + 1.0);
        assert_eq!(a.to_dense()[3][4], block[4 * 6 + 3] + block[6]);
        assert!(a.add_element(0, &lower[..2]).is_err());
        assert!(a.add_element(5, &lower).is_err());
        assert!(BlockAssembler::new(&dofs, [&[0usize, 7][..]]).is_err());
        let v = [1.0, 0.0, 0.0, 0.0, 0.0, 2.0];
        let mut out = [0.0; 6];
        a.multiply(None, &v, 1, &mut out);
        let dense = a.to_dense();
        for i in 0..6 {
            assert_eq!(out[i], dense[i][0] + 2.0 * dense[i][5]);
        }
        // Three vectors interleaved: each column of the product is the single product of its own.
        let columns = [v, [0.5, -1.0, 3.0, 0.0, 2.5, -4.0], [0.0, 0.0, 1.0, 1.0, 0.0, 0.0]];
        let interleaved: Vec<f64> = (0..6).flat_map(|i| columns.map(|c| c[i])).collect();
        let mut both = vec![f64::NAN; 18];
        a.multiply(None, &interleaved, 3, &mut both);
        for (k, c) in columns.iter().enumerate() {
            a.multiply(None, c, 1, &mut out);
            assert!((0..6).all(|i| (both[3 * i + k] - out[i]).abs() <= 1e-12 * out[i].abs()), "vector {k}");
        }
    }
}
