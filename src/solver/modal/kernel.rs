//! The per-vertex pass of every LMA / MWTS step: from the modal coordinates `q`, the positions
//! `x_i = X_i + u_i` and the modal force `g = Φᵀ R̃ᵀ f` at the new rotations, in one stream through
//! `Φ` and `Ψ`.
//!
//! Per vertex: `l = Φ_i q`, `w = Ψ_i q`, the warp coefficients of `|w|²`, `u = l + b (w × l) +
//! c (w × (w × l))`, `Rᵀf = f − a (w × f) + b (w × (w × f))`, and `g_j += Φ_ijᵀ Rᵀf` (LMA: `u = l`,
//! `Rᵀf = f`). Vertices go [`LANES`] at a time in the chunked layout of [`ModalBasis`], so every
//! operation is a SIMD operation across vertices; `Φ` and `Ψ` are read in single precision (half the
//! bytes of the stream that bounds a large pass, [`super::basis`]) and widened to double in the
//! registers, where all arithmetic is done; the pass is compiled for the best instruction set
//! the CPU has (AVX2 + FMA where available, chosen at run time; products and sums are written as
//! fused multiply-adds, which is also one rounding fewer).
//!
//! A large pass (at least [`SPLIT`] vertex-modes) goes in two halves of the chunks, each summing its
//! own force, the second's sums then added to the first's: at once on two threads where more than
//! one is set ([`crate::threads`]), else in turn, so the result does not depend on the thread count.
//! A small pass stays whole: handing half of it to another thread costs more than it saves.

use std::ops::Range;

use glam::DVec3;

use pulp::Simd;

use super::basis::{LANES, ModalBasis, Rows, chunks};
use super::warp::{B_SERIES, C_SERIES, past_series, series_terms};

/// Per-vertex vectors (rest positions, external forces) in the chunked layout `[chunk][axis][lane]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ChunkedVectors(Vec<Rows>);

impl ChunkedVectors {
    /// Chunk the vectors of `n` vertices; vertices past the end of `values` (and the padding lanes)
    /// get zero.
    pub fn new(values: &[DVec3], n: usize) -> Self {
        let mut out = vec![[[0.0; LANES]; 3]; chunks(n)];
        for (i, v) in values.iter().enumerate().take(n) {
            for a in 0..3 {
                out[i / LANES][a][i % LANES] = v[a];
            }
        }
        Self(out)
    }
}

/// Passes of at least this many vertices × modes go in two halves (module documentation).
pub const SPLIT: usize = 1 << 18;

/// One pass: the positions and the modal force at `q`. `warp` selects MWTS; otherwise LMA.
pub struct VertexPass<'a> {
    /// The modes.
    pub basis: &'a ModalBasis,
    /// Modal coordinates.
    pub q: &'a [f64],
    /// Rest positions.
    pub rest: &'a ChunkedVectors,
    /// External forces.
    pub forces: &'a ChunkedVectors,
    /// MWTS (warp) or LMA.
    pub warp: bool,
    /// Output: one position per vertex of `basis`.
    pub positions: &'a mut [DVec3],
    /// Output: `g = Φᵀ R̃ᵀ f`, one per mode.
    pub force: &'a mut [f64],
}

impl VertexPass<'_> {
    /// Run the pass, compiled for the best instruction set of this CPU ([`pulp`]'s run-time dispatch
    /// inlines `with_simd` into a function built for it; a closure would not be inlined).
    pub fn run(self) {
        let Self { basis, q, rest, forces, warp, positions, force } = self;
        let total = rest.0.len();
        let part =
            |chunks, positions| pulp::Arch::new().dispatch(Part { basis, q, rest, forces, warp, chunks, positions });
        if positions.len() * basis.modes() < SPLIT {
            force.copy_from_slice(&part(0..total, positions));
            return;
        }
        let half = total / 2;
        let (first, second) = positions.split_at_mut((half * LANES).min(positions.len()));
        force.copy_from_slice(&crate::threads::join_sum(|| part(0..half, first), || part(half..total, second)));
    }
}

/// The chunks `chunks` of a [`VertexPass`], writing their `positions`; returns their force.
struct Part<'a> {
    basis: &'a ModalBasis,
    q: &'a [f64],
    rest: &'a ChunkedVectors,
    forces: &'a ChunkedVectors,
    warp: bool,
    chunks: Range<usize>,
    positions: &'a mut [DVec3],
}

