//! The eight-lane sweep's moves between a batch's particle rows and its lanes (AVX2): each lane's
//! row (position and inverse mass, 32 bytes) loaded whole, made relative to the lane's first particle
//! in double precision, narrowed and transposed into registers of x, y, z and inverse mass; and the
//! moves transposed back and added to the rows in double precision, as are the multipliers.

use std::arch::x86_64::{__m128, __m256, __m256d};

use pulp::cast;
use pulp::x86::V3;

use super::batch::{Batch, CONSTANTS, LANES, Row};
use super::project::{Projected, Read};
use crate::linalg::real::{Lanes32, Real};

/// What reading and writing a batch's lanes needs besides the batch: the instruction set, the
/// sweep's compliances and the lanes' indices.
#[derive(Clone, Copy)]
pub struct Eight<const F: usize> {
    simd: V3,
    compliance: [__m256; F],
    index: __m256,
    /// The substep's first sweep: multipliers read as zero and overwritten.
    first: bool,
    /// The substep's last sweep: multipliers left as they are.
    last: bool,
}

impl<const F: usize> Eight<F> {
    /// For a sweep of these compliances, the substep's first or not and last or not.
    #[inline(always)]
    pub fn new(simd: V3, compliance: [f64; F], (first, last): (bool, bool)) -> Self {
        let index = cast([0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        let mut lanes = [simd.avx._mm256_setzero_ps(); F];
        for (lanes, &c) in lanes.iter_mut().zip(&compliance) {
            *lanes = simd.avx._mm256_set1_ps(c as f32);
        }
        Self { simd, compliance: lanes, index, first, last }
    }

    #[inline(always)]
    fn lanes(self, v: __m256) -> Lanes32<V3> {
        Lanes32 { simd: self.simd, v: cast(v) }
    }

    /// A batch's lanes as the projection reads them.
    #[inline(always)]
    pub fn read<const K: usize>(
        self,
        rows: &[Row],
        batch: &Batch<K, F>,
        lambda: &[[f64; LANES]; F],
    ) -> Read<Lanes32<V3>, K, F> {
        let (simd, avx) = (self.simd, self.simd.avx);
        // Each lane's origin: its first particle, with no inverse mass to subtract.
        let mut origins = [avx._mm256_setzero_pd(); LANES];
        for (origin, &i) in origins.iter_mut().zip(&batch.ids[0]) {
            *origin = avx._mm256_blend_pd::<0b1000>(cast(rows[i as usize].0), avx._mm256_setzero_pd());
        }
        let zero = self.lanes(avx._mm256_setzero_ps());
        let (mut x, mut w) = ([[zero; 3]; K], [zero; K]);
        for j in 0..K {
            let [px, py, pz, pw] = gather(simd, rows, &batch.ids[j], &origins);
            (x[j], w[j]) = ([self.lanes(px), self.lanes(py), self.lanes(pz)], self.lanes(pw));
        }
        let (mut multipliers, mut compliances) = ([zero; F], [zero; F]);
        for f in 0..F {
            compliances[f] = self.lanes(avx._mm256_mul_ps(cast(batch.factors[f]), self.compliance[f]));
            if !self.first {
                multipliers[f] = self.lanes(narrow(simd, halves(&lambda[f])));
            }
        }
        let mut constants = [zero; CONSTANTS];
        for (constant, values) in constants.iter_mut().zip(&batch.constants) {
            *constant = self.lanes(cast(*values));
        }
        Read { x, w, constants, lambda: multipliers, compliance: compliances }
    }

    /// A batch's projection, added to its rows and multipliers.
    #[inline(always)]
    pub fn write<const K: usize>(
        self,
        rows: &mut [Row],
        batch: &Batch<K, F>,
        lambda: &mut [[f64; LANES]; F],
        (deltas, steps): Projected<Lanes32<V3>, K, F>,
    ) {
        let (simd, avx) = (self.simd, self.simd.avx);
        // Lanes past the batch's count add nothing to their multipliers.
        let real = self.lanes(self.index).less(self.lanes(avx._mm256_set1_ps(batch.count as f32)));
        for (lambda, delta) in lambda.iter_mut().zip(deltas).filter(|_| !self.last) {
            let delta: __m256 = cast(Lanes32::select(real, delta, self.lanes(avx._mm256_setzero_ps())).v);
            let wide = [
                avx._mm256_cvtps_pd(avx._mm256_castps256_ps128(delta)),
                avx._mm256_cvtps_pd(avx._mm256_extractf128_ps::<1>(delta)),
            ];
            let (lo, hi): ([f64; 4], [f64; 4]) = if self.first {
                (cast(wide[0]), cast(wide[1]))
            } else {
                let [lo, hi] = halves(lambda);
                (cast(avx._mm256_add_pd(lo, wide[0])), cast(avx._mm256_add_pd(hi, wide[1])))
            };
            *lambda = [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]];
        }
        for (ids, [sx, sy, sz]) in batch.ids.iter().zip(steps) {
            scatter(simd, rows, ids, batch.count, [cast(sx.v), cast(sy.v), cast(sz.v)]);
        }
    }
}

/// Eight doubles as two registers.
#[inline(always)]
fn halves(v: &[f64; LANES]) -> [__m256d; 2] {
    [cast([v[0], v[1], v[2], v[3]]), cast([v[4], v[5], v[6], v[7]])]
}

/// `[lo, hi]` (four doubles each) as eight singles.
#[inline(always)]
fn narrow(simd: V3, [lo, hi]: [__m256d; 2]) -> __m256 {
    let avx = simd.avx;
    avx._mm256_insertf128_ps::<1>(avx._mm256_castps128_ps256(avx._mm256_cvtpd_ps(lo)), avx._mm256_cvtpd_ps(hi))
}

/// The four-by-four transposes of `a` (each register two blocks of four lanes).
#[inline(always)]
fn transpose(simd: V3, a: [__m256; 4]) -> [__m256; 4] {
    let avx = simd.avx;
    let t: [__m256d; 4] = [
        cast(avx._mm256_unpacklo_ps(a[0], a[1])),
        cast(avx._mm256_unpackhi_ps(a[0], a[1])),
        cast(avx._mm256_unpacklo_ps(a[2], a[3])),
        cast(avx._mm256_unpackhi_ps(a[2], a[3])),
    ];
    [
        cast(avx._mm256_unpacklo_pd(t[0], t[2])),
        cast(avx._mm256_unpackhi_pd(t[0], t[2])),
        cast(avx._mm256_unpacklo_pd(t[1], t[3])),
        cast(avx._mm256_unpackhi_pd(t[1], t[3])),
    ]
}

/// The rows `ids` relative to each lane's origin, in single precision, as registers of x, y, z
/// and inverse mass.
#[inline(always)]
fn gather(simd: V3, rows: &[Row], ids: &[u32; LANES], origins: &[__m256d; LANES]) -> [__m256; 4] {
    let avx = simd.avx;
    let mut r: [__m128; LANES] = [cast([0.0f32; 4]); LANES];
    for k in 0..LANES {
        r[k] = avx._mm256_cvtpd_ps(avx._mm256_sub_pd(cast(rows[ids[k] as usize].0), origins[k]));
    }
    // Lanes k and k + 4 side by side: x y z w | x y z w.
    let mut a = [avx._mm256_setzero_ps(); 4];
    for k in 0..4 {
        a[k] = avx._mm256_insertf128_ps::<1>(avx._mm256_castps128_ps256(r[k]), r[k + 4]);
    }
    transpose(simd, a)
}

/// Add the moves `[x, y, z]` of the first `count` lanes to the rows `ids`, in double precision.
#[inline(always)]
fn scatter(simd: V3, rows: &mut [Row], ids: &[u32; LANES], count: usize, [x, y, z]: [__m256; 3]) {
    let avx = simd.avx;
    // Lanes k and k + 4 of a[k]: x y z 0 | x y z 0.
    let a = transpose(simd, [x, y, z, avx._mm256_setzero_ps()]);
    for (k, &i) in ids.iter().enumerate().take(count) {
        let half = if k < 4 { avx._mm256_castps256_ps128(a[k]) } else { avx._mm256_extractf128_ps::<1>(a[k - 4]) };
        let row = &mut rows[i as usize];
        row.0 = cast(avx._mm256_add_pd(cast(row.0), avx._mm256_cvtps_pd(half)));
    }
}
