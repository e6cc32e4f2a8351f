//! The per-triangle pass of `mwts-rs` ([`super::rotation_strain`]): from the modal coordinates `q`,
//! each triangle's rotation `ω_t = W_t q` and in-plane strain `ε_t = E_t q`, the right side of the
//! reconstruction and the generalised forces through the adjoint.
//!
//! Per triangle, at rest: an orthonormal frame `(t₁, t₂)` of its plane and, for each corner `k`, the
//! in-plane vector `p_k = A_t (2X_k − X_{k−1} − X_{k+1})` in that frame, `s_k = (t₁·p_k, t₂·p_k)`.
//! Summing the three edges' terms of `b` per corner, the triangle adds `(M_t − I) p_k` to corner `k`
//! with `M_t = R_t (I + ε_t)`, `R_t = exp([ω_t]×)`. With `σ_k = (I + ε) s_k` (2×2 strain in the frame)
//! and `r_a = R t_a`: `M p_k = r₁ σ_k1 + r₂ σ_k2`, evaluated as `(r₁ − t₁) σ_k1 + (r₂ − t₂) σ_k2 +
//! t₁ (εs_k)₁ + t₂ (εs_k)₂` so that `q = 0` adds exactly zero.
//!
//! **Adjoint.** For `y = L⁻¹ f` ([`super::laplacian`]) the work `yᵀb` is `Σ_t s_t` with
//! `s_t = Σ_k y_k · M p_k = r₁·A₁ + r₂·A₂`, `A₁ = (1 + ε₁₁) Y₁ + ε₁₂ Y₂`, `A₂ = ε₁₂ Y₁ + (1 + ε₂₂) Y₂`,
//! where `Y_a = Σ_k s_ka y_k` are the triangle's load moments (constant while the loads are). So
//! `∂s/∂ε₁₁ = r₁·Y₁`, `∂s/∂ε₂₂ = r₂·Y₂`, `∂s/∂ε₁₂ = r₁·Y₂ + r₂·Y₁`, and since
//! `d exp([ω]×) = [J_l(ω) dω]× exp([ω]×)` with the left Jacobian `J_l(ω) = ∫₀¹ exp(s[ω]×) ds` (the
//! warp operator of [`super::warp`]), `∂s/∂ω = J_lᵀ (r₁ × A₁ + r₂ × A₂)`. The generalised force is
//! `Σ_t W_tᵀ ∂s/∂ω + E_tᵀ ∂s/∂ε`. A position drag's Jacobian rows are the same with
//! `f = e_i ⊗ e_a`, whose load moments are `Y_a = z_a e_a` for the scalar field `z = L⁻¹ e_i`.

use glam::DVec3;

use super::basis::ModalBasis;
use super::laplacian::NONE;
use super::rotation::{barycentric_gradients, triangle_jacobian};
use super::warp::{coefficients, warp};

/// A triangle's load moments `[Y₁, Y₂]` (module documentation).
pub type Moments = [DVec3; 2];

/// A triangle at rest.
#[derive(Debug, Clone, PartialEq)]
struct Rest {
    vertices: [usize; 3],
    /// Each corner's unknown in the reconstruction's system, or [`NONE`].
    unknowns: [u32; 3],
    /// `t₁, t₂`.
    frame: [DVec3; 2],
    /// `s_k` per corner.
    s: [[f64; 2]; 3],
}

/// The per-triangle rest data and modal rows of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct TrianglePass {
    rest: Vec<Rest>,
    modes: usize,
    /// Per triangle, `6m` values: the rows of `W_t` (x, y, z) then of `E_t` (ε₁₁, ε₂₂, ε₁₂), each
    /// `m` long.
    rows: Vec<f64>,
}

/// The Jacobian rows of one vertex's position, and the load moments that give them.
#[derive(Debug, Clone, PartialEq)]
pub struct DragRows {
    /// The vertex.
    pub vertex: usize,
    /// Per triangle: `(Σ_k s_k1 z_k, Σ_k s_k2 z_k)` for `z = L⁻¹ e_vertex`.
    moments: Vec<[f64; 2]>,
    /// `∂x_vertex/∂q` without the gauge's centroid term: 3 rows (x, y, z) of `m`.
    pub rows: Vec<f64>,
}

