//! The cloth as position-based dynamics sees it: particles with lumped masses (density × a third of
//! each adjacent triangle's area), anchored ones of infinite mass, one stretch constraint per edge,
//! one bending constraint per interior edge (hinge) with its rest angle (so curved rest shapes keep
//! their shape), and for a closed mesh the enclosed volume.

use glam::DVec3;

use crate::energy::{constraints, hinge};
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
    /// Rest dihedral angle, rad.
    pub rest: f64,
    /// `6|ē|²/(Ā₁ + Ā₂)`: the discrete shell's hinge energy is `k_b × this × (θ − θ̄)² / 2`, so its
    /// stiffness against `C = θ − θ̄` is `k_b` times this, 1/(N·m) compliance its inverse.
    pub weight: f64,
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
    /// Bending constraints.
    pub bends: Vec<Bend>,
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
        let topo = mesh.topology();
        let edges: Vec<Edge> =
            topo.edges.iter().map(|e| Edge { v: e.v, rest: (rest[e.v[0]] - rest[e.v[1]]).length() }).collect();
        let tri_areas = mesh.triangle_areas();
        let bends = topo
            .hinges
            .iter()
            .map(|h| {
                let x = h.v.map(|i| rest[i]);
                let e2 = (x[1] - x[0]).length_squared();
                let weight = 6.0 * e2 / (tri_areas[h.faces[0]] + tri_areas[h.faces[1]]);
                Bend { v: h.v, rest: hinge::angle(&x), weight }
            })
            .collect();
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
        let mean_edge = edges.iter().map(|e| e.rest).sum::<f64>() / edges.len().max(1) as f64;
        Ok(Self {
            areas: mesh.vertex_areas(),
            triangles: mesh.triangles().to_vec(),
            anchored: setup.anchored_mask(),
            loads: setup.loads.clone(),
            rest,
            edges,
            bends,
            six_volume,
            mean_edge,
        })
    }

    /// Whether the mesh is closed (can hold a pressure).
    pub fn is_closed(&self) -> bool {
        self.six_volume.is_some()
    }
}
