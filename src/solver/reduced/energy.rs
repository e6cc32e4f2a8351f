//! The discrete-shell energy of `rds` as a function of its reduced coordinates `c`: positions by the
//! rotation-strain reconstruction `x(c)` of the reduced basis, the full nonlinear energy `E(x(c))`
//! over every element, its generalised force and its stiffness.
//!
//! With `J = ∂x/∂c` and a per-vertex force field `r` (external forces minus `∇E`, plus whatever the
//! caller adds), the generalised force is `Jᵀ r`: the reconstruction's adjoint
//! ([`RotationStrain::set_forces`]), exact. The stiffness of `Π(c) = E(x(c)) − (work of r held
//! fixed)` is `Jᵀ ∇²E J − ∂(J(c)ᵀ r)/∂c` with `r` frozen: the first term from the exact Hessian
//! assembled at `x(c)` and `J`'s columns by forward differences of the reconstruction (a step of
//! 1e-6 of each vector's largest displacement), the second the reconstruction's load stiffness
//! (forward differences of the force pass). Both are approximations to about 1e-6; the force is
//! exact, so a Newton iteration on them still converges to the exact stationary point.
//!
//! With a [`Cubature`] set, `E` is its weighted sum `Σ_{e∈S} w_e E_e` over a few elements instead of
//! every element: the energy, its gradient (non-zero at the sampled elements' vertices only) and the
//! projected Hessian `Σ w_e J_eᵀ ∇²E_e J_e` (from the Jacobian's rows at those vertices, with no
//! sparse assembly). The reconstruction and its adjoint stay global.

use glam::DVec3;
use nalgebra::{DMatrix, DVector};

use super::basis::ReducedBasis;
use crate::energy::stretch::packed_entry;
use crate::energy::{DiscreteShell, HessianMode, ShellStiffness};
use crate::linalg::{BlockAssembler, DofMap};
use crate::mesh::TriMesh;
use crate::solver::SolverError;
use crate::solver::modal::basis::ModalBasis;
use crate::solver::modal::rotation_strain::RotationStrain;

/// The step of the Jacobian's central differences, relative to a vector's largest displacement.
const JACOBIAN_STEP: f64 = 1e-6;

/// A weighted set of elements whose energies stand for the whole energy (fitted by
/// [`super::cubature::fit`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Cubature {
    /// Element numbers (as [`crate::energy::DiscreteShell::for_each_stencil`]) and their weights.
    pub elements: Vec<(usize, f64)>,
    /// The relative residual of the fit on its training poses.
    pub training_error: f64,
}

/// A shell reduced to a basis, evaluated through the rotation-strain reconstruction.
#[derive(Debug)]
pub struct ReducedShell {
    rs: RotationStrain,
    /// The basis in the modal layout: its rows at a vertex, displacements and rotations.
    pub modal: ModalBasis,
    shell: DiscreteShell,
    hessian: BlockAssembler,
    dofs: DofMap,
    rest: Vec<DVec3>,
    /// Per coordinate, the largest displacement a unit of it makes, m.
    scales: Vec<f64>,
    /// Scratch: the force of the reconstruction's pass.
    force: Vec<f64>,
    /// The elements and weights the energy is summed over, when not every element.
    cubature: Option<Cubature>,
}

impl ReducedShell {
    /// The shell of `mesh` with `anchors` fixed and stiffnesses `k`, reduced to `basis`.
    pub fn new(
        mesh: &TriMesh,
        anchors: &[usize],
        k: ShellStiffness,
        basis: &ReducedBasis,
    ) -> Result<Self, SolverError> {
        let modal = basis.modal(mesh);
        let mut rs = RotationStrain::new(mesh, anchors, &modal)?;
        // The modes' and load responses' rotations act last, on triangles the rest have turned in the
        // material frame (module documentation).
        rs.compose_from(Some(basis.first_order()));
        let shell = DiscreteShell::new(mesh, k).map_err(|e| SolverError::Numerical(e.to_string()))?;
        let mut fixed = vec![false; mesh.vertex_count()];
        anchors.iter().for_each(|&a| fixed[a] = true);
        let dofs = DofMap::without(&fixed);
        let hessian = shell.hessian_pattern(&dofs).map_err(|e| SolverError::Numerical(e.to_string()))?;
        let scales =
            basis.shapes.iter().map(|s| s.iter().map(|u| u.length()).fold(0.0, f64::max).max(1e-300)).collect();
        Ok(Self {
            rs,
            force: vec![0.0; basis.len()],
            modal,
            shell,
            hessian,
            dofs,
            rest: mesh.positions().to_vec(),
            scales,
            cubature: None,
        })
    }

