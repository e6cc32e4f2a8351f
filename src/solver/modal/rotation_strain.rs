//! `mwts-rs`: the same modes as modal warping, with positions reconstructed globally from
//! per-triangle rotations and strains (rotation-strain coordinates: Huang et al. 2011; Pan, Bao &
//! Huang 2015) and generalised forces consistent with that reconstruction.
//!
//! Modal warping's closed form warps each vertex on its own and so cannot integrate rotations along
//! the material (`super::warp`). Here each triangle `t` gets its linear rotation `ω_t = W_t q` (the
//! rotation Jacobian of [`super::rotation`] before vertex averaging, applied to `Φ_t q`) and its
//! in-plane linear strain `ε_t = E_t q` (the symmetric part of the gradient of `Φq`, projected onto
//! its rest plane). Its three edges get the targets `g_e = exp([ω_t]×)(I + ε_t)(X_j − X_i)`, and the
//! positions are the weighted least-squares fit `min Σ_t A_t Σ_(i,j)∈t |(x_j − x_i) − g_e|²` with the
//! anchors fixed: one sparse SPD solve with three right sides per step ([`super::laplacian`], the
//! right sides from [`super::rs_pass`]). To first order the targets are `X_j − X_i + (Φq)_j −
//! (Φq)_i`, so `x(q) = X + Φq + O(|q|²)` and `∂x/∂q = Φ` at rest; a uniform `ω` with no strain is an
//! exact rigid rotation at any angle; `q = 0` is the rest shape bit for bit (the pass adds exact
//! zeros). Free shells: see the gauge in [`super::laplacian`]. `rds` composes each triangle's
//! rotation of two instead, `exp([ω_t^o]×) exp([ω_t^i]×)` from two groups of its coordinates
//! ([`RotationStrain::compose_from`], [`super::rs_pass`]); `mwts-rs` keeps one.
//!
//! **Forces.** The load acts through its virtual work on the reconstruction: `g(q) = J(q)ᵀ f` with
//! `J = ∂x/∂q`, so a static equilibrium is a stationary point of `½ qᵀΛq − fᵀx(q)`. By the adjoint,
//! `fᵀx` depends on `q` only through `yᵀb(q)` with `y = L⁻¹ f`: for constant loads (gravity, point
//! loads) `y` and the triangles' load moments are computed once per load change
//! ([`RotationStrain::set_forces`]), and a step is one per-triangle pass and one solve.
//!
//! **Dynamics** (in [`super::dynamics`]): `q̈ + D q̇ + Λ q = g(q)` by linearly implicit Euler — one
//! Newton step of backward Euler, with the load's stiffness `H = ∂g/∂q` (symmetric: `g` is the
//! gradient of `fᵀx`) in the step matrix `I + hD + h²(Λ − H)`. Taking `g` at the start of the step
//! instead, as `mwts` does, is unstable under large loads: on the V-beam at 1200 m/s² `H` has an
//! eigenvalue of −8.8e4 1/s² against `λ₁ = 1.5e3`, `h²|H| ≈ 97`, and the step flips between two shapes
//! (period two) instead of settling. `H` is computed by forward differences of `g` (one force-only
//! pass per mode, no solve; a step of 1e-6 rad of the largest triangle rotation per mode) and kept
//! while it predicts the force: after each step the part of `Δg` it missed, `r = Δg − H Δq`, acts as
//! an explicit stiffness, and `H` is recomputed when `h² |r_j| / (1 + hD_j + h²λ_j)` exceeds a quarter
//! of `|Δq|` (an explicit part that small cannot flip the step; see [`RotationStrain::after_step`]).
//! The configuration-dependent mass `J(q)ᵀ M J(q)` of Pan et al. is left out: the mass stays
//! `Φᵀ M Φ = I` (exact at rest, and static equilibria do not depend on it).
//!
//! **Drags.** A position drag on vertex `i` is linearised with the rows `J_i(q)` of the exact
//! Jacobian (the adjoint with `f = e_i ⊗ e_a`; the scalar field `z = L⁻¹ e_i` is kept while the drag
//! lasts). The rows are computed in the step's pass only once some triangle may have turned by
//! [`ROWS_TURN`] since they last were: the constraint is linearised about the current position
//! `x_i(q)`, so rows a little old change how fast a drag converges, not where it settles. The
//! positions integrate the rotations over the whole shell, so a far target can ask for modal
//! amplitudes whose rotations, somewhere else, are far outside the linearisation's reach: on the
//! creature (4 modes) a 0.22 m pull on the head took some triangles past half a turn in the first
//! step, and the following steps never settled (the energy grew from 1.6e3 to 2e6 J). So while a
//! position drag is active a step is a trust-region step: if it would turn some triangle by more than
//! [`DRAG_TURN`] (by the bound `Σ_j |Δq_j| s_j`, `s_j = max_t |W_t e_j|`) the whole step `Δq` (elastic
//! response and drag correction) is scaled down to that, and then by a relaxation that halves
//! whenever a step turns back against the previous one (`Σ_j s_j² Δq_j Δq'_j < 0`) and grows by a
//! quarter otherwise (between 1/1024 and 1): without it that pull never settled either, `q` flipping
//! every step between two shapes a full `DRAG_TURN` apart (the head moving 3 cm a step, at equal
//! energies, so it looked settled by energy). Equilibria, where `Δq = 0`, are not moved; a
//! far target is reached over several steps, or — out of the modes' reach — settles at a compromise
//! (measured in `tests/modal_rs.rs`). An orientation drag acts on the triangle rotations: it pins the
//! area-weighted mean of the
//! rotation vectors `ω_t` of the vertex's triangles — exactly `Ψ_i q`, so its rows are `mwts`'s.