impl pulp::WithSimd for Part<'_> {
    type Output = Vec<f64>;

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> Vec<f64> {
        let Self { basis, q, rest, forces, warp, chunks, positions } = self;
        let m = basis.modes();
        // A chunk's LANES vertices go `S::F64_LANES` at a time (two groups with AVX2).
        let groups = LANES / S::F64_LANES;
        let zero = simd.splat_f64s(0.0);
        let qs: Vec<S::f64s> = q.iter().map(|&x| simd.splat_f64s(x)).collect();
        let mut acc = vec![zero; m * groups];
        for (c, out) in chunks.zip(positions.chunks_mut(LANES)) {
            let (x, f) = (&rest.0[c], &forces.0[c]);
            let (phi, psi) = basis.chunk(c);
            for g in 0..groups {
                let at = |row: &[f64; LANES]| S::as_simd_f64s(row).0[g];
                let wide = |row: &[f32; LANES]| at(&row.map(f64::from));
                let mut l = [zero; 3];
                for (rows, &qj) in phi.iter().zip(&qs) {
                    for (la, row) in l.iter_mut().zip(rows) {
                        *la = simd.mul_add_e_f64s(wide(row), qj, *la);
                    }
                }
                let fv = f.each_ref().map(at);
                let (u, local) = if warp {
                    let mut w = [zero; 3];
                    for (rows, &qj) in psi.iter().zip(&qs) {
                        for (wa, row) in w.iter_mut().zip(rows) {
                            *wa = simd.mul_add_e_f64s(wide(row), qj, *wa);
                        }
                    }
                    let [a, b, cc] = coefficients(simd, &w);
                    // The warp first, so its temporaries are dead before the force's are made.
                    let u = rodrigues(simd, &w, &l, b, cc);
                    (u, rodrigues(simd, &w, &fv, simd.neg_f64s(a), b))
                } else {
                    (l, fv)
                };
                let first = g * S::F64_LANES;
                let u: [&[f64]; 3] = u.each_ref().map(|v| bytemuck::cast_slice(std::slice::from_ref(v)));
                for (k, p) in out.iter_mut().skip(first).take(S::F64_LANES).enumerate() {
                    let at = |a: usize| x[a][first + k] + u[a][k];
                    *p = DVec3::new(at(0), at(1), at(2));
                }
                for (rows, s) in phi.iter().zip(acc.iter_mut().skip(g).step_by(groups)) {
                    for (row, loc) in rows.iter().zip(&local) {
                        *s = simd.mul_add_e_f64s(wide(row), *loc, *s);
                    }
                }
            }
        }
        acc.chunks_exact(groups).map(|accj| accj.iter().map(|&v| simd.reduce_sum_f64s(v)).sum()).collect()
    }
}

/// `[sinθ/θ, (1 − cosθ)/θ², (θ − sinθ)/θ³]` for the rotation vectors `w` of a group of vertices:
/// the series with as many terms as the group's largest angle needs, the closed form for any vertex
/// at or past `π` (see [`super::warp::coefficients`]).
#[inline(always)]
pub(super) fn coefficients<S: Simd>(simd: S, w: &[S::f64s; 3]) -> [S::f64s; 3] {
    let t = simd.mul_add_e_f64s(w[0], w[0], simd.mul_add_e_f64s(w[1], w[1], simd.mul_f64s(w[2], w[2])));
    let top = simd.reduce_max_f64s(t);
    let n = series_terms(top);
    let horner = |series: &[f64]| {
        let mut acc = simd.splat_f64s(series[n - 1]);
        for &ck in series[..n - 1].iter().rev() {
            acc = simd.mul_add_e_f64s(acc, t, simd.splat_f64s(ck));
        }
        acc
    };
    let (b, c) = (horner(&B_SERIES), horner(&C_SERIES));
    let a = simd.mul_add_e_f64s(simd.neg_f64s(t), c, simd.splat_f64s(1.0));
    let mut out = [a, b, c];
    if past_series(top) {
        // Rare (twists past a half turn): per vertex, in closed form.
        let tt: &[f64] = bytemuck::cast_slice(std::slice::from_ref(&t));
        let mut lanes: [[f64; LANES]; 3] = [[0.0; LANES]; 3];
        for (k, &tk) in tt.iter().enumerate() {
            let exact = super::warp::coefficients(tk);
            (0..3).for_each(|i| lanes[i][k] = exact[i]);
        }
        out = lanes.each_ref().map(|l| S::as_simd_f64s(l).0[0]);
    }
    out
}

/// `v + s (w × v) + t (w × (w × v))`, lane-wise: the warp `(∫₀¹ exp(s[w]×) ds) v` for `s = b`,
/// `t = c`, and `Rᵀ v` for `s = −a`, `t = b`.
#[inline(always)]
pub(super) fn rodrigues<S: Simd>(simd: S, w: &[S::f64s; 3], v: &[S::f64s; 3], s: S::f64s, t: S::f64s) -> [S::f64s; 3] {
    let wv = cross(simd, w, v);
    let wwv = cross(simd, w, &wv);
    std::array::from_fn(|i| simd.mul_add_e_f64s(s, wv[i], simd.mul_add_e_f64s(t, wwv[i], v[i])))
}

