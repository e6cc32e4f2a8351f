//! The linear system of the rotation-strain reconstruction ([`super::rotation_strain`]).
//!
//! Minimising `Σ_t A_t Σ_(i,j)∈t |(u_j − u_i) − δg_e|²` over the displacements `u` of the free
//! vertices (anchored ones stay at zero) gives the normal equations `L u = b`: `L` is the graph
//! Laplacian of the mesh's edges weighted by the areas of the triangles they belong to (an interior
//! edge counts twice), with the rows and columns of fixed vertices removed; it is the same for the
//! three coordinates, so one scalar sparse Cholesky factor ([`VectorCholesky`]; the unknowns are
//! numbered in its fill-reducing order) solves all three in one pass. `b` is assembled by
//! [`super::rs_pass`].
//!
//! **Gauge.** A connected component without an anchor is fixed by `L` only up to a translation (the
//! targets are world-frame vectors, so its orientation is fixed by them: there is no rotational
//! freedom to pin). Its lowest-numbered vertex is removed from `L` (the gauge vertex, held at zero
//! while solving), and the solution is then translated so that the component's area-weighted
//! centroid (its centre of mass: the density is uniform) moves by the given `μ` — for modal
//! coordinates the centroid of `Φq`, which is zero for deformation modes (they are mass-orthogonal to
//! the translations) and the translation itself for kept rigid modes. That is the least-squares
//! minimiser with that centroid.
//!
//! **Adjoint.** With the gauge, `u = P L'⁻¹ b + 1 μ` where `P = I − 1wᵀ` removes the weighted mean
//! (`w` the area weights of the component), so `fᵀu = yᵀ b + Fᵀμ` with `y = L'⁻¹ (f − w F)` and
//! `F = Σ f` the net force on the component: [`EdgeLaplacian::adjoint`] returns `y` and `F`.

use glam::DVec3;

use crate::linalg::VectorCholesky;
use crate::linalg::padded::Padded;
use crate::mesh::TriMesh;
use crate::solver::SolverError;

/// Placing goes in two halves at once when each has at least this many vertices
/// ([`EdgeLaplacian::positions`]).
pub const HALVES: usize = 4096;

/// Marks a vertex that is not an unknown of `L` (anchored, or a gauge vertex), or is in no gauge.
pub const NONE: u32 = u32::MAX;

/// A connected component without anchors: its vertices and their centroid weights (summing to one).
#[derive(Debug, Clone, PartialEq)]
pub struct Gauge {
    /// The component's vertices; the first is the gauge vertex.
    pub vertices: Vec<usize>,
    /// Area weight of each vertex in the component's centroid.
    pub weights: Vec<f64>,
}

/// The factorised area-weighted edge Laplacian over the free vertices.
#[derive(Debug)]
pub struct EdgeLaplacian {
    factor: VectorCholesky,
    /// Per vertex: its unknown, or [`NONE`].
    unknown: Vec<u32>,
    /// Per vertex: its gauge, or [`NONE`].
    gauge_of: Vec<u32>,
    /// Per vertex: its weight in its gauge's centroid (zero outside gauges).
    weight: Vec<f64>,
    gauges: Vec<Gauge>,
}

fn numerical(e: impl std::fmt::Display) -> SolverError {
    SolverError::Numerical(format!("rotation-strain reconstruction: {e}"))
}