use glam::DVec3;
use nalgebra::DMatrix;

use super::basis::ModalBasis;
use super::laplacian::{EdgeLaplacian, Gauge};
use super::rs_pass::{DragRows, Moments, RightSide, TrianglePass};
use crate::linalg::padded::Padded;
use crate::mesh::TriMesh;
use crate::solver::SolverError;

/// The most a step under a position drag may turn any triangle, rad (module documentation).
pub const DRAG_TURN: f64 = 0.25;

/// How far any triangle may have turned (by the bound of [`RotationStrain::drag_trust`]) since the
/// position drags' Jacobian rows were computed before they are computed again, rad.
pub const ROWS_TURN: f64 = 0.01;

/// The drags' rows are also recomputed once the shell moves this many times less per step than it
/// has since they were computed: settling, so that an equilibrium under drags is linearised about
/// itself (a stationary point of the energy plus the drags' penalty, not of a nearby linearisation).
pub const SETTLED_ROWS: f64 = 64.0;

/// The reconstruction and its adjoint for one mesh, its anchors and a modal basis.
#[derive(Debug)]
pub struct RotationStrain {
    laplacian: EdgeLaplacian,
    pass: TrianglePass,
    rest: Vec<DVec3>,
    /// Per gauge, per mode: the centroid of the mode's displacement over the component.
    centroid_modes: Vec<Vec<DVec3>>,
    /// Per chunk of triangles of the pass: the loads' moments.
    loads: Vec<Moments>,
    /// Per gauge: the net load on the component.
    net: Vec<DVec3>,
    /// The position drags' Jacobian rows, at `rows_at`.
    drags: Vec<DragRows>,
    /// The `q` at which the drags' rows were computed (empty: never, or a drag or basis changed).
    rows_at: Vec<f64>,
    /// The `q` of the previous update.
    updated_at: Vec<f64>,
    /// The relaxation of steps under position drags, and the last step it allowed
    /// ([`RotationStrain::drag_trust`]).
    relax: f64,
    last_step: Vec<f64>,
    /// The load stiffness `H = ∂g/∂q` (module documentation), or `None` until the next update
    /// computes it.
    stiffness: Option<DMatrix<f64>>,
    /// Per mode: the largest triangle rotation a unit of it makes, rad.
    scales: Vec<f64>,
    /// Scratch: what the second half of the pass adds to the solve's top (to every unknown when
    /// the pass is cut by number).
    scratch: Vec<Padded>,
}

