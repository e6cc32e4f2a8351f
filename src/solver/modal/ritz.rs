//! Load-dependent Ritz vectors for drags: while a position drag lives, the static responses of the
//! shell to forces at the dragged vertices join the modal basis, so a local pull that a few global
//! modes cannot follow is followed by the deformation the shell itself would take (Wilson, Yuan &
//! Dickens 1982, "Dynamic analysis by direct superposition of Ritz vectors").
//!
//! For each dragged vertex (or group of vertices) `g` and axis `a` the response is
//! `s = (K − σM)⁻¹ f_ga`, `f_ga` a unit force on the group along `a`, one solve with the factor the
//! modal analysis uses ([`super::compute::factored`]). The responses are made `M`-orthogonal to the
//! modes, `s′ = s − Φ Φᵀ M s`, which also makes them `K`-orthogonal to exact eigenvectors:
//! `Φᵀ M s = (Λ − σ)⁻¹ Φᵀ f` and `Φᵀ K s = Λ (Λ − σ)⁻¹ Φᵀ f`, so `Φᵀ K s′ = 0`. A Rayleigh–Ritz
//! step on the responses alone (`Sᵀ K S y = μ Sᵀ M S y`, nearly dependent directions dropped)
//! then gives vectors with the modes' properties, mass-normalised and decoupled, with Ritz values `μ`:
//! the augmented basis is a [`ModalBasis`] like any other, and every modal method runs on it
//! unchanged. Its span contains the modes', so swapping it in projects the state exactly.
//!
//! The factor ([`DragFactor`]) is made at the first position drag, which then waits about a
//! second on the creature, unless one is at hand (`rds` keeps the one its basis was built with).
//! Once drags are expected ([`crate::solver::Solver::expect_drags`]: the viewer) it is made ahead,
//! in the background.

use glam::DVec3;
use nalgebra::{DMatrix, SymmetricEigen};

use super::basis::ModalBasis;
use super::compute::{Factored, ModalProblem, factored};
use crate::mesh::TriMesh;
use crate::solver::supersede::{Background, Generation};
use crate::solver::{DragKind, DragSet, SolverError};

/// The most groups of dragged vertices that get responses (three vectors each); past this many
/// dragged vertices, consecutive ones share a group (a track's selection is listed together).
pub const MAX_GROUPS: usize = 8;

/// Directions of the responses whose mass norm, after orthogonalisation, is below this fraction of
/// the largest are dropped as dependent.
const DEPENDENT: f64 = 1e-10;

/// The factored stiffness of one modal problem, ready to give static responses.
pub struct StaticResponse {
    factored: Factored,
}

impl std::fmt::Debug for StaticResponse {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StaticResponse").field("dofs", &self.factored.system.mass.len()).finish()
    }
}

/// A factor made for the drags, or why it could not be.
pub(crate) type Made = Result<StaticResponse, SolverError>;

/// The drags' factor of one shell: at hand, being made in the background, or not yet made.
#[derive(Default)]
pub(crate) struct DragFactor {
    ready: Option<StaticResponse>,
    making: Option<Background<StaticResponse>>,
    /// The background job's requests: cancelled when its factor is no longer wanted.
    generation: Generation,
    /// Drags are expected: a missing factor is made ahead, in the background.
    expected: bool,
}

impl DragFactor {
    /// Drags are expected from now on: start `make` (which makes the shell's factor) in the
    /// background unless a factor is at hand or under way.
    pub(crate) fn expect(&mut self, make: impl FnOnce() -> Made + Send + 'static) {
        self.expected = true;
        if self.ready.is_none() && self.making.is_none() {
            let work = move |_: &dyn Fn(f32)| make();
            let job = Background::start("shellwarp-drag-factor", "factor", &self.generation, Default::default(), work);
            self.making = Some(job);
        }
    }

    /// The shell changed: drop the old factor (stopping one being made at its next checkpoint) and
    /// take `ready` (made with the new shell's basis) if given, else, if drags are expected, start
    /// `make` (which makes the new shell's factor) in the background.
    pub(crate) fn renew(&mut self, ready: Option<StaticResponse>, make: impl FnOnce() -> Made + Send + 'static) {
        self.generation.cancel_all();
        (self.ready, self.making) = (ready, None);
        if self.expected {
            self.expect(make);
        }
    }

    /// Whether the factor is at hand or being made.
    pub(crate) fn prepared(&self) -> bool {
        self.ready.is_some() || self.making.is_some()
    }

    /// The shell's factor: the one at hand, else the background one (waiting for it), else one
    /// made here by `make`.
    pub(crate) fn get(&mut self, make: impl FnOnce() -> Made) -> Result<&StaticResponse, SolverError> {
        let made = self.making.take().and_then(|job| job.wait().ok());
        let ready = match (self.ready.take(), made) {
            (Some(r), _) | (None, Some(r)) => r,
            (None, None) => make()?,
        };
        Ok(self.ready.insert(ready))
    }
}

impl Drop for DragFactor {
    fn drop(&mut self) {
        self.generation.cancel_all();
    }
}

