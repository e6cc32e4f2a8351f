//! The reduced basis of `rds`: the `m` lowest vibration modes, and their modal derivatives corrected
//! for the rotation-strain reconstruction, pruned by mass-PCA.
//!
//! **Modal derivatives** (Barbič & James 2005; for discrete shells Hildebrandt et al. 2011). With `K`
//! the rest stiffness on the free DOFs and `H'(v) = d/dε ∇²E(X + εv)` at `ε = 0`, the second-order
//! static response to `Σ q_i φ_i` is `½ Σ q_i q_j ψ_ij`, where
//! `K ψ_ij = −½ (H'(φ_j) φ_i + H'(φ_i) φ_j)`: differentiating `∇E(X + tφ + ½t²ψ) = t K φ + O(t³)`
//! twice. `H'(φ)` is the central difference of the analytic Hessian along `φ`, at a step of
//! [`HESSIAN_STEP`] of the mode's largest displacement (its error is `O(step²)`, about 1e-8
//! relative; the tests check the `t³` law; the two Hessians of a difference are assembled at once
//! on two threads, [`threads::join`]). One factorisation of `K` serves every pair (the modal
//! analysis's own, when the modes were just computed rather than read from the cache); each solve
//! takes one step of iterative refinement against the unshifted `K` (the factor is of `K − σM`,
//! [`crate::solver::modal::compute::factored`]).
//!
//! **The correction.** `rds` maps coordinates to positions through the rotation-strain
//! reconstruction ([`crate::solver::modal::rotation_strain`]), which is already nonlinear: for the
//! modes alone it is `x(q) = X + Φq + ½ Σ q_i q_j χ_ij + O(|q|³)`, and `χ_ij` holds the rotations'
//! second order (a bent strip's tip moving back along the strip). Adding `ψ_ij` as it is would count
//! that twice: in the reconstruction of a displacement, what `ψ_ij` adds to the rotations is turned
//! by them again, and the rest of it (the membrane stretch a linear bend would make, which the
//! reconstruction never makes) is a stiff membrane displacement — the locking of the true energy on a
//! rotation-strain reconstruction. What the reconstruction lacks is `δ_ij = ψ_ij − χ_ij`: zero to
//! second order for a bent strip, the cross-section's opening for a V-beam. `χ_ij` is the second
//! central difference of the modes' reconstruction (steps of 1e-3 of the largest displacement; four
//! reconstructions a pair, three for `i = j`).
//!
//! **Load responses.** The static responses to a uniform acceleration along each axis,
//! `K⁻¹ M e_a` (one solve each with the same factor and refinement), join the modes when asked:
//! the lowest modes span a shell's sag under its own weight only in part (`tests/rds.rs`; figures in
//! BENCHMARKS.md, *`rds`: load responses*), and a body load is what gravity and the anchors'
//! acceleration put on every shell. Made mass-orthonormal to the modes, they are
//! first-order directions like them, and the derivative directions are made orthogonal to both.
//!
//! **Pruning.** Each `δ_ij` is scaled by `λ_1² / (λ_i λ_j)` (the amplitude of `q_i q_j` under a load,
//! relative to the lowest mode's), made mass-orthogonal to the modes, and the span of the scaled set
//! is cut to its leading `d` mass-principal directions (the eigenvectors of the Gram matrix
//! `Dᵀ M D`). The modes' span is kept exactly: pruning the stacked `[Φ, δ]` instead can drop part of
//! it. Derivatives are taken of the lowest [`DERIVED_MODES`] modes at most, and of none when the
//! anchors leave the shell a rigid motion (its `K` is singular).

use glam::DVec3;
use nalgebra::{DMatrix, SymmetricEigen};

use crate::energy::{DiscreteShell, HessianMode};
use crate::mesh::TriMesh;
use crate::solver::SolverError;
use crate::solver::modal::basis::ModalBasis;
use crate::solver::modal::compute::{Factored, ModalAnalysis, ModalProblem, factored};
use crate::solver::modal::rotation_strain::RotationStrain;
use crate::threads;

