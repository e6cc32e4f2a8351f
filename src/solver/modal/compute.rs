//! Modal analysis of a shell: the exact rest stiffness `K` (Hessian of the discrete-shell energy at
//! rest, anchored DOFs removed), lumped `M`, and the `m` lowest vibration modes by shift-invert Lanczos
//! on a sparse Cholesky factorisation of `K − σM`. Every returned pair's relative residual
//! `‖Kφ − λMφ‖ / ‖Kφ‖` is measured with the real `K` and reported.
//!
//! A free (unanchored) shell has 6 rigid modes with `λ = 0`; the shift is negative so `K − σM` is
//! positive definite, 6 extra pairs are requested and the near-zero ones are dropped — or, with
//! [`ModalProblem::keep_rigid`], kept in front of the deformation modes with `λ = 0` exactly, so the
//! shell can move as a whole (a free part held by tracks). Modal warping reproduces a rigid motion
//! exactly: for `u = t + ω × X` the closed form gives `(exp([ω]×) − I) X + (∫₀¹exp(s[ω]×)ds) t`, again
//! a rigid motion.

use std::time::Instant;

use glam::DVec3;

use super::basis::ModalBasis;
use crate::energy::{DiscreteShell, HessianMode, ShellStiffness};
use crate::linalg::lanczos::{LanczosOptions, lowest_modes};
use crate::linalg::ordering::nested_dissection;
use crate::linalg::{BlockAssembler, DofMap, SparseCholesky};
use crate::mesh::TriMesh;
use crate::scene::Setup;
use crate::solver::SolverError;
use crate::solver::params::{
    self,
    shared::{DENSITY, K_AREA, K_BEND, K_LENGTH},
};
use crate::solver::supersede::checkpoint;

/// What to analyse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalProblem<'a> {
    /// Rest mesh.
    pub mesh: &'a TriMesh,
    /// Anchored vertices, sorted.
    pub anchors: &'a [usize],
    /// Lumped vertex masses, kg.
    pub masses: &'a [f64],
    /// Shell stiffnesses.
    pub stiffness: ShellStiffness,
    /// Number of (deformation) modes wanted.
    pub modes: usize,
    /// Keep a free shell's rigid modes (as `λ = 0`, ahead of the `modes` deformation modes).
    pub keep_rigid: bool,
}

/// Wall-clock seconds of each precomputation stage.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct PrecomputeTimings {
    /// Building the pattern and assembling `K`.
    pub assembly: f64,
    /// Symbolic + numeric Cholesky of `K − σM`.
    pub factorisation: f64,
    /// Lanczos iterations, Ritz vectors and residual checks.
    pub eigen: f64,
}

/// A computed basis with its quality figures.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalAnalysis {
    /// The modes.
    pub basis: ModalBasis,
    /// `‖Kφ − λMφ‖ / ‖Kφ‖` per mode.
    pub residuals: Vec<f64>,
    /// Gershgorin bound on the largest eigenvalue of `M⁻¹K` (the conditioning behind the residuals).
    pub lambda_max: f64,
    /// Rigid (zero) modes found and skipped.
    pub rigid_modes: usize,
    /// Stage timings.
    pub timings: PrecomputeTimings,
    /// Block solves (passes over the Cholesky factor) the eigen iteration used, of [`EIGEN_BLOCK`]
    /// vectors each.
    pub solves: usize,
}