    /// Sum the energy over `cubature`'s elements, or over every element (`None`).
    pub fn set_cubature(&mut self, cubature: Option<Cubature>) {
        self.cubature = cubature;
    }

    /// The cubature in use, if any.
    pub fn cubature(&self) -> Option<&Cubature> {
        self.cubature.as_ref()
    }

    /// The number of elements of the full energy.
    pub fn element_count(&self) -> usize {
        self.shell.element_count()
    }

    /// One element's generalised force `J_eᵀ ∇E_e(x)` (the Jacobian's columns `j` over the free DOFs).
    pub fn element_force(&self, e: usize, x: &[DVec3], j: &DMatrix<f64>) -> DVector<f64> {
        let mut out = DVector::zeros(j.ncols());
        self.shell.element_gradient(e, x, |v, g| {
            if let Some(b) = self.dofs.block(v) {
                out += j.rows(3 * b, 3).transpose() * nalgebra::Vector3::new(g.x, g.y, g.z);
            }
        });
        out
    }

    /// One element's projected stiffness `J_eᵀ ∇²E_e(x) J_e`.
    pub fn element_stiffness(&self, e: usize, x: &[DVec3], j: &DMatrix<f64>) -> DMatrix<f64> {
        self.sampled_hessian(&[(e, 1.0)], x, j)
    }

    /// The generalised force `Jᵀ ∇E(x)` of every element (ignoring the cubature).
    pub fn exact_force(&self, x: &[DVec3], j: &DMatrix<f64>) -> DVector<f64> {
        let mut g = vec![DVec3::ZERO; x.len()];
        self.shell.gradient(x, &mut g);
        let mut gathered = vec![0.0; self.dofs.dofs()];
        self.dofs.gather(&g, &mut gathered);
        j.transpose() * DVector::from_vec(gathered)
    }

    /// The number of coordinates.
    pub fn dim(&self) -> usize {
        self.scales.len()
    }

    /// The positions `x(c)`.
    pub fn positions(&mut self, c: &[f64], x: &mut [DVec3]) {
        self.rs.reconstruct(c, x);
    }

    /// The elastic energy `E(x)` (by the cubature if one is set), J.
    pub fn energy(&self, x: &[DVec3]) -> f64 {
        match &self.cubature {
            Some(c) => self.shell.weighted_energy(x, &c.elements),
            None => self.shell.energy(x),
        }
    }

    /// `∇E(x)` into `out` (by the cubature if one is set); returns `E(x)`.
    pub fn gradient(&self, x: &[DVec3], out: &mut [DVec3]) -> f64 {
        match &self.cubature {
            Some(c) => self.shell.weighted_gradient(x, &c.elements, out),
            None => self.shell.gradient(x, out),
        }
    }

    /// The columns of `J = ∂x/∂c` at `c`, over the free DOFs (forward differences: one
    /// reconstruction a coordinate; an error of about the step, 1e-6, relative, which only the
    /// stiffness sees).
    pub fn jacobian(&mut self, c: &[f64]) -> DMatrix<f64> {
        let r = self.dim();
        let mut j = DMatrix::zeros(self.dofs.dofs(), r);
        let (mut at, mut moved) = (self.rest.clone(), self.rest.clone());
        self.rs.reconstruct(c, &mut at);
        let (mut a, mut b) = (vec![0.0; self.dofs.dofs()], vec![0.0; self.dofs.dofs()]);
        self.dofs.gather(&at, &mut b);
        let mut shifted = c.to_vec();
        for k in 0..r {
            let s = JACOBIAN_STEP / self.scales[k];
            shifted[k] = c[k] + s;
            self.rs.reconstruct(&shifted, &mut moved);
            shifted[k] = c[k];
            self.dofs.gather(&moved, &mut a);
            j.column_mut(k).iter_mut().zip(a.iter().zip(&b)).for_each(|(o, (p, m))| *o = (p - m) / s);
        }
        j
    }

    /// `Jᵀ ∇²E(x) J` (the exact Hessian at `x`, of the cubature's elements if one is set).
    pub fn projected_hessian(&mut self, x: &[DVec3], j: &DMatrix<f64>) -> DMatrix<f64> {
        if let Some(c) = &self.cubature {
            return self.sampled_hessian(&c.elements, x, j);
        }
        self.shell.assemble_hessian(&mut self.hessian, x, HessianMode::Exact);
        // `Jᵀ` column-major is `J` with its rows interleaved, and `(HJ)ᵀ = JᵀH` comes out likewise.
        let jt = j.transpose();
        let mut jth = DMatrix::zeros(j.ncols(), j.nrows());
        self.hessian.multiply(None, jt.as_slice(), j.ncols(), jth.as_mut_slice());
        let p = jth * j;
        (&p + p.transpose()) * 0.5
    }