/// The step of the Hessian's central difference, relative to the mode's largest displacement.
pub const HESSIAN_STEP: f64 = 1e-4;

/// The step of the reconstruction's second difference, relative to the mode's largest displacement.
const RECONSTRUCTION_STEP: f64 = 1e-3;

/// A mode whose eigenvalue is below this fraction of the largest of `M⁻¹K` is a mechanism (a rigid
/// motion the anchors leave free): `K` is singular to round-off.
const MECHANISM: f64 = 1e-12;

/// Derivatives are taken of at most this many of the lowest modes (their pairs: 528).
pub const DERIVED_MODES: usize = 32;

/// The derivative directions kept by default for `m` modes: all `m(m+1)/2` pairs up to `4m`.
pub fn default_derivatives(modes: usize) -> usize {
    let m = modes.min(DERIVED_MODES);
    (m * (m + 1) / 2).min(4 * modes)
}

/// A reduced basis: mass-orthonormal vectors, the modes first, then the load responses, then the
/// derivative directions (and drag responses while drags last).
#[derive(Debug, Clone, PartialEq)]
pub struct ReducedBasis {
    /// How many leading vectors are vibration modes.
    pub modes: usize,
    /// How many vectors after the modes are static responses to body loads.
    pub loads: usize,
    /// Per vector, its Rayleigh quotient `bᵀKb` (the eigenvalue for a mode), 1/s².
    pub stiffness: Vec<f64>,
    /// The vectors, per vertex (zero at anchors).
    pub shapes: Vec<Vec<DVec3>>,
}

impl ReducedBasis {
    /// The number of vectors.
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// How many leading vectors are first-order directions (modes and load responses); the rest are
    /// second-order (derivative directions) or drag responses.
    pub fn first_order(&self) -> usize {
        self.modes + self.loads
    }

    /// The basis in the layout of the modal methods (for the reconstruction and rotations), on `mesh`.
    pub fn modal(&self, mesh: &TriMesh) -> ModalBasis {
        ModalBasis::new(mesh, self.stiffness.clone(), &self.shapes)
    }
}

/// The modes of `analysis`, the static responses to body loads if `loads`, and `derivatives` pruned
/// derivative directions (fewer if the derivatives span fewer), reporting progress in `[0, 1]`;
/// the static solves use `factor` (the analysis's factor of `K − σM`, when it was just computed) or
/// make one. Returned with the factor if there is one, for the drags' static responses to reuse.
pub fn build(
    problem: &ModalProblem<'_>,
    analysis: &ModalAnalysis,
    factor: Option<Factored>,
    loads: bool,
    derivatives: usize,
    progress: &dyn Fn(f32),
) -> Result<(ReducedBasis, Option<Factored>), SolverError> {
    let m = analysis.basis.modes();
    let modes: Vec<Vec<DVec3>> = (0..m).map(|j| analysis.basis.shape(j)).collect();
    let mut basis = ReducedBasis { modes: m, loads: 0, stiffness: analysis.basis.eigenvalues.clone(), shapes: modes };
    let derived = m.min(DERIVED_MODES);
    let derivatives = if derived == 0 { 0 } else { derivatives };
    // Anchors that leave a rigid motion free (one row, turning about it) make `K` singular: the
    // static solves have no answer, and the basis is the modes alone.
    let mechanism = analysis.basis.eigenvalues.iter().any(|l| *l <= MECHANISM * analysis.lambda_max);
    if (!loads && derivatives == 0) || analysis.rigid_modes > 0 || mechanism {
        return Ok((basis, factor));
    }
    let factor = match factor {
        Some(factor) => factor,
        None => factored(problem)?,
    };
    if loads {
        let kept = principal(problem.masses, &basis.shapes, body_load_responses(problem, &factor)?, 3);
        basis.loads = kept.len();
        extend(&mut basis, &factor, kept);
    }
    if derivatives > 0 {
        let raw = derivatives_of(problem, &factor, &basis.shapes[..derived], progress)?;
        let corrected = corrections(problem, analysis, derived, raw)?;
        progress(0.9);
        let lambda = &analysis.basis.eigenvalues;
        let first = lambda[0].abs().max(f64::MIN_POSITIVE);
        let scale = |i: usize| first / lambda[i].abs().max(first);
        let weighted: Vec<Vec<DVec3>> = pairs(derived)
            .zip(corrected)
            .map(|((i, j), d)| d.iter().map(|v| *v * (scale(i) * scale(j))).collect())
            .collect();
        let kept = principal(problem.masses, &basis.shapes, weighted, derivatives);
        extend(&mut basis, &factor, kept);
    }
    progress(1.0);
    Ok((basis, Some(factor)))
}

