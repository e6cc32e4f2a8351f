//! A modal basis: eigenvalues, mode shapes `Φ` and modal rotations `Ψ = WΦ`.
//!
//! Stored for the per-step pass ([`super::kernel`]): vertices in chunks of [`LANES`], and within a
//! chunk mode by mode and axis by axis, each row `LANES` values wide (`[chunk][mode][axis][lane]`). A
//! step streams once through both arrays, a chunk at a time, with the lanes in SIMD registers. The
//! last chunk is padded with zero rows.
//!
//! The pass streams a copy of both arrays rounded to single precision ([`ModalBasis::chunk`]), and
//! computes in double. On a large shell it is bound by the bytes it reads, `6 m` values a vertex, and
//! half the bytes take it from 2.2–2.5 ms to 1.3 ms a step at 100,002 vertices and 16 modes on two
//! threads (BENCHMARKS.md). The rounding moves a displacement by at most `2⁻²⁴ Σ_j |Φ_ij q_j|`
//! (6e-8 relative), far below any reduced model's own error; every other use of the basis (drags,
//! rotations, projections, the reconstruction of `mwts-rs` and `rds`) reads the double-precision
//! values.

use glam::DVec3;

use super::rotation::RotationOperator;
use crate::mesh::TriMesh;

/// Vertices per chunk: the SIMD width of the per-step pass (two AVX2 registers of `f64`).
pub const LANES: usize = 8;

/// One chunk's three axes of one mode (or of one vector), `LANES` vertices each.
pub type Rows = [[f64; LANES]; 3];

/// [`Rows`] rounded to single precision, as the per-step pass streams them.
pub type SingleRows = [[f32; LANES]; 3];

/// `m` vibration modes of a shell. Shapes are mass-normalised (`Φᵀ M Φ = I`); anchored vertices
/// have zero rows.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalBasis {
    /// Eigenvalues `λ_j = ω_j²`, ascending, 1/s².
    pub eigenvalues: Vec<f64>,
    /// `Φ` as `[chunk][mode][axis][lane]`.
    phi: Vec<Rows>,
    /// `Ψ = WΦ` in the same layout.
    psi: Vec<Rows>,
    /// `Φ` and `Ψ` rounded to single precision, for the per-step pass.
    single_phi: Vec<SingleRows>,
    single_psi: Vec<SingleRows>,
    modes: usize,
    vertices: usize,
}

/// Index of `(vertex, mode)` in the chunked layout of `modes` modes.
fn index(modes: usize, v: usize, mode: usize) -> usize {
    v / LANES * modes + mode
}

/// Number of chunks of `LANES` vertices that hold `n` vertices.
pub fn chunks(n: usize) -> usize {
    n.div_ceil(LANES)
}

impl ModalBasis {
    /// Build from eigenvalues and per-mode vertex displacement shapes; computes `Ψ` with `W` of `mesh`.
    pub fn new(mesh: &TriMesh, eigenvalues: Vec<f64>, shapes: &[Vec<DVec3>]) -> Self {
        let m = eigenvalues.len();
        let n = mesh.vertex_count();
        let w = RotationOperator::new(mesh);
        let len = chunks(n) * m;
        let (mut phi, mut psi) = (vec![[[0.0; LANES]; 3]; len], vec![[[0.0; LANES]; 3]; len]);
        for (j, shape) in shapes.iter().enumerate() {
            let rot = w.apply(shape);
            for v in 0..n {
                for a in 0..3 {
                    phi[index(m, v, j)][a][v % LANES] = shape[v][a];
                    psi[index(m, v, j)][a][v % LANES] = rot[v][a];
                }
            }
        }
        let single =
            |rows: &[Rows]| -> Vec<SingleRows> { rows.iter().map(|r| r.map(|a| a.map(|x| x as f32))).collect() };
        let (single_phi, single_psi) = (single(&phi), single(&psi));
        Self { eigenvalues, phi, psi, single_phi, single_psi, modes: m, vertices: n }
    }

    /// Number of modes `m`.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices
    }

    /// Natural frequencies `ω_j / 2π`, Hz.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues.iter().map(|l| l.max(0.0).sqrt() / std::f64::consts::TAU).collect()
    }

    /// Linear displacement of vertex `v`, `Φ_v q`.
    pub fn displacement(&self, v: usize, q: &[f64]) -> DVec3 {
        self.vertex_times(&self.phi, v, q)
    }

    /// Rotation vector of vertex `v`, `Ψ_v q`.
    pub fn rotation(&self, v: usize, q: &[f64]) -> DVec3 {
        self.vertex_times(&self.psi, v, q)
    }

    /// Entry `Φ[v, axis, mode]`.
    pub fn phi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.phi[index(self.modes, v, mode)][axis][v % LANES]
    }

    /// Entry `Ψ[v, axis, mode]`.
    pub fn psi(&self, v: usize, axis: usize, mode: usize) -> f64 {
        self.psi[index(self.modes, v, mode)][axis][v % LANES]
    }

    /// Chunk `c` of `Φ` and of `Ψ` in single precision: one [`SingleRows`] per mode.
    pub fn chunk(&self, c: usize) -> (&[SingleRows], &[SingleRows]) {
        let m = self.modes;
        (&self.single_phi[c * m..(c + 1) * m], &self.single_psi[c * m..(c + 1) * m])
    }

    /// Entries `Φ[v, axis, mode]` and `Ψ[v, axis, mode]` as the per-step pass reads them.
    #[cfg(test)]
    pub(super) fn single(&self, v: usize, axis: usize, mode: usize) -> (f64, f64) {
        let (k, i) = (index(self.modes, v, mode), v % LANES);
        (f64::from(self.single_phi[k][axis][i]), f64::from(self.single_psi[k][axis][i]))
    }

    /// Mode `j`'s displacement of every vertex.
    pub fn shape(&self, j: usize) -> Vec<DVec3> {
        (0..self.vertices).map(|v| DVec3::new(self.phi(v, 0, j), self.phi(v, 1, j), self.phi(v, 2, j))).collect()
    }

    /// Least-squares coordinates of a displacement field in this basis (`Φᵀ M u` for mass `M`).
    pub fn project(&self, masses: &[f64], u: &[DVec3]) -> Vec<f64> {
        (0..self.modes)
            .map(|j| {
                let phi = |v: usize| DVec3::new(self.phi(v, 0, j), self.phi(v, 1, j), self.phi(v, 2, j));
                u.iter().zip(masses).enumerate().map(|(v, (uv, mv))| mv * uv.dot(phi(v))).sum()
            })
            .collect()
    }

    fn vertex_times(&self, data: &[Rows], v: usize, q: &[f64]) -> DVec3 {
        let k = v % LANES;
        let at = |j: usize| data[index(self.modes, v, j)].map(|row| row[k]);
        q.iter().enumerate().fold(DVec3::ZERO, |acc, (j, qj)| acc + DVec3::from_array(at(j)) * *qj)
    }
}