impl EdgeLaplacian {
    /// Assemble and factorise `L` for `mesh` with `anchors` fixed.
    pub fn new(mesh: &TriMesh, anchors: &[usize]) -> Result<Self, SolverError> {
        let n = mesh.vertex_count();
        let mut anchored = vec![false; n];
        for &a in anchors {
            *anchored.get_mut(a).ok_or_else(|| numerical(format!("anchor {a} of a mesh of {n} vertices")))? = true;
        }
        let (component, count) = mesh.components();
        let mut held = vec![false; count];
        (0..n).filter(|&v| anchored[v]).for_each(|v| held[component[v]] = true);
        let areas = mesh.vertex_areas();
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); count];
        (0..n).filter(|&v| !held[component[v]]).for_each(|v| members[component[v]].push(v));
        let (mut gauge_of, mut weight) = (vec![NONE; n], vec![0.0; n]);
        let mut gauges = Vec::new();
        for vertices in members.into_iter().filter(|m| !m.is_empty()) {
            let total: f64 = vertices.iter().map(|&v| areas[v]).sum();
            let weights: Vec<f64> = vertices.iter().map(|&v| areas[v] / total).collect();
            for (&v, &w) in vertices.iter().zip(&weights) {
                (gauge_of[v], weight[v]) = (gauges.len() as u32, w);
            }
            anchored[vertices[0]] = true;
            gauges.push(Gauge { vertices, weights });
        }
        let free: Vec<usize> = (0..n).filter(|&v| !anchored[v]).collect();
        if free.is_empty() {
            return Err(numerical("no free vertex"));
        }
        let mut slot = vec![NONE; n];
        free.iter().enumerate().for_each(|(i, &v)| slot[v] = i as u32);
        let mut entries = Vec::new();
        for (t, area) in mesh.triangles().iter().zip(mesh.triangle_areas()) {
            for k in 0..3 {
                let (i, j) = (slot[t[k]], slot[t[(k + 1) % 3]]);
                for d in [i, j].into_iter().filter(|&d| d != NONE) {
                    entries.push(faer::sparse::Triplet::new(d as usize, d as usize, area));
                }
                if i != NONE && j != NONE {
                    entries.push(faer::sparse::Triplet::new(i.min(j) as usize, i.max(j) as usize, -area));
                }
            }
        }
        let matrix = faer::sparse::SparseColMat::<usize, f64>::try_new_from_triplets(free.len(), free.len(), &entries)
            .map_err(|e| numerical(format!("{e:?}")))?;
        let factor = VectorCholesky::new(matrix.as_ref()).map_err(numerical)?;
        // Number the unknowns in the factor's order.
        let mut unknown = vec![NONE; n];
        for (k, &i) in factor.order().iter().enumerate() {
            unknown[free[i]] = k as u32;
        }
        Ok(Self { factor, unknown, gauge_of, weight, gauges })
    }

    /// Number of unknowns (free vertices less the gauge vertices).
    pub fn dim(&self) -> usize {
        self.factor.dim()
    }

    /// Whether a solve goes in two halves (of the factor's elimination tree).
    pub fn splits(&self) -> bool {
        self.halves().is_some()
    }

    /// The ends of the two halves of the unknowns a solve runs apart (`0..a`, `a..b`; the rest, their
    /// common top, after both), if it has them: no edge joins the two halves.
    pub fn halves(&self) -> Option<[usize; 2]> {
        self.factor.halves()
    }

    /// Entries of the Cholesky factor.
    pub fn factor_entries(&self) -> usize {
        self.factor.factor_entries()
    }

    /// Per vertex: its unknown (row of `L`), or [`NONE`] for anchored and gauge vertices.
    pub fn unknowns(&self) -> &[u32] {
        &self.unknown
    }

    /// The anchorless components.
    pub fn gauges(&self) -> &[Gauge] {
        &self.gauges
    }

    /// The gauge of vertex `v`'s component, if it has no anchor.
    pub fn gauge_of(&self, v: usize) -> Option<usize> {
        self.gauge_of.get(v).filter(|&&g| g != NONE).map(|&g| g as usize)
    }

    /// The right side `b`, one 3-vector per unknown, to fill before [`EdgeLaplacian::positions`].
    pub fn rhs_mut(&mut self) -> &mut [Padded] {
        self.factor.rhs_mut()
    }

    /// Solve `L u = b` for the right side filled in [`EdgeLaplacian::rhs_mut`] and write every
    /// vertex's position `rest + u` into `out` (`u` zero at anchors), each anchorless component
    /// translated so that its centroid moves by `centroids[g]` (one per gauge). The vertices go in
    /// two halves at once ([`crate::threads::halves`]) from twice [`HALVES`] on.
    pub fn positions(&mut self, centroids: &[DVec3], rest: &[DVec3], out: &mut [DVec3]) {
        self.factor.solve();
        let (x, unknown, gauge_of) = (self.factor.solution(), &self.unknown, &self.gauge_of);
        let u = |v: usize| at(x, unknown[v]);
        let shifts: Vec<DVec3> = (self.gauges.iter().zip(centroids))
            .map(|(g, mu)| *mu - g.vertices.iter().zip(&g.weights).map(|(&v, w)| u(v) * *w).sum::<DVec3>())
            .collect();
        crate::threads::halves(out, HALVES, |first, part| {
            for (v, p) in (first..).zip(part) {
                let (shift, u) = (shifts.get(gauge_of[v] as usize), u(v));
                *p = rest[v] + shift.map_or(u, |s| u + *s);
            }
        });
    }

    /// The adjoint of the reconstruction for per-vertex forces `f`: `y` per vertex (zero where
    /// [`EdgeLaplacian::unknowns`] is [`NONE`]) and the net force `F` on each anchorless component,
    /// such that `fᵀu = yᵀb + Σ_g F_gᵀ μ_g` (module documentation).
    pub fn adjoint(&mut self, f: &[DVec3]) -> (Vec<DVec3>, Vec<DVec3>) {
        let net: Vec<DVec3> = self.gauges.iter().map(|g| g.vertices.iter().map(|&v| f[v]).sum()).collect();
        let rhs = self.factor.rhs_mut();
        for (v, &k) in self.unknown.iter().enumerate().filter(|(_, k)| **k != NONE) {
            let shift = net.get(self.gauge_of[v] as usize).map_or(DVec3::ZERO, |fg| *fg * self.weight[v]);
            rhs[k as usize] = (f[v] - shift).into();
        }
        self.factor.solve();
        let x = self.factor.solution();
        (self.unknown.iter().map(|&k| at(x, k)).collect(), net)
    }
}

