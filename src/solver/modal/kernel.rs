//! The per-vertex pass of every LMA / MWTS step: from the modal coordinates `q`, the positions
//! `x_i = X_i + u_i` and the modal force `g = Φᵀ R̃ᵀ f` at the new rotations, in one stream through
//! `Φ` and `Ψ`.
//!
//! Per vertex: `l = Φ_i q`, `w = Ψ_i q`, the warp coefficients of `|w|²`, `u = l + b (w × l) +
//! c (w × (w × l))`, `Rᵀf = f − a (w × f) + b (w × (w × f))`, and `g_j += Φ_ijᵀ Rᵀf` (LMA: `u = l`,
//! `Rᵀf = f`). Vertices go [`LANES`] at a time in the chunked layout of [`ModalBasis`], so every
//! operation is a SIMD operation across vertices; the pass is compiled for the best instruction set
//! the CPU has (AVX2 + FMA where available, chosen at run time; products and sums are written as
//! fused multiply-adds, which is also one rounding fewer).

use glam::DVec3;

use super::basis::{LANES, ModalBasis, Rows, chunks};
use super::warp::coefficients_lanes;

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
        pulp::Arch::new().dispatch(self);
    }
}

impl pulp::WithSimd for VertexPass<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let Self { basis, q, rest, forces, warp, positions, force } = self;
        let m = basis.modes();
        let mut acc = vec![[0.0; LANES]; m];
        for (c, ((out, x), f)) in positions.chunks_mut(LANES).zip(&rest.0).zip(&forces.0).enumerate() {
            let (phi, psi) = basis.chunk(c);
            let l = combine(phi, q);
            // MWTS: the warp first, so its temporaries are dead before the force's are made.
            let (u, local) = if warp {
                let w = combine(psi, q);
                let mut t = [0.0; LANES];
                for k in 0..LANES {
                    t[k] = w[0][k].mul_add(w[0][k], w[1][k].mul_add(w[1][k], w[2][k] * w[2][k]));
                }
                let [a, b, cc] = coefficients_lanes(&t);
                (rodrigues(&w, &l, &b, &cc), rodrigues(&w, f, &a.map(|x| -x), &b))
            } else {
                (l, *f)
            };
            for (k, p) in out.iter_mut().enumerate() {
                *p = DVec3::new(x[0][k] + u[0][k], x[1][k] + u[1][k], x[2][k] + u[2][k]);
            }
            for (rows, accj) in phi.iter().zip(acc.iter_mut()) {
                let mut s = *accj;
                for (row, loc) in rows.iter().zip(&local) {
                    for k in 0..LANES {
                        s[k] = row[k].mul_add(loc[k], s[k]);
                    }
                }
                *accj = s;
            }
        }
        for (g, accj) in force.iter_mut().zip(&acc) {
            *g = accj.iter().sum();
        }
    }
}

/// `Σ_j q_j · rows_j` for one chunk of `Φ` or `Ψ`.
#[inline(always)]
fn combine(data: &[Rows], q: &[f64]) -> Rows {
    let mut out = [[0.0; LANES]; 3];
    for (rows, &qj) in data.iter().zip(q) {
        for (o, row) in out.iter_mut().zip(rows) {
            for k in 0..LANES {
                o[k] = row[k].mul_add(qj, o[k]);
            }
        }
    }
    out
}

/// `v + s (w × v) + t (w × (w × v))`, lane-wise: the warp `(∫₀¹ exp(s[w]×) ds) v` for `s = b`,
/// `t = c`, and `Rᵀ v` for `s = −a`, `t = b`.
#[inline(always)]
fn rodrigues(w: &Rows, v: &Rows, s: &[f64; LANES], t: &[f64; LANES]) -> Rows {
    let wv = cross(w, v);
    let wwv = cross(w, &wv);
    let mut out = *v;
    for ((o, x), y) in out.iter_mut().zip(&wv).zip(&wwv) {
        for k in 0..LANES {
            o[k] = s[k].mul_add(x[k], t[k].mul_add(y[k], o[k]));
        }
    }
    out
}

/// Lane-wise cross product.
#[inline(always)]
fn cross(a: &Rows, b: &Rows) -> Rows {
    let mut out = [[0.0; LANES]; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let (j, l) = ((i + 1) % 3, (i + 2) % 3);
        for k in 0..LANES {
            o[k] = a[j][k].mul_add(b[l][k], -(a[l][k] * b[j][k]));
        }
    }
    out
}