impl RotationStrain {
    /// Factorise the reconstruction of `mesh` with `anchors` fixed, for the modes of `basis` and no
    /// loads.
    pub fn new(mesh: &TriMesh, anchors: &[usize], basis: &ModalBasis) -> Result<Self, SolverError> {
        let laplacian = EdgeLaplacian::new(mesh, anchors)?;
        let rest = mesh.positions().to_vec();
        let pass = TrianglePass::new(&rest, mesh.triangles(), laplacian.unknowns(), laplacian.halves(), basis);
        let mut rs = Self {
            loads: Vec::new(),
            net: vec![DVec3::ZERO; laplacian.gauges().len()],
            scratch: Vec::new(),
            centroid_modes: Vec::new(),
            drags: Vec::new(),
            rows_at: Vec::new(),
            updated_at: Vec::new(),
            relax: 1.0,
            last_step: Vec::new(),
            stiffness: None,
            scales: Vec::new(),
            laplacian,
            pass,
            rest,
        };
        rs.set_basis(basis);
        rs.set_forces(&[]);
        Ok(rs)
    }

    /// Use a new basis (same mesh and anchors). The drags' adjoint fields do not depend on it; their
    /// rows are refilled by the next [`RotationStrain::update`].
    pub fn set_basis(&mut self, basis: &ModalBasis) {
        self.pass.set_basis(&self.rest, basis);
        let mode = |v: usize, j: usize| DVec3::new(basis.phi(v, 0, j), basis.phi(v, 1, j), basis.phi(v, 2, j));
        let centroid = |g: &Gauge, j: usize| g.vertices.iter().zip(&g.weights).map(|(&v, w)| mode(v, j) * *w).sum();
        self.centroid_modes =
            self.laplacian.gauges().iter().map(|g| (0..basis.modes()).map(|j| centroid(g, j)).collect()).collect();
        self.drags.iter_mut().for_each(|d| d.rows = vec![0.0; 3 * basis.modes()]);
        self.rows_at.clear();
        self.last_step.clear();
        self.scales = self.pass.rotation_scales();
        self.stiffness = None;
    }

    /// Compose each triangle's rotation of two (`exp([ω^outer]×) exp([ω^inner]×)`, the coordinates
    /// from `first` on making the inner one; [`TrianglePass::compose_from`]), or make it one rotation
    /// of all coordinates (`None`, the default).
    pub fn compose_from(&mut self, first: Option<usize>) {
        self.pass.compose_from(first);
        self.rows_at.clear();
        self.stiffness = None;
    }

    /// Set the per-vertex external forces (missing trailing vertices get none), constant until the
    /// next call: their adjoint and the triangles' load moments.
    pub fn set_forces(&mut self, forces: &[DVec3]) {
        let mut f = vec![DVec3::ZERO; self.rest.len()];
        f.iter_mut().zip(forces).for_each(|(a, b)| *a = *b);
        let (y, net) = self.laplacian.adjoint(&f);
        self.loads = self.pass.moments(&y);
        self.net = net;
        self.stiffness = None;
    }

    /// Positions `x(q)` and the generalised force `g(q) = J(q)ᵀ f`; the position drags' Jacobian rows
    /// and the load stiffness too if they are due (the rows once some triangle may have turned by
    /// [`ROWS_TURN`] since they were computed: a drag's step is linearised about its current
    /// position with them, so older rows change how fast it converges, not where it settles).
    pub fn update(&mut self, q: &[f64], positions: &mut [DVec3], force: &mut [f64]) {
        let moved = |at: &[f64]| q.iter().zip(at).zip(&self.scales).map(|((a, b), s)| (a - b).abs() * s).sum::<f64>();
        let (age, step) = (moved(&self.rows_at), moved(&self.updated_at));
        let settling = age > SETTLED_ROWS * step && age > 1e-13;
        let due = !self.drags.is_empty() && (self.rows_at.len() != q.len() || age > ROWS_TURN || settling);
        self.updated_at = q.to_vec();
        crate::solver::supersede::awake(self.splits(), || {
            let drags = if due { &mut self.drags[..] } else { &mut [] };
            let rhs = RightSide { rhs: self.laplacian.rhs_mut(), scratch: &mut self.scratch };
            self.pass.run(q, Some((&self.loads, &mut *force)), Some(rhs), drags);
            self.solve_positions(q, positions, force);
        });
        if due {
            self.rows_at = q.to_vec();
        }
        if self.stiffness.is_none() {
            self.stiffness = Some(self.load_stiffness(q, force));
        }
    }

    /// Whether a reconstruction has halves to run at once (its triangle pass or its solve), so it
    /// runs on the pool with its threads awake ([`crate::solver::supersede::awake`]).
    fn splits(&self) -> bool {
        self.pass.splits() || self.laplacian.splits()
    }

