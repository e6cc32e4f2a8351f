//! The per-triangle pass of `mwts-rs` ([`super::rotation_strain`]): from the modal coordinates `q`,
//! each triangle's rotation `ω_t = W_t q` and in-plane strain `ε_t = E_t q`, the right side of the
//! reconstruction, the generalised force through the adjoint, and the position drags' Jacobian rows.
//!
//! Per triangle, at rest: an orthonormal frame `(t₁, t₂)` of its plane and, for each corner `k`, the
//! in-plane vector `p_k = A_t (2X_k − X_{k−1} − X_{k+1})` in that frame, `s_k = (t₁·p_k, t₂·p_k)`.
//! Summing the three edges' terms of `b` per corner, the triangle adds `(M_t − I) p_k` to corner `k`
//! with `M_t = R_t (I + ε_t)`, `R_t = exp([ω_t]×)`. With `σ_k = (I + ε) s_k` (2×2 strain in the frame)
//! and `r_a = R t_a`: `M p_k = r₁ σ_k1 + r₂ σ_k2`. The change is linear in `s_k`, `(M − I) p_k =
//! s_k1 c₁ + s_k2 c₂` with the triangle's columns `c_a = (M − I) t_a`, evaluated as `c₁ = (r₁ − t₁) +
//! ε₁₁ r₁ + ε₁₂ r₂`, `c₂ = (r₂ − t₂) + ε₁₂ r₁ + ε₂₂ r₂` (with `r_a − t_a = a ω × t_a + b ω × (ω × t_a)`,
//! the Rodrigues coefficients of [`super::warp`]) so that `q = 0` adds exactly zero.
//!
//! **Adjoint.** For `y = L⁻¹ f` ([`super::laplacian`]) the work `yᵀb` is `Σ_t s_t` with
//! `s_t = Σ_k y_k · M p_k = r₁·A₁ + r₂·A₂`, `A₁ = (1 + ε₁₁) Y₁ + ε₁₂ Y₂`, `A₂ = ε₁₂ Y₁ + (1 + ε₂₂) Y₂`,
//! where `Y_a = Σ_k s_ka y_k` are the triangle's load moments (constant while the loads are). So
//! `∂s/∂ε₁₁ = r₁·Y₁`, `∂s/∂ε₂₂ = r₂·Y₂`, `∂s/∂ε₁₂ = r₁·Y₂ + r₂·Y₁`, and since
//! `d exp([ω]×) = [J_l(ω) dω]× exp([ω]×)` with the left Jacobian `J_l(ω) = ∫₀¹ exp(s[ω]×) ds` (the
//! warp operator), `∂s/∂ω = J_lᵀ (r₁ × A₁ + r₂ × A₂)`. The generalised force is
//! `Σ_t W_tᵀ ∂s/∂ω + E_tᵀ ∂s/∂ε`. A position drag's rows (`f = e_i ⊗ e_a`) take the scalar field
//! `z = L⁻¹ e_i` with moments `c = Σ_k z_k s_k`: for axis `a`, `∂s/∂ω = J_lᵀ (v × e_a)` with
//! `v = r₁ σ₁ + r₂ σ₂`, `σ = (I + ε) c`, and `∂s/∂ε = (r₁ₐ c₁, r₂ₐ c₂, r₁ₐ c₂ + r₂ₐ c₁)`.
//!
//! **Composed rotations.** Where asked ([`TrianglePass::compose_from`]), a triangle's rotation is
//! the product `R = R_o R_i` of an outer rotation `R_o = exp([ω^o]×)` from the coordinates before
//! some index and an inner one `R_i = exp([ω^i]×)` from the rest: what the inner coordinates turn
//! (a V-beam's section opening, in `rds`'s derivative directions) is turned in the material frame,
//! and the outer ones (the modes' bend) turn the result, as they do in the shell. To first order
//! this is `exp([ω^o + ω^i]×)`; summed instead, two large rotations about different axes give
//! targets that disagree between neighbouring triangles, and the fit leaves membrane strain (the
//! V-beam through its collapse, BENCHMARKS.md). Then `r_a − t_a = (R_o − I)(t_a + u_a) + u_a`
//! with `u_a = (R_i − I) t_a`, and since `dR = [J_l(ω^o) dω^o]× R + R_o [J_l(ω^i) dω^i]× R_i`,
//! `∂s/∂ω^o = J_l(ω^o)ᵀ v` as before and `∂s/∂ω^i = J_l(ω^i)ᵀ R_oᵀ v` for the same
//! `v = r₁ × A₁ + r₂ × A₂` (for a drag, `v × e_a`): the cross product turns with `R_oᵀ`.
//!
//! Triangles go [`LANES`] at a time, every quantity a SIMD vector across them (compiled for the CPU's
//! best instruction set, as in [`super::kernel`]); only the scatter of `b` is per triangle.
//!
//! **Two halves.** From [`SPLIT`] triangles on, where the reconstruction's solve has two halves of
//! its unknowns (`0..a` and `a..b`, joined by no edge, then their common top `b..`;
//! [`super::laplacian::EdgeLaplacian::halves`]), the triangles are cut along them: first those with a
//! corner in the first half, then those with a corner in the second (a triangle with corners only
//! in the top goes with the smaller group). Each half of the chunks sums its own force and drag
//! rows and scatters into its own unknowns of the right side; what the second half adds to the
//! top's unknowns goes to a scratch, added to the first's when both are done, and so do its sums
//! ([`crate::threads::join_sum`]). With more than one thread ([`crate::threads`]) the halves run at
//! once; on one they run in turn, so that the sums do not depend on the thread count. Where the solve
//! has no halves (fewer unknowns than it splits from), the triangles are halved by their number and
//! the second half's scratch takes every unknown.

