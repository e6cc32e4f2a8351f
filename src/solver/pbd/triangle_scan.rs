//! Tests run every substep over every triangle of the cloth — the watch's for turning
//! ([`super::turned`]) and the least area's for shrinking ([`super::near_least_area`]) — so they take eight
//! triangles at a time where the CPU has AVX2, in single precision, from the rows the sweeps read
//! ([`super::batch::Rows`]: positions rounded once, relative to the first particle), each batch's
//! corners loaded as the sweeps load theirs ([`super::avx2_lanes`]). A CPU without AVX2 runs the same
//! arithmetic one triangle at a time.

use super::batch::{Batch, Batches, CONSTANTS, Indexed, LANES, Packable, Row};
use crate::linalg::real::{self, Lanes32, Real, V3};

/// A test of a triangle at `R` sets of positions.
pub trait Test<const R: usize>: Copy + Send + Sync {
    /// Positive where the triangle with corners `c` (at each set of positions) and the constants of its
    /// lane passes; else zero or less (or NaN).
    fn margin<N: Real>(&self, c: [[V3<N>; 3]; R], constants: [N; CONSTANTS]) -> N;
}

/// Triangles packed as lanes of the sweeps' batches are (the corners as the particles), eight to a
/// batch in their order: triangle `t` is lane `t % 8` of batch `t / 8`, and lanes past a batch's count
/// repeat its last.
pub type Triangles = [Batch<3, 0>];

/// A triangle as a lane of a scan's batches: its corners as the particles, and its constants.
#[derive(Debug, Clone, Copy)]
struct Lane([u32; 3], [f64; CONSTANTS]);

impl Packable<3, 0> for Lane {
    fn particles(&self) -> [usize; 3] {
        self.0.map(|i| i as usize)
    }
    fn constants(&self) -> [f64; CONSTANTS] {
        self.1
    }
    fn factors(&self) -> [f64; 0] {
        []
    }
}

/// Triangles (their corners) with their constants, packed as [`Triangles`].
pub fn pack(triangles: impl IntoIterator<Item = ([u32; 3], [f64; CONSTANTS])>) -> Vec<Batch<3, 0>> {
    let all: Vec<Lane> = triangles.into_iter().map(|(t, c)| Lane(t, c)).collect();
    Batches::new(&all, &[0, all.len()]).batches
}

/// Scans of at least twice this many batches are made in two halves at once where there are several
/// threads ([`crate::threads::join`]); the halves' lists, joined in order, are the list of one scan.
const SPLIT: usize = 128;

/// Into `failed` (cleared first), in order, the triangles of `batches` that fail `test` at `rows`:
/// eight at a time if `fastest` and the CPU has AVX2, else one at a time.
pub fn failing<T: Test<R>, const R: usize>(
    batches: &Triangles,
    rows: [Indexed<&[Row]>; R],
    test: T,
    fastest: bool,
    failed: &mut Vec<u32>,
) {
    failed.clear();
    let half = batches.len() / 2;
    if crate::threads::threads() > 1 && half >= SPLIT {
        let (first, second) = batches.split_at(half);
        let mut more = Vec::new();
        crate::threads::join(
            || scan(first, 0, rows, test, fastest, failed),
            || scan(second, half, rows, test, fastest, &mut more),
        );
        failed.extend(more);
    } else {
        scan(batches, 0, rows, test, fastest, failed);
    }
}

