//! Irregular cloth sheets from constrained Delaunay refinement (spade).

use glam::DVec3;
use spade::{AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation};

use super::MAX_VERTICES;
use crate::mesh::{MeshError, TriMesh};

/// Minimum interior angle the refinement aims for (degrees). Above ~30° refinement may not terminate.
const ANGLE_LIMIT_DEG: f64 = 28.0;

/// An irregular triangulated sheet in the y = 0 plane centred on the origin, `size[0]` along x by
/// `size[1]` along z, with target edge length `edge`. Normals point +y.
///
/// Built with spade's constrained Delaunay refinement: the boundary rectangle gets points every
/// ≈`edge` (each side split into `round(side / edge)` equal parts, at least one), then
/// `refine` inserts Steiner points until every triangle has area ≤ √3/4·`edge`² (an equilateral
/// triangle of side `edge`) and minimum angle ≥ 28°. Interior valence is irregular (mostly 5–7),
/// unlike [`super::grid`]. Vertices are numbered by z, then x (as the grid's rows), so that a range
/// of indices is a patch of the sheet. The result is deterministic (spade's refinement has no
/// randomness).
///
/// The cloth-on-a-ball drape of the particle-cloth paper uses 958 particles on a square:
/// `delaunay_sheet([1.0, 1.0], 0.0451)` gives 961 vertices (0.0450 → 965, 0.0452 → 955; the count is
/// not monotone in `edge` and may shift if spade changes its refinement order).
pub fn delaunay_sheet(size: [f64; 2], edge: f64) -> Result<TriMesh, MeshError> {
    if !size.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(MeshError::BadParameter { name: "size", reason: format!("must be positive, got {size:?}") });
    }
    if !(edge.is_finite() && edge > 0.0) {
        return Err(MeshError::BadParameter { name: "edge", reason: format!("must be positive, got {edge}") });
    }
    let max_area = 3f64.sqrt() / 4.0 * edge * edge;
    let estimate = size[0] * size[1] / max_area;
    // The interior (area) and the boundary (perimeter) each bound the vertex count from below.
    let boundary_points = 2.0 * (size[0] + size[1]) / edge;
    if estimate.max(boundary_points) > MAX_VERTICES as f64 {
        return Err(MeshError::BadParameter {
            name: "edge",
            reason: format!(
                "{edge} is too small for a {size:?} sheet (≈{:.0} vertices, at most {MAX_VERTICES})",
                estimate.max(boundary_points)
            ),
        });
    }
    let bad = |e: &dyn std::fmt::Display| MeshError::BadParameter {
        name: "edge",
        reason: format!("triangulation failed: {e}"),
    };
    let (hx, hz) = (size[0] / 2.0, size[1] / 2.0);
    let nx = ((size[0] / edge).round() as usize).max(1);
    let nz = ((size[1] / edge).round() as usize).max(1);
    // Boundary loop, counter-clockwise in (x, z): bottom, right, top, left.
    let mut boundary = Vec::with_capacity(2 * (nx + nz));
    for i in 0..nx {
        boundary.push(Point2::new(-hx + size[0] * i as f64 / nx as f64, -hz));
    }
    for j in 0..nz {
        boundary.push(Point2::new(hx, -hz + size[1] * j as f64 / nz as f64));
    }
    for i in 0..nx {
        boundary.push(Point2::new(hx - size[0] * i as f64 / nx as f64, hz));
    }
    for j in 0..nz {
        boundary.push(Point2::new(-hx, hz - size[1] * j as f64 / nz as f64));
    }
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    let mut handles = Vec::with_capacity(boundary.len());
    for p in boundary {
        handles.push(cdt.insert(p).map_err(|e| bad(&e))?);
    }
    for k in 0..handles.len() {
        cdt.add_constraint(handles[k], handles[(k + 1) % handles.len()]);
    }
    let params = RefinementParameters::<f64>::new()
        .with_max_allowed_area(max_area)
        .with_angle_limit(AngleLimit::from_deg(ANGLE_LIMIT_DEG))
        .with_max_additional_vertices((4.0 * estimate) as usize + 1000);
    let result = cdt.refine(params);
    if !result.refinement_complete {
        return Err(bad(&"refinement did not complete"));
    }
    let points: Vec<DVec3> = cdt.vertices().map(|v| DVec3::new(v.position().x, 0.0, v.position().y)).collect();
    // Numbered across the sheet in z, then x, so that index ranges are patches of it.
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].z.total_cmp(&points[b].z).then(points[a].x.total_cmp(&points[b].x)));
    let mut index = vec![0; points.len()];
    order.iter().enumerate().for_each(|(new, &old)| index[old] = new);
    let positions = order.iter().map(|&old| points[old]).collect();
    // Spade's faces are counter-clockwise in (x, z), whose normal is −y: swap two corners for +y.
    let triangles = cdt
        .inner_faces()
        .map(|f| {
            let [a, b, c] = f.vertices().map(|v| index[v.fix().index()]);
            [a, c, b]
        })
        .collect();
    TriMesh::new(positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_sheet(m: &TriMesh, size: [f64; 2]) {
        let p = m.positions();
        for t in m.triangles() {
            let n = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
            assert!(n.y > 0.0 && n.x == 0.0 && n.z == 0.0, "triangle {t:?} normal {n}");
        }
        let area: f64 = m.triangle_areas().iter().sum();
        assert!((area - size[0] * size[1]).abs() < 1e-12 * size[0] * size[1], "area {area}");
        let (lo, hi) = m.bounding_box();
        assert!((lo - DVec3::new(-size[0] / 2.0, 0.0, -size[1] / 2.0)).length() < 1e-15);
        assert!((hi - DVec3::new(size[0] / 2.0, 0.0, size[1] / 2.0)).length() < 1e-15);
        // One boundary loop, Euler characteristic of a disc.
        let t = m.topology();
        let euler = m.vertex_count() as isize - t.edges.len() as isize + m.triangles().len() as isize;
        assert_eq!(euler, 1);
    }

    #[test]
    fn paper_drape_sheet_has_about_958_vertices() {
        let m = delaunay_sheet([1.0, 1.0], 0.0451).unwrap();
        let n = m.vertex_count();
        assert!((940..=980).contains(&n), "{n} vertices");
        check_sheet(&m, [1.0, 1.0]);
        // Irregular: interior vertices with valence other than 6, and a spread of valences.
        let t = m.topology();
        let mut on_boundary = vec![false; n];
        for &e in &t.boundary_edges {
            t.edges[e].v.iter().for_each(|&v| on_boundary[v] = true);
        }
        let interior: Vec<usize> = (0..n).filter(|&v| !on_boundary[v]).map(|v| t.valence[v]).collect();
        let not_six = interior.iter().filter(|&&k| k != 6).count();
        assert!(not_six * 10 > interior.len(), "{not_six} of {} interior vertices have valence ≠ 6", interior.len());
        assert!(interior.contains(&5) && interior.contains(&7));
        // Edges are near the requested length.
        let p = m.positions();
        let mean = t.edges.iter().map(|e| (p[e.v[0]] - p[e.v[1]]).length()).sum::<f64>() / t.edges.len() as f64;
        assert!((0.6 * 0.0451..1.2 * 0.0451).contains(&mean), "mean edge {mean}");
    }

    #[test]
    fn rectangular_sheets_and_determinism() {
        let a = delaunay_sheet([2.0, 0.5], 0.1).unwrap();
        check_sheet(&a, [2.0, 0.5]);
        assert_eq!(a, delaunay_sheet([2.0, 0.5], 0.1).unwrap());
        // Edge larger than the sheet: still a valid (tiny) mesh.
        check_sheet(&delaunay_sheet([0.3, 0.2], 5.0).unwrap(), [0.3, 0.2]);
    }

    #[test]
    fn refuses_bad_parameters() {
        assert!(delaunay_sheet([0.0, 1.0], 0.1).is_err());
        assert!(delaunay_sheet([1.0, f64::NAN], 0.1).is_err());
        assert!(delaunay_sheet([1.0, 1.0], 0.0).is_err());
        assert!(delaunay_sheet([1.0, 1.0], -0.1).is_err());
        assert!(delaunay_sheet([1.0, 1.0], f64::INFINITY).is_err());
        assert!(delaunay_sheet([1.0, 1.0], 1e-6).is_err());
        // A thin sheet has a small area but a long boundary: refused before the boundary is allocated.
        assert!(matches!(delaunay_sheet([1e6, 1e-9], 1e-3), Err(MeshError::BadParameter { name: "edge", .. })));
    }
}