/// The relative residual `‖Kφ − λMφ‖ / ‖Kφ‖` every returned eigenpair is meant to meet.
///
/// One exception, explicit and reported ([`ModalAnalysis::above_target`], flagged by `shellwarp
/// modes`): a mode whose residual stopped improving above this, but below the round-off bound
/// [`round_off_floor`], is accepted, because no double-precision vector does better. Evaluating
/// `Kφ` in f64 alone errs by about `ε Σ_j |K_ij||φ_j|`, i.e. up to `ε λ_max/λ` relative to
/// `‖Kφ‖ = λ‖Mφ‖`, and rounding the exact eigenvector to f64 excites the stiffest modes by as much.
/// A stiff membrane with a soft bending mode on a fine mesh gets there: a 1 m × 2 cm strip of
/// 100 × 2 segments with `k_A = 100`, `k_B = 0.001` has `λ_max/λ_1 ≈ 4e10`, and its first mode stops
/// at 4e-6 however long the iteration runs (the bound is pessimistic: 5e-4 there). The built-in
/// scenes and the tests stay below 1e-8.
pub const MAX_RESIDUAL: f64 = 1e-8;

/// The eigen iteration goes on until every pair's relative residual is below this (a decade under
/// [`MAX_RESIDUAL`]), or has stopped improving (round-off), once the transformed problem has converged.
pub const TARGET_RESIDUAL: f64 = 1e-9;

/// Vectors per Lanczos block. One pass over the Cholesky factor (114 MB on the creature) solves them
/// all, each value of the factor serving the four in one register ([`crate::linalg::SparseCholesky`]);
/// on the creature at 4 modes, 12 block solves replace 23 single ones.
pub const EIGEN_BLOCK: usize = 4;

fn numerical(e: impl std::fmt::Display) -> SolverError {
    SolverError::Numerical(e.to_string())
}

/// The generalised eigenproblem `K φ = λ M φ` of a modal problem, as the analysis solves it.
pub struct ModalSystem {
    /// The exact rest stiffness over the free DOFs (anchored vertices removed), both triangles.
    pub k: BlockAssembler,
    /// The lumped mass of each free DOF, kg.
    pub mass: Vec<f64>,
    /// The shift `σ` of the shift-invert iteration (negative, below the spectrum).
    pub shift: f64,
    /// Which vertices the DOFs belong to.
    pub dofs: DofMap,
}

/// Assemble the stiffness and mass of `problem` and choose the eigen solver's shift: a millionth of
/// the mean diagonal ratio `K_ii / M_ii`, negative (below the elastic spectrum, and below the zero
/// modes of a free shell, so `K − σM` is positive definite).
pub fn system(problem: &ModalProblem<'_>) -> Result<ModalSystem, SolverError> {
    let mesh = problem.mesh;
    let shell = DiscreteShell::new(mesh, problem.stiffness).map_err(numerical)?;
    let mut fixed = vec![false; mesh.vertex_count()];
    problem.anchors.iter().for_each(|&a| fixed[a] = true);
    let dofs = DofMap::without(&fixed);
    let mut k = shell.hessian_pattern(&dofs).map_err(numerical)?;
    shell.assemble_hessian(&mut k, mesh.positions(), HessianMode::Exact);
    let mass: Vec<f64> = dofs.free_vertices().iter().flat_map(|&v| [problem.masses[v]; 3]).collect();
    let dim = mass.len().max(1);
    let mean_ratio = (0..mass.len()).map(|i| k_values_diag(&k, i) / mass[i]).sum::<f64>() / dim as f64;
    let shift = -1e-6 * mean_ratio.max(f64::MIN_POSITIVE);
    Ok(ModalSystem { k, mass, shift, dofs })
}

/// The relative tolerance the Lanczos iteration converges the transformed problem to.
pub const LANCZOS_TOLERANCE: f64 = 1e-13;

/// The shifted stiffness `K − σM` of a modal problem, factored (nested-dissection order): what the
/// eigen iteration and the drags' static responses ([`super::ritz`]) solve with.
pub struct Factored {
    /// The eigenproblem; `system.k` holds `K − σM`.
    pub system: ModalSystem,
    /// The Cholesky factor of `K − σM`.
    pub chol: SparseCholesky,
    /// Wall-clock seconds of assembly and of factorisation.
    pub timings: (f64, f64),
}