    /// Positions `x(q)` alone: no generalised force, no drag rows and no load stiffness (for methods
    /// that keep their own, `rds`).
    pub fn reconstruct(&mut self, q: &[f64], positions: &mut [DVec3]) {
        crate::solver::supersede::awake(self.splits(), || {
            let rhs = RightSide { rhs: self.laplacian.rhs_mut(), scratch: &mut self.scratch };
            self.pass.run(q, None, Some(rhs), &mut []);
            self.place(q, positions);
        });
    }

    /// The generalised force `J(q)ᵀ f` of the per-vertex forces `f` (which become the forces set),
    /// without positions: one adjoint solve and one pass. The load stiffness is left to be
    /// recomputed by the next [`RotationStrain::update`].
    pub fn force_of(&mut self, q: &[f64], forces: &[DVec3]) -> Vec<f64> {
        self.set_forces(forces);
        let mut g = vec![0.0; q.len()];
        self.pass.run(q, Some((&self.loads, &mut g)), None, &mut []);
        self.add_centroid_forces(&mut g);
        g
    }

    /// Finish an update after the pass: the net loads' work on the centroids, and the positions.
    fn solve_positions(&mut self, q: &[f64], positions: &mut [DVec3], force: &mut [f64]) {
        self.add_centroid_forces(force);
        self.place(q, positions);
    }

    /// The positions from the right side the pass left: one solve, and the gauges' centroids.
    fn place(&mut self, q: &[f64], positions: &mut [DVec3]) {
        let centroids: Vec<DVec3> =
            (self.centroid_modes.iter()).map(|modes| modes.iter().zip(q).map(|(c, qj)| *c * *qj).sum()).collect();
        self.laplacian.positions(&centroids, &self.rest, positions);
    }

    /// The trust region of a step `dq` under a position drag (module documentation): the factor (at
    /// most 1) that keeps the bound `Σ_j |dq_j| max_t |W_t e_j|` on any triangle's turn within
    /// [`DRAG_TURN`], times the relaxation, which halves when the step turns back against the last
    /// one and grows by a quarter when it does not (between 1/1024 and 1).
    pub fn drag_trust(&mut self, dq: &[f64]) -> f64 {
        let turn: f64 = dq.iter().zip(&self.scales).map(|(d, s)| d.abs() * s).sum();
        let back: f64 = (dq.iter().zip(&self.last_step).zip(&self.scales)).map(|((a, b), s)| a * b * s * s).sum();
        self.relax = if back < 0.0 { 0.5 * self.relax } else { 1.25 * self.relax }.clamp(1.0 / 1024.0, 1.0);
        let trust = self.relax * if turn > DRAG_TURN { DRAG_TURN / turn } else { 1.0 };
        self.last_step = dq.iter().map(|d| d * trust).collect();
        trust
    }

    /// The load stiffness `H = ∂g/∂q` in use (module documentation).
    pub fn stiffness(&self) -> Option<&DMatrix<f64>> {
        self.stiffness.as_ref()
    }

    /// After a step from `q` to `q + dq` that changed the force by `dg`, with `implicit[j] =
    /// 1 + hD_j + h²λ_j` the diagonal of the step matrix and `h` the step: drop `H` (so that the next
    /// update recomputes it) if the part of `dg` it did not predict is large enough to act as a
    /// destabilising explicit stiffness (module documentation).
    pub fn after_step(&mut self, dq: &[f64], dg: &[f64], implicit: &[f64], h: f64) {
        let Some(stiffness) = &self.stiffness else { return };
        let predicted = stiffness * nalgebra::DVector::from_column_slice(dq);
        let missed: f64 = (dg.iter().zip(predicted.iter()).zip(implicit))
            .map(|((g, p), d)| (h * h * (g - p) / d).powi(2))
            .sum::<f64>()
            .sqrt();
        let moved = dq.iter().map(|x| x * x).sum::<f64>().sqrt();
        if missed > 0.25 * moved || !missed.is_finite() {
            self.stiffness = None;
        }
    }

    /// `g += Σ_g C_gᵀ F_g`: the work of the net load on a free component's centroid.
    fn add_centroid_forces(&self, force: &mut [f64]) {
        for (modes, net) in self.centroid_modes.iter().zip(&self.net) {
            force.iter_mut().zip(modes).for_each(|(g, c)| *g += c.dot(*net));
        }
    }