/// Lane-wise cross product.
#[inline(always)]
pub(super) fn cross<S: Simd>(simd: S, a: &[S::f64s; 3], b: &[S::f64s; 3]) -> [S::f64s; 3] {
    let c = |i: usize, j: usize| simd.mul_add_e_f64s(a[i], b[j], simd.neg_f64s(simd.mul_f64s(a[j], b[i])));
    [c(1, 2), c(2, 0), c(0, 1)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;
    use crate::solver::modal::warp::{rotation, warp_operator};

    /// The SIMD pass against the per-vertex matrix forms `x = X + (∫exp) Φq`, `g = Φᵀ Rᵀ f` with the
    /// single-precision `Φ` and `Ψ` it reads (each within half a unit in the last place of the
    /// double-precision basis), on meshes whose last chunk is partial and whose rotations run from
    /// tiny to past a half turn (every branch of the coefficients: 7, 10 and 16 series terms and the
    /// closed form), one small (a whole pass) and one large enough to go in two halves.
    #[test]
    fn pass_matches_the_per_vertex_matrix_forms() {
        // 39 vertices: four full chunks and one of 7; 87,591: 10,948 full chunks and one of 7.
        for cells in [[12, 2], [300, 290]] {
            pass_matches_the_per_vertex_matrix_forms_on(grid([1.0, 0.3], cells).unwrap());
        }
    }

    fn pass_matches_the_per_vertex_matrix_forms_on(mesh: crate::mesh::TriMesh) {
        let n = mesh.vertex_count();
        assert_ne!(n % LANES, 0);
        let shapes: Vec<Vec<DVec3>> = (0..3i32)
            .map(|j| {
                let s = |p: DVec3| ((j + 1) as f64 * (p.x + 0.5)).powi(j + 2);
                mesh.positions().iter().map(|p| DVec3::new(0.1 * s(*p), s(*p), 0.3 * p.y * s(*p))).collect()
            })
            .collect();
        let basis = ModalBasis::new(&mesh, vec![1.0, 2.0, 3.0], &shapes);
        assert_eq!(n * 3 >= SPLIT, n > 1000, "{n} vertices");
        let forces: Vec<DVec3> = (0..n).map(|i| DVec3::new(0.2, -1.0, 0.1 * i as f64)).collect();
        let (rest, chunked) = (ChunkedVectors::new(mesh.positions(), n), ChunkedVectors::new(&forces, n));
        // The pass's Φ and Ψ: the basis rounded to single precision, entry by entry.
        let single = |v: usize, j: usize| -> (DVec3, DVec3) {
            let (phi, psi): (Vec<f64>, Vec<f64>) = (0..3).map(|a| basis.single(v, a, j)).unzip();
            for a in 0..3 {
                for (got, exact) in [(phi[a], basis.phi(v, a, j)), (psi[a], basis.psi(v, a, j))] {
                    assert!((got - exact).abs() <= exact.abs() * f64::from(f32::EPSILON) / 2.0, "{got} vs {exact}");
                }
            }
            (DVec3::from_slice(&phi), DVec3::from_slice(&psi))
        };
        for scale in [1e-3, 0.1, 0.6, 2.0] {
            let q = [scale, -0.7 * scale, 0.4 * scale];
            let largest = (0..n).map(|v| basis.rotation(v, &q).length()).fold(0.0, f64::max);
            for warp in [false, true] {
                let (mut positions, mut force) = (vec![DVec3::ZERO; n], vec![0.0; 3]);
                VertexPass {
                    basis: &basis,
                    q: &q,
                    rest: &rest,
                    forces: &chunked,
                    warp,
                    positions: &mut positions,
                    force: &mut force,
                }
                .run();
                let mut expected = [0.0; 3];
                for v in 0..n {
                    let rows: Vec<(DVec3, DVec3)> = (0..3).map(|j| single(v, j)).collect();
                    let l = rows.iter().zip(&q).fold(DVec3::ZERO, |acc, ((phi, _), qj)| acc + *phi * *qj);
                    let w = rows.iter().zip(&q).fold(DVec3::ZERO, |acc, ((_, psi), qj)| acc + *psi * *qj);
                    let (u, local) =
                        if warp { (warp_operator(w) * l, rotation(w).transpose() * forces[v]) } else { (l, forces[v]) };
                    let want = mesh.positions()[v] + u;
                    assert!(
                        (positions[v] - want).length() <= 1e-12 * (1.0 + want.length()),
                        "vertex {v}, θ ≤ {largest}"
                    );
                    for (j, e) in expected.iter_mut().enumerate() {
                        *e += rows[j].0.dot(local);
                    }
                }
                for (g, e) in force.iter().zip(&expected) {
                    assert!(
                        (g - e).abs() <= 1e-11 * (1.0 + e.abs()),
                        "modal force {g} vs {e}, θ ≤ {largest}, warp {warp}"
                    );
                }
            }
            if scale == 2.0 {
                assert!(largest > std::f64::consts::PI, "the test reaches the closed form: θ ≤ {largest}");
            }
        }
    }
}
