//! Linearised rotations of a shell: the rotation vector that best explains a small displacement of
//! each triangle, and the per-vertex average of those (the operator `W` of `w = W u`).
//!
//! For a triangle with rest centroid `c̄` and `r_k = X_k − c̄`, the least-squares rotation `w_t`
//! minimising `Σ_k |w × r_k − (u_k − ū)|²` solves `A_t w_t = Σ_k r_k × u_k` with
//! `A_t = Σ_k (|r_k|² I − r_k r_kᵀ)` (`Σ_k r_k = 0` removes `ū`). It is exact for rigid motions,
//! including the out-of-plane tilt that the tetrahedral ½-curl would halve.

use glam::{DMat3, DVec3};

use crate::mesh::TriMesh;

/// `[r]×`, the matrix of `v ↦ r × v`.
pub fn cross_matrix(r: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, r.z, -r.y), DVec3::new(-r.z, 0.0, r.x), DVec3::new(r.y, -r.x, 0.0))
}

/// The three 3×3 blocks `J_k = A⁻¹ [r_k]×` of a triangle's rotation Jacobian `w_t = Σ_k J_k u_k`.
pub fn triangle_jacobian(x: [DVec3; 3]) -> [DMat3; 3] {
    let c = (x[0] + x[1] + x[2]) / 3.0;
    let r = x.map(|p| p - c);
    let a = r.iter().fold(DMat3::ZERO, |a, rk| {
        a + DMat3::from_diagonal(DVec3::splat(rk.length_squared())) - DMat3::from_cols(rk * rk.x, rk * rk.y, rk * rk.z)
    });
    let inv = a.inverse();
    r.map(|rk| inv * cross_matrix(rk))
}

/// The linear map from vertex displacements to vertex rotation vectors (`w = W u`): each vertex takes
/// the area-weighted mean of its triangles' least-squares rotations. Constant: built once at rest.
#[derive(Debug, Clone)]
pub struct RotationOperator {
    /// Per triangle: its vertices and Jacobian blocks.
    blocks: Vec<([usize; 3], [DMat3; 3])>,
    /// Per triangle: its weight in each of its vertices' averages (area / vertex's total area).
    weights: Vec<[f64; 3]>,
    vertex_count: usize,
}

impl RotationOperator {
    /// Precompute the Jacobians and weights at the mesh's rest shape.
    pub fn new(mesh: &TriMesh) -> Self {
        let x = mesh.positions();
        let areas = mesh.triangle_areas();
        let mut total = vec![0.0; mesh.vertex_count()];
        for (t, a) in mesh.triangles().iter().zip(&areas) {
            t.iter().for_each(|&i| total[i] += a);
        }
        let blocks = mesh.triangles().iter().map(|t| (*t, triangle_jacobian(t.map(|i| x[i])))).collect();
        let weights = mesh.triangles().iter().zip(&areas).map(|(t, a)| t.map(|i| a / total[i])).collect();
        Self { blocks, weights, vertex_count: mesh.vertex_count() }
    }

    /// Vertex rotation vectors `w = W u` of a displacement field `u`.
    pub fn apply(&self, u: &[DVec3]) -> Vec<DVec3> {
        let mut w = vec![DVec3::ZERO; self.vertex_count];
        for ((t, j), wt) in self.blocks.iter().zip(&self.weights) {
            let rot = j[0] * u[t[0]] + j[1] * u[t[1]] + j[2] * u[t[2]];
            for k in 0..3 {
                w[t[k]] += wt[k] * rot;
            }
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;

    #[test]
    fn cross_matrix_is_the_cross_product() {
        let (a, b) = (DVec3::new(0.3, -1.2, 2.0), DVec3::new(-0.7, 0.4, 1.1));
        assert!((cross_matrix(a) * b - a.cross(b)).length() < 1e-15);
    }

    #[test]
    fn single_triangle_returns_its_small_rigid_rotation() {
        let x = [DVec3::new(0.1, 0.2, -0.3), DVec3::new(1.3, 0.1, 0.2), DVec3::new(0.4, 0.9, 0.5)];
        let j = triangle_jacobian(x);
        for w in [DVec3::new(1e-3, 0.0, 0.0), DVec3::new(0.0, 0.0, 2e-3), DVec3::new(-1e-3, 4e-4, 7e-4)] {
            let t = DVec3::new(0.5, -0.2, 0.1);
            // Linearised rigid motion: u = w × X + t (exactly linear, so the answer is exact).
            let u = x.map(|p| w.cross(p) + t);
            let got = j[0] * u[0] + j[1] * u[1] + j[2] * u[2];
            // Round-off relative to the displacement (dominated by the translation), not to w.
            assert!((got - w).length() < 1e-14, "{got} vs {w}");
        }
        // Out-of-plane tilt of a flat triangle: the full tilt, not half of it.
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Z];
        let j = triangle_jacobian(flat);
        let w = DVec3::new(0.0, 0.0, 1e-3);
        let u = flat.map(|p| w.cross(p));
        assert!(((j[0] * u[0] + j[1] * u[1] + j[2] * u[2]) - w).length() < 1e-16);
    }

    #[test]
    fn whole_mesh_rotation_is_recovered_at_every_vertex() {
        let mesh = grid([1.0, 0.4], [6, 3]).unwrap();
        let op = RotationOperator::new(&mesh);
        let w = DVec3::new(2e-3, -1e-3, 5e-4);
        let u: Vec<DVec3> = mesh.positions().iter().map(|&p| w.cross(p) + DVec3::Y).collect();
        for wi in op.apply(&u) {
            assert!((wi - w).length() < 1e-13, "{wi}");
        }
    }
}
