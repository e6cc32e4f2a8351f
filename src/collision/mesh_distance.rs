//! Signed distance to a closed triangle mesh: closest point through a bounding-volume hierarchy,
//! sign from angle-weighted pseudonormals (Bærentzen & Aanæs 2005), which is exact for any point of a
//! closed, consistently oriented mesh whichever feature (face, edge, vertex) is closest.

use std::collections::HashMap;

use glam::DVec3;

use super::CollisionError;
use super::closest::{self, Feature, closest_on_triangle};
use crate::mesh::TriMesh;

const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: first triangle in `order`; inner node: index of the left child.
    start: usize,
    /// Leaf: number of triangles; inner node: 0.
    count: usize,
    /// Inner node: index of the right child.
    right: usize,
}

/// A closed triangle mesh prepared for signed-distance queries.
#[derive(Debug, Clone)]
pub struct MeshDistance {
    positions: Vec<DVec3>,
    triangles: Vec<[usize; 3]>,
    face_normals: Vec<DVec3>,
    vertex_normals: Vec<DVec3>,
    edge_normals: HashMap<(usize, usize), DVec3>,
    nodes: Vec<Node>,
    order: Vec<usize>,
}

impl MeshDistance {
    /// Prepare `mesh`, which must be closed (no boundary edges); normals point outward by its winding.
    pub fn new(mesh: &TriMesh) -> Result<Self, CollisionError> {
        let boundary = mesh.topology().boundary_edges.len();
        if boundary > 0 {
            return Err(CollisionError::OpenMesh { boundary_edges: boundary });
        }
        let positions = mesh.positions().to_vec();
        let triangles = mesh.triangles().to_vec();
        let face_normals: Vec<DVec3> = triangles
            .iter()
            .map(|t| (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]).normalize())
            .collect();
        let mut vertex_normals = vec![DVec3::ZERO; positions.len()];
        let mut edge_normals: HashMap<(usize, usize), DVec3> = HashMap::new();
        for (t, n) in triangles.iter().zip(&face_normals) {
            for k in 0..3 {
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let angle = (positions[b] - positions[a]).angle_between(positions[c] - positions[a]);
                vertex_normals[a] += *n * angle;
                *edge_normals.entry((a.min(b), a.max(b))).or_default() += *n;
            }
        }
        let mut order: Vec<usize> = (0..triangles.len()).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1);
        let centroids: Vec<DVec3> =
            triangles.iter().map(|t| (positions[t[0]] + positions[t[1]] + positions[t[2]]) / 3.0).collect();
        build(&mut nodes, &mut order, 0, triangles.len(), &positions, &triangles, &centroids);
        Ok(Self { positions, triangles, face_normals, vertex_normals, edge_normals, nodes, order })
    }

    /// The mesh's vertex positions (body frame).
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// The mesh's triangles.
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// The outward angle-weighted pseudonormal of each vertex (not normalised).
    pub fn vertex_normals(&self) -> &[DVec3] {
        &self.vertex_normals
    }

    /// Signed distance from `x` to the surface (negative inside) and the unit outward direction.
    pub fn signed_distance(&self, x: DVec3) -> (f64, DVec3) {
        let mut best = (f64::INFINITY, 0usize, DVec3::ZERO, Feature::Face);
        // Depth-first, nearer child first, each node with its box distance (computed once). The tree
        // splits at the median, so its depth is log₂(triangles / LEAF_SIZE) and the stack holds at most
        // depth + 1 entries: 64 is enough for any mesh that fits in memory, and no allocation per query.
        let box_d2 = |i: usize| box_distance_squared(x, self.nodes[i].min, self.nodes[i].max);
        let mut stack = [(0usize, 0.0f64); 64];
        stack[0] = (0, box_d2(0));
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let (i, d2_box) = stack[len];
            if d2_box >= best.0 {
                continue;
            }
            let node = self.nodes[i];
            if node.count > 0 {
                for &t in &self.order[node.start..node.start + node.count] {
                    let tri = self.triangles[t].map(|v| self.positions[v]);
                    let (weights, feature) = closest_on_triangle(x, tri);
                    let p = closest::at(tri, weights);
                    let d2 = (x - p).length_squared();
                    if d2 < best.0 {
                        best = (d2, t, p, feature);
                    }
                }
                continue;
            }
            let (l, r) = ((node.start, box_d2(node.start)), (node.right, box_d2(node.right)));
            // Visit the nearer child first (pushed last).
            let (first, second) = if l.1 < r.1 { (r, l) } else { (l, r) };
            stack[len] = first;
            stack[len + 1] = second;
            len += 2;
        }
        let (d2, t, p, feature) = best;
        let tri = self.triangles[t];
        let pseudo = match feature {
            Feature::Face => self.face_normals[t],
            Feature::Edge(k) => {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                self.edge_normals.get(&(a.min(b), a.max(b))).copied().unwrap_or(self.face_normals[t])
            }
            Feature::Vertex(k) => self.vertex_normals[tri[k]],
        };
        let d = d2.sqrt();
        let sign = if (x - p).dot(pseudo) < 0.0 { -1.0 } else { 1.0 };
        let normal = if d > 1e-12 { (x - p) / d * sign } else { pseudo.normalize() };
        (sign * d, normal)
    }
}

