//! Closed spheres: the geodesic icosphere and the latitude–longitude UV sphere.

use std::collections::HashMap;

use glam::DVec3;

use super::vertex_budget;
use crate::mesh::{MeshError, TriMesh};

/// Unit directions of a geodesic sphere and its outward-wound triangles (see [`icosphere`]).
pub(crate) fn unit_icosphere(frequency: usize) -> Result<(Vec<DVec3>, Vec<[usize; 3]>), MeshError> {
    let f = frequency;
    if f == 0 {
        return Err(MeshError::BadParameter { name: "frequency", reason: "must be at least 1".into() });
    }
    let count = vertex_budget("frequency", f.checked_mul(f).and_then(|f2| f2.checked_mul(10)).map(|n| n + 2))?;
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|c| DVec3::from_array(c).normalize());
    const FACES: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut positions: Vec<DVec3> = corners.to_vec();
    positions.reserve(count - 12);
    // Points strictly inside each icosahedron edge, stored once, ordered from the lower corner index.
    let mut edge_points: HashMap<(usize, usize), usize> = HashMap::with_capacity(30);
    let mut triangles = Vec::with_capacity(20 * f * f);
    let mut face_ids = vec![0usize; (f + 1) * (f + 2) / 2];
    for face in FACES {
        let [a, mut b, mut c] = face;
        let (pa, pb, pc) = (corners[a], corners[b], corners[c]);
        if (pb - pa).cross(pc - pa).dot(pa + pb + pc) < 0.0 {
            std::mem::swap(&mut b, &mut c);
        }
        let (pa, pb, pc) = (corners[a], corners[b], corners[c]);
        // Index of the k-th interior point (1 ≤ k < f) on the edge from corner u to corner v.
        let mut on_edge = |u: usize, v: usize, k: usize, positions: &mut Vec<DVec3>| {
            let (lo, hi, k) = if u < v { (u, v, k) } else { (v, u, f - k) };
            let first = *edge_points.entry((lo, hi)).or_insert_with(|| {
                let first = positions.len();
                for m in 1..f {
                    let s = m as f64 / f as f64;
                    positions.push(corners[lo].lerp(corners[hi], s).normalize());
                }
                first
            });
            first + k - 1
        };
        // Barycentric lattice point (i, j): pa + (pb − pa)·i/f + (pc − pa)·j/f, i + j ≤ f.
        let slot = |i: usize, j: usize| i * (2 * f + 3 - i) / 2 + j;
        for i in 0..=f {
            for j in 0..=f - i {
                let id = match (i, j) {
                    (0, 0) => a,
                    (i, 0) if i == f => b,
                    (0, j) if j == f => c,
                    (i, 0) => on_edge(a, b, i, &mut positions),
                    (0, j) => on_edge(a, c, j, &mut positions),
                    (i, j) if i + j == f => on_edge(b, c, j, &mut positions),
                    (i, j) => {
                        let (u, v) = (i as f64 / f as f64, j as f64 / f as f64);
                        positions.push((pa + (pb - pa) * u + (pc - pa) * v).normalize());
                        positions.len() - 1
                    }
                };
                face_ids[slot(i, j)] = id;
            }
        }
        for i in 0..f {
            for j in 0..f - i {
                triangles.push([face_ids[slot(i, j)], face_ids[slot(i + 1, j)], face_ids[slot(i, j + 1)]]);
                if i + j + 1 < f {
                    triangles.push([face_ids[slot(i + 1, j)], face_ids[slot(i + 1, j + 1)], face_ids[slot(i, j + 1)]]);
                }
            }
        }
    }
    Ok((positions, triangles))
}

fn check_radius(radius: f64) -> Result<(), MeshError> {
    if radius.is_finite() && radius > 0.0 {
        Ok(())
    } else {
        Err(MeshError::BadParameter { name: "radius", reason: format!("must be positive, got {radius}") })
    }
}

/// A geodesic sphere of `radius` centred on the origin: every face of an icosahedron split into
/// `frequency²` triangles and projected onto the sphere. Vertices are shared across faces by index
/// bookkeeping (no float welding), giving `10·frequency² + 2` vertices and `20·frequency²` triangles,
/// wound counter-clockwise seen from outside. At most [`super::MAX_VERTICES`] vertices (frequency 632).
pub fn icosphere(radius: f64, frequency: usize) -> Result<TriMesh, MeshError> {
    check_radius(radius)?;
    let (dirs, triangles) = unit_icosphere(frequency)?;
    TriMesh::new(dirs.into_iter().map(|d| d * radius).collect(), triangles)
}

