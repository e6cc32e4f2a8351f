//! The cloth as position-based dynamics sees it: particles with lumped masses (density × a third of
//! each adjacent triangle's area), anchored ones of infinite mass, one stretch constraint per edge,
//! one bending constraint per interior edge (hinge) with its rest angle (so curved rest shapes keep
//! their shape), and for a closed mesh the enclosed volume.
//!
//! An interior edge's stretch and its hinge's bending share the edge's two particles, so the sweeps
//! take them together ([`StretchBend`]: one gather of the hinge's four particles, the stretch
//! projected, then the bending at the stretched positions, one scatter); the boundary edges, which
//! have no hinge, go on their own before them. Without bending, every edge goes on its own.

use glam::DVec3;

use super::batch::{Batches, CONSTANTS, Packable};
use crate::energy::constraints::{self, RestAngle};
use crate::energy::hinge;
use crate::scene::Setup;
use crate::solver::SolverError;

/// An edge-length constraint `|p₁ − p₂| = l₀`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// Its two particles.
    pub v: [usize; 2],
    /// Rest length, m.
    pub rest: f64,
}

/// A bending constraint on a hinge `[a, b, c, d]` (see [`crate::mesh::Hinge`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bend {
    /// Its four particles.
    pub v: [usize; 4],
    /// Rest dihedral angle.
    pub rest: RestAngle,
    /// `(Ā₁ + Ā₂)/(6|ē|²)`: the discrete shell's hinge energy is `k_b (θ − θ̄)² / (2 × this)`, so its
    /// compliance against `C = θ − θ̄` is this over `k_b`.
    pub inverse_weight: f64,
}

/// An interior edge's stretch and its hinge's bending, projected one after the other: the hinge's
/// particles `[a, b, c, d]`, of which `a, b` are the edge's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StretchBend {
    /// The edge's rest length, m.
    pub rest: f64,
    /// The hinge.
    pub bend: Bend,
}

impl Packable<2, 1> for Edge {
    fn particles(&self) -> [usize; 2] {
        self.v
    }
    fn constants(&self) -> [f64; CONSTANTS] {
        [self.rest, 0.0, 0.0]
    }
    fn factors(&self) -> [f64; 1] {
        [1.0]
    }
}

impl Packable<4, 2> for StretchBend {
    fn particles(&self) -> [usize; 4] {
        self.bend.v
    }
    fn constants(&self) -> [f64; CONSTANTS] {
        [self.rest, self.bend.rest.cos, self.bend.rest.sin]
    }
    fn factors(&self) -> [f64; 2] {
        [1.0, self.bend.inverse_weight]
    }
}

/// The constraint set and masses of a scene's mesh.
#[derive(Debug, Clone)]
pub struct Model {
    /// Rest positions.
    pub rest: Vec<DVec3>,
    /// Triangles (for wind, self-collision, volume and drawing).
    pub triangles: Vec<[usize; 3]>,
    /// Lumped masses per unit density (a third of each adjacent triangle's area), m².
    pub areas: Vec<f64>,
    /// Anchored particles (infinite mass).
    pub anchored: Vec<bool>,
    /// Constant point loads, N.
    pub loads: Vec<DVec3>,
    /// Stretch constraints.
    pub edges: Vec<Edge>,
    /// Every stretch constraint packed for the sweeps, in colours (no two edges of a colour share a
    /// particle): what the sweeps take when there is no bending.
    pub edge_batches: Batches<2, 1>,
    /// The boundary edges' stretch constraints, packed likewise.
    pub boundary_batches: Batches<2, 1>,
    /// The interior edges' stretch with their hinges' bending, packed likewise.
    pub hinge_batches: Batches<4, 2>,
    /// Six times the rest volume, for a closed mesh (`None`: the mesh has a boundary).
    pub six_volume: Option<f64>,
    /// Mean rest edge length, m.
    pub mean_edge: f64,
}