/// Append `shapes` to `basis` with their Rayleigh quotients `bᵀKb`.
fn extend(basis: &mut ReducedBasis, factor: &Factored, shapes: Vec<Vec<DVec3>>) {
    let dofs = &factor.system.dofs;
    let (mut v, mut kv) = (vec![0.0; dofs.dofs()], vec![0.0; dofs.dofs()]);
    for shape in shapes {
        dofs.gather(&shape, &mut v);
        factor.multiply_unshifted(&v, &mut kv);
        basis.stiffness.push(v.iter().zip(&kv).map(|(a, b)| a * b).sum());
        basis.shapes.push(shape);
    }
}

/// `K⁻¹ b` for the `count` columns of `b` (free DOFs, column after column), by the factor of
/// `K − σM` and one step of iterative refinement against the unshifted `K`.
fn solve_unshifted(factor: &Factored, b: &[f64], count: usize) -> Result<Vec<f64>, SolverError> {
    let dim = factor.system.mass.len();
    let mut x = b.to_vec();
    factor.chol.solve_many(&mut x, count).map_err(numerical)?;
    let mut correction = vec![0.0; count * dim];
    let mut product = vec![0.0; dim];
    for ((x, b), c) in x.chunks(dim).zip(b.chunks(dim)).zip(correction.chunks_mut(dim)) {
        factor.multiply_unshifted(x, &mut product);
        c.iter_mut().zip(b.iter().zip(&product)).for_each(|(c, (b, kx))| *c = b - kx);
    }
    factor.chol.solve_many(&mut correction, count).map_err(numerical)?;
    x.iter_mut().zip(&correction).for_each(|(x, c)| *x += c);
    Ok(x)
}

/// The static responses `K⁻¹ M e_a` to a uniform acceleration along each axis, per vertex, each of
/// unit mass norm.
fn body_load_responses(problem: &ModalProblem<'_>, factor: &Factored) -> Result<Vec<Vec<DVec3>>, SolverError> {
    let (dofs, mass) = (&factor.system.dofs, &factor.system.mass);
    let dim = mass.len();
    let mut rhs = vec![0.0; 3 * dim];
    for (a, column) in rhs.chunks_mut(dim).enumerate() {
        column.iter_mut().zip(mass).skip(a).step_by(3).for_each(|(f, m)| *f = *m);
    }
    let x = solve_unshifted(factor, &rhs, 3)?;
    Ok(x.chunks(dim)
        .map(|column| {
            let norm = column.iter().zip(mass).map(|(x, m)| m * x * x).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
            let mut full = vec![DVec3::ZERO; problem.mesh.vertex_count()];
            dofs.scatter_add(column, 1.0 / norm, &mut full);
            full
        })
        .collect())
}

/// The pairs `(i, j)`, `i ≤ j < n`, in the order the derivatives are stored.
fn pairs(n: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..n).flat_map(move |i| (i..n).map(move |j| (i, j)))
}

fn numerical(e: impl std::fmt::Display) -> SolverError {
    SolverError::Numerical(e.to_string())
}