    /// `H = ∂g/∂q` at `q` (where the force is `g`) by forward differences, symmetrised.
    fn load_stiffness(&self, q: &[f64], g: &[f64]) -> DMatrix<f64> {
        let m = q.len();
        let mut h = DMatrix::zeros(m, m);
        let (mut shifted, mut gj) = (q.to_vec(), vec![0.0; m]);
        for (j, step) in self.scales.iter().map(|&s| 1e-6 / s.max(f64::MIN_POSITIVE)).enumerate() {
            shifted[j] = q[j] + step;
            self.pass.run(&shifted, Some((&self.loads, &mut gj)), None, &mut []);
            self.add_centroid_forces(&mut gj);
            shifted[j] = q[j];
            for i in 0..m {
                h[(i, j)] = (gj[i] - g[i]) / step;
            }
        }
        (&h + h.transpose()) * 0.5
    }

    /// The Jacobian `∂x_vertex/∂q` (3 rows, x, y, z, of `m`) at the `q` where the rows were last due
    /// ([`RotationStrain::update`]). A vertex asked for the first time gets its adjoint field, and the
    /// update is redone at `q` to fill every drag's rows (same positions and force); it is kept until
    /// [`RotationStrain::keep_drags`] drops it.
    pub fn position_rows(&mut self, vertex: usize, q: &[f64], positions: &mut [DVec3], force: &mut [f64]) -> Vec<f64> {
        if !self.drags.iter().any(|d| d.vertex == vertex) {
            let mut f = vec![DVec3::ZERO; self.rest.len()];
            if let Some(fv) = f.get_mut(vertex) {
                *fv = DVec3::X;
            }
            let (y, _) = self.laplacian.adjoint(&f);
            let z: Vec<f64> = y.iter().map(|v| v.x).collect();
            self.drags.push(self.pass.drag_rows(vertex, &z));
            self.rows_at.clear();
            self.last_step.clear();
            self.relax = 1.0;
            self.update(q, positions, force);
        }
        let m = q.len();
        let mut rows = self.drags.iter().find(|d| d.vertex == vertex).map_or(vec![0.0; 3 * m], |d| d.rows.clone());
        if let Some(modes) = self.laplacian.gauge_of(vertex).and_then(|g| self.centroid_modes.get(g)) {
            for (j, c) in modes.iter().enumerate() {
                (0..3).for_each(|a| rows[a * m + j] += c[a]);
            }
        }
        rows
    }