/// A latitude–longitude sphere of `radius` centred on the origin with poles on ±y: `rings` bands
/// from pole to pole (at least 2) and `sectors` around (at least 3). Each pole is a single vertex
/// with a triangle fan, so no triangle is degenerate: `(rings − 1)·sectors + 2` vertices,
/// `2·(rings − 1)·sectors` triangles, wound counter-clockwise seen from outside.
///
/// Vertex 0 is the north pole (+y), then ring by ring from the north, each ring starting on +x,
/// and the south pole last. At most [`super::MAX_VERTICES`] vertices.
pub fn uv_sphere(radius: f64, rings: usize, sectors: usize) -> Result<TriMesh, MeshError> {
    check_radius(radius)?;
    if rings < 2 {
        return Err(MeshError::BadParameter { name: "rings", reason: format!("need at least 2, got {rings}") });
    }
    if sectors < 3 {
        return Err(MeshError::BadParameter { name: "sectors", reason: format!("need at least 3, got {sectors}") });
    }
    let count = (rings - 1).checked_mul(sectors).and_then(|n| n.checked_add(2));
    let mut positions = Vec::with_capacity(vertex_budget("rings", count)?);
    positions.push(DVec3::Y * radius);
    for k in 1..rings {
        let (st, ct) = (std::f64::consts::PI * k as f64 / rings as f64).sin_cos();
        for s in 0..sectors {
            let (sp, cp) = (std::f64::consts::TAU * s as f64 / sectors as f64).sin_cos();
            positions.push(DVec3::new(st * cp, ct, st * sp) * radius);
        }
    }
    let south = positions.len();
    positions.push(DVec3::NEG_Y * radius);
    let ring = |k: usize, s: usize| 1 + (k - 1) * sectors + s % sectors;
    let mut triangles = Vec::with_capacity(2 * (rings - 1) * sectors);
    for s in 0..sectors {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
    }
    for k in 1..rings - 1 {
        for s in 0..sectors {
            let (a, b, c, d) = (ring(k, s), ring(k, s + 1), ring(k + 1, s), ring(k + 1, s + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    for s in 0..sectors {
        triangles.push([south, ring(rings - 1, s), ring(rings - 1, s + 1)]);
    }
    TriMesh::new(positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn euler(m: &TriMesh) -> isize {
        m.vertex_count() as isize - m.topology().edges.len() as isize + m.triangles().len() as isize
    }

    fn assert_closed_outward_sphere(m: &TriMesh, radius: f64) {
        assert!(m.topology().boundary_edges.is_empty());
        assert_eq!(euler(m), 2);
        for p in m.positions() {
            assert!((p.length() - radius).abs() < 1e-12 * radius);
        }
        // Every face outward, not just on average.
        for t in m.triangles() {
            let [a, b, c] = t.map(|i| m.positions()[i]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }

    #[test]
    fn icosphere_counts_closedness_and_orientation() {
        for f in [1, 2, 3, 36] {
            let m = icosphere(2.0, f).unwrap();
            assert_eq!(m.vertex_count(), 10 * f * f + 2, "frequency {f}");
            assert_eq!(m.triangles().len(), 20 * f * f);
            assert_eq!(m.topology().edges.len(), 30 * f * f);
            assert_closed_outward_sphere(&m, 2.0);
        }
    }

    #[test]
    fn icosphere_valence_is_five_at_corners_six_elsewhere() {
        let m = icosphere(1.0, 4).unwrap();
        let v = &m.topology().valence;
        assert!(v[..12].iter().all(|&k| k == 5));
        assert!(v[12..].iter().all(|&k| k == 6));
    }

    #[test]
    fn icosphere_area_converges_to_the_sphere() {
        let exact = 4.0 * std::f64::consts::PI * 9.0;
        for f in [1, 2, 4, 8, 16, 36] {
            let area: f64 = icosphere(3.0, f).unwrap().triangle_areas().iter().sum();
            let rel = (exact - area) / exact;
            // Inscribed polyhedron: always below, error ≈ 0.31/f² (measured).
            assert!(rel > 0.0 && rel < 0.35 / (f * f) as f64, "f = {f}: relative error {rel}");
        }
    }

    #[test]
    fn uv_sphere_counts_closedness_and_orientation() {
        for (rings, sectors) in [(2, 3), (3, 4), (16, 32), (40, 7)] {
            let m = uv_sphere(0.5, rings, sectors).unwrap();
            assert_eq!(m.vertex_count(), (rings - 1) * sectors + 2);
            assert_eq!(m.triangles().len(), 2 * (rings - 1) * sectors);
            assert_closed_outward_sphere(&m, 0.5);
        }
        let area: f64 = uv_sphere(1.0, 64, 128).unwrap().triangle_areas().iter().sum();
        assert!((area / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn refuses_bad_parameters() {
        assert!(icosphere(1.0, 0).is_err());
        assert!(icosphere(0.0, 2).is_err());
        assert!(icosphere(f64::NAN, 2).is_err());
        assert!(icosphere(-1.0, 2).is_err());
        assert!(uv_sphere(1.0, 1, 8).is_err());
        assert!(uv_sphere(1.0, 4, 2).is_err());
        assert!(uv_sphere(f64::INFINITY, 4, 8).is_err());
        for (rings, sectors) in [(usize::MAX, usize::MAX), (2001, 2001), (3, usize::MAX / 2 + 1)] {
            assert!(matches!(uv_sphere(1.0, rings, sectors), Err(MeshError::BadParameter { name: "rings", .. })));
        }
        for f in [633, 1 << 31, usize::MAX] {
            assert!(matches!(icosphere(1.0, f), Err(MeshError::BadParameter { name: "frequency", .. })), "{f}");
        }
    }
}