/// The displacement-space modal derivatives `ψ_ij` of `modes`, in [`pairs`] order.
pub fn derivatives_of(
    problem: &ModalProblem<'_>,
    factor: &Factored,
    modes: &[Vec<DVec3>],
    progress: &dyn Fn(f32),
) -> Result<Vec<Vec<DVec3>>, SolverError> {
    let n = modes.len();
    let dofs = &factor.system.dofs;
    let dim = factor.system.mass.len();
    let shell = DiscreteShell::new(problem.mesh, problem.stiffness).map_err(numerical)?;
    let mut asm = shell.hessian_pattern(dofs).map_err(numerical)?;
    let mut minus = asm.clone();
    let rest = problem.mesh.positions();
    // The modes gathered to the free DOFs and interleaved (entry `d` of mode `i` at `d n + i`), so
    // each `H'(φ_j)` multiplies all of them in one pass.
    let mut reduced = vec![0.0; dim * n];
    let mut v = vec![0.0; dim];
    for (i, u) in modes.iter().enumerate() {
        dofs.gather(u, &mut v);
        v.iter().enumerate().for_each(|(d, x)| reduced[d * n + i] = *x);
    }
    // rhs_ij = −½ (H'(φ_j) φ_i + H'(φ_i) φ_j): each H'(φ_j) once, times every mode.
    let count = n * (n + 1) / 2;
    let index = |i: usize, j: usize| {
        let (a, b) = if i <= j { (i, j) } else { (j, i) };
        a * n - a * (a + 1) / 2 + b
    };
    let mut rhs = vec![0.0; count * dim];
    let mut product = vec![0.0; dim * n];
    for (j, phi) in modes.iter().enumerate() {
        let largest = phi.iter().map(|p| p.length()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        let e = HESSIAN_STEP / largest;
        let shifted = |s: f64| -> Vec<DVec3> { rest.iter().zip(phi).map(|(x, p)| *x + *p * s).collect() };
        threads::join(
            || shell.assemble_hessian(&mut asm, &shifted(e), HessianMode::Exact),
            || shell.assemble_hessian(&mut minus, &shifted(-e), HessianMode::Exact),
        );
        let dh: Vec<f64> = asm.values().iter().zip(minus.values()).map(|(a, b)| (a - b) / (2.0 * e)).collect();
        asm.multiply(Some(&dh), &reduced, n, &mut product);
        for i in 0..n {
            let k = index(i, j);
            // A diagonal pair gets H'(φ_i)φ_i twice over: −½(2 H'φφ).
            let weight = if i == j { -1.0 } else { -0.5 };
            let column = product.iter().skip(i).step_by(n);
            rhs[k * dim..(k + 1) * dim].iter_mut().zip(column).for_each(|(r, p)| *r += weight * p);
        }
        progress(0.4 * (j + 1) as f32 / n as f32);
    }
    let psi = solve_unshifted(factor, &rhs, count)?;
    progress(0.6);
    Ok(psi
        .chunks(dim)
        .map(|column| {
            let mut full = vec![DVec3::ZERO; rest.len()];
            dofs.scatter_add(column, 1.0, &mut full);
            full
        })
        .collect())
}

/// `δ_ij = ψ_ij − χ_ij` (module documentation) for the lowest `derived` modes of `analysis`.
fn corrections(
    problem: &ModalProblem<'_>,
    analysis: &ModalAnalysis,
    derived: usize,
    raw: Vec<Vec<DVec3>>,
) -> Result<Vec<Vec<DVec3>>, SolverError> {
    let m = analysis.basis.modes();
    let mut rs = RotationStrain::new(problem.mesh, problem.anchors, &analysis.basis)?;
    let rest = problem.mesh.positions();
    let (mut x, mut force) = (rest.to_vec(), vec![0.0; m]);
    let mut q = vec![0.0; m];
    let steps: Vec<f64> = (0..derived)
        .map(|j| {
            let largest =
                (0..rest.len()).map(|v| analysis.basis.displacement(v, &unit(m, j)).length()).fold(0.0, f64::max);
            RECONSTRUCTION_STEP / largest.max(f64::MIN_POSITIVE)
        })
        .collect();
    let mut at = |i: usize, a: f64, j: usize, b: f64, x: &mut Vec<DVec3>| {
        q.iter_mut().for_each(|v| *v = 0.0);
        q[i] += a;
        q[j] += b;
        rs.update(&q, x, &mut force);
    };
    let mut out = Vec::with_capacity(raw.len());
    for ((i, j), psi) in pairs(derived).zip(raw) {
        let (a, b) = (steps[i], steps[j]);
        let chi: Vec<DVec3> = if i == j {
            at(i, a, i, 0.0, &mut x);
            let plus = x.clone();
            at(i, -a, i, 0.0, &mut x);
            (0..rest.len()).map(|v| (plus[v] - 2.0 * rest[v] + x[v]) / (a * a)).collect()
        } else {
            let mut corner = |sa: f64, sb: f64| {
                at(i, sa * a, j, sb * b, &mut x);
                x.clone()
            };
            let (pp, pm, mp, mm) = (corner(1.0, 1.0), corner(1.0, -1.0), corner(-1.0, 1.0), corner(-1.0, -1.0));
            (0..rest.len()).map(|v| (pp[v] - pm[v] - mp[v] + mm[v]) / (4.0 * a * b)).collect()
        };
        out.push(psi.iter().zip(&chi).map(|(p, c)| *p - *c).collect());
    }
    Ok(out)
}

fn unit(m: usize, j: usize) -> Vec<f64> {
    let mut e = vec![0.0; m];
    e[j] = 1.0;
    e
}

/// The leading `count` mass-principal directions of `vectors` after removing their components along
/// the mass-orthonormal `base`, mass-orthonormal themselves (fewer where the span is smaller).
fn principal(masses: &[f64], base: &[Vec<DVec3>], mut vectors: Vec<Vec<DVec3>>, count: usize) -> Vec<Vec<DVec3>> {
    let dot = |a: &[DVec3], b: &[DVec3]| a.iter().zip(b).zip(masses).map(|((x, y), m)| m * x.dot(*y)).sum::<f64>();
    let remove = |v: &mut Vec<DVec3>, along: &[DVec3]| {
        let s = dot(v, along);
        v.iter_mut().zip(along).for_each(|(x, y)| *x -= *y * s);
    };
    for v in vectors.iter_mut() {
        for _ in 0..2 {
            base.iter().for_each(|b| remove(v, b));
        }
    }
    let p = vectors.len();
    let mut gram = DMatrix::zeros(p, p);
    for a in 0..p {
        for b in a..p {
            gram[(a, b)] = dot(&vectors[a], &vectors[b]);
            gram[(b, a)] = gram[(a, b)];
        }
    }
    let eigen = SymmetricEigen::new(gram);
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let largest = eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
    let mut kept: Vec<Vec<DVec3>> = Vec::new();
    for &k in order.iter().take(count) {
        if eigen.eigenvalues[k] <= 1e-12 * largest {
            break;
        }
        let column = eigen.eigenvectors.column(k);
        let mut v = vec![DVec3::ZERO; masses.len()];
        for (c, d) in column.iter().zip(&vectors) {
            v.iter_mut().zip(d).for_each(|(x, y)| *x += *y * *c);
        }
        // Gram–Schmidt again (twice) against everything kept, for orthonormality to round-off.
        for _ in 0..2 {
            base.iter().chain(&kept).for_each(|b| remove(&mut v, b));
        }
        let norm = dot(&v, &v).sqrt();
        if norm <= 1e-9 * eigen.eigenvalues[k].sqrt() {
            continue;
        }
        v.iter_mut().for_each(|x| *x /= norm);
        kept.push(v);
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::ShellStiffness;
    use crate::mesh::TriMesh;
    use crate::mesh::generate::{grid, v_beam};
    use crate::solver::modal::compute::{analyse, analyse_factored};

    /// A clamped shell: its mesh, anchors (the vertices left of x = −0.45) and masses.
    fn clamped(mesh: TriMesh) -> (TriMesh, Vec<usize>, Vec<f64>) {
        let anchors = (0..mesh.vertex_count()).filter(|&v| mesh.positions()[v].x < -0.45).collect();
        let masses = mesh.vertex_areas().iter().map(|a| a * 0.5).collect();
        (mesh, anchors, masses)
    }

    const K: ShellStiffness = ShellStiffness { k_area: 1000.0, k_length: 1000.0, k_bend: 0.5 };

    fn problem<'a>(mesh: &'a TriMesh, anchors: &'a [usize], masses: &'a [f64], modes: usize) -> ModalProblem<'a> {
        ModalProblem { mesh, anchors, masses, stiffness: K, modes, keep_rigid: false }
    }

    /// `|∇E(X + tφ_i + tφ_j + ½t² Σ ψ) − t K (φ_i + φ_j)|` over the free vertices, with or without the
    /// derivatives' term.
    fn residual(p: &ModalProblem<'_>, modes: &[Vec<DVec3>], psi: &[Vec<DVec3>], (i, j): (usize, usize), t: f64) -> f64 {
        let shell = DiscreteShell::new(p.mesh, p.stiffness).unwrap();
        let rest = p.mesh.positions();
        let n = rest.len();
        let index = |a: usize, b: usize| pairs(modes.len()).position(|q| q == (a.min(b), a.max(b))).unwrap();
        // ½ (q_i φ_i + q_j φ_j)ᵀ ψ (q_i φ_i + q_j φ_j) with q_i = q_j = t: ½ t² (ψ_ii + 2ψ_ij + ψ_jj).
        let second: Vec<DVec3> = if i == j {
            psi[index(i, i)].clone()
        } else {
            (0..n).map(|v| psi[index(i, i)][v] + psi[index(i, j)][v] * 2.0 + psi[index(j, j)][v]).collect()
        };
        let u: Vec<DVec3> = (0..n).map(|v| if i == j { modes[i][v] } else { modes[i][v] + modes[j][v] }).collect();
        let at =
            |s: f64| -> Vec<DVec3> { (0..n).map(|v| rest[v] + u[v] * t + second[v] * (s * 0.5 * t * t)).collect() };
        let (mut g, mut k_u) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
        shell.gradient(&at(1.0), &mut g);
        // K u by a central difference of the gradient (exact for the linear part to O(ε²)).
        let e = 1e-7;
        let (mut gp, mut gm) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
        shell.gradient(&(0..n).map(|v| rest[v] + u[v] * e).collect::<Vec<_>>(), &mut gp);
        shell.gradient(&(0..n).map(|v| rest[v] - u[v] * e).collect::<Vec<_>>(), &mut gm);
        k_u.iter_mut().enumerate().for_each(|(v, k)| *k = (gp[v] - gm[v]) / (2.0 * e));
        let free = (0..n).filter(|v| !p.anchors.contains(v));
        free.map(|v| (g[v] - k_u[v] * t).length_squared()).sum::<f64>().sqrt()
    }

    #[test]
    fn with_the_derivatives_the_static_residual_is_third_order() {
        // ∇E(X + tφ + ½t²ψ) = tKφ + O(t³) only if Kψ_ij = −½(H'(φ_j)φ_i + H'(φ_i)φ_j): halving t
        // divides the residual by 8 with ψ and by 4 without (Barbič & James 2005).
        let (mesh, anchors, masses) = clamped(v_beam(1.0, 0.2, 90.0, [12, 4]).unwrap());
        let p = problem(&mesh, &anchors, &masses, 3);
        let analysis = analyse(&p, &|_| {}).unwrap();
        let modes: Vec<Vec<DVec3>> = (0..3).map(|j| analysis.basis.shape(j)).collect();
        let psi = derivatives_of(&p, &factored(&p).unwrap(), &modes, &|_| {}).unwrap();
        let none = vec![vec![DVec3::ZERO; mesh.vertex_count()]; psi.len()];
        for pair in [(0, 0), (1, 1), (0, 2), (1, 2)] {
            let t = 2e-3;
            let with = residual(&p, &modes, &psi, pair, t) / residual(&p, &modes, &psi, pair, t / 2.0);
            let without = residual(&p, &modes, &none, pair, t) / residual(&p, &modes, &none, pair, t / 2.0);
            eprintln!("pair {pair:?}: residual ratio on halving t: {with:.3} with ψ, {without:.3} without");
            assert!((with - 8.0).abs() < 0.5, "{pair:?}: {with}");
            assert!((without - 4.0).abs() < 0.5, "{pair:?}: {without}");
        }
    }

    #[test]
    fn the_correction_leaves_a_bent_strip_almost_nothing_and_opens_a_v_beam() {
        // A flat strip bent in its first mode: the reconstruction's rotations already hold the second
        // order (the tip moving back), so δ_00 = ψ_00 − χ_00 is a small part of ψ_00. A V-beam's first
        // mode also opens its section, which no rotation of the modes makes: δ_00 stays.
        let cases = [
            ("strip", grid([1.0, 0.2], [16, 3]).unwrap(), 0.05, 0.0),
            ("V-beam", v_beam(1.0, 0.2, 90.0, [16, 4]).unwrap(), 1.0, 0.02),
        ];
        for (name, mesh, most, least) in cases {
            let (mesh, anchors, masses) = clamped(mesh);
            let p = problem(&mesh, &anchors, &masses, 1);
            let analysis = analyse(&p, &|_| {}).unwrap();
            let modes = vec![analysis.basis.shape(0)];
            let psi = derivatives_of(&p, &factored(&p).unwrap(), &modes, &|_| {}).unwrap();
            let delta = corrections(&p, &analysis, 1, psi.clone()).unwrap();
            let norm = |u: &[DVec3]| u.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
            let ratio = norm(&delta[0]) / norm(&psi[0]);
            eprintln!("{name}: |ψ_00 − χ_00| / |ψ_00| = {ratio:.4}");
            assert!(ratio < most && ratio > least, "{name}: {ratio}");
        }
    }

    #[test]
    fn the_modes_come_first_unchanged_and_the_basis_with_its_load_responses_is_mass_orthonormal() {
        let (mesh, anchors, masses) = clamped(v_beam(1.0, 0.2, 90.0, [12, 4]).unwrap());
        let p = problem(&mesh, &anchors, &masses, 4);
        let analysis = analyse(&p, &|_| {}).unwrap();
        let (basis, factor) = build(&p, &analysis, None, true, 7, &|_| {}).unwrap();
        assert_eq!((basis.modes, basis.loads, basis.len()), (4, 3, 14));
        // With the analysis's own factor (the modes just computed) the basis is the same, bit for
        // bit, and that factor comes back for the drags.
        let (fresh, analysis_factor) = analyse_factored(&p, &|_| {}).unwrap();
        assert_eq!(fresh.basis, analysis.basis);
        let made = analysis_factor.timings;
        let (reused, back) = build(&p, &fresh, Some(analysis_factor), true, 7, &|_| {}).unwrap();
        assert_eq!(reused, basis);
        // The factor given is the one used and returned (its clock readings), not a new one.
        assert!(factor.is_some_and(|f| f.timings != made) && back.is_some_and(|f| f.timings == made));
        for j in 0..4 {
            assert_eq!(basis.shapes[j], analysis.basis.shape(j), "mode {j}");
        }
        let dot = |a: &[DVec3], b: &[DVec3]| a.iter().zip(b).zip(&masses).map(|((x, y), m)| m * x.dot(*y)).sum::<f64>();
        let mut worst: f64 = 0.0;
        for a in 0..basis.len() {
            for b in 0..basis.len() {
                let want = if a == b { 1.0 } else { 0.0 };
                worst = worst.max((dot(&basis.shapes[a], &basis.shapes[b]) - want).abs());
            }
        }
        eprintln!("largest departure of ΦᵀMΦ from I: {worst:.1e}");
        assert!(worst < 1e-9, "{worst}");
        for v in &anchors {
            assert!(basis.shapes.iter().all(|s| s[*v] == DVec3::ZERO), "anchored vertex {v} moves");
        }
        // The load responses and derivative directions are stiffer than the lowest mode.
        assert!(basis.stiffness[4..].iter().all(|k| *k > basis.stiffness[0]), "{:?}", basis.stiffness);
    }
}
