//! Which of a set of triangles have turned by more than an angle since their normals were taken
//! (self-collision's test that its flat patches are still flat, [`super::self_collision`]).
//!
//! The test runs every substep over every triangle of the cloth, at the substep's start and its
//! predicted end, so it takes eight triangles at a time where the CPU has AVX2, in single precision,
//! at both positions at once, from the rows the sweeps read ([`super::batch::Rows`]: positions
//! rounded once, relative to the first particle), each batch's corners loaded as the sweeps load
//! theirs ([`super::eight`]). Rounding cannot pass a triangle that
//! has turned too far: the test is for an angle a hundredth of a radian (0.57°) under the limit, and a
//! triangle passes only if the rounding of its normal (bounded from its corners' distance from the
//! rows' origin and its edges) is under half of that. A CPU without AVX2 runs the same arithmetic one
//! triangle at a time.

use glam::DVec3;

use super::batch::{Batch, Batches, CONSTANTS, Indexed, LANES, Packable, Row};
use crate::linalg::real::{self, Lanes32, Real, V3};

/// How much under the limit the single-precision test holds its triangles, radians.
const SLACK: f64 = 1e-2;

/// A watched triangle: its corners and its unit normal when it was taken, packed as a lane of the
/// sweeps' batches are ([`Batches`]: the corners as its particles, the normal as its constants).
#[derive(Debug, Clone, Copy)]
struct Watched([u32; 3], DVec3);

impl Packable<3, 0> for Watched {
    fn particles(&self) -> [usize; 3] {
        self.0.map(|i| i as usize)
    }
    fn constants(&self) -> [f64; CONSTANTS] {
        self.1.to_array()
    }
    fn factors(&self) -> [f64; 0] {
        []
    }
}

/// Triangles and their normals, watched for turning, eight to a batch in their order (triangle `t` is
/// lane `t % 8` of batch `t / 8`; lanes past a batch's count repeat its last).
#[derive(Debug, Clone, Default)]
pub struct Watch {
    batches: Vec<Batch<3, 0>>,
}

impl Watch {
    /// Watch these triangles, with their unit normals now.
    pub fn new(triangles: impl IntoIterator<Item = ([u32; 3], DVec3)>) -> Self {
        let all: Vec<Watched> = triangles.into_iter().map(|(t, n)| Watched(t, n)).collect();
        Self { batches: Batches::new(&all, &[0, all.len()]).batches }
    }

    /// Take triangle `t`'s unit normal now (its lane, and the lanes after it that repeat it).
    pub fn set(&mut self, t: usize, normal: DVec3) {
        let b = &mut self.batches[t / LANES];
        let lanes = if t % LANES + 1 == b.count { t % LANES..LANES } else { t % LANES..t % LANES + 1 };
        for (values, n) in b.constants.iter_mut().zip(normal.to_array()) {
            values[lanes.clone()].fill(n as f32);
        }
    }

    /// Into `turned` (cleared first), in order, the watched triangles that have turned at the
    /// positions of either of `rows` by `angle` or more since their normals were taken (or have no
    /// normal there); maybe also some that turned by a little less, never one that turned by less
    /// than `angle` − 10 mrad.
    pub fn turned(&self, rows: [Indexed<&[Row]>; 2], angle: f64, turned: &mut Vec<u32>) {
        self.check(rows, angle, true, turned);
    }

    /// [`Self::turned`], eight triangles at a time if `fastest` and the CPU has AVX2, else one at a time.
    fn check(&self, rows: [Indexed<&[Row]>; 2], angle: f64, fastest: bool, turned: &mut Vec<u32>) {
        turned.clear();
        if rows[0].mask != rows[1].mask {
            turned.extend(self.batches.iter().enumerate().flat_map(|(b, batch)| lanes(b, batch, 0xff)));
            return;
        }
        let test = Test::new(angle);
        #[cfg(target_arch = "x86_64")]
        let turned = if fastest {
            match crate::linalg::isa::eight(Eight { test, batches: &self.batches, rows, turned }) {
                Ok(()) => return,
                Err(kernel) => kernel.turned,
            }
        } else {
            turned
        };
        let one = |v: f32| Lanes32 { simd: pulp::Scalar::new(), v };
        for (b, batch) in self.batches.iter().enumerate() {
            let failed = (0..LANES).filter(|&k| {
                let normal = [one(batch.constants[0][k]), one(batch.constants[1][k]), one(batch.constants[2][k])];
                rows.iter().any(|rows| {
                    let corner = |c: usize| {
                        let r = rows.rows[batch.ids[c][k] as usize].0;
                        [one(r[0]), one(r[1]), one(r[2])]
                    };
                    let margin = test.margin([corner(0), corner(1), corner(2)], normal).v;
                    margin <= 0.0 || margin.is_nan()
                })
            });
            let mask = failed.fold(0, |mask, k| mask | 1 << k);
            turned.extend(lanes(b, batch, mask));
        }
    }
}

