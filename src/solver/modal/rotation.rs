//! Linearised rotations of a shell: the infinitesimal rotation of each triangle's (linear)
//! displacement field, and the per-vertex average of those (the operator `W` of `w = W u`).
//!
//! A triangle with unit normal `n` and barycentric gradients `g_k` (in its plane) carries the linear
//! field `u(x) = Σ_k N_k(x) u_k`. Its rotation has two parts: the tilt of the normal,
//! `w_tilt = −n × ∇(n·u) = −[n]× Σ_k g_k (n·u_k)`, and the spin about the normal, half the surface
//! curl, `w_spin = ½ n (n · Σ_k g_k × u_k)`. So `w_t = Σ_k J_k u_k` with
//! `J_k = ½ n nᵀ [g_k]× − [n]× g_k nᵀ` (the spec's normal-based form). It is exact for rigid motions,
//! including the out-of-plane tilt that the tetrahedral ½-curl would halve, and — unlike the
//! least-squares fit `min_w Σ_k |w × r_k − (u_k − ū)|²`, also exact for rigid motions — it reads no
//! rotation into a pure strain: stretching a V-beam by 1e-3 along its axis gives the least-squares fit
//! a spurious rotation of 2.3e-4 at some vertices, and this form exactly zero. (On the flat beam and
//! the V-beam under gravity both give the same MWTS results to four digits.)

use glam::{DMat3, DVec3};

use crate::energy::hinge::{cross_matrix, outer};
use crate::mesh::TriMesh;

/// The three 3×3 blocks `J_k = ½ n nᵀ [g_k]× − [n]× g_k nᵀ` of a triangle's rotation Jacobian
/// `w_t = Σ_k J_k u_k` (see the module documentation). The triangle must not be degenerate (meshes
/// reject those at load time).
pub fn triangle_jacobian(x: [DVec3; 3]) -> [DMat3; 3] {
    let (unit, gradients) = barycentric_gradients(x);
    gradients.map(|g| outer(unit, unit) * cross_matrix(g) * 0.5 - cross_matrix(unit) * outer(g, unit))
}

/// A triangle's unit normal and the gradients `g_k` (in its plane) of its three barycentric
/// coordinates: a linear field `u(x) = Σ_k N_k(x) u_k` has the gradient `Σ_k u_k g_kᵀ`. The triangle
/// must not be degenerate.
pub fn barycentric_gradients(x: [DVec3; 3]) -> (DVec3, [DVec3; 3]) {
    let n = (x[1] - x[0]).cross(x[2] - x[0]);
    let twice_area_sq = n.length_squared();
    // Barycentric gradient of vertex k: n × (edge opposite k, oriented k+1 → k+2) / |n|².
    let gradient = |k: usize| n.cross(x[(k + 2) % 3] - x[(k + 1) % 3]) / twice_area_sq;
    (n / twice_area_sq.sqrt(), [0, 1, 2].map(gradient))
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
    use crate::mesh::generate::{grid, icosphere, v_beam};

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
        // Flat, creased (a 60° V: triangles of two planes meet at the crease vertices) and closed.
        let meshes = [
            ("flat grid", grid([1.0, 0.4], [6, 3]).unwrap()),
            ("V-beam", v_beam(1.0, 0.3, 60.0, [8, 4]).unwrap()),
            ("sphere", icosphere(0.5, 3).unwrap()),
        ];
        for (name, mesh) in meshes {
            let op = RotationOperator::new(&mesh);
            for w in [DVec3::new(2e-3, -1e-3, 5e-4), DVec3::new(0.0, 0.0, 1e-3), DVec3::new(-1e-3, 3e-3, 0.0)] {
                let u: Vec<DVec3> = mesh.positions().iter().map(|&p| w.cross(p) + DVec3::Y).collect();
                let worst = op.apply(&u).iter().map(|wi| (*wi - w).length()).fold(0.0, f64::max);
                eprintln!("{name}, w = {w}: worst vertex error {worst:.1e}");
                assert!(worst < 1e-13, "{name}: {worst}");
            }
        }
    }

    #[test]
    fn a_pure_stretch_has_no_rotation_and_a_bend_rotates_each_section_by_its_slope() {
        let mesh = v_beam(1.0, 0.3, 60.0, [20, 4]).unwrap();
        let op = RotationOperator::new(&mesh);
        // Stretching along the axis is a strain, not a rotation.
        let stretch: Vec<DVec3> = mesh.positions().iter().map(|p| DVec3::X * 1e-3 * p.x).collect();
        let spurious = op.apply(&stretch).iter().map(|w| w.length()).fold(0.0, f64::max);
        eprintln!("stretch 1e-3: largest rotation {spurious:.1e}");
        assert!(spurious < 1e-18, "{spurious}");
        // Beam bending, plane sections rotating: u = (−(y − ȳ) κx, κx²/2, 0) rotates the section at x by
        // κx about z (plus an axial strain −(y − ȳ)κ, which must not count). Each triangle sees the
        // slope at its centroid, so a vertex gets the mean over its ring: exact inside, half a cell off
        // at the two end rows.
        let (kappa, y_mean) = (1e-3, mesh.positions().iter().map(|p| p.y).sum::<f64>() / mesh.vertex_count() as f64);
        let bend: Vec<DVec3> = mesh
            .positions()
            .iter()
            .map(|p| DVec3::new(-(p.y - y_mean) * kappa * p.x, 0.5 * kappa * p.x * p.x, 0.0))
            .collect();
        let h = 1.0 / 20.0;
        for (p, w) in mesh.positions().iter().zip(op.apply(&bend)) {
            let end = (p.x.abs() - 0.5).abs() < 1e-9;
            let tol = if end { 0.5 * kappa * h } else { 1e-15 };
            assert!((w - DVec3::Z * kappa * p.x).length() <= tol, "x = {}: {w} vs {}", p.x, kappa * p.x);
        }
    }
}