    /// Forget the drags on vertices for which `keep` is false.
    pub fn keep_drags(&mut self, keep: impl Fn(usize) -> bool) {
        self.drags.retain(|d| keep(d.vertex));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::{grid, icosphere, v_beam};
    use crate::solver::modal::warp::rotation;

    /// Three smooth, unrelated mode shapes, each largest displacement 1 (zero at `anchors`, as real
    /// modes are).
    fn basis(mesh: &TriMesh, anchors: &[usize]) -> ModalBasis {
        let shapes: Vec<Vec<DVec3>> = (0..3)
            .map(|j| {
                let jf = j as f64 + 1.0;
                let shape: Vec<DVec3> = (mesh.positions().iter().enumerate())
                    .map(|(v, p)| {
                        let s = (p.x + 0.5).powi(j + 2);
                        let field = DVec3::new(0.3 * (jf * p.z).sin() * s, s, 0.4 * p.y * s + 0.2 * p.z * p.x);
                        if anchors.contains(&v) { DVec3::ZERO } else { field }
                    })
                    .collect();
                let largest = shape.iter().map(|u| u.length()).fold(0.0, f64::max);
                shape.iter().map(|u| *u / largest).collect()
            })
            .collect();
        ModalBasis::new(mesh, vec![1.0, 4.0, 9.0], &shapes)
    }

    /// A clamped V-beam (a crease: triangles of two planes) and a free sphere.
    fn cases() -> Vec<(&'static str, TriMesh, Vec<usize>)> {
        let beam = v_beam(1.0, 0.3, 90.0, [12, 4]).unwrap();
        let anchors: Vec<usize> = (0..beam.vertex_count()).filter(|&v| beam.positions()[v].x < -0.45).collect();
        vec![("V-beam", beam, anchors), ("free sphere", icosphere(0.5, 2).unwrap(), Vec::new())]
    }

    /// The reconstruction of `mesh` with the modes of [`basis`] under uneven forces.
    fn loaded(mesh: &TriMesh, anchors: &[usize]) -> (ModalBasis, RotationStrain, Vec<DVec3>) {
        let b = basis(mesh, anchors);
        let mut rs = RotationStrain::new(mesh, anchors, &b).unwrap();
        let f: Vec<DVec3> = (0..mesh.vertex_count())
            .map(|i| DVec3::new((0.7 * i as f64).sin(), -1.0, (1.3 * i as f64).cos() * 0.5))
            .collect();
        rs.set_forces(&f);
        (b, rs, f)
    }

    #[test]
    fn a_uniform_rotation_without_strain_turns_the_whole_mesh_rigidly() {
        // One mode, the linearised rotation about the centroid: every triangle gets the same ω and zero
        // strain, and the reconstruction is the exact rotation at any angle (past π and 2π too).
        let meshes =
            [grid([1.0, 0.4], [8, 3]).unwrap(), v_beam(1.0, 0.3, 120.0, [8, 4]).unwrap(), icosphere(0.5, 2).unwrap()];
        for mesh in meshes {
            let areas = mesh.vertex_areas();
            let c =
                mesh.positions().iter().zip(&areas).map(|(p, a)| *p * *a).sum::<DVec3>() / areas.iter().sum::<f64>();
            let axis = DVec3::new(0.3, -0.8, 0.5).normalize();
            let shape: Vec<DVec3> = mesh.positions().iter().map(|p| axis.cross(*p - c)).collect();
            let basis = ModalBasis::new(&mesh, vec![0.0], &[shape]);
            let mut rs = RotationStrain::new(&mesh, &[], &basis).unwrap();
            let n = mesh.vertex_count();
            let (mut x, mut g) = (vec![DVec3::ZERO; n], vec![0.0]);
            for angle in [1e-3, 0.7, 2.5, 4.0, 9.0] {
                rs.update(&[angle], &mut x, &mut g);
                let r = rotation(axis * angle);
                let worst = (0..n).map(|v| (x[v] - (c + r * (mesh.positions()[v] - c))).length()).fold(0.0, f64::max);
                eprintln!("{} vertices, rotation by {angle} rad: worst vertex off by {worst:.1e} m", n);
                assert!(worst < 1e-13, "{angle}: {worst}");
            }
        }
    }

    #[test]
    fn two_uniform_rotations_composed_turn_the_mesh_by_their_product() {
        // Two modes, linearised rotations about different axes: summed, the triangles turn by
        // exp([a θ + b φ]×); composed (the second inside the first), by exp([a θ]×) exp([b φ]×).
        // Both are rigid motions of the whole mesh, about its centroid, and they differ.
        let mesh = icosphere(0.5, 2).unwrap();
        let areas = mesh.vertex_areas();
        let c = mesh.positions().iter().zip(&areas).map(|(p, a)| *p * *a).sum::<DVec3>() / areas.iter().sum::<f64>();
        let axes = [DVec3::new(0.3, -0.8, 0.5).normalize(), DVec3::new(0.9, 0.1, -0.2).normalize()];
        let shapes: Vec<Vec<DVec3>> =
            axes.iter().map(|a| mesh.positions().iter().map(|p| a.cross(*p - c)).collect()).collect();
        let basis = ModalBasis::new(&mesh, vec![0.0, 0.0], &shapes);
        let mut rs = RotationStrain::new(&mesh, &[], &basis).unwrap();
        let n = mesh.vertex_count();
        let (mut x, mut g) = (vec![DVec3::ZERO; n], vec![0.0; 2]);
        let q = [1.3, 2.2];
        let off = |x: &[DVec3], r: glam::DMat3| {
            (0..n).map(|v| (x[v] - (c + r * (mesh.positions()[v] - c))).length()).fold(0.0, f64::max)
        };
        let (summed, composed) =
            (rotation(axes[0] * q[0] + axes[1] * q[1]), rotation(axes[0] * q[0]) * rotation(axes[1] * q[1]));
        rs.update(&q, &mut x, &mut g);
        assert!(off(&x, summed) < 1e-13, "summed: {}", off(&x, summed));
        rs.compose_from(Some(1));
        rs.update(&q, &mut x, &mut g);
        eprintln!(
            "composed: worst vertex off by {:.1e} m; the summed rotation is {:.2} m away",
            off(&x, composed),
            off(&x, summed)
        );
        assert!(off(&x, composed) < 1e-13, "composed: {}", off(&x, composed));
        assert!(off(&x, summed) > 0.1);
    }

    #[test]
    fn q_zero_is_the_rest_shape_bit_for_bit_and_the_first_order_is_the_linear_modes() {
        for (name, mesh, anchors) in cases() {
            let (b, mut rs, f) = loaded(&mesh, &anchors);
            let n = mesh.vertex_count();
            let (mut x, mut g) = (vec![DVec3::ZERO; n], vec![0.0; 3]);
            rs.update(&[0.4, -0.3, 0.2], &mut x, &mut g);
            assert!(x.iter().zip(mesh.positions()).any(|(a, b)| (*a - *b).length() > 0.05), "{name}: it moved");
            rs.update(&[0.0; 3], &mut x, &mut g);
            assert_eq!(x, mesh.positions(), "{name}: the rest shape, bit for bit");
            // At rest the targets are those of Φq (compatible, zero at the anchors; a free shell's
            // centroid follows Φq's), so J(0) = Φ and the consistent force is the linear one, Φᵀ f.
            for (j, gj) in g.iter().enumerate() {
                let linear: f64 = (0..n).map(|v| f[v].dot(b.displacement(v, &unit(j)))).sum();
                eprintln!("{name}, mode {j}: g(0) = {gj:.12e}, Φᵀf = {linear:.12e}");
                assert!((gj - linear).abs() < 1e-10 * linear.abs().max(1.0), "{name}, mode {j}: {gj} vs {linear}");
            }
        }
    }

    fn unit(j: usize) -> [f64; 3] {
        let mut e = [0.0; 3];
        e[j] = 1.0;
        e
    }

    #[test]
    fn consistent_forces_and_drag_rows_match_central_differences() {
        // One rotation of all three coordinates, and the third's composed inside the first two's.
        for ((name, mesh, anchors), inner) in cases().into_iter().flat_map(|c| [(c.clone(), None), (c, Some(2))]) {
            let (b, mut rs, f) = loaded(&mesh, &anchors);
            rs.compose_from(inner);
            let n = mesh.vertex_count();
            let (mut x, mut g) = (vec![DVec3::ZERO; n], vec![0.0; 3]);
            // Large rotations and strains.
            let q = [1.6, -1.0, 0.6];
            let dragged = n - 2;
            rs.update(&q, &mut x, &mut g);
            let rows = rs.position_rows(dragged, &q, &mut x, &mut g);
            let largest = (0..n).map(|v| b.rotation(v, &q).length()).fold(0.0, f64::max);
            assert!(largest > 1.0, "{name}: large rotations ({largest:.2} rad)");
            let h = 1e-5;
            for j in 0..3 {
                let at = |s: f64, rs: &mut RotationStrain| {
                    let mut qs = q;
                    qs[j] += s;
                    let (mut xs, mut gs) = (vec![DVec3::ZERO; n], vec![0.0; 3]);
                    rs.update(&qs, &mut xs, &mut gs);
                    xs
                };
                let (plus, minus) = (at(h, &mut rs), at(-h, &mut rs));
                let work = |x: &[DVec3]| f.iter().zip(x).map(|(a, b)| a.dot(*b)).sum::<f64>();
                let fd = (work(&plus) - work(&minus)) / (2.0 * h);
                eprintln!(
                    "{name} ({inner:?}), mode {j} (rotations up to {largest:.2} rad): g = {:.10e}, FD {fd:.10e}",
                    g[j]
                );
                assert!((g[j] - fd).abs() < 1e-6 * fd.abs(), "{name}, mode {j}: {} vs {fd}", g[j]);
                let column = (plus[dragged] - minus[dragged]) / (2.0 * h);
                let got = DVec3::new(rows[j], rows[3 + j], rows[6 + j]);
                eprintln!("{name}, mode {j}: ∂x_{dragged}/∂q = {got:.8}, FD {column:.8}");
                assert!((got - column).length() < 1e-6 * column.length(), "{name}, mode {j}: {got} vs {column}");
            }
        }
    }
}