/// Onto `failed`, in order, the triangles of `batches` (batch `b` of them is batch `first + b` of the
/// scan) that fail `test` at `rows`.
fn scan<T: Test<R>, const R: usize>(
    batches: &Triangles,
    first: usize,
    rows: [Indexed<&[Row]>; R],
    test: T,
    fastest: bool,
    failed: &mut Vec<u32>,
) {
    #[cfg(target_arch = "x86_64")]
    let failed = if fastest {
        match crate::linalg::isa::eight(Eight { test, batches, first, rows, failed }) {
            Ok(()) => return,
            Err(kernel) => kernel.failed,
        }
    } else {
        failed
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = fastest;
    let one = |v: f32| Lanes32 { simd: pulp::Scalar::new(), v };
    for (b, batch) in batches.iter().enumerate() {
        let fails = (0..LANES).filter(|&k| {
            let corners = rows.map(|rows| {
                [0, 1, 2].map(|c| rows.rows[batch.ids[c][k] as usize].0).map(|r| [one(r[0]), one(r[1]), one(r[2])])
            });
            let margin = test.margin(corners, batch.constants.map(|values| one(values[k]))).v;
            margin <= 0.0 || margin.is_nan()
        });
        let mask = fails.fold(0, |mask, k| mask | 1 << k);
        failed.extend(lanes(first + b, batch, mask));
    }
}

/// The triangles of batch `b` at the lanes set in `mask` (those past its count repeat its last).
pub fn lanes(b: usize, batch: &Batch<3, 0>, mask: i32) -> impl Iterator<Item = u32> {
    (0..batch.count).filter(move |&k| mask >> k & 1 != 0).map(move |k| (b * LANES + k) as u32)
}

/// The normal `(c₁ − c₀) × (c₂ − c₀)` of a triangle with corners `c` read from rows (single
/// precision, relative to the rows' origin) and computed in single precision, and a bound on how far
/// it is from the exact normal of the positions the rows were filled from. Every corner is within
/// `r = |c₀|₁ + |e₁|₁ + |e₂|₁` of the origin in each coordinate, so was rounded by at most `r ε/2`
/// there, and each edge is off by at most `r ε` per coordinate, `√3 r ε < 2 r ε = d` along its
/// length; that moves the normal by at most `d (|e₁| + |e₂| + d)`, and the cross product's own
/// rounding adds under `4ε |e₁|₁|e₂|₁`.
#[inline(always)]
pub fn rounded_normal<N: Real>(c: [V3<N>; 3]) -> (V3<N>, N) {
    let unit = f64::from(f32::EPSILON);
    let (e1, e2) = (real::sub(c[1], c[0]), real::sub(c[2], c[0]));
    let (l1, l2) = (norm1(e1), norm1(e2));
    let d = l1.constant(2.0 * unit) * (norm1(c[0]) + l1 + l2);
    (real::cross(e1, e2), d * (l1 + l2 + d) + l1.constant(4.0 * unit) * l1 * l2)
}

/// `|v|₁`.
#[inline(always)]
fn norm1<N: Real>(v: V3<N>) -> N {
    v[0].abs() + v[1].abs() + v[2].abs()
}

/// The test eight triangles at a time, as a kernel for [`crate::linalg::isa::eight`].
#[cfg(target_arch = "x86_64")]
struct Eight<'a, T, const R: usize> {
    test: T,
    batches: &'a Triangles,
    /// Where `batches` begin among the scan's.
    first: usize,
    rows: [Indexed<&'a [Row]>; R],
    failed: &'a mut Vec<u32>,
}

#[cfg(target_arch = "x86_64")]
impl<T: Test<R>, const R: usize> crate::linalg::isa::Eight for Eight<'_, T, R> {
    type Output = ();

    #[inline(always)]
    fn run(self, simd: pulp::x86::V3) {
        use pulp::cast;
        // Loops, not closures: a closure the compiler declines to inline would run without AVX2.
        let zero = Lanes32 { simd, v: cast(simd.avx._mm256_setzero_ps()) };
        // Sliced to the mask, so that indices masked by it need no bounds checks.
        let rows = self.rows.map(|r| Indexed { rows: &r.rows[..=r.mask], ..r });
        for (k, b) in self.batches.iter().enumerate() {
            let (mut c, mut constants) = ([[[zero; 3]; 3]; R], [zero; CONSTANTS]);
            for (j, ids) in b.ids.iter().enumerate() {
                for (c, rows) in c.iter_mut().zip(&rows) {
                    let [x, y, z, _] = super::avx2_lanes::gather(simd, *rows, ids);
                    c[j] = [Lanes32 { simd, v: cast(x) }, Lanes32 { simd, v: cast(y) }, Lanes32 { simd, v: cast(z) }];
                }
            }
            for (constant, values) in constants.iter_mut().zip(&b.constants) {
                constant.v = cast(*values);
            }
            let m = self.test.margin(c, constants);
            let passed = simd.avx._mm256_movemask_ps(cast(m.constant(0.0).less(m)));
            if passed != 0xff {
                self.failed.extend(lanes(self.first + k, b, !passed & 0xff));
            }
        }
    }
}