mod halves;

use std::ops::Range;

use glam::DVec3;
use pulp::Simd;

use super::basis::{LANES, ModalBasis, chunks};
use super::kernel::{coefficients, cross, rodrigues};
use super::laplacian::NONE;
use super::rotation::{barycentric_gradients, triangle_jacobian};
use crate::linalg::padded::Padded;
use halves::{Target, cut};

/// Passes over at least this many triangles go in two halves (module documentation); a smaller one
/// stays whole: handing half of it to another thread would cost more than it saves.
pub const SPLIT: usize = 4096;

/// One value per triangle of a chunk.
type Lanes = [f64; LANES];

/// A chunk of triangles' load moments `[Y₁, Y₂]` (module documentation), x, y, z each.
pub type Moments = [[Lanes; 3]; 2];

/// A chunk of triangles at rest: what the step's pass reads (their vertices are kept apart, in
/// [`TrianglePass`], so that the pass streams no more than it uses).
#[derive(Debug, Clone, PartialEq)]
struct Chunk {
    /// Each corner's unknown in the reconstruction's system, or [`NONE`] (also for padding lanes).
    unknowns: [[u32; LANES]; 3],
    /// `t₁` (x, y, z) then `t₂`.
    frame: [Lanes; 6],
    /// `s_k` per corner: `s₀₁, s₀₂, s₁₁, …`.
    s: [Lanes; 6],
}

/// The per-triangle rest data and modal rows of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct TrianglePass {
    chunks: Vec<Chunk>,
    /// Per chunk, each corner's vertex (padding lanes: vertex 0).
    corners: Vec<[[usize; LANES]; 3]>,
    triangles: usize,
    modes: usize,
    /// Per chunk, `6m` rows: `W_t` (x, y, z) then `E_t` (ε₁₁, ε₂₂, ε₁₂), mode by mode.
    rows: Vec<Lanes>,
    /// The coordinates from this one on turn their triangles first, in the material frame, and the
    /// ones before it after them ([`TrianglePass::compose_from`]); `None`: one rotation of all.
    inner: Option<usize>,
    /// The first chunk of the second half (module documentation).
    half: usize,
    /// The ends of the two halves of the unknowns when the pass is cut along them.
    unknown_halves: Option<[usize; 2]>,
}

/// Where a pass writes the right side of the reconstruction: the system's own, and a scratch for
/// what the second half of the triangles adds to the top's unknowns (module documentation), kept
/// between passes.
#[derive(Debug)]
pub struct RightSide<'a> {
    /// One 3-vector per unknown.
    pub rhs: &'a mut [Padded],
    /// Resized as needed.
    pub scratch: &'a mut Vec<Padded>,
}

/// The Jacobian rows of one vertex's position, and the adjoint moments that give them.
#[derive(Debug, Clone, PartialEq)]
pub struct DragRows {
    /// The vertex.
    pub vertex: usize,
    /// Per chunk: `c = Σ_k z_k s_k` for `z = L⁻¹ e_vertex`.
    moments: Vec<[[Lanes; 1]; 2]>,
    /// `∂x_vertex/∂q` without the gauge's centroid term: 3 rows (x, y, z) of `m`.
    pub rows: Vec<f64>,
}

