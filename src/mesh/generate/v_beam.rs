//! The V-beam: two strips meeting at a crease, the curved-rest-shape test of the thin-shell solver.

use glam::DVec3;

use super::grid;
use crate::mesh::{MeshError, TriMesh};

/// Two strips of width `width / 2` meeting at a crease along the x axis, `x ∈ [−length/2, length/2]`.
///
/// The developed coordinate `s ∈ [−width/2, width/2]` runs across the beam in `segments[1]` cells
/// (which must be even, so the crease is the vertex row `s = 0`); vertex `(x, s)` sits at
/// `(x, |s|·cos(angle/2), s·sin(angle/2))`. So `angle_deg = 180` is exactly [`grid`] with
/// `size = [length, width]`, and smaller angles open a V upward with `angle_deg` between the strips.
///
/// Vertex indexing and triangle winding are those of [`grid`] (index `i * (segments[1] + 1) + j`,
/// normals +y in the flat case, pointing into the V otherwise). `angle_deg` must lie in `[10, 180]`.
pub fn v_beam(length: f64, width: f64, angle_deg: f64, segments: [usize; 2]) -> Result<TriMesh, MeshError> {
    if !(length.is_finite() && length > 0.0) {
        return Err(MeshError::BadParameter { name: "length", reason: format!("must be positive, got {length}") });
    }
    if !(width.is_finite() && width > 0.0) {
        return Err(MeshError::BadParameter { name: "width", reason: format!("must be positive, got {width}") });
    }
    if !(10.0..=180.0).contains(&angle_deg) {
        return Err(MeshError::BadParameter {
            name: "angle_deg",
            reason: format!("must lie in [10, 180] degrees, got {angle_deg}"),
        });
    }
    if !segments[1].is_multiple_of(2) {
        return Err(MeshError::BadParameter {
            name: "segments",
            reason: format!("cells across must be even so the crease is a vertex row, got {}", segments[1]),
        });
    }
    let flat = grid([length, width], segments)?;
    let half = (angle_deg / 2.0).to_radians();
    let (sin, cos) = half.sin_cos();
    // The grid puts s on z; the middle row j = segments[1]/2 is exactly z = 0.
    let positions = flat.positions().iter().map(|p| DVec3::new(p.x, p.z.abs() * cos, p.z * sin)).collect();
    flat.with_positions(positions)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_v_beam_is_the_grid() {
        let v = v_beam(2.0, 0.5, 180.0, [8, 4]).unwrap();
        let g = grid([2.0, 0.5], [8, 4]).unwrap();
        assert_eq!(v.triangles(), g.triangles());
        for (a, b) in v.positions().iter().zip(g.positions()) {
            assert!((*a - *b).length() < 1e-15);
        }
    }

    #[test]
    fn crease_row_and_opening_angle() {
        let (nx, nz) = (6, 4);
        let m = v_beam(3.0, 1.0, 90.0, [nx, nz]).unwrap();
        let p = m.positions();
        let id = |i: usize, j: usize| i * (nz + 1) + j;
        for i in 0..=nx {
            let crease = p[id(i, nz / 2)];
            assert_eq!((crease.y, crease.z), (0.0, 0.0));
            // The two outer edges make a 90° angle at the crease and sit at distance width/2.
            let (a, b) = (p[id(i, 0)] - crease, p[id(i, nz)] - crease);
            assert!((a.length() - 0.5).abs() < 1e-14 && (b.length() - 0.5).abs() < 1e-14);
            assert!((a.angle_between(b).to_degrees() - 90.0).abs() < 1e-10);
            assert!(a.y > 0.0 && b.y > 0.0, "the V opens upward");
        }
        // Area is preserved (developable).
        assert!((m.triangle_areas().iter().sum::<f64>() - 3.0).abs() < 1e-12);
        assert_eq!(m.topology().boundary_edges.len(), 2 * nx + 2 * nz);
        // Face normals point into the V: up, and towards the crease plane z = 0.
        for t in m.triangles() {
            let [a, b, c] = t.map(|i| p[i]);
            let (n, centre) = ((b - a).cross(c - a), (a + b + c) / 3.0);
            assert!(n.y > 0.0 && n.z * centre.z < 0.0, "triangle {t:?}: normal {n}");
        }
    }

    #[test]
    fn refuses_bad_parameters() {
        assert!(v_beam(1.0, 1.0, 9.0, [4, 4]).is_err());
        assert!(v_beam(1.0, 1.0, 181.0, [4, 4]).is_err());
        assert!(v_beam(1.0, 1.0, f64::NAN, [4, 4]).is_err());
        assert!(v_beam(1.0, 1.0, 90.0, [4, 3]).is_err());
        assert!(v_beam(1.0, 1.0, 90.0, [0, 4]).is_err());
        assert!(v_beam(1.0, 1.0, 90.0, [4, 0]).is_err());
        assert!(v_beam(0.0, 1.0, 90.0, [4, 4]).is_err());
        assert!(v_beam(1.0, f64::INFINITY, 90.0, [4, 4]).is_err());
        assert!(v_beam(1.0, 1.0, 10.0, [4, 4]).is_ok());
        assert!(matches!(
            v_beam(1.0, 1.0, 90.0, [usize::MAX, 2]),
            Err(MeshError::BadParameter { name: "segments", .. })
        ));
    }
}
