//! Which of a set of triangles have turned by more than an angle since their normals were taken
//! (self-collision's test that its flat patches are still flat, [`super::self_collision`]).
//!
//! The test runs every substep over every triangle of the cloth, at the substep's start and its
//! predicted end, eight triangles at a time in single precision, at both positions at once
//! ([`super::triangle_scan`]). Rounding cannot pass a triangle that has turned too far: the test is for an
//! angle a hundredth of a radian (0.57°) under the limit, and a triangle passes only if the rounding
//! of its normal (bounded from its corners' distance from the rows' origin and its edges,
//! [`triangle_scan::rounded_normal`]) is under half of that.

use glam::DVec3;

use super::batch::{Batch, CONSTANTS, Indexed, LANES, Row};
use super::triangle_scan;
use crate::linalg::real::{self, Real, V3};

/// How much under the limit the single-precision test holds its triangles, radians.
const SLACK: f64 = 1e-2;

/// Triangles and their normals, watched for turning, eight to a batch in their order (triangle `t` is
/// lane `t % 8` of batch `t / 8`; lanes past a batch's count repeat its last).
#[derive(Debug, Clone, Default)]
pub struct Watch {
    batches: Vec<Batch<3, 0>>,
}

impl Watch {
    /// Watch these triangles, with their unit normals now.
    pub fn new(triangles: impl IntoIterator<Item = ([u32; 3], DVec3)>) -> Self {
        Self { batches: triangle_scan::pack(triangles.into_iter().map(|(t, n)| (t, n.to_array()))) }
    }

    /// Take triangle `t`'s unit normal now (its lane, and the lanes after it that repeat it).
    pub fn set(&mut self, t: usize, normal: DVec3) {
        let b = &mut self.batches[t / LANES];
        let lanes = if t % LANES + 1 == b.count { t % LANES..LANES } else { t % LANES..t % LANES + 1 };
        for (values, n) in b.constants.iter_mut().zip(normal.to_array()) {
            values[lanes.clone()].fill(n as f32);
        }
    }

    /// Take every triangle's unit normal now (`normals`, in the triangles' order).
    pub fn set_all(&mut self, normals: &[DVec3]) {
        for (batch, normals) in self.batches.iter_mut().zip(normals.chunks(LANES)) {
            for (k, n) in (0..LANES).map(|k| (k, normals[k.min(normals.len() - 1)].to_array())) {
                (0..3).for_each(|c| batch.constants[c][k] = n[c] as f32);
            }
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
        if rows[0].mask != rows[1].mask {
            turned.clear();
            turned.extend(self.batches.iter().enumerate().flat_map(|(b, batch)| triangle_scan::lanes(b, batch, 0xff)));
            return;
        }
        triangle_scan::failing(&self.batches, rows, Turn::new(angle), fastest, turned);
    }
}

/// The test's constants: the cosine of the tested angle (the limit less the slack) and the sine of
/// half the slack, squared.
#[derive(Debug, Clone, Copy)]
struct Turn {
    cos2: f64,
    sin2: f64,
}

impl Turn {
    fn new(angle: f64) -> Self {
        Self { cos2: (angle - SLACK).cos().powi(2), sin2: (0.5 * SLACK).sin().powi(2) }
    }

    /// Positive where a triangle with corners `c` has turned from `normal` by less than the tested
    /// angle, with its normal's rounding under half the slack; else zero or less (or NaN).
    #[inline(always)]
    fn margin<N: Real>(&self, c: [V3<N>; 3], normal: V3<N>) -> N {
        let zero = c[0][0].constant(0.0);
        let (n, error) = triangle_scan::rounded_normal(c);
        let (along, length2) = (real::dot(n, normal), real::dot(n, n));
        let within = along * along - zero.constant(self.cos2) * length2;
        let exact = zero.constant(self.sin2) * length2 - error * error;
        let m = N::select(zero.less(along), within, zero);
        N::select(zero.less(m), exact, zero)
    }
}

impl triangle_scan::Test<2> for Turn {
    /// Positive where the triangle has turned by less than the tested angle at both ends.
    #[inline(always)]
    fn margin<N: Real>(&self, [start, end]: [[V3<N>; 3]; 2], normal: [N; CONSTANTS]) -> N {
        let m = Turn::margin(self, start, normal);
        N::select(m.constant(0.0).less(m), Turn::margin(self, end, normal), m)
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

    /// Taking every normal at once packs the batches as taking them one by one does, the lanes past a
    /// batch's count included.
    #[test]
    fn every_normal_taken_at_once_is_each_taken_alone() {
        let triangles: Vec<([u32; 3], DVec3)> = (0..13u32).map(|k| ([3 * k, 3 * k + 1, 3 * k + 2], DVec3::Z)).collect();
        let normals: Vec<DVec3> =
            (0..13).map(|k| DVec3::new((0.3 * k as f64).sin(), 0.2, (0.3 * k as f64).cos()).normalize()).collect();
        let (mut alone, mut at_once) = (Watch::new(triangles.clone()), Watch::new(triangles));
        normals.iter().enumerate().for_each(|(t, &n)| alone.set(t, n));
        at_once.set_all(&normals);
        assert_eq!(alone.batches, at_once.batches);
        assert_ne!(alone.batches, Watch::new((0..13u32).map(|k| ([3 * k, 3 * k + 1, 3 * k + 2], DVec3::Z))).batches);
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
