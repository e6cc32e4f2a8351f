//! Which triangles start a substep near their least area ([`super::project::least_area`]): those
//! whose area, at the substep's start, is under twice the least. The test runs every substep over
//! every triangle, eight at a time in single precision from the rows of the substep's start
//! ([`super::triangle_scan`]), and the bound on the rounding of a normal
//! ([`triangle_scan::rounded_normal`]) keeps every triangle the exact test would keep: it lists a
//! triangle when its area might be under twice the least, and the projection tests the listed ones
//! again in double precision. (Tested one at a time in double precision, it took a noticeable share
//! of the hanging sheet's frame: `BENCHMARKS.md`, *Design measurements quoted from module docs*.)

use super::batch::{Batch, CONSTANTS, Indexed, Row};
use super::triangle_scan;
use crate::linalg::real::{self, Real, V3};

/// The cloth's triangles with twice their rest areas (each its first constant), eight to a batch in
/// their order.
#[derive(Debug, Clone)]
pub struct Areas {
    batches: Vec<Batch<3, 0>>,
}

impl Areas {
    /// These triangles, with twice their rest areas.
    pub fn new(triangles: &[[usize; 3]], double_areas: &[f64]) -> Self {
        Self {
            batches: triangle_scan::pack(
                triangles.iter().zip(double_areas).map(|(t, &a)| (t.map(|i| i as u32), [a, 0.0, 0.0])),
            ),
        }
    }

    /// Into `found` (cleared first), in order, every triangle whose area at `rows` is under `twice`
    /// its least, as a fraction of its rest area (maybe also some whose area is a little over).
    pub fn under(&self, rows: Indexed<&[Row]>, twice: f64, found: &mut Vec<u32>) {
        triangle_scan::failing(&self.batches, [rows], Roomy(twice), true, found);
    }
}

/// The test: a triangle is roomy when twice its area, less its rounding, is at least this fraction of
/// twice its rest area.
#[derive(Debug, Clone, Copy)]
struct Roomy(f64);

impl triangle_scan::Test<1> for Roomy {
    #[inline(always)]
    fn margin<N: Real>(&self, [c]: [[V3<N>; 3]; 1], [rest, _, _]: [N; CONSTANTS]) -> N {
        let (n, error) = triangle_scan::rounded_normal(c);
        let least = rest.constant(self.0) * rest + error;
        real::dot(n, n) - least * least
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::solver::pbd::batch::Rows;

    /// The triangles listed at `y`, by either path.
    fn under(areas: &Areas, y: &[DVec3], twice: f64, fastest: bool) -> Vec<u32> {
        let mut rows = Rows::default();
        rows.fill(y, &vec![1.0; y.len()]);
        let mut found = Vec::new();
        triangle_scan::failing(&areas.batches, [rows.indexed()], Roomy(twice), fastest, &mut found);
        found
    }

    /// Thirteen triangles (a full batch and a part-filled one) far from the origin, squeezed to
    /// fractions of their rest area: those under the bound are listed, in any lane and by either
    /// path, and those clearly over it are not; the double-precision test agrees on every one.
    #[test]
    fn the_triangles_under_the_bound_are_listed_and_the_roomy_ones_are_not() {
        let offset = DVec3::new(3.0, -2.0, 1.5);
        let fractions = [1.0, 0.5, 0.41, 0.39, 0.1, 0.0, -0.3, 0.8, 0.45, 0.35, 1.2, 0.02, 0.4001];
        let (mut y, mut triangles, mut rest) = (Vec::new(), Vec::new(), Vec::new());
        for (k, &f) in fractions.iter().enumerate() {
            let base = offset + DVec3::new(0.05 * k as f64, 0.0, 0.0);
            y.extend([base, base + DVec3::new(0.01, 0.0, 0.0), base + DVec3::new(0.004, 0.009 * f, 0.0)]);
            triangles.push([3 * k, 3 * k + 1, 3 * k + 2]);
            rest.push(0.01 * 0.009);
        }
        let twice = 0.4;
        let areas = Areas::new(&triangles, &rest);
        let exact: Vec<u32> = (0..fractions.len() as u32)
            .filter(|&t| {
                let [a, b, c] = triangles[t as usize].map(|i| y[i]);
                (b - a).cross(c - a).length() < twice * rest[t as usize]
            })
            .collect();
        for fastest in [true, false] {
            let got = under(&areas, &y, twice, fastest);
            assert!(exact.iter().all(|t| got.contains(t)), "{got:?} misses some of {exact:?}");
            let clear: Vec<u32> = (0..fractions.len() as u32).filter(|&t| fractions[t as usize].abs() > 0.41).collect();
            assert!(clear.iter().all(|t| !got.contains(t)), "{got:?} lists a roomy one of {clear:?}");
        }
        assert_eq!(exact.len(), 6, "under 0.4 of the rest area: {exact:?}");
    }
}
