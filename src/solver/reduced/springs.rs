//! Drags on `rds` as springs on its reduced coordinates `c`.
//!
//! **Drags.** A position drag on vertex `i` is `a = x_i(c)`, with rows `J_i` of the Jacobian; an
//! orientation drag is the vertex's rotation `Ψ_i c` (the mean of its triangles' rotation vectors,
//! linear in `c` in the rotation-strain reconstruction), a frame drag the mean over a group (`A` its
//! rows). Each is a spring `½ (a − t)ᵀ K_s (a − t)` whose 3 × 3 stiffness is the inverse of the
//! compliance `damping · A h²(I + h²K₀)⁻¹ Aᵀ`: `damping` times the drag's own response to a step's
//! force in the linear model (its static response where the shell is stiff, as in the modal
//! methods), direction by direction, so a reachable target is met to about `damping` of what the
//! linear shell would give, and an over-determined one settles at a compromise.

use glam::DVec3;
use nalgebra::{DMatrix, DVector};

use super::energy::ReducedShell;
use crate::solver::modal::basis::ModalBasis;
use crate::solver::{DragKind, DragSet};

/// The springs of every drag in `drags` on the basis `modal` with rest reduced stiffness `rest`, for a
/// step `h` and the relative compliance `damping` (module documentation).
pub fn springs(drags: &DragSet, modal: &ModalBasis, rest: &DMatrix<f64>, h: f64, damping: f64) -> Vec<Spring> {
    if drags.is_empty() && drags.frames().next().is_none() {
        return Vec::new();
    }
    let r = modal.modes();
    let rotation = |v: usize| DMatrix::from_fn(3, r, |a, k| modal.psi(v, a, k));
    // The step's response to a reduced force, h² (I + h²K₀)⁻¹: the static compliance K₀⁻¹ in stiff
    // directions, h² in a mechanism's (a shell free to swing about its anchored row).
    let step = DMatrix::identity(r, r) + rest * (h * h);
    let response = match step.cholesky() {
        Some(c) => c.inverse() * (h * h),
        None => DMatrix::identity(r, r) * (h * h),
    };
    let compliance = |a: &DMatrix<f64>| stiffness_of(&(a * &response * a.transpose() * damping));
    let mut springs = Vec::new();
    for (_, d) in drags.iter() {
        match d.kind {
            DragKind::Position(p) => {
                let rows = DMatrix::from_fn(3, r, |a, k| modal.phi(d.vertex, a, k));
                springs.push(Spring::Position { vertex: d.vertex, target: p, stiffness: compliance(&rows) });
            }
            DragKind::Orientation(w) => {
                let rows = rotation(d.vertex);
                springs.push(Spring::Rotation { stiffness: compliance(&rows), rows, target: w });
            }
        }
    }
    for (_, f) in drags.frames() {
        let mut rows = DMatrix::zeros(3, r);
        f.vertices.iter().for_each(|&v| rows += rotation(v));
        rows /= f.vertices.len() as f64;
        springs.push(Spring::Rotation { stiffness: compliance(&rows), rows, target: f.rotation });
    }
    springs
}

/// A drag as a spring, its stiffness a 3 × 3 matrix.
pub enum Spring {
    /// Vertex `vertex` pulled to `target`.
    Position {
        /// The dragged vertex.
        vertex: usize,
        /// Its target, m.
        target: DVec3,
        /// The 3 × 3 stiffness, N/m.
        stiffness: DMatrix<f64>,
    },
    /// A rotation `rows · c` pulled to `target`.
    Rotation {
        /// The rows `A` (3 × r) of the rotation vector `A c`.
        rows: DMatrix<f64>,
        /// The target rotation vector, rad.
        target: DVec3,
        /// The 3 × 3 stiffness.
        stiffness: DMatrix<f64>,
    },
}

/// The spring stiffness `C⁺` of a compliance `C` (symmetric 3 × 3): directions the drag cannot move
/// (an anchored vertex's) get none.
fn stiffness_of(c: &DMatrix<f64>) -> DMatrix<f64> {
    let eigen = nalgebra::SymmetricEigen::new((c + c.transpose()) * 0.5);
    let largest = eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
    let mut k = DMatrix::zeros(3, 3);
    for (i, mu) in eigen.eigenvalues.iter().enumerate() {
        if *mu > 1e-12 * largest {
            let v = eigen.eigenvectors.column(i);
            k += v * v.transpose() / *mu;
        }
    }
    k
}

fn column(v: DVec3) -> DVector<f64> {
    DVector::from_column_slice(&v.to_array())
}

impl Spring {
    /// The spring's energy at coordinates `c` with positions `x`.
    pub fn energy(&self, c: &DVector<f64>, x: &[DVec3]) -> f64 {
        let gap = match self {
            Spring::Position { vertex, target, .. } => column(x[*vertex] - *target),
            Spring::Rotation { rows, target, .. } => rows * c - column(*target),
        };
        let (Spring::Position { stiffness, .. } | Spring::Rotation { stiffness, .. }) = self;
        0.5 * gap.dot(&(stiffness * &gap))
    }

    /// A position spring's force on its vertex, added to `force`.
    pub fn add_force(&self, x: &[DVec3], force: &mut [DVec3]) {
        if let Spring::Position { vertex, target, stiffness } = self {
            let f = stiffness * column(x[*vertex] - *target);
            force[*vertex] -= DVec3::new(f[0], f[1], f[2]);
        }
    }

    /// A spring's stiffness (and a rotation spring's gradient, which acts on `c` directly) added to
    /// the reduced gradient and stiffness.
    pub fn add_stiffness(
        &self,
        shell: &ReducedShell,
        j: &DMatrix<f64>,
        c: &DVector<f64>,
        gradient: &mut DVector<f64>,
        stiffness: &mut DMatrix<f64>,
    ) {
        match self {
            Spring::Position { vertex, stiffness: k, .. } => {
                let rows = shell.rows(j, *vertex);
                *stiffness += rows.transpose() * k * rows;
            }
            Spring::Rotation { rows, target, stiffness: k } => {
                *gradient += rows.transpose() * (k * (rows * c - column(*target)));
                *stiffness += rows.transpose() * k * rows;
            }
        }
    }
}
