//! A modal basis: eigenvalues, mode shapes `Φ` and modal rotations `Ψ = WΦ`, laid out per vertex
//! so that one step touches each vertex's data once.

use glam::DVec3;

use super::rotation::RotationOperator;
use crate::mesh::TriMesh;

/// `m` vibration modes of a shell. Shapes are mass-normalised (`Φᵀ M Φ = I`); anchored vertices
/// have zero rows.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalBasis {
    /// Eigenvalues `λ_j = ω_j²`, ascending, 1/s².
    pub eigenvalues: Vec<f64>,
    /// `Φ` as `[(vertex · 3 + axis) · m + mode]`.
    phi: Vec<f64>,
    /// `Ψ = WΦ` in the same layout.
    psi: Vec<f64>,
    modes: usize,
}

impl ModalBasis {
    /// Build from eigenvalues and per-mode vertex displacement shapes; computes `Ψ` with `W` of `mesh`.
    pub fn new(mesh: &TriMesh, eigenvalues: Vec<f64>, shapes: &[Vec<DVec3>]) -> Self {
        let m = eigenvalues.len();
        let n = mesh.vertex_count();
        let w = RotationOperator::new(mesh);
        let mut phi = vec![0.0; n * 3 * m];
        let mut psi = vec![0.0; n * 3 * m];
        for (j, shape) in shapes.iter().enumerate() {
            let rot = w.apply(shape);
            for v in 0..n {
                for a in 0..3 {
                    phi[(v * 3 + a) * m + j] = shape[v][a];
                    psi[(v * 3 + a) * m + j] = rot[v][a];
                }
            }
        }
        Self { eigenvalues, phi, psi, modes: m }
    }

    /// Number of modes `m`.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.phi.len() / (3 * self.modes.max(1))
    }

    /// Natural frequencies `ω_j / 2π`, Hz.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues.iter().map(|l| l.max(0.0).sqrt() / std::f64::consts::TAU).collect()
    }

    /// Row block of `Φ` for vertex `v`: `(Φ_v q)` = linear displacement of `v`.
    pub fn displacement(&self, v: usize, q: &[f64]) -> DVec3 {
        row_times(&self.phi, v, self.modes, q)
    }

    /// Row block of `Ψ` for vertex `v`: `(Ψ_v q)` = rotation vector of `v`.
    pub fn rotation(&self, v: usize, q: &[f64]) -> DVec3 {
        row_times(&self.psi, v, self.modes, q)
    }

    /// Entry `Φ[v, axis, mode]`.
    pub fn phi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.phi[(v * 3 + axis) * self.modes + mode]
    }

    /// Entry `Ψ[v, axis, mode]`.
    pub fn psi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.psi[(v * 3 + axis) * self.modes + mode]
    }

    /// Vertex `v`'s three rows of `Φ` and of `Ψ`, each `3 · m` long (axis-major).
    pub fn rows(&self, v: usize) -> (&[f64], &[f64]) {
        let r = v * 3 * self.modes..(v + 1) * 3 * self.modes;
        (&self.phi[r.clone()], &self.psi[r])
    }

    /// Least-squares coordinates of a displacement field in this basis (`Φᵀ M u` for mass `M`).
    pub fn project(&self, masses: &[f64], u: &[DVec3]) -> Vec<f64> {
        let m = self.modes;
        let mut q = vec![0.0; m];
        for (v, (mv, uv)) in masses.iter().zip(u).enumerate() {
            for a in 0..3 {
                let row = &self.phi[(v * 3 + a) * m..(v * 3 + a + 1) * m];
                q.iter_mut().zip(row).for_each(|(qj, p)| *qj += p * mv * uv[a]);
            }
        }
        q
    }
}

fn row_times(data: &[f64], v: usize, m: usize, q: &[f64]) -> DVec3 {
    let r = |a: usize| data[(v * 3 + a) * m..(v * 3 + a + 1) * m].iter().zip(q).map(|(x, y)| x * y).sum::<f64>();
    DVec3::new(r(0), r(1), r(2))
}
