//! Who interacts with whom: the spring graph of a cloth, its valence weights and particle masses.
//!
//! - Triangle meshes (Noh & Jung): edge neighbours carry stretch springs; for every interior edge
//!   the two vertices opposite it are "diagonal" neighbours and carry a buckling spring. A pair that
//!   occurs twice (two hinges joining the same two vertices) is one spring and one neighbour.
//!   A buckling spring stands for the strip of cloth along the edge it crosses: its bending width is
//!   that edge's rest length (summed if two hinges share the pair).
//!   Valence weights `wᵢ = max_j |N_j| / |N_i|` over the union of both neighbour kinds.
//!   Masses: one third of every incident triangle's mass.
//! - Regular quad grids (Choi & Ko's original): first neighbours (the four axis neighbours and the
//!   four cell diagonals) carry stretch springs, second neighbours (two apart along an axis) carry
//!   buckling springs, whose bending width is the grid spacing across them; no valence weights (all
//!   1); masses: a quarter of every incident cell's mass.
//!
//! The bending width turns the cloth's bending rigidity per unit width (N·m) into each spring's
//! flexural rigidity (N·m²). With it, the buckling energy `½ k_b w L κ²` of a sheet bent to curvature
//! `κ` is the same at every resolution (with a constant per-spring `k_b` it would grow as `1/L`).

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use crate::mesh::TriMesh;

/// The interactions of a cloth.
#[derive(Debug, Clone, PartialEq)]
pub struct SpringGraph {
    /// Particle pairs `(i, j)` with `i < j`: the stretch springs `0..stretch`, then the buckling
    /// springs; each pair at most once per kind.
    pub pairs: Vec<[usize; 2]>,
    /// How many of the springs (the first ones) are stretch springs.
    pub stretch: usize,
    /// Rest length of each spring, m.
    pub rest: Vec<f64>,
    /// Bending width of each buckling spring (0 for stretch springs), m.
    pub width: Vec<f64>,
    /// Valence weight of each particle.
    pub weights: Vec<f64>,
    /// Lumped mass of each particle, kg.
    pub masses: Vec<f64>,
}

impl SpringGraph {
    /// The graph of a triangle mesh with surface `density` (kg/m²).
    pub fn triangle_mesh(mesh: &TriMesh, density: f64) -> Self {
        let topology = mesh.topology();
        let edges: Vec<[usize; 2]> = topology.edges.iter().map(|e| sorted(e.v)).collect();
        let mut index: HashMap<[usize; 2], usize> = HashMap::new();
        let mut diagonals: Vec<([usize; 2], f64)> = Vec::new();
        for h in &topology.hinges {
            let pair = sorted([h.v[2], h.v[3]]);
            let width = (mesh.positions()[h.v[1]] - mesh.positions()[h.v[0]]).length();
            match index.get(&pair) {
                Some(&k) => diagonals[k].1 += width,
                None => {
                    index.insert(pair, diagonals.len());
                    diagonals.push((pair, width));
                }
            }
        }
        let n = mesh.vertex_count();
        let mut neighbours = vec![HashSet::new(); n];
        for &[i, j] in edges.iter().chain(diagonals.iter().map(|(p, _)| p)) {
            neighbours[i].insert(j);
            neighbours[j].insert(i);
        }
        let most = neighbours.iter().map(HashSet::len).max().unwrap_or(1).max(1) as f64;
        let weights = neighbours.iter().map(|nb| if nb.is_empty() { 1.0 } else { most / nb.len() as f64 }).collect();
        let masses = mesh.vertex_areas().into_iter().map(|a| a * density).collect();
        Self::assemble(mesh.positions(), &edges, &diagonals, weights, masses)
    }