/// Split the dragged vertices (in their order) into at most [`MAX_GROUPS`] consecutive groups.
pub fn groups(dragged: &[usize]) -> Vec<Vec<usize>> {
    let size = dragged.len().div_ceil(MAX_GROUPS).max(1);
    dragged.chunks(size).map(<[usize]>::to_vec).collect()
}

/// The groups ([`groups`]) of the vertices under position drags in `drags`, each once, in order.
pub fn dragged_groups(drags: &DragSet) -> Vec<Vec<usize>> {
    let mut dragged: Vec<usize> = Vec::new();
    for (_, d) in drags.iter() {
        if matches!(d.kind, DragKind::Position(_)) && !dragged.contains(&d.vertex) {
            dragged.push(d.vertex);
        }
    }
    groups(&dragged)
}

impl StaticResponse {
    /// Assemble and factor the problem's shifted stiffness.
    pub fn new(problem: &ModalProblem<'_>) -> Result<Self, SolverError> {
        Ok(Self::of(factored(problem)?))
    }

    /// Around a factor already made ([`factored`]).
    pub fn of(factored: Factored) -> Self {
        Self { factored }
    }

    /// `base` with the Ritz vectors of the static responses to unit forces on each of `groups` (their
    /// anchored vertices ignored; a group with none free adds nothing).
    pub fn augment(&self, base: &ModalBasis, mesh: &TriMesh, groups: &[Vec<usize>]) -> Result<ModalBasis, SolverError> {
        let Factored { system, chol, .. } = &self.factored;
        let (dofs, mass, dim) = (&system.dofs, &system.mass, system.mass.len());
        let columns: Vec<(usize, Vec<usize>)> = groups
            .iter()
            .flat_map(|g| (0..3).map(move |a| (a, g.iter().filter_map(|&v| dofs.block(v)).collect::<Vec<_>>())))
            .filter(|(_, blocks)| !blocks.is_empty())
            .collect();
        if columns.is_empty() {
            return Ok(base.clone());
        }
        let r = columns.len();
        let mut s = vec![0.0; dim * r];
        for (c, (a, blocks)) in columns.iter().enumerate() {
            blocks.iter().for_each(|&b| s[c * dim + 3 * b + a] = 1.0 / blocks.len() as f64);
        }
        chol.solve_many(&mut s, r).map_err(|e| SolverError::Numerical(e.to_string()))?;
        let modes: Vec<Vec<f64>> = (0..base.modes())
            .map(|j| {
                let mut phi = vec![0.0; dim];
                dofs.gather(&base.shape(j), &mut phi);
                phi
            })
            .collect();
        let m_dot = |x: &[f64], y: &[f64]| x.iter().zip(y).zip(mass).map(|((a, b), m)| a * b * m).sum::<f64>();
        for col in s.chunks_mut(dim) {
            for _ in 0..2 {
                for phi in &modes {
                    let c = m_dot(phi, col);
                    col.iter_mut().zip(phi).for_each(|(x, p)| *x -= c * p);
                }
            }
        }
        // Rayleigh–Ritz on the responses: G = SᵀMS, A = SᵀKS.
        let mut ks = vec![0.0; dim * r];
        for (col, out) in s.chunks(dim).zip(ks.chunks_mut(dim)) {
            self.factored.multiply_unshifted(col, out);
        }
        let (cols, kcols): (Vec<&[f64]>, Vec<&[f64]>) = (s.chunks(dim).collect(), ks.chunks(dim).collect());
        let g = DMatrix::from_fn(r, r, |i, j| m_dot(cols[i], cols[j]));
        let a = DMatrix::from_fn(r, r, |i, j| cols[i].iter().zip(kcols[j]).map(|(x, y)| x * y).sum::<f64>());
        let gram = SymmetricEigen::new(g);
        let top = gram.eigenvalues.iter().copied().fold(0.0, f64::max);
        let kept: Vec<usize> = (0..r).filter(|&i| gram.eigenvalues[i] > DEPENDENT * top).collect();
        let t =
            DMatrix::from_fn(r, kept.len(), |i, k| gram.eigenvectors[(i, kept[k])] / gram.eigenvalues[kept[k]].sqrt());
        let reduced = t.transpose() * &a * &t;
        let ritz = SymmetricEigen::new((&reduced + reduced.transpose()) * 0.5);
        let y = &t * &ritz.eigenvectors;
        let mut order: Vec<usize> = (0..kept.len()).collect();
        order.sort_by(|&i, &j| ritz.eigenvalues[i].total_cmp(&ritz.eigenvalues[j]));
        let mut values = base.eigenvalues.clone();
        let mut shapes: Vec<Vec<DVec3>> = (0..base.modes()).map(|j| base.shape(j)).collect();
        for &k in &order {
            let mut v = vec![0.0; dim];
            for (i, col) in cols.iter().enumerate() {
                v.iter_mut().zip(col.iter()).for_each(|(x, c)| *x += y[(i, k)] * c);
            }
            let mut full = vec![DVec3::ZERO; mesh.vertex_count()];
            dofs.scatter_add(&v, 1.0, &mut full);
            shapes.push(full);
            values.push(ritz.eigenvalues[k].max(0.0));
        }
        Ok(ModalBasis::new(mesh, values, &shapes))
    }
}