impl Factored {
    /// `out = K x` with the unshifted `K`, as `(K − σM) x + σ M x`: the two differ only on the
    /// diagonal, so no second copy of the stiffness's values is kept.
    pub fn multiply_unshifted(&self, x: &[f64], out: &mut [f64]) {
        let ModalSystem { k, mass, shift, .. } = &self.system;
        k.multiply(None, x, 1, out);
        out.iter_mut().zip(x).zip(mass).for_each(|((o, x), m)| *o += shift * m * x);
    }
}

/// Assemble and factor `K − σM` of `problem`.
pub fn factored(problem: &ModalProblem<'_>) -> Result<Factored, SolverError> {
    let t0 = Instant::now();
    let mut system = system(problem)?;
    let (k, shift, mass) = (&mut system.k, system.shift, &system.mass);
    k.add_diagonal(&mass.iter().map(|m| -shift * m).collect::<Vec<_>>());
    let assembly = t0.elapsed().as_secs_f64();
    // A superseded background run (an analysis, the drags' factor) stops here, before the factor.
    checkpoint();
    let t1 = Instant::now();
    let points: Vec<DVec3> = system.dofs.free_vertices().iter().map(|&v| problem.mesh.positions()[v]).collect();
    let order: Vec<usize> = nested_dissection(&points, &k.block_adjacency())
        .into_iter()
        .flat_map(|b| [3 * b, 3 * b + 1, 3 * b + 2])
        .collect();
    let mut chol = SparseCholesky::with_order(k.matrix(), &order).map_err(numerical)?;
    chol.factor(k.matrix()).map_err(numerical)?;
    Ok(Factored { system, chol, timings: (assembly, t1.elapsed().as_secs_f64()) })
}

/// Run the modal analysis, reporting progress in `[0, 1]` through `progress`.
pub fn analyse(problem: &ModalProblem<'_>, progress: &dyn Fn(f32)) -> Result<ModalAnalysis, SolverError> {
    analyse_factored(problem, progress).map(|(analysis, _)| analysis)
}