    /// `Σ w_e J_eᵀ ∇²E_e(x) J_e` over weighted elements.
    fn sampled_hessian(&self, elements: &[(usize, f64)], x: &[DVec3], j: &DMatrix<f64>) -> DMatrix<f64> {
        let r = j.ncols();
        let mut p = DMatrix::zeros(r, r);
        for &(e, w) in elements {
            self.shell.element_hessian(e, x, HessianMode::Exact, |vertices, lower| {
                let k = vertices.len();
                let mut je = DMatrix::zeros(3 * k, r);
                vertices.iter().enumerate().for_each(|(a, &v)| je.rows_mut(3 * a, 3).copy_from(&self.rows(j, v)));
                let h = DMatrix::from_fn(3 * k, 3 * k, |a, b| packed_entry(lower, a, b));
                p += je.transpose() * (h * je) * w;
            });
        }
        (&p + p.transpose()) * 0.5
    }

    /// The generalised force `J(c)ᵀ r` of the per-vertex forces `r`, and its derivative `∂(J(c)ᵀ r)/∂c`
    /// with `r` held fixed (module documentation).
    pub fn pull_back(&mut self, c: &[f64], r: &[DVec3]) -> (DVector<f64>, DMatrix<f64>) {
        self.rs.set_forces(r);
        let mut x = self.rest.clone();
        self.rs.update(c, &mut x, &mut self.force);
        let n = self.dim();
        let stiffness = self.rs.stiffness().cloned().unwrap_or_else(|| DMatrix::zeros(n, n));
        (DVector::from_column_slice(&self.force), stiffness)
    }

    /// The coordinates whose positions are closest to `target` in the mass norm (Gauss–Newton from
    /// `start`, a few iterations), and the velocities closest to `velocity` there: how a state moves
    /// to a new basis.
    pub fn fit(
        &mut self,
        masses: &[f64],
        target: &[DVec3],
        velocity: &[DVec3],
        start: Vec<f64>,
    ) -> (Vec<f64>, Vec<f64>) {
        let weights: Vec<f64> = self.dofs.free_vertices().iter().flat_map(|&v| [masses[v]; 3]).collect();
        let weigh = |j: &DMatrix<f64>| {
            let mut w = j.clone();
            w.row_iter_mut().zip(&weights).for_each(|(mut row, m)| row *= *m);
            w
        };
        let gathered = |u: &[DVec3], dofs: &DofMap| {
            let mut out = vec![0.0; dofs.dofs()];
            dofs.gather(u, &mut out);
            DVector::from_vec(out)
        };
        let mut c = DVector::from_vec(start);
        let mut x = self.rest.clone();
        let mut j = self.jacobian(c.as_slice());
        for _ in 0..8 {
            self.positions(c.as_slice(), &mut x);
            let gap: Vec<DVec3> = target.iter().zip(&x).map(|(a, b)| *a - *b).collect();
            let wj = weigh(&j);
            let Some(normal) = (j.transpose() * &wj).cholesky() else { break };
            let dc = normal.solve(&(wj.transpose() * gathered(&gap, &self.dofs)));
            c += &dc;
            j = self.jacobian(c.as_slice());
            if dc.norm() <= 1e-12 * (1.0 + c.norm()) {
                break;
            }
        }
        let wj = weigh(&j);
        let v = match (j.transpose() * &wj).cholesky() {
            Some(normal) => normal.solve(&(wj.transpose() * gathered(velocity, &self.dofs))),
            None => DVector::zeros(c.len()),
        };
        (c.as_slice().to_vec(), v.as_slice().to_vec())
    }

    /// The generalised force `J(c)ᵀ r` alone (no stiffness).
    pub fn force(&mut self, c: &[f64], r: &[DVec3]) -> DVector<f64> {
        DVector::from_vec(self.rs.force_of(c, r))
    }

    /// The rows `∂x_v/∂c` of one vertex from the Jacobian's columns (zero for an anchored vertex).
    pub fn rows(&self, j: &DMatrix<f64>, v: usize) -> DMatrix<f64> {
        match self.dofs.block(v) {
            Some(b) => j.rows(3 * b, 3).into_owned(),
            None => DMatrix::zeros(3, j.ncols()),
        }
    }
}