/// What a triangle's rotation and strain do at the current `q`.
struct Kinematics {
    omega: DVec3,
    /// `[sinθ/θ, (1 − cosθ)/θ², (θ − sinθ)/θ³]` of `|ω|`.
    coefficients: [f64; 3],
    /// `(ε₁₁, ε₂₂, ε₁₂)`.
    strain: [f64; 3],
    /// `R t_a − t_a`.
    turned: [DVec3; 2],
}

impl Kinematics {
    fn new(rows: &[f64], q: &[f64], frame: &[DVec3; 2]) -> Self {
        let m = q.len();
        let dot = |r: usize| rows[r * m..(r + 1) * m].iter().zip(q).map(|(a, b)| a * b).sum::<f64>();
        let omega = DVec3::new(dot(0), dot(1), dot(2));
        let coefficients = coefficients(omega.length_squared());
        let [a, b, _] = coefficients;
        let turned = frame.map(|t| {
            let wt = omega.cross(t);
            wt * a + omega.cross(wt) * b
        });
        Self { omega, coefficients, strain: [dot(3), dot(4), dot(5)], turned }
    }

    /// `(M − I) p` for a corner with in-plane coordinates `s`.
    fn target_change(&self, frame: &[DVec3; 2], s: [f64; 2]) -> DVec3 {
        let [e11, e22, e12] = self.strain;
        let es = [e11 * s[0] + e12 * s[1], e12 * s[0] + e22 * s[1]];
        let sigma = [s[0] + es[0], s[1] + es[1]];
        self.turned[0] * sigma[0] + self.turned[1] * sigma[1] + frame[0] * es[0] + frame[1] * es[1]
    }

    /// `(∂s/∂ω, ∂s/∂ε)` for load moments `y`.
    fn adjoint(&self, frame: &[DVec3; 2], y: Moments) -> (DVec3, [f64; 3]) {
        let [e11, e22, e12] = self.strain;
        let (r1, r2) = (frame[0] + self.turned[0], frame[1] + self.turned[1]);
        let a1 = y[0] * (1.0 + e11) + y[1] * e12;
        let a2 = y[0] * e12 + y[1] * (1.0 + e22);
        let d_omega = warp(-self.omega, self.coefficients, r1.cross(a1) + r2.cross(a2));
        (d_omega, [r1.dot(y[0]), r2.dot(y[1]), r1.dot(y[1]) + r2.dot(y[0])])
    }
}

/// `out += W_tᵀ d_omega + E_tᵀ d_strain` for one triangle's `rows`.
fn add_transposed(rows: &[f64], (d_omega, d_strain): (DVec3, [f64; 3]), out: &mut [f64]) {
    let m = out.len();
    let d = [d_omega.x, d_omega.y, d_omega.z, d_strain[0], d_strain[1], d_strain[2]];
    for (row, dr) in rows.chunks_exact(m).zip(d) {
        out.iter_mut().zip(row).for_each(|(o, r)| *o += r * dr);
    }
}

impl TrianglePass {
    /// The triangles of `mesh` that have a free corner (`unknowns` from the reconstruction's system;
    /// the others never move), with the modal rows of `basis`.
    pub fn new(rest_positions: &[DVec3], triangles: &[[usize; 3]], unknowns: &[u32], basis: &ModalBasis) -> Self {
        let x = rest_positions;
        let rest = triangles
            .iter()
            .filter(|t| t.iter().any(|&v| unknowns[v] != NONE))
            .map(|&t| {
                let [a, b, c] = t.map(|v| x[v]);
                let normal = (b - a).cross(c - a);
                let t1 = (b - a).normalize();
                let frame = [t1, normal.normalize().cross(t1)];
                let area = 0.5 * normal.length();
                let s = [0, 1, 2].map(|k| {
                    let p = (x[t[k]] * 2.0 - x[t[(k + 2) % 3]] - x[t[(k + 1) % 3]]) * area;
                    [frame[0].dot(p), frame[1].dot(p)]
                });
                Rest { vertices: t, unknowns: t.map(|v| unknowns[v]), frame, s }
            })
            .collect();
        let mut pass = Self { rest, modes: 0, rows: Vec::new() };
        pass.set_basis(x, basis);
        pass
    }

