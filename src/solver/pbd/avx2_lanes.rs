//! The eight-lane sweep's moves between a batch's particle rows and its lanes (AVX2): each lane's
//! row (position and inverse mass, 16 bytes of single precision) loaded whole and transposed into
//! registers of x, y, z and inverse mass, made relative to the lane's first particle; and the moved
//! positions transposed back and stored whole. The multipliers are added in double precision.

use std::arch::x86_64::{__m256, __m256d};

use pulp::cast;
use pulp::x86::V3;

use super::batch::{Batch, CONSTANTS, LANES, Projected, Read, Shared, Source};
use crate::linalg::real::Lanes32;

/// A batch's rows as read, particle slot by slot: registers of x, y, z and inverse mass.
pub type Raw<const K: usize> = [[__m256; 4]; K];

/// What reading and writing a batch's lanes needs besides the batch: the instruction set and the
/// sweep's compliances.
#[derive(Clone, Copy)]
pub struct Eight<const F: usize> {
    simd: V3,
    compliance: [__m256; F],
    /// The substep's first sweep: multipliers read as zero and overwritten.
    first: bool,
    /// The substep's last sweep: multipliers left as they are.
    last: bool,
}

impl<const F: usize> Eight<F> {
    /// For a sweep of these compliances, the substep's first or not and last or not.
    #[inline(always)]
    pub fn new(simd: V3, compliance: [f64; F], (first, last): (bool, bool)) -> Self {
        let mut lanes = [simd.avx._mm256_setzero_ps(); F];
        for (lanes, &c) in lanes.iter_mut().zip(&compliance) {
            *lanes = simd.avx._mm256_set1_ps(c as f32);
        }
        Self { simd, compliance: lanes, first, last }
    }

    #[inline(always)]
    fn lanes(self, v: __m256) -> Lanes32<V3> {
        Lanes32 { simd: self.simd, v: cast(v) }
    }

    /// A batch's lanes as the projection reads them, and its rows as they were (transposed), for
    /// [`Self::write`].
    #[inline(always)]
    pub fn read<const K: usize>(
        self,
        rows: Shared<'_>,
        batch: &Batch<K, F>,
        lambda: &[[f64; LANES]; F],
    ) -> (Read<Lanes32<V3>, K, F>, Raw<K>) {
        let (simd, avx) = (self.simd, self.simd.avx);
        // Loops, not closures: a closure the compiler declines to inline would run without AVX2.
        let mut raw: Raw<K> = [[avx._mm256_setzero_ps(); 4]; K];
        for (raw, ids) in raw.iter_mut().zip(&batch.ids) {
            *raw = gather(simd, rows, ids);
        }
        let zero = self.lanes(avx._mm256_setzero_ps());
        let (mut x, mut w) = ([[zero; 3]; K], [zero; K]);
        for j in 0..K {
            // Relative to the lane's first particle (exact for neighbours, Sterbenz).
            for a in 0..3 {
                x[j][a] = self.lanes(avx._mm256_sub_ps(raw[j][a], raw[0][a]));
            }
            w[j] = self.lanes(raw[j][3]);
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
        (Read { x, w, constants, lambda: multipliers, compliance: compliances }, raw)
    }

    /// A batch's projection, added to its rows (as [`Self::read`] gave them) and multipliers.
    #[inline(always)]
    pub fn write<const K: usize>(
        self,
        rows: Shared<'_>,
        batch: &Batch<K, F>,
        lambda: &mut [[f64; LANES]; F],
        raw: Raw<K>,
        (deltas, steps): Projected<Lanes32<V3>, K, F>,
    ) {
        let (simd, avx) = (self.simd, self.simd.avx);
        // Lanes past the batch's count, repeating its last, keep its multipliers: the same each sweep.
        for (lambda, delta) in lambda.iter_mut().zip(deltas).filter(|_| !self.last) {
            let delta: __m256 = cast(delta.v);
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
        for ((ids, [sx, sy, sz]), [x, y, z, w]) in batch.ids.iter().zip(steps).zip(raw) {
            let moved =
                [avx._mm256_add_ps(x, cast(sx.v)), avx._mm256_add_ps(y, cast(sy.v)), avx._mm256_add_ps(z, cast(sz.v))];
            scatter(simd, rows, ids, [moved[0], moved[1], moved[2], w]);
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

/// The rows `ids` as registers of x, y, z and inverse mass.
#[inline(always)]
pub fn gather(simd: V3, rows: impl Source, ids: &[u32; LANES]) -> [__m256; 4] {
    let avx = simd.avx;
    // Lanes k and k + 4 side by side: x y z w | x y z w.
    let mut a = [avx._mm256_setzero_ps(); 4];
    for (k, a) in a.iter_mut().enumerate() {
        let (low, high) = (cast(rows.row(ids[k])), cast(rows.row(ids[k + 4])));
        *a = avx._mm256_insertf128_ps::<1>(avx._mm256_castps128_ps256(low), high);
    }
    transpose(simd, a)
}

/// Store the lanes of registers of x, y, z and inverse mass as the rows `ids`. Lanes past a batch's
/// count repeat its last lane, so they store the rows it stores, with the same values, after it.
#[inline(always)]
fn scatter(simd: V3, rows: Shared<'_>, ids: &[u32; LANES], lanes: [__m256; 4]) {
    let avx = simd.avx;
    // Lanes k and k + 4 of a[k]: x y z w | x y z w.
    let a = transpose(simd, lanes);
    for (k, &i) in ids.iter().enumerate() {
        let half = if k < 4 { avx._mm256_castps256_ps128(a[k]) } else { avx._mm256_extractf128_ps::<1>(a[k - 4]) };
        rows.set(i, cast(half));
    }
}
