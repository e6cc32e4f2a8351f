//! Edge/hinge/boundary topology of a validated, consistently oriented triangle mesh.

use std::collections::HashMap;

use super::MeshError;

/// A unique undirected edge with the triangles on each side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    /// Its two vertices, as traversed by `faces[0]` (so `faces[0]` contains the directed edge `v[0] → v[1]`).
    pub v: [usize; 2],
    /// The triangle that traverses `v[0] → v[1]`, and the one on the other side (traversing `v[1] → v[0]`), if any.
    pub faces: [usize; 2],
    /// Whether there is a second triangle (`faces[1]` is meaningful only then).
    pub interior: bool,
}

/// An interior edge with its two triangles: the stencil of bending energies and diagonal springs.
///
/// `v[0] → v[1]` is the shared edge as traversed by the first triangle `(v[0], v[1], v[2])`;
/// the second triangle is `(v[1], v[0], v[3])`. So `v[2]` and `v[3]` are the vertices opposite the edge,
/// and both triangles are listed in the mesh's own winding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hinge {
    /// Index of the shared edge in [`Topology::edges`].
    pub edge: usize,
    /// Edge vertices `v[0], v[1]`, then the opposite vertex of the first and of the second triangle.
    pub v: [usize; 4],
    /// The two triangles: `(v0, v1, v2)` and `(v1, v0, v3)` up to rotation.
    pub faces: [usize; 2],
}

/// Everything derived from connectivity alone, computed once.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Unique edges.
    pub edges: Vec<Edge>,
    /// Interior edges with their two triangles and opposite vertices.
    pub hinges: Vec<Hinge>,
    /// Indices into `edges` of edges with a single triangle.
    pub boundary_edges: Vec<usize>,
    /// Number of edge neighbours of each vertex.
    pub valence: Vec<usize>,
}

