//! The validated triangle mesh type.

use glam::DVec3;

use super::{MeshError, Topology};

/// A validated, consistently oriented 2-manifold triangle mesh (boundary allowed) with its topology.
///
/// Construct with [`TriMesh::new`]; the fields are read-only afterwards so topology can never go stale.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    positions: Vec<DVec3>,
    triangles: Vec<[usize; 3]>,
    topology: Topology,
}

/// Triangles whose area is below this fraction of the squared bounding-box diagonal are degenerate.
const DEGENERATE_RELATIVE_AREA: f64 = 1e-14;

impl TriMesh {
    /// Validate positions and triangles and build the topology.
    ///
    /// Errors (checked in this order): empty mesh, non-finite coordinate, coordinates so large that
    /// lengths overflow, out-of-range index, degenerate triangle (repeated vertex or near-zero area),
    /// unreferenced vertex, non-manifold edge, inconsistent orientation, duplicate triangle.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[usize; 3]>) -> Result<Self, MeshError> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(MeshError::Empty { vertices: positions.len(), triangles: triangles.len() });
        }
        if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NonFinite { vertex });
        }
        let (lo, hi) = bounds(&positions);
        if !(hi - lo).length_squared().is_finite() {
            return Err(MeshError::Overflow { largest: lo.abs().max(hi.abs()).max_element() });
        }
        let n = positions.len();
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i >= n) {
                return Err(MeshError::IndexOutOfRange { triangle, index, vertex_count: n });
            }
        }
        let min_area = DEGENERATE_RELATIVE_AREA * (hi - lo).length_squared();
        for (triangle, t) in triangles.iter().enumerate() {
            let area = area_of(&positions, t);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || area <= min_area {
                return Err(MeshError::DegenerateTriangle { triangle, area });
            }
        }
        let mut used = vec![false; n];
        triangles.iter().flatten().for_each(|&i| used[i] = true);
        if let Some(vertex) = used.iter().position(|u| !u) {
            return Err(MeshError::UnreferencedVertex { vertex });
        }
        let topology = Topology::build(n, &triangles)?;
        Ok(Self { positions, triangles, topology })
    }

    /// Rest positions.
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Triangles as vertex-index triples, counter-clockwise seen from the front.
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// Edges, hinges, boundary and valence.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Total area at positions `x` (one per vertex), m².
    pub fn area_at(&self, x: &[DVec3]) -> f64 {
        self.triangles.iter().map(|t| area_of(x, t)).sum()
    }

    /// Relative area change `(A(x) − A₀) / A₀` of positions `x` against the rest shape (signed).
    pub fn area_change(&self, x: &[DVec3]) -> f64 {
        let rest = self.area_at(&self.positions);
        (self.area_at(x) - rest) / rest
    }

    /// Area of every triangle at rest.
    pub fn triangle_areas(&self) -> Vec<f64> {
        self.triangles.iter().map(|t| area_of(&self.positions, t)).collect()
    }

    /// One third of the area of every incident triangle, per vertex (the lumped-mass weights).
    pub fn vertex_areas(&self) -> Vec<f64> {
        let mut a = vec![0.0; self.positions.len()];
        for t in &self.triangles {
            let third = area_of(&self.positions, t) / 3.0;
            t.iter().for_each(|&i| a[i] += third);
        }
        a
    }

    /// Axis-aligned bounding box `(min, max)` of the rest positions.
    pub fn bounding_box(&self) -> (DVec3, DVec3) {
        bounds(&self.positions)
    }

    /// The connected component of every vertex (numbered from 0 in order of their lowest vertex), and
    /// how many there are. Unreferenced vertices are refused at construction, so every vertex is in one.
    pub fn components(&self) -> (Vec<usize>, usize) {
        let n = self.positions.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        for t in &self.triangles {
            for k in 1..3 {
                let (a, b) = (root(&mut parent, t[0]), root(&mut parent, t[k]));
                parent[a.max(b)] = a.min(b);
            }
        }
        let mut label = vec![usize::MAX; n];
        let mut count = 0;
        let component = (0..n)
            .map(|i| {
                let r = root(&mut parent, i);
                if label[r] == usize::MAX {
                    label[r] = count;
                    count += 1;
                }
                label[r]
            })
            .collect();
        (component, count)
    }

    /// The mesh of the vertices `keep` (in that order: new vertex `k` is `keep[k]`) and the triangles
    /// among them.
    pub fn submesh(&self, keep: &[usize]) -> Result<Self, MeshError> {
        let mut index = vec![usize::MAX; self.positions.len()];
        keep.iter().enumerate().for_each(|(k, &v)| index[v] = k);
        let triangles = self
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| index[v] != usize::MAX))
            .map(|t| t.map(|v| index[v]))
            .collect();
        Self::new(keep.iter().map(|&v| self.positions[v]).collect(), triangles)
    }

    /// The same connectivity with new positions (which must be finite and as many as before).
    pub fn with_positions(&self, positions: Vec<DVec3>) -> Result<Self, MeshError> {
        if positions.len() != self.positions.len() {
            return Err(MeshError::BadParameter {
                name: "positions",
                reason: format!("expected {} positions, got {}", self.positions.len(), positions.len()),
            });
        }
        Self::new(positions, self.triangles.clone())
    }

    /// The same connectivity with every rest position mapped through `f` (e.g. to place a generated
    /// mesh in a scene). Re-validated: a map that collapses a triangle or yields NaN is an error.
    pub fn transformed(&self, f: impl Fn(DVec3) -> DVec3) -> Result<Self, MeshError> {
        Self::new(self.positions.iter().map(|&p| f(p)).collect(), self.triangles.clone())
    }
}

/// Axis-aligned bounds of a point set (`(+inf, -inf)` when empty).
pub(crate) fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)))
}