impl TrianglePass {
    /// The triangles with a free corner (`unknowns` from the reconstruction's system; the others
    /// never move), with the modal rows of `basis`.
    pub fn new(
        rest: &[DVec3],
        triangles: &[[usize; 3]],
        unknowns: &[u32],
        halves: Option<[usize; 2]>,
        basis: &ModalBasis,
    ) -> Self {
        let moving: Vec<[usize; 3]> =
            triangles.iter().filter(|t| t.iter().any(|&v| unknowns[v] != NONE)).copied().collect();
        let (order, half, unknown_halves) = cut(&moving, unknowns, halves);
        let empty = Chunk { unknowns: [[NONE; LANES]; 3], frame: [[0.0; LANES]; 6], s: [[0.0; LANES]; 6] };
        let mut chunked = vec![empty; chunks(order.len())];
        let mut corners = vec![[[0; LANES]; 3]; chunked.len()];
        for (i, t) in order.iter().enumerate().filter_map(|(i, t)| Some((i, (*t)?))) {
            let (chunk, lane) = (&mut chunked[i / LANES], i % LANES);
            let [a, b, c] = t.map(|v| rest[v]);
            let normal = (b - a).cross(c - a);
            let t1 = (b - a).normalize();
            let frame = [t1, normal.normalize().cross(t1)];
            let area = 0.5 * normal.length();
            for k in 0..3 {
                (corners[i / LANES][k][lane], chunk.unknowns[k][lane]) = (t[k], unknowns[t[k]]);
                let p = (rest[t[k]] * 2.0 - rest[t[(k + 2) % 3]] - rest[t[(k + 1) % 3]]) * area;
                (chunk.s[2 * k][lane], chunk.s[2 * k + 1][lane]) = (frame[0].dot(p), frame[1].dot(p));
                (chunk.frame[k][lane], chunk.frame[3 + k][lane]) = (frame[0][k], frame[1][k]);
            }
        }
        let mut pass = Self {
            chunks: chunked,
            corners,
            triangles: moving.len(),
            modes: 0,
            rows: Vec::new(),
            inner: None,
            half,
            unknown_halves,
        };
        pass.set_basis(rest, basis);
        pass
    }

    /// Recompute the modal rows for a new basis.
    pub fn set_basis(&mut self, rest: &[DVec3], basis: &ModalBasis) {
        let m = basis.modes();
        self.modes = m;
        self.rows = vec![[0.0; LANES]; 6 * m * self.chunks.len()];
        for (c, (chunk, vertices)) in self.chunks.iter().zip(&self.corners).enumerate() {
            for lane in (0..LANES).filter(|&l| chunk.unknowns.iter().any(|u| u[l] != NONE)) {
                let corners = [0, 1, 2].map(|k| vertices[k][lane]);
                let x = corners.map(|v| rest[v]);
                let jacobian = triangle_jacobian(x);
                let (_, gradients) = barycentric_gradients(x);
                let t = [0, 3]
                    .map(|o| DVec3::new(chunk.frame[o][lane], chunk.frame[o + 1][lane], chunk.frame[o + 2][lane]));
                for j in 0..m {
                    let phi = corners.map(|v| DVec3::new(basis.phi(v, 0, j), basis.phi(v, 1, j), basis.phi(v, 2, j)));
                    let omega: DVec3 = (0..3).map(|k| jacobian[k] * phi[k]).sum();
                    // t_aᵀ F t_b with F = Σ_k φ_k g_kᵀ, symmetrised.
                    let f = |a: DVec3, b: DVec3| (0..3).map(|k| a.dot(phi[k]) * gradients[k].dot(b)).sum::<f64>();
                    let values = [
                        omega.x,
                        omega.y,
                        omega.z,
                        f(t[0], t[0]),
                        f(t[1], t[1]),
                        0.5 * (f(t[0], t[1]) + f(t[1], t[0])),
                    ];
                    for (r, value) in values.into_iter().enumerate() {
                        self.rows[(c * 6 + r) * m + j][lane] = value;
                    }
                }
            }
        }
    }

    /// Compose each triangle's rotation of two: `R_t = exp([ω_t^outer]×) exp([ω_t^inner]×)`, with
    /// `ω^inner` from the coordinates `first..` and `ω^outer` from those before (module
    /// documentation, *Composed rotations*); `None` (the default), or a `first` at or past the last
    /// coordinate: one rotation `exp([W_t q]×)`.
    pub fn compose_from(&mut self, first: Option<usize>) {
        self.inner = first;
    }

    /// Whether the pass goes in two halves (module documentation).
    pub fn splits(&self) -> bool {
        self.half < self.chunks.len()
    }

    /// Number of triangles in the pass.
    pub fn len(&self) -> usize {
        self.triangles
    }