    /// The graph of a regular `(nx + 1) × (nz + 1)` grid of particles numbered `i·(nz + 1) + j`
    /// (as [`crate::mesh::generate::grid`] makes them), with cell sides `dx`, `dz` and surface `density`.
    pub fn quad_grid(positions: &[DVec3], [nx, nz]: [usize; 2], [dx, dz]: [f64; 2], density: f64) -> Self {
        let id = |i: usize, j: usize| i * (nz + 1) + j;
        let mut first = Vec::new();
        let mut second = Vec::new();
        // Second neighbours along x stand for a strip as wide as the spacing along z, and vice versa.
        for i in 0..=nx {
            for j in 0..=nz {
                if i < nx {
                    first.push([id(i, j), id(i + 1, j)]);
                }
                if j < nz {
                    first.push([id(i, j), id(i, j + 1)]);
                }
                if i < nx && j < nz {
                    first.push([id(i, j), id(i + 1, j + 1)]);
                    first.push(sorted([id(i + 1, j), id(i, j + 1)]));
                }
                if i + 1 < nx {
                    second.push(([id(i, j), id(i + 2, j)], dz));
                }
                if j + 1 < nz {
                    second.push(([id(i, j), id(i, j + 2)], dx));
                }
            }
        }
        let cell_mass = density * dx * dz / 4.0;
        let masses = (0..=nx)
            .flat_map(|i| (0..=nz).map(move |j| (i, j)))
            .map(|(i, j)| {
                let cells_x = usize::from(i > 0) + usize::from(i < nx);
                let cells_z = usize::from(j > 0) + usize::from(j < nz);
                cell_mass * (cells_x * cells_z) as f64
            })
            .collect();
        Self::assemble(positions, &first, &second, vec![1.0; positions.len()], masses)
    }

    fn assemble(
        positions: &[DVec3],
        stretch: &[[usize; 2]],
        buckling: &[([usize; 2], f64)],
        weights: Vec<f64>,
        masses: Vec<f64>,
    ) -> Self {
        let pairs: Vec<[usize; 2]> = stretch.iter().copied().chain(buckling.iter().map(|(p, _)| *p)).collect();
        let width = stretch.iter().map(|_| 0.0).chain(buckling.iter().map(|(_, w)| *w)).collect();
        let rest = pairs.iter().map(|&[i, j]| (positions[j] - positions[i]).length()).collect();
        Self { pairs, stretch: stretch.len(), rest, width, weights, masses }
    }
}

fn sorted([a, b]: [usize; 2]) -> [usize; 2] {
    [a.min(b), a.max(b)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn square_of_two_triangles_has_one_diagonal_and_weights() {
        // Triangles (0,1,2) and (0,2,3): edges 01 12 20 23 30, one hinge on 0–2 with wings 1 and 3.
        let mesh =
            TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 0.0, 1.0), DVec3::Z], vec![[0, 2, 1], [0, 3, 2]])
                .unwrap();
        let g = SpringGraph::triangle_mesh(&mesh, 2.0);
        assert_eq!(g.stretch, 5);
        assert_eq!(g.pairs[5..], [[1, 3]]);
        assert!((g.rest[5] - 2f64.sqrt()).abs() < 1e-15);
        // It crosses the edge 0–2 (length √2): that is its bending width.
        assert!((g.width[5] - 2f64.sqrt()).abs() < 1e-15 && g.width[..5].iter().all(|w| *w == 0.0));
        // |N| = 3 for every vertex (0, 2 via edges; 1, 3 via two edges and the diagonal): weights 1.
        assert_eq!(g.weights, vec![1.0; 4]);
        // Masses: density × area/3 per incident triangle; total = density × 1 m².
        assert!((g.masses.iter().sum::<f64>() - 2.0).abs() < 1e-15);
    }

    #[test]
    fn a_vertex_opposite_two_edges_counts_once() {
        // A 2 × 2 grid with alternating cell diagonals: the centre vertex is opposite several edges.
        let mesh = generate::grid([1.0, 1.0], [2, 2]).unwrap();
        let g = SpringGraph::triangle_mesh(&mesh, 1.0);
        let mut counts = vec![HashSet::new(); mesh.vertex_count()];
        for &[i, j] in &g.pairs {
            counts[i].insert(j);
            counts[j].insert(i);
        }
        let most = counts.iter().map(HashSet::len).max().unwrap();
        for (w, c) in g.weights.iter().zip(&counts) {
            assert!((w * c.len() as f64 - most as f64).abs() < 1e-12);
        }
        // No pair appears twice within a kind.
        let mut seen = HashSet::new();
        assert!(g.pairs.iter().enumerate().all(|(s, p)| seen.insert((*p, s < g.stretch))));
    }

    #[test]
    fn quad_grid_has_first_and_second_neighbours() {
        let mesh = generate::grid([1.0, 1.0], [3, 2]).unwrap();
        let g = SpringGraph::quad_grid(mesh.positions(), [3, 2], [1.0 / 3.0, 0.5], 1.0);
        let stretch = g.stretch;
        // Axis springs 3·3 + 4·2 = 17, cell diagonals 2·6 = 12; second neighbours 2·3 + 4·1 = 10.
        assert_eq!(stretch, 29);
        assert_eq!(g.pairs.len() - stretch, 10);
        assert!((g.masses.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(g.pairs.iter().all(|p| p[0] < p[1]));
    }
}