/// The solution's value at `unknown` (zero for [`NONE`]).
fn at(solution: &[Padded], unknown: u32) -> DVec3 {
    solution.get(unknown as usize).map_or(DVec3::ZERO, |&x| x.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::{grid, icosphere};

    /// Fill `b` for targets `δg_e = v_j − v_i` of a displacement field `v` (as the pass does).
    fn compatible_rhs(mesh: &TriMesh, lap: &mut EdgeLaplacian, v: &[DVec3]) {
        let unknown = lap.unknowns().to_vec();
        let rhs = lap.rhs_mut();
        rhs.fill(Padded::ZERO);
        for (t, a) in mesh.triangles().iter().zip(mesh.triangle_areas()) {
            for k in 0..3 {
                let (i, j) = (t[k], t[(k + 1) % 3]);
                let d: Padded = ((v[j] - v[i]) * a).into();
                for (vertex, sign) in [(j, 1.0), (i, -1.0)] {
                    if let Some(r) = rhs.get_mut(unknown[vertex] as usize) {
                        *r += d * sign;
                    }
                }
            }
        }
    }

    fn field(p: DVec3) -> DVec3 {
        DVec3::new((3.0 * p.x).sin() * p.z, p.x * p.x - 0.3 * p.z, (2.0 * p.z).cos() * p.x)
    }

    #[test]
    fn compatible_targets_are_reproduced_with_anchors_and_with_a_gauge() {
        // Anchored: a field that vanishes at the anchors comes back exactly (to round-off).
        let mesh = grid([1.0, 0.4], [10, 4]).unwrap();
        let anchors: Vec<usize> = (0..5).collect();
        let mut lap = EdgeLaplacian::new(&mesh, &anchors).unwrap();
        let v: Vec<DVec3> = mesh
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| if anchors.contains(&i) { DVec3::ZERO } else { field(*p) })
            .collect();
        compatible_rhs(&mesh, &mut lap, &v);
        let mut u = vec![DVec3::ONE; v.len()];
        lap.positions(&[], &vec![DVec3::ZERO; u.len()], &mut u);
        let worst = u.iter().zip(&v).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        eprintln!("anchored grid: compatible field reproduced to {worst:.1e}");
        assert!(worst < 1e-12, "{worst}");
        // Free: reproduced up to a translation, which the gauge fixes to the given centroid shift.
        let mesh = icosphere(0.5, 2).unwrap();
        let mut lap = EdgeLaplacian::new(&mesh, &[]).unwrap();
        assert_eq!(lap.gauges().len(), 1);
        let v: Vec<DVec3> = mesh.positions().iter().map(|p| field(*p)).collect();
        let g = lap.gauges()[0].clone();
        let mean: DVec3 = g.vertices.iter().zip(&g.weights).map(|(&i, w)| v[i] * *w).sum();
        compatible_rhs(&mesh, &mut lap, &v);
        let mut u = vec![DVec3::ZERO; v.len()];
        lap.positions(&[mean], &vec![DVec3::ZERO; u.len()], &mut u);
        let worst = u.iter().zip(&v).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        eprintln!("free sphere: compatible field reproduced to {worst:.1e}");
        assert!(worst < 1e-12, "{worst}");
    }

    #[test]
    fn the_adjoint_gives_the_work_of_a_force_on_the_solution() {
        // fᵀu = yᵀb + Fᵀμ for arbitrary (incompatible) right sides, free and anchored.
        for (mesh, anchors) in
            [(grid([1.0, 0.4], [8, 3]).unwrap(), vec![0, 1, 2, 3]), (icosphere(0.5, 1).unwrap(), vec![])]
        {
            let mut lap = EdgeLaplacian::new(&mesh, &anchors).unwrap();
            let n = mesh.vertex_count();
            let f: Vec<DVec3> = (0..n).map(|i| field(DVec3::splat(0.37 * i as f64))).collect();
            let b: Vec<DVec3> =
                (0..lap.dim()).map(|i| DVec3::new((1.3 * i as f64).sin(), 0.5, -0.1 * i as f64)).collect();
            let mu: Vec<DVec3> = lap.gauges().iter().map(|_| DVec3::new(0.1, -0.2, 0.3)).collect();
            lap.rhs_mut().iter_mut().zip(&b).for_each(|(r, b)| *r = (*b).into());
            let mut u = vec![DVec3::ZERO; n];
            lap.positions(&mu, &vec![DVec3::ZERO; n], &mut u);
            let work: f64 = f.iter().zip(&u).map(|(a, b)| a.dot(*b)).sum();
            let (y, net) = lap.adjoint(&f);
            let yb: f64 = (0..n)
                .filter(|&v| lap.unknowns()[v] != NONE)
                .map(|v| y[v].dot(b[lap.unknowns()[v] as usize]))
                .sum::<f64>()
                + net.iter().zip(&mu).map(|(a, b)| a.dot(*b)).sum::<f64>();
            eprintln!("fᵀu = {work:.15e}, yᵀb + Fᵀμ = {yb:.15e}");
            assert!((work - yb).abs() < 1e-12 * work.abs().max(1.0), "{work} vs {yb}");
        }
    }
}
