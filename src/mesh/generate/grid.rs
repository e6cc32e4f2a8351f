//! Regular grids: beams, strips and cloth sheets.

use glam::DVec3;

use super::vertex_budget;
use crate::mesh::{MeshError, TriMesh};

/// A regular grid in the y = 0 plane centred on the origin, `size[0]` along x by `size[1]` along z,
/// with `segments[0] × segments[1]` cells, each split into two triangles with alternating diagonals
/// (so the mesh has no preferred shear direction). Normals point +y.
///
/// Vertex `(i, j)` (i along x, j along z) has index `i * (segments[1] + 1) + j`. At most
/// [`super::MAX_VERTICES`] vertices.
pub fn grid(size: [f64; 2], segments: [usize; 2]) -> Result<TriMesh, MeshError> {
    if !(size.iter().all(|s| s.is_finite() && *s > 0.0)) {
        return Err(MeshError::BadParameter { name: "size", reason: format!("must be positive, got {size:?}") });
    }
    let [nx, nz] = segments;
    if nx == 0 || nz == 0 {
        return Err(MeshError::BadParameter { name: "segments", reason: "need at least one cell each way".into() });
    }
    let count = nx.checked_add(1).zip(nz.checked_add(1)).and_then(|(a, b)| a.checked_mul(b));
    let mut positions = Vec::with_capacity(vertex_budget("segments", count)?);
    for i in 0..=nx {
        for j in 0..=nz {
            let x = size[0] * (i as f64 / nx as f64 - 0.5);
            let z = size[1] * (j as f64 / nz as f64 - 0.5);
            positions.push(DVec3::new(x, 0.0, z));
        }
    }
    let id = |i: usize, j: usize| i * (nz + 1) + j;
    let mut triangles = Vec::with_capacity(2 * nx * nz);
    for i in 0..nx {
        for j in 0..nz {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            // Counter-clockwise seen from +y: a(x,z) → d(x,z+1) → c(x+1,z+1).
            if (i + j) % 2 == 0 {
                triangles.push([a, d, c]);
                triangles.push([a, c, b]);
            } else {
                triangles.push([a, d, b]);
                triangles.push([b, d, c]);
            }
        }
    }
    TriMesh::new(positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_topology_of_a_3_by_2_grid() {
        let m = grid([3.0, 2.0], [3, 2]).unwrap();
        assert_eq!(m.vertex_count(), 12);
        assert_eq!(m.triangles().len(), 12);
        let t = m.topology();
        // Edges: 3·3 along x + 4·2 along z + 6 diagonals.
        assert_eq!(t.edges.len(), 9 + 8 + 6);
        assert_eq!(t.boundary_edges.len(), 2 * 3 + 2 * 2);
        assert_eq!(t.hinges.len(), t.edges.len() - t.boundary_edges.len());
        assert!((m.triangle_areas().iter().sum::<f64>() - 6.0).abs() < 1e-12);
        let p = m.positions();
        for t in m.triangles() {
            let n = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).normalize();
            assert!((n - DVec3::Y).length() < 1e-12, "triangle {t:?}: normal {n} should be +y");
        }
    }

    #[test]
    fn refuses_bad_parameters() {
        assert!(grid([0.0, 1.0], [2, 2]).is_err());
        assert!(grid([1.0, f64::NAN], [2, 2]).is_err());
        assert!(grid([1.0, 1.0], [0, 2]).is_err());
        // Too many vertices, or a count that overflows: refused before allocating.
        for segments in [[2000, 2000], [usize::MAX, 1], [usize::MAX / 2, 3]] {
            match grid([1.0, 1.0], segments) {
                Err(MeshError::BadParameter { name: "segments", reason }) => {
                    assert!(reason.contains("too large"), "{reason}")
                }
                other => panic!("{segments:?}: {other:?}"),
            }
        }
    }
}
