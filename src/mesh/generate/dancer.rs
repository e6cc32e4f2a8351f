//! The dancer's shell parts (the modal-warping paper's Fig. 8): a hat, a tunic over the upper body and
//! two trouser legs, as open tubes — four connected components of one mesh, in that order — sized for
//! a figure of `height` metres standing on `y = 0` and facing +z.

use glam::DVec3;

use super::vertex_budget;
use crate::mesh::{MeshError, TriMesh};

/// An open tube along +y from `y0` (radius `r0`) to `y1` (radius `r1`) around `(x, z)`, with `around`
/// segments around and `along` segments along; triangles wound so that normals point outward.
fn tube(
    centre: DVec3,
    (y0, r0): (f64, f64),
    (y1, r1): (f64, f64),
    [around, along]: [usize; 2],
) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let mut positions = Vec::with_capacity(around * (along + 1));
    for j in 0..=along {
        let s = j as f64 / along as f64;
        let (y, r) = (y0 + s * (y1 - y0), r0 + s * (r1 - r0));
        for i in 0..around {
            let a = std::f64::consts::TAU * i as f64 / around as f64;
            positions.push(centre + DVec3::new(r * a.cos(), y, -r * a.sin()));
        }
    }
    let index = |i: usize, j: usize| j * around + i % around;
    let mut triangles = Vec::with_capacity(2 * around * along);
    for j in 0..along {
        for i in 0..around {
            triangles.push([index(i, j), index(i + 1, j), index(i + 1, j + 1)]);
            triangles.push([index(i, j), index(i + 1, j + 1), index(i, j + 1)]);
        }
    }
    (positions, triangles)
}

/// The four parts of a dancer `height` metres tall, `around` segments around each tube.
pub fn dancer(height: f64, around: usize) -> Result<TriMesh, MeshError> {
    if !(height.is_finite() && height > 0.0) {
        return Err(MeshError::BadParameter { name: "height", reason: format!("must be positive, got {height}") });
    }
    if around < 3 {
        return Err(MeshError::BadParameter { name: "around", reason: format!("must be at least 3, got {around}") });
    }
    vertex_budget("around", around.checked_mul(60))?;
    let h = height / 1.8;
    let along = |length: f64| ((length * around as f64 / 0.6).round() as usize).max(2);
    let parts = [
        // Hat: a cone from the brim on the head to a small open top.
        tube(DVec3::ZERO, (1.72 * h, 0.16 * h), (1.98 * h, 0.03 * h), [around, along(0.3)]),
        // Tunic: from the shoulders down over the hips.
        tube(DVec3::ZERO, (0.85 * h, 0.2 * h), (1.5 * h, 0.15 * h), [around, along(0.65)]),
        // Trouser legs: from the hips to the ankles.
        tube(DVec3::new(-0.09 * h, 0.0, 0.0), (0.1 * h, 0.05 * h), (0.95 * h, 0.07 * h), [around, along(0.85)]),
        tube(DVec3::new(0.09 * h, 0.0, 0.0), (0.1 * h, 0.05 * h), (0.95 * h, 0.07 * h), [around, along(0.85)]),
    ];
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for (p, t) in parts {
        let offset = positions.len();
        triangles.extend(t.into_iter().map(|t| t.map(|i| i + offset)));
        positions.extend(p);
    }
    TriMesh::new(positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_open_tubes_in_order() {
        let m = dancer(1.8, 12).unwrap();
        let (component, count) = m.components();
        assert_eq!(count, 4);
        assert!(component.windows(2).all(|w| w[0] <= w[1]), "parts in order");
        let (lo, hi) = m.bounding_box();
        assert!(lo.y >= 0.0 && (hi.y - 1.98).abs() < 1e-9);
        assert!(dancer(-1.0, 12).is_err() && dancer(1.8, 2).is_err());
    }
}