impl Model {
    /// The constraint set of the setup's mesh.
    pub fn new(setup: &Setup) -> Result<Self, SolverError> {
        let mesh = &setup.mesh;
        let rest = mesh.positions().to_vec();
        if u32::try_from(rest.len()).is_err() {
            return Err(SolverError::Unsuitable {
                method: "pbd",
                reason: format!("{} particles: the sweeps index particles with 32 bits", rest.len()),
            });
        }
        let topo = mesh.topology();
        let edges: Vec<Edge> =
            topo.edges.iter().map(|e| Edge { v: e.v, rest: (rest[e.v[0]] - rest[e.v[1]]).length() }).collect();
        let tri_areas = mesh.triangle_areas();
        let hinges: Vec<StretchBend> = topo
            .hinges
            .iter()
            .map(|h| {
                let x = h.v.map(|i| rest[i]);
                let e2 = (x[1] - x[0]).length_squared();
                let inverse_weight = (tri_areas[h.faces[0]] + tri_areas[h.faces[1]]) / (6.0 * e2);
                let bend = Bend { v: h.v, rest: RestAngle::new(hinge::angle(&x)), inverse_weight };
                StretchBend { rest: edges[h.edge].rest, bend }
            })
            .collect();
        let boundary: Vec<Edge> = topo.boundary_edges.iter().map(|&e| edges[e]).collect();
        let closed = topo.boundary_edges.is_empty();
        let six_volume = closed.then(|| {
            let mut g = vec![DVec3::ZERO; rest.len()];
            constraints::six_volume(&rest, mesh.triangles(), &mut g)
        });
        if six_volume.is_some_and(|v| v <= 0.0) {
            return Err(SolverError::Unsuitable {
                method: "pbd",
                reason: "the closed mesh encloses no positive volume (inward-wound triangles?)".into(),
            });
        }
        // In an order where constraints that follow each other rarely share a particle, the processor
        // overlaps their arithmetic instead of waiting for each update (Gauss–Seidel all the same).
        let (edges, edge_colours) = by_colour(edges, |e| &e.v);
        let (boundary, boundary_colours) = by_colour(boundary, |e| &e.v);
        let (hinges, hinge_colours) = by_colour(hinges, |h| &h.bend.v);
        let mean_edge = edges.iter().map(|e| e.rest).sum::<f64>() / edges.len().max(1) as f64;
        Ok(Self {
            areas: mesh.vertex_areas(),
            triangles: mesh.triangles().to_vec(),
            anchored: setup.anchored_mask(),
            loads: setup.loads.clone(),
            rest,
            edge_batches: Batches::new(&edges, &edge_colours),
            boundary_batches: Batches::new(&boundary, &boundary_colours),
            hinge_batches: Batches::new(&hinges, &hinge_colours),
            edges,
            six_volume,
            mean_edge,
        })
    }

    /// Whether the mesh is closed (can hold a pressure).
    pub fn is_closed(&self) -> bool {
        self.six_volume.is_some()
    }
}

/// The items in order of a greedy colouring (no two items of a colour share a particle), each colour
/// in the items' own order, and where each colour begins (with the end last).
fn by_colour<T: Copy, const K: usize>(items: Vec<T>, particles: impl Fn(&T) -> &[usize; K]) -> (Vec<T>, Vec<usize>) {
    let n = items.iter().flat_map(|t| particles(t).iter()).max().map_or(0, |m| m + 1);
    let mut used = vec![0u64; n];
    let mut colours: Vec<u32> = Vec::with_capacity(items.len());
    for item in &items {
        let taken = particles(item).iter().fold(0u64, |m, &i| m | used[i]);
        let colour = (!taken).trailing_zeros().min(63);
        particles(item).iter().for_each(|&i| used[i] |= 1 << colour);
        colours.push(colour);
    }
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&k| colours[k]);
    let count = colours.iter().max().map_or(0, |&c| c as usize + 1);
    let starts = (0..=count).map(|c| colours.iter().filter(|&&k| (k as usize) < c).count()).collect();
    (order.into_iter().map(|k| items[k]).collect(), starts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colouring_keeps_every_item_and_separates_neighbours_within_a_colour() {
        let items: Vec<[usize; 2]> = (0..40).map(|i| [i % 13, (i * 7 + 3) % 13]).filter(|e| e[0] != e[1]).collect();
        let (ordered, starts) = by_colour(items.clone(), |e| e);
        let (mut a, mut b) = (items.clone(), ordered.clone());
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "a permutation");
        assert_eq!((starts[0], *starts.last().unwrap()), (0, ordered.len()));
        for colour in starts.windows(2) {
            let mut seen = std::collections::HashSet::new();
            for e in &ordered[colour[0]..colour[1]] {
                assert!(e.iter().all(|v| seen.insert(*v)), "{e:?} shares a particle within its colour");
            }
        }
        assert!(starts.len() <= 13, "{} colours for a graph of degree ≤ 12", starts.len() - 1);
    }
}