fn build(
    nodes: &mut Vec<Node>,
    order: &mut [usize],
    start: usize,
    end: usize,
    positions: &[DVec3],
    triangles: &[[usize; 3]],
    centroids: &[DVec3],
) -> usize {
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for &t in &order[start..end] {
        for v in triangles[t] {
            min = min.min(positions[v]);
            max = max.max(positions[v]);
        }
    }
    let index = nodes.len();
    nodes.push(Node { min, max, start, count: end - start, right: 0 });
    if end - start <= LEAF_SIZE {
        return index;
    }
    let extent = max - min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = (start + end) / 2;
    order[start..end].select_nth_unstable_by(mid - start, |&a, &b| centroids[a][axis].total_cmp(&centroids[b][axis]));
    let left = build(nodes, order, start, mid, positions, triangles, centroids);
    let right = build(nodes, order, mid, end, positions, triangles, centroids);
    nodes[index] = Node { min, max, start: left, count: 0, right };
    index
}

fn box_distance_squared(x: DVec3, min: DVec3, max: DVec3) -> f64 {
    (min - x).max(x - max).max(DVec3::ZERO).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn matches_the_exact_sphere_and_cube_distances() {
        // A fine icosphere: distances to it are within the chordal error of the sphere's.
        let sphere = generate::icosphere(1.0, 16).unwrap();
        let sdf = MeshDistance::new(&sphere).unwrap();
        let mut state = 7u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let x = DVec3::new(next(), next(), next()) * 1.6;
            let (d, n) = sdf.signed_distance(x);
            let exact = x.length() - 1.0;
            assert!((d - exact).abs() < 5e-3, "x = {x}: {d} vs {exact}");
            if x.length() > 0.2 {
                assert!(n.dot(x.normalize()) > 0.95, "normal {n} at {x}");
            }
        }
        // A unit cube (12 triangles): the sign is right next to edges and vertices too.
        let cube = cube_mesh();
        let sdf = MeshDistance::new(&cube).unwrap();
        for (x, want) in [
            (DVec3::new(0.5, 0.5, 0.5), -0.5),
            (DVec3::new(1.2, 0.5, 0.5), 0.2),
            (DVec3::new(0.999, 0.999, 0.5), -0.001),
            (DVec3::new(1.001, 1.001, 0.5), 0.001 * 2f64.sqrt()),
            (DVec3::new(1.1, 1.1, 1.1), 0.03f64.sqrt()),
            (DVec3::new(0.99, 0.98, 0.999), -0.001),
        ] {
            let (d, _) = sdf.signed_distance(x);
            assert!((d - want).abs() < 1e-12, "x = {x}: {d} vs {want}");
        }
    }

    #[test]
    fn refuses_an_open_mesh() {
        let sheet = generate::grid([1.0, 1.0], [2, 2]).unwrap();
        assert!(matches!(MeshDistance::new(&sheet), Err(CollisionError::OpenMesh { boundary_edges: 8 })));
    }

    fn cube_mesh() -> TriMesh {
        let p: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64)).collect();
        // Outward-wound faces: x = 0, x = 1, y = 0, y = 1, z = 0, z = 1.
        let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
        let t = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        TriMesh::new(p, t).unwrap()
    }
}