/// [`analyse`], with the factor of `K − σM` it solved with, for more solves with the same matrix.
pub fn analyse_factored(
    problem: &ModalProblem<'_>,
    progress: &dyn Fn(f32),
) -> Result<(ModalAnalysis, Factored), SolverError> {
    let mesh = problem.mesh;
    let n = mesh.vertex_count();
    let free = problem.anchors.is_empty();
    let dim = 3 * n.saturating_sub(problem.anchors.len());
    let wanted = problem.modes + if free { 6 } else { 0 };
    if problem.modes == 0 || wanted > dim {
        return Err(SolverError::Unsuitable {
            method: "modal",
            reason: format!("{} modes asked of a shell with {dim} free DOFs", problem.modes),
        });
    }
    progress(0.05);
    let factor = factored(problem)?;
    let (assembly, factorisation) = factor.timings;
    let ModalSystem { mass, shift, dofs, .. } = &factor.system;
    progress(0.3);

    let t2 = Instant::now();
    // Relative residuals with the unshifted K.
    let mut kphi = vec![0.0; dim];
    let relative_residual = |lambda: f64, phi: &[f64]| {
        factor.multiply_unshifted(phi, &mut kphi);
        let r2: f64 = kphi.iter().zip(phi).zip(mass).map(|((kp, p), m)| (kp - lambda * m * p).powi(2)).sum();
        let k2: f64 = kphi.iter().map(|x| x * x).sum();
        if k2 > 0.0 { (r2 / k2).sqrt() } else { r2.sqrt() }
    };
    let options = LanczosOptions {
        shift: *shift,
        tolerance: LANCZOS_TOLERANCE,
        target: TARGET_RESIDUAL,
        block: EIGEN_BLOCK,
        ..Default::default()
    };
    // Every block solve reports (a superseded background analysis stops there, not minutes later at
    // the end of a long eigen solve): a fraction rising towards 0.9 as the solves accumulate.
    let expected = (2 * wanted).div_ceil(EIGEN_BLOCK) as f32 + 10.0;
    let mut block_solves = 0.0;
    let solve = |x: &mut [f64], b: usize| {
        progress(0.3 + 0.6 * block_solves / (block_solves + expected));
        block_solves += 1.0;
        factor.chol.solve_many(x, b).map_err(|e| e.to_string())
    };
    let pairs = lowest_modes(mass, wanted, solve, relative_residual, options).map_err(numerical)?;
    progress(0.9);
    let residuals = &pairs.residuals;
    let scale = pairs.values.last().copied().unwrap_or(1.0).abs().max(f64::MIN_POSITIVE);
    // No double-precision vector can do better than ε·λ_max/λ (its rounding excites the stiffest
    // modes); λ_max ≤ max_i Σ_j |K_ij| / M_ii (Gershgorin).
    let lambda_max = gershgorin_max(&factor.system);
    let rigid: Vec<bool> = pairs.values.iter().map(|&l| free && l.abs() < 1e-8 * scale).collect();
    let rigid_modes = rigid.iter().filter(|&&r| r).count();
    let mut keep: Vec<usize> = (0..wanted).filter(|&i| !rigid[i]).take(problem.modes).collect();
    if problem.keep_rigid {
        keep.splice(0..0, (0..wanted).filter(|&i| rigid[i]));
    }
    let floor = |i: usize| round_off_floor(pairs.values[i], lambda_max);
    if let Some(&bad) = keep.iter().find(|&&i| residuals[i] > MAX_RESIDUAL.max(floor(i))) {
        return Err(SolverError::Numerical(format!(
            "mode {bad}: relative residual {:.2e} exceeds {MAX_RESIDUAL:.0e} (round-off floor {:.1e})",
            residuals[bad],
            floor(bad)
        )));
    }
    let shapes: Vec<Vec<DVec3>> = keep
        .iter()
        .map(|&i| {
            let mut full = vec![DVec3::ZERO; n];
            dofs.scatter_add(&pairs.vectors[i], 1.0, &mut full);
            full
        })
        .collect();
    let values = keep.iter().map(|&i| if rigid[i] { 0.0 } else { pairs.values[i] }).collect();
    let basis = ModalBasis::new(mesh, values, &shapes);
    let eigen = t2.elapsed().as_secs_f64();
    progress(1.0);
    let analysis = ModalAnalysis {
        basis,
        residuals: keep.iter().map(|&i| residuals[i]).collect(),
        rigid_modes,
        lambda_max,
        timings: PrecomputeTimings { assembly, factorisation, eigen },
        solves: pairs.block_solves,
    };
    Ok((analysis, factor))
}

/// The deformation modes of a scene's shell (its mesh, anchors, lumped masses and stiffnesses),
/// computed afresh (no cache).
pub fn analyse_scene(setup: &Setup, modes: usize) -> Result<ModalAnalysis, SolverError> {
    let masses = setup.masses();
    analyse(&ModalProblem::of_scene(setup, &masses, modes)?, &|_| {})
}

impl<'a> ModalProblem<'a> {
    /// The problem of a scene's shell: its mesh, anchors and stiffnesses, with `masses` its lumped
    /// masses; the material's values checked against the shell's parameter ranges first.
    pub fn of_scene(setup: &'a Setup, masses: &'a [f64], modes: usize) -> Result<Self, SolverError> {
        params::check_scene([&K_AREA, &K_LENGTH, &K_BEND, &DENSITY], setup)?;
        let stiffness = ShellStiffness::from(&setup.scene.material);
        Ok(Self { mesh: &setup.mesh, anchors: &setup.anchors, masses, stiffness, modes, keep_rigid: false })
    }
}