    /// Recompute the modal rows for a new basis.
    pub fn set_basis(&mut self, rest_positions: &[DVec3], basis: &ModalBasis) {
        let m = basis.modes();
        self.modes = m;
        self.rows = vec![0.0; 6 * m * self.rest.len()];
        for (tri, rows) in self.rest.iter().zip(self.rows.chunks_exact_mut(6 * m)) {
            let x = tri.vertices.map(|v| rest_positions[v]);
            let jacobian = triangle_jacobian(x);
            let (_, gradients) = barycentric_gradients(x);
            let [t1, t2] = tri.frame;
            for j in 0..m {
                let phi = tri.vertices.map(|v| DVec3::new(basis.phi(v, 0, j), basis.phi(v, 1, j), basis.phi(v, 2, j)));
                let omega: DVec3 = (0..3).map(|k| jacobian[k] * phi[k]).sum();
                // t_aᵀ F t_b with F = Σ_k φ_k g_kᵀ, symmetrised.
                let f = |a: DVec3, b: DVec3| (0..3).map(|k| a.dot(phi[k]) * gradients[k].dot(b)).sum::<f64>();
                let values = [omega.x, omega.y, omega.z, f(t1, t1), f(t2, t2), 0.5 * (f(t1, t2) + f(t2, t1))];
                for (r, value) in values.into_iter().enumerate() {
                    rows[r * m + j] = value;
                }
            }
        }
    }

    /// Number of triangles in the pass.
    pub fn len(&self) -> usize {
        self.rest.len()
    }

    /// Whether no triangle moves.
    pub fn is_empty(&self) -> bool {
        self.rest.is_empty()
    }

    /// Per triangle, the moments `Y_a = Σ_k s_ka y_k` of a per-vertex adjoint field `y`.
    pub fn moments(&self, y: &[DVec3]) -> Vec<Moments> {
        self.rest.iter().map(|t| [0, 1].map(|a| (0..3).map(|k| y[t.vertices[k]] * t.s[k][a]).sum())).collect()
    }

    /// The Jacobian rows of `vertex`'s position for the scalar adjoint field `z = L⁻¹ e_vertex`
    /// (filled by the next [`TrianglePass::run`]).
    pub fn drag_rows(&self, vertex: usize, z: &[f64]) -> DragRows {
        let moments =
            self.rest.iter().map(|t| [0, 1].map(|a| (0..3).map(|k| z[t.vertices[k]] * t.s[k][a]).sum())).collect();
        DragRows { vertex, moments, rows: vec![0.0; 3 * self.modes] }
    }

    /// One pass at `q`: the right side `rhs` of the reconstruction (three columns), the generalised
    /// force `force` of the loads with moments `loads` (without the gauges' centroid terms), and the
    /// Jacobian rows of every drag in `drags`.
    pub fn run(&self, q: &[f64], loads: &[Moments], rhs: &mut [f64], force: &mut [f64], drags: &mut [DragRows]) {
        let (m, n) = (self.modes, rhs.len() / 3);
        rhs.fill(0.0);
        force.fill(0.0);
        drags.iter_mut().for_each(|d| d.rows.fill(0.0));
        for (t, ((tri, rows), load)) in self.rest.iter().zip(self.rows.chunks_exact(6 * m)).zip(loads).enumerate() {
            let k = Kinematics::new(rows, q, &tri.frame);
            for (&u, s) in tri.unknowns.iter().zip(tri.s) {
                if u != NONE {
                    let (u, d) = (u as usize, k.target_change(&tri.frame, s));
                    (rhs[u], rhs[n + u], rhs[2 * n + u]) = (rhs[u] + d.x, rhs[n + u] + d.y, rhs[2 * n + u] + d.z);
                }
            }
            add_transposed(rows, k.adjoint(&tri.frame, *load), force);
            for drag in drags.iter_mut() {
                let [z1, z2] = drag.moments[t];
                if z1 == 0.0 && z2 == 0.0 {
                    continue;
                }
                for (axis, out) in DVec3::AXES.iter().zip(drag.rows.chunks_exact_mut(m)) {
                    add_transposed(rows, k.adjoint(&tri.frame, [*axis * z1, *axis * z2]), out);
                }
            }
        }
    }
}