/// The triangles of batch `b` at the lanes set in `mask` (those past its count repeat its last).
fn lanes(b: usize, batch: &Batch<3, 0>, mask: i32) -> impl Iterator<Item = u32> {
    (0..batch.count).filter(move |&k| mask >> k & 1 != 0).map(move |k| (b * LANES + k) as u32)
}

/// The test's constants: the cosine of the tested angle (the limit less the slack) and the sine of
/// half the slack, squared; and the bounds on rounding, with room to spare.
#[derive(Debug, Clone, Copy)]
struct Test {
    cos2: f64,
    sin2: f64,
    /// A row's rounding per coordinate, in units of its distance from the origin.
    position: f64,
    /// A product's relative rounding.
    product: f64,
}

impl Test {
    fn new(angle: f64) -> Self {
        let unit = f64::from(f32::EPSILON);
        Self {
            cos2: (angle - SLACK).cos().powi(2),
            sin2: (0.5 * SLACK).sin().powi(2),
            position: unit,
            product: 4.0 * unit,
        }
    }

    /// Positive where a triangle with corners `c` has turned from `normal` by less than the tested
    /// angle, with its normal's rounding under half the slack; else zero or less (or NaN).
    #[inline(always)]
    fn margin<N: Real>(&self, c: [V3<N>; 3], normal: V3<N>) -> N {
        let zero = c[0][0].constant(0.0);
        let (e1, e2) = (real::sub(c[1], c[0]), real::sub(c[2], c[0]));
        let n = real::cross(e1, e2);
        let (along, length2) = (real::dot(n, normal), real::dot(n, n));
        // The normal's rounding. Every corner is within `r = |c₀|₁ + |e₁|₁ + |e₂|₁` of the origin in
        // each coordinate, so was rounded by at most `r ε/2` there, and each edge is off by at most
        // `r ε` per coordinate, `√3 r ε < 2 r ε = d` along its length; that moves the normal by at
        // most `d (|e₁| + |e₂| + d)`, and the cross product's own rounding adds under `4ε |e₁|₁|e₂|₁`.
        let (l1, l2) = (norm1(e1), norm1(e2));
        let d = zero.constant(2.0 * self.position) * (norm1(c[0]) + l1 + l2);
        let error = d * (l1 + l2 + d) + zero.constant(self.product) * l1 * l2;
        let within = along * along - zero.constant(self.cos2) * length2;
        let exact = zero.constant(self.sin2) * length2 - error * error;
        let m = N::select(zero.less(along), within, zero);
        N::select(zero.less(m), exact, zero)
    }
}

/// `|v|₁`.
#[inline(always)]
fn norm1<N: Real>(v: V3<N>) -> N {
    v[0].abs() + v[1].abs() + v[2].abs()
}

/// The test eight triangles at a time, as a kernel for [`crate::linalg::isa::eight`].
#[cfg(target_arch = "x86_64")]
struct Eight<'a> {
    test: Test,
    batches: &'a [Batch<3, 0>],
    rows: [Indexed<&'a [Row]>; 2],
    turned: &'a mut Vec<u32>,
}