/// The round-off floor of the relative residual of a mode `λ` when the largest eigenvalue of `M⁻¹K` is
/// at most `lambda_max`: `64 ε λ_max / |λ|` (see [`MAX_RESIDUAL`]).
pub fn round_off_floor(lambda: f64, lambda_max: f64) -> f64 {
    64.0 * f64::EPSILON * lambda_max / lambda.abs().max(f64::MIN_POSITIVE)
}

impl ModalAnalysis {
    /// The modes whose residual exceeds [`MAX_RESIDUAL`] (accepted only because it is within the
    /// round-off floor), with that floor.
    pub fn above_target(&self) -> Vec<(usize, f64)> {
        self.residuals
            .iter()
            .zip(&self.basis.eigenvalues)
            .enumerate()
            .filter(|(_, (r, _))| **r > MAX_RESIDUAL)
            .map(|(j, (_, &l))| (j, round_off_floor(l, self.lambda_max)))
            .collect()
    }
}

/// Gershgorin bound on the largest eigenvalue of `M⁻¹K`, from the shifted `K − σM` of `system`.
fn gershgorin_max(system: &ModalSystem) -> f64 {
    let m = system.k.matrix();
    let sym = m.symbolic();
    let (ptr, rows, values) = (sym.col_ptr(), sym.row_idx(), m.val());
    let (mass, shift) = (&system.mass, system.shift);
    (0..mass.len())
        .map(|j| {
            let unshifted = |p: usize| values[p] + if rows[p] == j { shift * mass[j] } else { 0.0 };
            (ptr[j]..ptr[j + 1]).map(|p| unshifted(p).abs()).sum::<f64>() / mass[j]
        })
        .fold(0.0, f64::max)
}

/// Diagonal entry `i` of the assembled matrix.
fn k_values_diag(k: &BlockAssembler, i: usize) -> f64 {
    let m = k.matrix();
    let sym = m.symbolic();
    let (ptr, rows) = (sym.col_ptr(), sym.row_idx());
    (ptr[i]..ptr[i + 1]).find(|&p| rows[p] == i).map_or(0.0, |p| m.val()[p])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;

    #[test]
    fn the_unshifted_product_is_the_assembled_stiffness_times_the_vector() {
        // `K − σM` and `K` differ by `σM ≈ 1e-6 K` on the diagonal: a product that left out the
        // shift's term would be off by about 1e-6 of `Kx`, far above the round-off allowed here.
        let mesh = grid([1.0, 0.2], [8, 2]).unwrap();
        let anchors: Vec<usize> = (0..mesh.vertex_count()).filter(|&v| mesh.positions()[v].x < -0.45).collect();
        let masses: Vec<f64> = mesh.vertex_areas().iter().map(|a| a * 0.5).collect();
        let stiffness = ShellStiffness { k_area: 1000.0, k_length: 1000.0, k_bend: 0.5 };
        let problem =
            ModalProblem { mesh: &mesh, anchors: &anchors, masses: &masses, stiffness, modes: 2, keep_rigid: false };
        let factor = factored(&problem).unwrap();
        let plain = system(&problem).unwrap();
        let x: Vec<f64> = (0..factor.system.mass.len()).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let (mut want, mut got, mut shifted) = (vec![0.0; x.len()], vec![0.0; x.len()], vec![0.0; x.len()]);
        plain.k.multiply(None, &x, 1, &mut want);
        factor.multiply_unshifted(&x, &mut got);
        factor.system.k.multiply(None, &x, 1, &mut shifted);
        let gap = |a: &[f64]| want.iter().zip(a).map(|(w, v)| (w - v).abs()).fold(0.0, f64::max);
        let scale = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
        eprintln!("largest gap to Kx: {:.1e} unshifted, {:.1e} shifted (of {scale:.1e})", gap(&got), gap(&shifted));
        assert!(gap(&got) <= 1e-12 * scale, "{} of {scale}", gap(&got));
        assert!(gap(&shifted) > 1e-9 * scale, "the shift is too small for this test to see");
    }
}
