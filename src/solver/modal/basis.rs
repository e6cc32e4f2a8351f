//! A modal basis: eigenvalues, mode shapes `Φ` and modal rotations `Ψ = WΦ`, stored mode by mode
//! (each column a contiguous `3n` array) so that `Φq`, `Ψq` and `Φᵀf` are vectorised AXPYs and dot
//! products over long arrays.

use glam::DVec3;

use super::rotation::RotationOperator;
use crate::mesh::TriMesh;

/// `m` vibration modes of a shell. Shapes are mass-normalised (`Φᵀ M Φ = I`); anchored vertices
/// have zero rows.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalBasis {
    /// Eigenvalues `λ_j = ω_j²`, ascending, 1/s².
    pub eigenvalues: Vec<f64>,
    /// `Φ` as `[mode · 3n + vertex · 3 + axis]`.
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
                    phi[j * 3 * n + 3 * v + a] = shape[v][a];
                    psi[j * 3 * n + 3 * v + a] = rot[v][a];
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

    /// Linear displacement of vertex `v`, `Φ_v q`.
    pub fn displacement(&self, v: usize, q: &[f64]) -> DVec3 {
        vertex_times(&self.phi, self.vertex_count(), v, q)
    }

    /// Rotation vector of vertex `v`, `Ψ_v q`.
    pub fn rotation(&self, v: usize, q: &[f64]) -> DVec3 {
        vertex_times(&self.psi, self.vertex_count(), v, q)
    }

    /// Entry `Φ[v, axis, mode]`.
    pub fn phi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.phi[mode * 3 * self.vertex_count() + 3 * v + axis]
    }

    /// Entry `Ψ[v, axis, mode]`.
    pub fn psi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.psi[mode * 3 * self.vertex_count() + 3 * v + axis]
    }

    /// Column `mode` of `Φ` (`3n` values, vertex-major).
    pub fn phi_column(&self, mode: usize) -> &[f64] {
        let n3 = 3 * self.vertex_count();
        &self.phi[mode * n3..(mode + 1) * n3]
    }

    /// `Φ q` into `out` (`3n` values).
    pub fn combine_phi(&self, q: &[f64], out: &mut [f64]) {
        combine(&self.phi, q, out);
    }

    /// `Ψ q` into `out` (`3n` values).
    pub fn combine_psi(&self, q: &[f64], out: &mut [f64]) {
        combine(&self.psi, q, out);
    }

    /// Least-squares coordinates of a displacement field in this basis (`Φᵀ M u` for mass `M`).
    pub fn project(&self, masses: &[f64], u: &[DVec3]) -> Vec<f64> {
        (0..self.modes)
            .map(|j| {
                let col = self.phi_column(j);
                u.iter()
                    .zip(masses)
                    .enumerate()
                    .map(|(v, (uv, mv))| mv * uv.dot(DVec3::from_slice(&col[3 * v..])))
                    .sum()
            })
            .collect()
    }
}

fn vertex_times(data: &[f64], n: usize, v: usize, q: &[f64]) -> DVec3 {
    q.iter().enumerate().fold(DVec3::ZERO, |acc, (j, qj)| acc + DVec3::from_slice(&data[j * 3 * n + 3 * v..]) * *qj)
}

/// `Σ_j q_j · column_j` of a column-major matrix with `out.len()` rows.
fn combine(data: &[f64], q: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (col, &qj) in data.chunks_exact(out.len()).zip(q) {
        out.iter_mut().zip(col).for_each(|(o, c)| *o += qj * c);
    }
}