impl Topology {
    /// Build the topology and check that the mesh is an oriented 2-manifold (with boundary) without
    /// doubled triangles.
    ///
    /// Precondition (checked by [`super::TriMesh::new`], its only caller): every index is below
    /// `vertex_count`. A triangle that repeats a vertex is reported as degenerate.
    pub(crate) fn build(vertex_count: usize, triangles: &[[usize; 3]]) -> Result<Self, MeshError> {
        if let Some(triangle) = triangles.iter().position(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
            return Err(MeshError::DegenerateTriangle { triangle, area: 0.0 });
        }
        // Directed half-edge (a, b) → triangle. Two triangles on the same directed edge means either a
        // non-manifold edge or inconsistent winding; we tell which by counting the undirected uses.
        let mut undirected: HashMap<(usize, usize), usize> = HashMap::with_capacity(triangles.len() * 2);
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *undirected.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        if let Some((&(a, b), &count)) = undirected.iter().filter(|(_, c)| **c > 2).min_by_key(|(k, _)| **k) {
            return Err(MeshError::NonManifoldEdge { a, b, count });
        }
        let mut half: HashMap<(usize, usize), usize> = HashMap::with_capacity(triangles.len() * 3);
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if half.insert((a, b), ti).is_some() {
                    return Err(MeshError::InconsistentOrientation { a: a.min(b), b: a.max(b) });
                }
            }
        }
        // Walk triangles in order so edge numbering is deterministic.
        let mut edge_of: HashMap<(usize, usize), usize> = HashMap::with_capacity(undirected.len());
        let mut edges = Vec::with_capacity(undirected.len());
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                if edge_of.contains_key(&key) {
                    continue;
                }
                edge_of.insert(key, edges.len());
                let other = half.get(&(b, a)).copied();
                edges.push(Edge { v: [a, b], faces: [ti, other.unwrap_or(ti)], interior: other.is_some() });
            }
        }
        let mut hinges = Vec::new();
        let mut boundary_edges = Vec::new();
        for (ei, e) in edges.iter().enumerate() {
            if !e.interior {
                boundary_edges.push(ei);
                continue;
            }
            let [a, b] = e.v;
            // Each face has three distinct vertices, two of them a and b: the third is the opposite one.
            let opposite = |f: usize| triangles[f].into_iter().filter(|&x| x != a && x != b).sum::<usize>();
            let (c, d) = (opposite(e.faces[0]), opposite(e.faces[1]));
            if c == d {
                return Err(MeshError::DuplicateTriangle {
                    first: e.faces[0].min(e.faces[1]),
                    second: e.faces[0].max(e.faces[1]),
                });
            }
            hinges.push(Hinge { edge: ei, v: [a, b, c, d], faces: e.faces });
        }
        let mut valence = vec![0; vertex_count];
        for e in &edges {
            valence[e.v[0]] += 1;
            valence[e.v[1]] += 1;
        }
        Ok(Self { edges, hinges, boundary_edges, valence })
    }

    /// Edge-neighbour lists of every vertex (sorted).
    pub fn vertex_neighbours(&self) -> Vec<Vec<usize>> {
        let mut nb = vec![Vec::new(); self.valence.len()];
        for e in &self.edges {
            nb[e.v[0]].push(e.v[1]);
            nb[e.v[1]].push(e.v[0]);
        }
        for n in &mut nb {
            n.sort_unstable();
        }
        nb
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing the diagonal of a unit square: 0-1-2, 0-2-3.
    fn square() -> Vec<[usize; 3]> {
        vec![[0, 1, 2], [0, 2, 3]]
    }

    #[test]
    fn square_has_five_edges_one_hinge_four_boundary() {
        let t = Topology::build(4, &square()).unwrap();
        assert_eq!(t.edges.len(), 5);
        assert_eq!(t.boundary_edges.len(), 4);
        assert_eq!(t.hinges.len(), 1);
        let h = t.hinges[0];
        // Shared edge 2→0 in the first triangle (0,1,2); opposite vertices 1 (first) and 3 (second).
        assert_eq!(h.v, [2, 0, 1, 3]);
        assert_eq!(h.faces, [0, 1]);
        assert_eq!(t.valence, vec![3, 2, 3, 2]);
    }

    #[test]
    fn tetrahedron_is_closed() {
        let tris = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let t = Topology::build(4, &tris).unwrap();
        assert_eq!(t.edges.len(), 6);
        assert_eq!(t.hinges.len(), 6);
        assert!(t.boundary_edges.is_empty());
        assert_eq!(t.valence, vec![3; 4]);
        for h in &t.hinges {
            // Opposite vertices are the two vertices not on the edge.
            let mut all = h.v.to_vec();
            all.sort_unstable();
            assert_eq!(all, vec![0, 1, 2, 3]);
            // The first triangle contains the directed edge v0 → v1 and v2.
            let f = tris[h.faces[0]];
            let k = f.iter().position(|&x| x == h.v[0]).unwrap();
            assert_eq!(f[(k + 1) % 3], h.v[1]);
            assert_eq!(f[(k + 2) % 3], h.v[2]);
        }
    }

    #[test]
    fn fan_of_three_triangles_on_one_edge_is_non_manifold() {
        let tris = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        assert_eq!(Topology::build(5, &tris), Err(MeshError::NonManifoldEdge { a: 0, b: 1, count: 3 }));
    }

    #[test]
    fn flipped_neighbour_is_inconsistent() {
        let tris = vec![[0, 1, 2], [0, 1, 3]];
        assert_eq!(Topology::build(4, &tris), Err(MeshError::InconsistentOrientation { a: 0, b: 1 }));
    }

    #[test]
    fn repeated_vertex_and_doubled_triangle_are_errors() {
        assert_eq!(Topology::build(2, &[[0, 0, 1]]), Err(MeshError::DegenerateTriangle { triangle: 0, area: 0.0 }));
        // A pillow: every edge is a hinge whose two opposite vertices coincide.
        assert_eq!(
            Topology::build(6, &[[0, 1, 2], [3, 4, 5], [3, 5, 4]]),
            Err(MeshError::DuplicateTriangle { first: 1, second: 2 })
        );
    }

    #[test]
    fn neighbours_are_edge_adjacent_vertices() {
        let t = Topology::build(4, &square()).unwrap();
        assert_eq!(t.vertex_neighbours(), vec![vec![1, 2, 3], vec![0, 2], vec![0, 1, 3], vec![0, 2]]);
    }
}