    /// Whether no triangle moves.
    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }

    /// Per chunk, the moments `Σ_k s_k y_k` of a per-vertex adjoint field `y` (vector or scalar).
    fn weighted<const R: usize>(&self, value: impl Fn(usize) -> [f64; R]) -> Vec<[[Lanes; R]; 2]> {
        (self.chunks.iter().zip(&self.corners))
            .map(|(chunk, vertices)| {
                let mut out = [[[0.0; LANES]; R]; 2];
                for (lane, k) in (0..LANES).flat_map(|l| (0..3).map(move |k| (l, k))) {
                    let y = value(vertices[k][lane]);
                    for (a, out) in out.iter_mut().enumerate() {
                        for (o, yr) in out.iter_mut().zip(y) {
                            o[lane] += chunk.s[2 * k + a][lane] * yr;
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// Per chunk, the load moments `Y_a = Σ_k s_ka y_k` of a per-vertex adjoint field `y`.
    pub fn moments(&self, y: &[DVec3]) -> Vec<Moments> {
        self.weighted(|v| y[v].to_array())
    }

    /// The Jacobian rows of `vertex`'s position for the scalar adjoint field `z = L⁻¹ e_vertex`
    /// (filled by the next [`TrianglePass::run`]).
    pub fn drag_rows(&self, vertex: usize, z: &[f64]) -> DragRows {
        DragRows { vertex, moments: self.weighted(|v| [z[v]]), rows: vec![0.0; 3 * self.modes] }
    }

    /// Per mode: the largest triangle rotation a unit of it makes, `max_t |W_t e_j|`, rad.
    pub fn rotation_scales(&self) -> Vec<f64> {
        let m = self.modes;
        (0..m)
            .map(|j| {
                (self.rows.chunks_exact(6 * m))
                    .flat_map(|rows| (0..LANES).map(move |l| (0..3).map(|r| rows[r * m + j][l].powi(2)).sum::<f64>()))
                    .fold(0.0, f64::max)
                    .sqrt()
            })
            .collect()
    }

    /// One pass at `q`: the right side `rhs` of the reconstruction (one 3-vector per unknown, with
    /// the scratch for the second half; not computed if `None`), the generalised force of the loads
    /// with moments `loads.0` into `loads.1` (without the gauges' centroid terms; not computed if
    /// `None`, which halves the per-triangle work of a pass that only places the shell), and the
    /// Jacobian rows of every drag in `drags`.
    pub fn run(
        &self,
        q: &[f64],
        loads: Option<(&[Moments], &mut [f64])>,
        rhs: Option<RightSide<'_>>,
        drags: &mut [DragRows],
    ) {
        let rows = &*drags;
        let moments = loads.as_ref().map(|(m, _)| *m);
        let half =
            |chunks, rhs| pulp::Arch::new().dispatch(Pass { pass: self, q, loads: moments, chunks, rhs, drags: rows });
        let all = 0..self.chunks.len();
        let (first, second) = (all.start..self.half, self.half..all.end);
        let sums = match (rhs, self.splits()) {
            (Some(RightSide { rhs, scratch }), true) => {
                // Cut by number: the top is every unknown, and all the second half adds goes to the scratch.
                let [a, b] = self.unknown_halves.unwrap_or([0, 0]);
                scratch.clear();
                scratch.resize(rhs.len() - b, Padded::ZERO);
                let (low, top) = rhs.split_at_mut(b);
                let (first_own, second_own) = low.split_at_mut(a);
                let first_rhs = Target { own: (first_own, 0), top: (&mut *top, b) };
                let second_rhs = Target { own: (second_own, a), top: (&mut scratch[..], b) };
                let sums = crate::threads::join_sum(|| half(first, Some(first_rhs)), || half(second, Some(second_rhs)));
                top.iter_mut().zip(scratch.iter()).for_each(|(t, s)| *t += *s);
                sums
            }
            (Some(RightSide { rhs, .. }), false) => {
                let end = rhs.len();
                half(all, Some(Target { own: (rhs, 0), top: (&mut [], end) }))
            }
            (None, true) => crate::threads::join_sum(|| half(first, None), || half(second, None)),
            (None, false) => half(all, None),
        };
        self.finish(loads, drags, sums)
    }

    /// The end of [`TrianglePass::run`]: its sums handed out, the force then each drag's rows.
    fn finish(&self, mut loads: Option<(&[Moments], &mut [f64])>, drags: &mut [DragRows], sums: Vec<f64>) {
        if let Some((_, force)) = loads.as_mut() {
            force.copy_from_slice(&sums[..self.modes]);
        }
        for (drag, rows) in drags.iter_mut().zip(sums[self.modes..].chunks_exact(3 * self.modes)) {
            drag.rows.copy_from_slice(rows);
        }
    }
}

/// The arguments of one half of [`TrianglePass::run`], for the dispatch to the best instruction set:
/// its chunks, and where it scatters its right side. It returns its sums: the force, then each
/// drag's three rows.
struct Pass<'a> {
    pass: &'a TrianglePass,
    q: &'a [f64],
    loads: Option<&'a [Moments]>,
    chunks: Range<usize>,
    rhs: Option<Target<'a>>,
    drags: &'a [DragRows],
}

impl pulp::WithSimd for Pass<'_> {
    type Output = Vec<f64>;

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> Vec<f64> {
        let Self { pass, q, loads, chunks, mut rhs, drags } = self;
        let m = pass.modes;
        let inner = pass.inner.filter(|&first| first < m);
        let groups = LANES / S::F64_LANES;
        let zero = simd.splat_f64s(0.0);
        let qs: Vec<S::f64s> = q.iter().map(|&x| simd.splat_f64s(x)).collect();
        // Accumulators, one SIMD vector per group and mode: the force, then each drag's three rows.
        let mut acc = vec![zero; m * groups * (1 + 3 * drags.len())];
        if let Some(rhs) = rhs.as_mut() {
            rhs.own.0.fill(Padded::ZERO);
            rhs.top.0.fill(Padded::ZERO);
        }
        for c in chunks {
            let (chunk, load) = (&pass.chunks[c], loads.map(|l| &l[c]));
            let rows = &pass.rows[c * 6 * m..(c + 1) * 6 * m];
            let mut change = [[[0.0; LANES]; 3]; 3];
            for g in 0..groups {
                let t = Triangle::new(simd, rows, &qs, chunk, g, inner);
                if rhs.is_some() {
                    let columns = t.columns(simd);
                    for (k, out) in change.iter_mut().enumerate() {
                        let (s1, s2) = (at::<S>(&chunk.s[2 * k], g), at::<S>(&chunk.s[2 * k + 1], g));
                        let d = combine(simd, &columns[0], s1, &columns[1], s2);
                        for (lanes, di) in out.iter_mut().zip(d) {
                            let di: &[f64] = bytemuck::cast_slice(std::slice::from_ref(&di));
                            lanes[g * S::F64_LANES..(g + 1) * S::F64_LANES].copy_from_slice(di);
                        }
                    }
                }
                if let Some(load) = load {
                    let d = t.load_adjoint(simd, [vector::<S>(&load[0], g), vector::<S>(&load[1], g)]);
                    accumulate(simd, rows, g, d, &mut acc[g..m * groups]);
                }
                for (k, drag) in drags.iter().enumerate() {
                    let moments = &drag.moments[c];
                    let d = t.drag_adjoint(simd, [at::<S>(&moments[0][0], g), at::<S>(&moments[1][0], g)]);
                    for (axis, d) in d.into_iter().enumerate() {
                        let slot = (1 + 3 * k + axis) * m * groups;
                        accumulate(simd, rows, g, d, &mut acc[slot + g..slot + m * groups]);
                    }
                }
            }
            if let Some(rhs) = rhs.as_mut() {
                for (k, out) in change.iter().enumerate() {
                    for (lane, &u) in chunk.unknowns[k].iter().enumerate() {
                        if let Some(b) = rhs.get_mut(u) {
                            *b += Padded::from(DVec3::new(out[0][lane], out[1][lane], out[2][lane]));
                        }
                    }
                }
            }
        }
        acc.chunks_exact(groups).map(|v| v.iter().map(|&x| simd.reduce_sum_f64s(x)).sum()).collect()
    }
}

/// Lanes `g` of a chunk's row (no closures in the kernel: they would not be compiled for its
/// instruction set).
#[inline(always)]
fn at<S: Simd>(row: &Lanes, g: usize) -> S::f64s {
    S::as_simd_f64s(row).0[g]
}

/// Lanes `g` of three rows.
#[inline(always)]
fn vector<S: Simd>(rows: &[Lanes; 3], g: usize) -> [S::f64s; 3] {
    [at::<S>(&rows[0], g), at::<S>(&rows[1], g), at::<S>(&rows[2], g)]
}

#[inline(always)]
fn dot<S: Simd>(simd: S, u: &[S::f64s; 3], v: &[S::f64s; 3]) -> S::f64s {
    simd.mul_add_e_f64s(u[0], v[0], simd.mul_add_e_f64s(u[1], v[1], simd.mul_f64s(u[2], v[2])))
}

/// `u a + v b` per component.
#[inline(always)]
fn combine<S: Simd>(simd: S, u: &[S::f64s; 3], a: S::f64s, v: &[S::f64s; 3], b: S::f64s) -> [S::f64s; 3] {
    [
        simd.mul_add_e_f64s(u[0], a, simd.mul_f64s(v[0], b)),
        simd.mul_add_e_f64s(u[1], a, simd.mul_f64s(v[1], b)),
        simd.mul_add_e_f64s(u[2], a, simd.mul_f64s(v[2], b)),
    ]
}

#[inline(always)]
fn add<S: Simd>(simd: S, u: &[S::f64s; 3], v: &[S::f64s; 3]) -> [S::f64s; 3] {
    [simd.add_f64s(u[0], v[0]), simd.add_f64s(u[1], v[1]), simd.add_f64s(u[2], v[2])]
}

/// `a ω × t + b ω × (ω × t)`: `exp([ω]×) t − t` for the Rodrigues coefficients `a`, `b`.
#[inline(always)]
fn turn<S: Simd>(simd: S, omega: &[S::f64s; 3], t: &[S::f64s; 3], a: S::f64s, b: S::f64s) -> [S::f64s; 3] {
    let wt = cross(simd, omega, t);
    combine(simd, &wt, a, &cross(simd, omega, &wt), b)
}

/// `out[j] += Σ_r rows[r m + j] d_r` for the `m` modes of group `g` (`out` holds every `groups`-th
/// accumulator from the group's first), `d = (∂s/∂ω, ∂s/∂ε)`; the coordinates of an inner rotation
/// (from `inner.0` on) take `∂s/∂ω^inner = inner.1` instead (module documentation, *Composed
/// rotations*).
#[inline(always)]
fn accumulate<S: Simd>(simd: S, rows: &[Lanes], g: usize, (d, inner): Adjoint<S>, out: &mut [S::f64s]) {
    let m = rows.len() / 6;
    let groups = LANES / S::F64_LANES;
    let (outer, turned) = match inner {
        Some((first, t)) => (first, [t[0], t[1], t[2], d[3], d[4], d[5]]),
        None => (m, d),
    };
    let mut columns = out.iter_mut().step_by(groups).enumerate();
    for (j, s) in columns.by_ref().take(outer) {
        column(simd, rows, g, j, &d, s);
    }
    for (j, s) in columns {
        column(simd, rows, g, j, &turned, s);
    }
}

/// `s += Σ_r rows[r m + j] d_r`, lanes `g`, for one mode `j` of [`accumulate`].
#[inline(always)]
fn column<S: Simd>(simd: S, rows: &[Lanes], g: usize, j: usize, d: &[S::f64s; 6], s: &mut S::f64s) {
    let m = rows.len() / 6;
    for (r, dr) in d.iter().enumerate() {
        *s = simd.mul_add_e_f64s(at::<S>(&rows[r * m + j], g), *dr, *s);
    }
}

/// A triangle group's `(∂s/∂ω, ∂s/∂ε)`, and for its inner rotation, if any, that rotation's first
/// coordinate and `∂s/∂ω^inner`.
type Adjoint<S> = ([<S as Simd>::f64s; 6], Option<(usize, [<S as Simd>::f64s; 3])>);

/// A group of triangles' inner rotation (module documentation, *Composed rotations*).
struct Inner<S: Simd> {
    /// Its first coordinate.
    first: usize,
    /// `ω^inner`.
    omega: [S::f64s; 3],
    /// Its `[(1 − cosθ)/θ², (θ − sinθ)/θ³]`.
    jacobian: [S::f64s; 2],
}

impl<S: Simd> Inner<S> {
    /// `(first, J_l(ω^inner)ᵀ R_outerᵀ v)` for `v = Σ_a r_a × A_a`, the outer rotation `outer` given
    /// with its Rodrigues coefficients `[sinθ/θ, (1 − cosθ)/θ²]`.
    #[inline(always)]
    fn adjoint(
        &self,
        simd: S,
        outer: &[S::f64s; 3],
        rodrigues_of: [S::f64s; 2],
        v: &[S::f64s; 3],
    ) -> (usize, [S::f64s; 3]) {
        let back = rodrigues(simd, outer, v, simd.neg_f64s(rodrigues_of[0]), rodrigues_of[1]);
        (self.first, rodrigues(simd, &self.omega, &back, self.jacobian[0], self.jacobian[1]))
    }
}

/// A group of triangles at the current `q`: rotation, strain, frame and the turned frame.
struct Triangle<S: Simd> {
    omega: [S::f64s; 3],
    /// `[(1 − cosθ)/θ², (θ − sinθ)/θ³]` (with `J_lᵀ v = v − b ω×v + c ω×(ω×v)`).
    jacobian: [S::f64s; 2],
    /// `(ε₁₁, ε₂₂, ε₁₂)`.
    strain: [S::f64s; 3],
    /// `r_a − t_a`.
    turned: [[S::f64s; 3]; 2],
    /// `r_a`.
    r: [[S::f64s; 3]; 2],
    /// The outer rotation's `[sinθ/θ, (1 − cosθ)/θ²]`, for `R_outerᵀ`.
    rodrigues: [S::f64s; 2],
    /// The inner rotation, if the triangles' rotations are composed.
    inner: Option<Inner<S>>,
}

impl<S: Simd> Triangle<S> {
    #[inline(always)]
    fn new(simd: S, rows: &[Lanes], q: &[S::f64s], chunk: &Chunk, g: usize, inner: Option<usize>) -> Self {
        let m = q.len();
        // The outer rotation, from the coordinates before the inner one's (all of them if none).
        let first = inner.unwrap_or(m);
        let mut kin = [simd.splat_f64s(0.0); 6];
        for (r, k) in kin.iter_mut().enumerate() {
            let end = if r < 3 { first } else { m };
            for (row, &qj) in rows[r * m..r * m + end].iter().zip(q) {
                *k = simd.mul_add_e_f64s(at::<S>(row, g), qj, *k);
            }
        }
        let omega = [kin[0], kin[1], kin[2]];
        let [a, b, c] = coefficients(simd, &omega);
        let frame = [
            [at::<S>(&chunk.frame[0], g), at::<S>(&chunk.frame[1], g), at::<S>(&chunk.frame[2], g)],
            [at::<S>(&chunk.frame[3], g), at::<S>(&chunk.frame[4], g), at::<S>(&chunk.frame[5], g)],
        ];
        // r_a = R_outer R_inner t_a; r_a − t_a = (R_outer − I)(t_a + u_a) + u_a with u_a = (R_inner − I) t_a,
        // so that q = 0 still turns nothing, exactly.
        let (turned, inner) = match inner {
            None => ([turn(simd, &omega, &frame[0], a, b), turn(simd, &omega, &frame[1], a, b)], None),
            Some(first) => {
                let mut w = [simd.splat_f64s(0.0); 3];
                for (r, wr) in w.iter_mut().enumerate() {
                    for (row, &qj) in rows[r * m + first..(r + 1) * m].iter().zip(&q[first..]) {
                        *wr = simd.mul_add_e_f64s(at::<S>(row, g), qj, *wr);
                    }
                }
                let [ai, bi, ci] = coefficients(simd, &w);
                let u = [turn(simd, &w, &frame[0], ai, bi), turn(simd, &w, &frame[1], ai, bi)];
                // No closure here: it would not be compiled for the kernel's instruction set.
                let turned = [
                    add(simd, &u[0], &turn(simd, &omega, &add(simd, &frame[0], &u[0]), a, b)),
                    add(simd, &u[1], &turn(simd, &omega, &add(simd, &frame[1], &u[1]), a, b)),
                ];
                (turned, Some(Inner { first, omega: w, jacobian: [simd.neg_f64s(bi), ci] }))
            }
        };
        let r = [add(simd, &frame[0], &turned[0]), add(simd, &frame[1], &turned[1])];
        let jacobian = [simd.neg_f64s(b), c];
        Self { omega, jacobian, strain: [kin[3], kin[4], kin[5]], turned, r, rodrigues: [a, b], inner }
    }

    /// `(I + ε) s` for in-plane coordinates `s`.
    #[inline(always)]
    fn stretch(&self, simd: S, s: [S::f64s; 2]) -> [S::f64s; 2] {
        let [e11, e22, e12] = self.strain;
        [
            simd.mul_add_e_f64s(e11, s[0], simd.mul_add_e_f64s(e12, s[1], s[0])),
            simd.mul_add_e_f64s(e12, s[0], simd.mul_add_e_f64s(e22, s[1], s[1])),
        ]
    }

    /// `c_a = (M − I) t_a`, so that a corner with in-plane coordinates `s` changes by
    /// `(M − I) p = s₁ c₁ + s₂ c₂`: `c₁ = (r₁ − t₁) + ε₁₁ r₁ + ε₁₂ r₂`, `c₂ = (r₂ − t₂) + ε₁₂ r₁ + ε₂₂ r₂`
    /// (exact zeros at `q = 0`).
    #[inline(always)]
    fn columns(&self, simd: S) -> [[S::f64s; 3]; 2] {
        let [e11, e22, e12] = self.strain;
        let [r1, r2] = &self.r;
        [
            add(simd, &self.turned[0], &combine(simd, r1, e11, r2, e12)),
            add(simd, &self.turned[1], &combine(simd, r1, e12, r2, e22)),
        ]
    }

    /// `(∂s/∂ω, ∂s/∂ε)` for the load moments `y = [Y₁, Y₂]`.
    #[inline(always)]
    fn load_adjoint(&self, simd: S, y: [[S::f64s; 3]; 2]) -> Adjoint<S> {
        let [e11, e22, e12] = self.strain;
        let one = simd.splat_f64s(1.0);
        let a1 = combine(simd, &y[0], simd.add_f64s(one, e11), &y[1], e12);
        let a2 = combine(simd, &y[0], e12, &y[1], simd.add_f64s(one, e22));
        let sum = add(simd, &cross(simd, &self.r[0], &a1), &cross(simd, &self.r[1], &a2));
        let d = rodrigues(simd, &self.omega, &sum, self.jacobian[0], self.jacobian[1]);
        let [r1, r2] = &self.r;
        let cross_terms = simd.add_f64s(dot(simd, r1, &y[1]), dot(simd, r2, &y[0]));
        // Not `Option::map`: a closure would not be compiled for the kernel's instruction set.
        let mut inner = None;
        if let Some(i) = &self.inner {
            inner = Some(i.adjoint(simd, &self.omega, self.rodrigues, &sum));
        }
        ([d[0], d[1], d[2], dot(simd, r1, &y[0]), dot(simd, r2, &y[1]), cross_terms], inner)
    }

    /// `(∂s/∂ω, ∂s/∂ε)` for a drag's moments `z`, for each axis.
    #[inline(always)]
    fn drag_adjoint(&self, simd: S, z: [S::f64s; 2]) -> [Adjoint<S>; 3] {
        let sigma = self.stretch(simd, z);
        let v = combine(simd, &self.r[0], sigma[0], &self.r[1], sigma[1]);
        let zero = simd.splat_f64s(0.0);
        let mut out = [([zero; 6], None); 3];
        for (axis, (d, inner)) in out.iter_mut().enumerate() {
            // v × e_axis.
            let mut u = [zero; 3];
            (u[(axis + 1) % 3], u[(axis + 2) % 3]) = (v[(axis + 2) % 3], simd.neg_f64s(v[(axis + 1) % 3]));
            let w = rodrigues(simd, &self.omega, &u, self.jacobian[0], self.jacobian[1]);
            let (r1, r2) = (self.r[0][axis], self.r[1][axis]);
            let mixed = simd.mul_add_e_f64s(r1, z[1], simd.mul_f64s(r2, z[0]));
            *d = [w[0], w[1], w[2], simd.mul_f64s(r1, z[0]), simd.mul_f64s(r2, z[1]), mixed];
            if let Some(i) = &self.inner {
                *inner = Some(i.adjoint(simd, &self.omega, self.rodrigues, &u));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;
    use crate::solver::modal::laplacian::EdgeLaplacian;

    #[test]
    fn a_pass_cut_along_the_solves_halves_gives_what_the_whole_pass_does() {
        // A sheet clamped along one side, large enough for the reconstruction's solve to have halves
        // and the pass to go in two: its right side, force and drag rows against the same pass whole.
        let mesh = grid([1.0, 0.75], [79, 61]).unwrap();
        let rest = mesh.positions();
        let anchors: Vec<usize> = (0..rest.len()).filter(|&v| rest[v].x < -0.49).collect();
        let laplacian = EdgeLaplacian::new(&mesh, &anchors).unwrap();
        let [a, b] = laplacian.halves().expect("the solve has halves");
        let shapes: Vec<Vec<DVec3>> = (0..3)
            .map(|j| {
                let s = |p: DVec3| (p.x + 0.5).powi(j + 2);
                let field = |p: DVec3| DVec3::new(0.3 * (p.y * (j + 1) as f64).sin(), 0.2 * p.x * p.y, 1.0) * s(p);
                rest.iter()
                    .enumerate()
                    .map(|(v, p)| if anchors.contains(&v) { DVec3::ZERO } else { field(*p) })
                    .collect()
            })
            .collect();
        let basis = ModalBasis::new(&mesh, vec![1.0, 4.0, 9.0], &shapes);
        let unknowns = laplacian.unknowns();
        // Cut along the halves, cut by number, and whole.
        let [along, by_number] =
            [Some([a, b]), None].map(|halves| TrianglePass::new(rest, mesh.triangles(), unknowns, halves, &basis));
        let whole = TrianglePass { half: by_number.chunks.len(), ..by_number.clone() };
        assert!(along.splits() && by_number.splits() && !whole.splits());
        let passes = [along, by_number, whole];
        let y: Vec<DVec3> = (0..rest.len()).map(|v| DVec3::new((0.3 * v as f64).sin(), -1.0, 0.2)).collect();
        let z: Vec<f64> = (0..rest.len()).map(|v| (0.11 * v as f64).cos()).collect();
        let q = [1.2, -0.7, 0.5];
        let moving: Vec<[usize; 3]> =
            mesh.triangles().iter().filter(|t| t.iter().any(|&v| unknowns[v] != NONE)).copied().collect();
        let (order, half, _) = cut(&moving, unknowns, Some([a, b]));
        assert!(order[..half * LANES].iter().any(Option::is_none), "the first half's last chunk is padded");
        let results: Vec<(Vec<Padded>, Vec<f64>, Vec<f64>)> = passes
            .iter()
            .map(|pass| {
                let (mut rhs, mut scratch, mut force) = (vec![Padded::ZERO; laplacian.dim()], Vec::new(), vec![0.0; 3]);
                let mut drags = [pass.drag_rows(rest.len() - 1, &z)];
                let loads = pass.moments(&y);
                pass.run(
                    &q,
                    Some((&loads, &mut force)),
                    Some(RightSide { rhs: &mut rhs, scratch: &mut scratch }),
                    &mut drags,
                );
                let [drag] = drags;
                // A pass for the force alone gives the same force.
                let mut alone = vec![0.0; 3];
                pass.run(&q, Some((&loads, &mut alone)), None, &mut []);
                assert_eq!(alone, force);
                (rhs, force, drag.rows)
            })
            .collect();
        let (rhs, force, rows) = &results[2];
        let largest = rhs.iter().map(|b| DVec3::from(*b).length()).fold(0.0, f64::max);
        let top = rhs[b..].iter().filter(|t| DVec3::from(**t).length() > 1e-3 * largest).count();
        assert!(top > 0, "the top's unknowns take terms");
        for (name, (cut_rhs, cut_force, cut_rows)) in ["along the halves", "by number"].iter().zip(&results) {
            let worst =
                cut_rhs.iter().zip(rhs).map(|(c, w)| (DVec3::from(*c) - DVec3::from(*w)).length()).fold(0.0, f64::max);
            eprintln!(
                "cut {name}: {} unknowns, halves {a} and {}, top {}; worst {worst:.1e} of {largest:.1e}",
                rhs.len(),
                b - a,
                rhs.len() - b
            );
            assert!(worst <= 1e-13 * largest, "{name}: {worst} of {largest}");
            for (cut, whole) in cut_force.iter().chain(cut_rows).zip(force.iter().chain(rows)) {
                assert!((cut - whole).abs() <= 1e-12 * whole.abs().max(1.0), "{name}: {cut} against {whole}");
            }
        }
    }
}