/// A triangle's three edges, each as its vertices in increasing order (edge `k` joins corners `k`
/// and `k + 1`).
pub(crate) fn sides(t: [usize; 3]) -> [[usize; 2]; 3] {
    std::array::from_fn(|k| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])])
}

/// The area of triangle `t` at positions `p`.
pub(crate) fn area_of(p: &[DVec3], t: &[usize; 3]) -> f64 {
    0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64) -> Vec<DVec3> {
        vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, z), DVec3::new(0.0, 1.0, 0.0)]
    }
    const SQ: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    #[test]
    fn valid_square_areas_and_bounds() {
        let m = TriMesh::new(square(0.0), SQ.to_vec()).unwrap();
        assert_eq!(m.triangle_areas(), vec![0.5, 0.5]);
        let va = m.vertex_areas();
        assert!((va.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!((va[0] - 1.0 / 3.0).abs() < 1e-15 && (va[1] - 1.0 / 6.0).abs() < 1e-15);
        assert_eq!(m.bounding_box(), (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
    }

    #[test]
    fn every_validation_error_is_reported() {
        assert_eq!(TriMesh::new(vec![], vec![]), Err(MeshError::Empty { vertices: 0, triangles: 0 }));
        let mut nan = square(0.0);
        nan[2].y = f64::NAN;
        assert_eq!(TriMesh::new(nan, SQ.to_vec()), Err(MeshError::NonFinite { vertex: 2 }));
        let huge: Vec<DVec3> = square(0.0).into_iter().map(|p| p * 1e300).collect();
        assert_eq!(TriMesh::new(huge, SQ.to_vec()), Err(MeshError::Overflow { largest: 1e300 }));
        assert_eq!(
            TriMesh::new(square(0.0), vec![[0, 1, 2], [0, 2, 7]]),
            Err(MeshError::IndexOutOfRange { triangle: 1, index: 7, vertex_count: 4 })
        );
        assert!(matches!(
            TriMesh::new(square(0.0), vec![[0, 1, 2], [0, 2, 2], [0, 2, 3]]),
            Err(MeshError::DegenerateTriangle { triangle: 1, .. })
        ));
        let mut collinear = square(0.0);
        collinear[3] = DVec3::new(2.0, 2.0, 0.0); // on the line through 0 and 2
        assert!(matches!(TriMesh::new(collinear, SQ.to_vec()), Err(MeshError::DegenerateTriangle { triangle: 1, .. })));
        let mut extra = square(0.0);
        extra.push(DVec3::ONE);
        assert_eq!(TriMesh::new(extra, SQ.to_vec()), Err(MeshError::UnreferencedVertex { vertex: 4 }));
        let mut five = square(0.0);
        five.push(DVec3::new(0.5, -1.0, 0.0));
        five.push(DVec3::new(0.5, 0.5, 1.0));
        assert!(matches!(
            TriMesh::new(five, vec![[0, 1, 2], [1, 0, 4], [0, 1, 5], [0, 2, 3]]),
            Err(MeshError::NonManifoldEdge { a: 0, b: 1, count: 3 })
        ));
        assert_eq!(
            TriMesh::new(square(0.0), vec![[0, 1, 2], [0, 3, 2]]),
            Err(MeshError::InconsistentOrientation { a: 0, b: 2 })
        );
        // A "pillow": the same triangle twice, with opposite windings.
        assert_eq!(
            TriMesh::new(square(0.0)[..3].to_vec(), vec![[0, 1, 2], [0, 2, 1]]),
            Err(MeshError::DuplicateTriangle { first: 0, second: 1 })
        );
    }

    #[test]
    fn with_positions_keeps_connectivity() {
        let m = TriMesh::new(square(0.0), SQ.to_vec()).unwrap();
        let bent = m.with_positions(square(0.5)).unwrap();
        assert_eq!(bent.topology(), m.topology());
        assert!(m.with_positions(vec![DVec3::ZERO]).is_err());
    }

    #[test]
    fn transformed_maps_positions_and_revalidates() {
        let m = TriMesh::new(square(0.0), SQ.to_vec()).unwrap();
        let moved = m.transformed(|p| 2.0 * p + DVec3::X).unwrap();
        assert_eq!(moved.positions()[2], DVec3::new(3.0, 2.0, 0.0));
        assert_eq!(moved.topology(), m.topology());
        assert!(matches!(m.transformed(|p| p * DVec3::new(1.0, 0.0, 1.0)), Err(MeshError::DegenerateTriangle { .. })));
        assert_eq!(m.transformed(|_| DVec3::NAN), Err(MeshError::NonFinite { vertex: 0 }));
    }
}

#[cfg(test)]
mod component_tests {
    use super::*;

    #[test]
    fn copies_are_separate_components_and_submeshes_keep_their_order() {
        let quad = |x: f64| {
            vec![
                DVec3::new(x, 0.0, 0.0),
                DVec3::new(x + 1.0, 0.0, 0.0),
                DVec3::new(x, 1.0, 0.0),
                DVec3::new(x + 1.0, 1.0, 0.0),
            ]
        };
        let positions: Vec<DVec3> = quad(0.0).into_iter().chain(quad(5.0)).collect();
        let mesh = TriMesh::new(positions, vec![[0, 1, 2], [1, 3, 2], [4, 5, 6], [5, 7, 6]]).unwrap();
        assert_eq!(mesh.components(), (vec![0, 0, 0, 0, 1, 1, 1, 1], 2));
        let second = mesh.submesh(&[4, 5, 6, 7]).unwrap();
        assert_eq!(second.triangles(), &[[0, 1, 2], [1, 3, 2]]);
        assert_eq!(second.positions()[0].x, 5.0);
    }
}