#[cfg(target_arch = "x86_64")]
impl crate::linalg::isa::Eight for Eight<'_> {
    type Output = ();

    #[inline(always)]
    fn run(self, simd: pulp::x86::V3) {
        use pulp::cast;
        // Loops, not closures: a closure the compiler declines to inline would run without AVX2.
        let zero = Lanes32 { simd, v: cast(simd.avx._mm256_setzero_ps()) };
        // Sliced to the mask, so that indices masked by it need no bounds checks.
        let [start, end] = self.rows;
        let (start, end) =
            (Indexed { rows: &start.rows[..=start.mask], ..start }, Indexed { rows: &end.rows[..=end.mask], ..end });
        for (k, b) in self.batches.iter().enumerate() {
            let (mut c, mut d, mut normal) = ([[zero; 3]; 3], [[zero; 3]; 3], [zero; 3]);
            for ((c, d), ids) in c.iter_mut().zip(&mut d).zip(&b.ids) {
                let [x, y, z, _] = super::eight::gather(simd, start.rows, start.mask, ids);
                *c = [Lanes32 { simd, v: cast(x) }, Lanes32 { simd, v: cast(y) }, Lanes32 { simd, v: cast(z) }];
                let [x, y, z, _] = super::eight::gather(simd, end.rows, end.mask, ids);
                *d = [Lanes32 { simd, v: cast(x) }, Lanes32 { simd, v: cast(y) }, Lanes32 { simd, v: cast(z) }];
            }
            for (n, values) in normal.iter_mut().zip(&b.constants) {
                n.v = cast(*values);
            }
            let (m, n) = (self.test.margin(c, normal), self.test.margin(d, normal));
            let pass = simd.avx._mm256_and_ps(cast(m.constant(0.0).less(m)), cast(n.constant(0.0).less(n)));
            let passed = simd.avx._mm256_movemask_ps(pass);
            if passed != 0xff {
                self.turned.extend(lanes(k, b, !passed & 0xff));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::pbd::batch::Rows;

    /// The rows of positions `y`.
    fn rows(y: &[DVec3]) -> Rows {
        let mut rows = Rows::default();
        rows.fill(y, &vec![1.0; y.len()]);
        rows
    }

    /// The triangles of `watch` turned between `rows`, by either path.
    fn turned(watch: &Watch, rows: [&Rows; 2], limit: f64, fastest: bool) -> Vec<u32> {
        let mut turned = Vec::new();
        watch.check(rows.map(Rows::indexed), limit, fastest, &mut turned);
        turned
    }

    /// A triangle of a flat sheet far from the origin, turned about its first edge by `degrees`.
    fn turned_triangle(degrees: f64, offset: DVec3) -> (Vec<DVec3>, [u32; 3]) {
        let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
        (vec![offset, offset + DVec3::new(0.01, 0.0, 0.0), offset + DVec3::new(0.004, 0.009 * c, 0.009 * s)], [0, 1, 2])
    }

    /// The batch test agrees with the angle: a triangle turned under the limit less the slack passes
    /// and one turned to the limit or beyond does not, at the start or the end, in any lane of a batch
    /// and at either path, and only it is reported; its normal taken again, it passes; one with no
    /// normal any more has turned.
    #[test]
    fn a_triangle_has_turned_exactly_when_its_normal_has() {
        let limit = 10f64.to_radians();
        for offset in [DVec3::ZERO, DVec3::new(3.0, -2.0, 1.5)] {
            for (degrees, expect) in
                [(0.0, false), (9.4, false), (10.0, true), (10.5, true), (90.0, true), (200.0, true)]
            {
                // 13 triangles (a full batch and a part-filled one), the one tested in each place.
                for place in [0, 7, 12] {
                    let (mut flat, mut y, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
                    for k in 0..13u32 {
                        let (p, t) = turned_triangle(if k == place { degrees } else { 0.0 }, offset);
                        triangles.push((t.map(|i| i + 3 * k), DVec3::Z));
                        y.extend(p);
                        flat.extend(turned_triangle(0.0, offset).0);
                    }
                    let mut watch = Watch::new(triangles);
                    let (flat, y) = (rows(&flat), rows(&y));
                    for fastest in [true, false] {
                        for (when, both) in [("end", [&flat, &y]), ("start", [&y, &flat])] {
                            let got = turned(&watch, both, limit, fastest);
                            let want = if expect { vec![place] } else { vec![] };
                            assert_eq!(got, want, "{degrees}° at {place} at the {when}, {offset}, fastest {fastest}");
                        }
                    }
                    // Its normal taken as it is now (the first edge is along x): no longer turned.
                    let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
                    watch.set(place as usize, DVec3::new(0.0, -s, c));
                    for fastest in [true, false] {
                        assert!(turned(&watch, [&y, &y], limit, fastest).is_empty(), "{degrees}° at {place} taken");
                    }
                }
            }
        }
        let (mut y, t) = turned_triangle(0.0, DVec3::ZERO);
        y[2] = y[0] + 0.5 * (y[1] - y[0]);
        for fastest in [true, false] {
            let y = rows(&y);
            assert!(
                turned(&Watch::new([(t, DVec3::Z)]), [&y, &y], limit, fastest) == [0],
                "a degenerate triangle has turned"
            );
        }
    }

    /// A cloth whose triangles are small for its distance from the first vertex (rounding over half
    /// the slack) counts as turned rather than risk passing a turned one.
    #[test]
    fn rounding_too_coarse_for_the_triangles_counts_as_turned() {
        let (mut y, t) = turned_triangle(0.0, DVec3::new(1.0, 0.0, 0.0));
        let limit = 10f64.to_radians();
        for fastest in [true, false] {
            let y = rows(&y);
            assert!(turned(&Watch::new([(t, DVec3::Z)]), [&y, &y], limit, fastest).is_empty());
        }
        y.insert(0, DVec3::new(-1e5, 0.0, 0.0));
        for fastest in [true, false] {
            let y = rows(&y);
            assert_eq!(turned(&Watch::new([(t.map(|i| i + 1), DVec3::Z)]), [&y, &y], limit, fastest), [0]);
        }
    }
}
