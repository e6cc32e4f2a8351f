//! Degrees of freedom: which vertices are free (anchored ones are removed), and gathering/scattering
//! between per-vertex vectors and reduced `3 × free` vectors.

use glam::DVec3;

/// Map from vertices to free-vertex blocks. Free vertex `f` owns reduced DOFs `3f, 3f + 1, 3f + 2`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DofMap {
    block_of: Vec<Option<usize>>,
    free: Vec<usize>,
}

impl DofMap {
    /// Every vertex free.
    pub fn all(vertex_count: usize) -> Self {
        Self { block_of: (0..vertex_count).map(Some).collect(), free: (0..vertex_count).collect() }
    }

    /// Vertices with `fixed[v]` removed.
    pub fn without(fixed: &[bool]) -> Self {
        let mut block_of = vec![None; fixed.len()];
        let mut free = Vec::with_capacity(fixed.len());
        for (v, &f) in fixed.iter().enumerate() {
            if !f {
                block_of[v] = Some(free.len());
                free.push(v);
            }
        }
        Self { block_of, free }
    }

    /// Number of vertices of the full mesh.
    pub fn vertex_count(&self) -> usize {
        self.block_of.len()
    }

    /// Number of free vertices.
    pub fn free_count(&self) -> usize {
        self.free.len()
    }

    /// Number of reduced DOFs (`3 × free`).
    pub fn dofs(&self) -> usize {
        3 * self.free.len()
    }

    /// The free block of vertex `v`, if it is free (and exists).
    pub fn block(&self, v: usize) -> Option<usize> {
        self.block_of.get(v).copied().flatten()
    }

    /// The free vertices in block order.
    pub fn free_vertices(&self) -> &[usize] {
        &self.free
    }

    /// Copy the free vertices' vectors of `full` into the reduced vector `out` (length [`DofMap::dofs`]).
    pub fn gather(&self, full: &[DVec3], out: &mut [f64]) {
        for (f, &v) in self.free.iter().enumerate() {
            out[3 * f..3 * f + 3].copy_from_slice(&full[v].to_array());
        }
    }

    /// Add `scale ×` the reduced vector to the free vertices' entries of `full`.
    pub fn scatter_add(&self, reduced: &[f64], scale: f64, full: &mut [DVec3]) {
        for (f, &v) in self.free.iter().enumerate() {
            full[v] += DVec3::from_slice(&reduced[3 * f..3 * f + 3]) * scale;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn removes_fixed_vertices_and_round_trips() {
        let m = DofMap::without(&[false, true, false, true]);
        assert_eq!(m.free_vertices(), &[0, 2]);
        assert_eq!((m.block(0), m.block(1), m.block(2), m.block(9)), (Some(0), None, Some(1), None));
        let full = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        let mut r = vec![0.0; m.dofs()];
        m.gather(&full, &mut r);
        assert_eq!(r, vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let mut back = [DVec3::ZERO; 4];
        m.scatter_add(&r, 2.0, &mut back);
        assert_eq!(back, [DVec3::X * 2.0, DVec3::ZERO, DVec3::Z * 2.0, DVec3::ZERO]);
        assert_eq!(DofMap::all(3).dofs(), 9);
    }
}
