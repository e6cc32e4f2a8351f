//! An optimised cubature of the reduced shell's energy (An, Kim & James 2008, "Optimizing cubature
//! for efficient integration of subspace deformations"; for discrete shells von Tycowicz, Schulz,
//! Seidel & Hildebrandt 2013): `E(x(c)) ≈ Σ_{e∈S} w_e E_e(x(c))` over a few elements `S` with
//! weights `w_e ≥ 0`, so each Newton iteration evaluates a few hundred elements instead of all.
//!
//! **Training.** On `P` poses `c_p` the exact generalised force `f(c_p) = J_pᵀ ∇E(x(c_p))` is the
//! target and each element's own `g_e(c_p) = J_{p,e}ᵀ ∇E_e(x(c_p))` a column; each pose's rows are
//! divided by `|f(c_p)|`, so small and large poses count alike. The rest stiffness
//! `K₀ = Σ_e J_eᵀ ∇²E_e J_e` is a target too, column by column (each divided by its norm): a
//! cubature that gets the forces of finite poses right can still leave a stiff direction nearly
//! free at rest, and the equilibrium then slides along it (BENCHMARKS.md, *the cubature*). The fit
//! is `min |A w − b|²`, `w ≥ 0`, grown greedily: the candidates whose columns point most along the
//! residual join `S`
//! (a batch of an eighth of `|S|` at a time), the weights are re-solved by non-negative least
//! squares ([`crate::linalg::nnls`], warm), until the relative residual is below
//! [`TOLERANCE`] or `S` has the requested size. Candidates are every element up to [`POOL`], else a
//! fixed random sample of that many.
//!
//! **Poses.** The first-order coordinates (the modes' and the load responses') are drawn normal with
//! standard deviation `√(λ₁/λ_k)` (equal expected energy, `λ_k` the Rayleigh quotient), scaled so the
//! linear displacement's largest vertex moves `d`; the derivative
//! directions' likewise, scaled to `d²/L` (they are second order), with `L` the rest shape's
//! diagonal and `d/L` cycling through [`AMPLITUDES`]. Poses drawn with another seed measure the
//! error on poses the fit has not seen ([`relative_errors`]).

use glam::DVec3;
use nalgebra::{DMatrix, DVector};

use super::basis::ReducedBasis;
use super::energy::{Cubature, ReducedShell};
use crate::linalg::nnls;
use crate::linalg::random::Rng;

/// The fewest training poses.
pub const MIN_POSES: usize = 24;

/// The most training poses.
pub const MAX_POSES: usize = 300;

/// The greedy fit stops when the training residual is below this fraction of the target.
pub const TOLERANCE: f64 = 2e-3;

/// At most this many candidate elements.
pub const POOL: usize = 6000;

/// The poses' largest linear displacement, as fractions of the rest shape's diagonal.
pub const AMPLITUDES: [f64; 5] = [0.01, 0.05, 0.15, 0.3, 0.5];

/// The seed of the training poses.
const TRAINING_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// `count` poses of `basis` (module documentation), from `seed`.
pub fn poses(basis: &ReducedBasis, rest: &[DVec3], count: usize, seed: u64) -> Vec<Vec<f64>> {
    let (lo, hi) =
        rest.iter().fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let diagonal = (hi - lo).length();
    let mut rng = Rng(seed | 1);
    let groups = [0..basis.first_order(), basis.first_order()..basis.len()];
    (0..count)
        .map(|p| {
            let d = AMPLITUDES[p % AMPLITUDES.len()] * diagonal;
            let mut c = vec![0.0; basis.len()];
            for (g, range) in groups.iter().enumerate() {
                let Some(lowest) = basis.stiffness[range.clone()].iter().copied().filter(|l| *l > 0.0).reduce(f64::min)
                else {
                    continue;
                };
                for k in range.clone() {
                    c[k] = rng.normal() * (lowest / basis.stiffness[k].max(lowest)).sqrt();
                }
                let largest = (0..rest.len())
                    .map(|v| range.clone().map(|k| basis.shapes[k][v] * c[k]).sum::<DVec3>().length())
                    .fold(0.0, f64::max);
                let target = if g == 0 { d } else { d * d / diagonal };
                range.clone().for_each(|k| c[k] *= target / largest.max(1e-300));
            }
            c
        })
        .collect()
}

/// Fit a cubature of at most `size` elements to `shell` (whose own cubature is ignored) on
/// poses of `basis`: enough for four rows a weight, between [`MIN_POSES`] and [`MAX_POSES`].
pub fn fit(
    shell: &mut ReducedShell,
    basis: &ReducedBasis,
    rest: &[DVec3],
    size: usize,
    progress: &dyn Fn(f32),
) -> Cubature {
    let saved = shell.cubature().cloned();
    shell.set_cubature(None);
    let elements = shell.element_count();
    let pool: Vec<usize> = if elements <= POOL {
        (0..elements).collect()
    } else {
        let mut rng = Rng(TRAINING_SEED);
        let mut all: Vec<usize> = (0..elements).collect();
        for i in 0..POOL {
            let j = i + ((0.5 * (rng.uniform() + 1.0)) * (elements - i) as f64) as usize;
            all.swap(i, j.min(elements - 1));
        }
        all.truncate(POOL);
        all
    };
    let r = basis.len();
    // Four rows a weight at least, so the fit cannot follow the poses' particulars.
    let count = (4 * size).div_ceil(r.max(1)).clamp(MIN_POSES, MAX_POSES);
    let poses = poses(basis, rest, count, TRAINING_SEED);
    // The rest stiffness's columns first (r blocks of r rows), then the poses' forces.
    let offset = r * r;
    let mut a = DMatrix::zeros(offset + count * r, pool.len());
    let mut b = DVector::zeros(offset + count * r);
    let j = shell.jacobian(&vec![0.0; r]);
    let stiffness = shell.projected_hessian(rest, &j);
    for k in 0..r {
        let scale = 1.0 / stiffness.column(k).norm().max(1e-300);
        b.rows_mut(k * r, r).copy_from(&(stiffness.column(k) * scale));
    }
    for (column, &e) in pool.iter().enumerate() {
        let ke = shell.element_stiffness(e, rest, &j);
        for k in 0..r {
            let scale = 1.0 / stiffness.column(k).norm().max(1e-300);
            a.view_mut((k * r, column), (r, 1)).copy_from(&(ke.column(k) * scale));
        }
    }
    let mut x = rest.to_vec();
    for (p, c) in poses.iter().enumerate() {
        shell.positions(c, &mut x);
        let j = shell.jacobian(c);
        let target = shell.exact_force(&x, &j);
        let scale = 1.0 / target.norm().max(1e-300);
        b.rows_mut(offset + p * r, r).copy_from(&(target * scale));
        for (column, &e) in pool.iter().enumerate() {
            a.view_mut((offset + p * r, column), (r, 1)).copy_from(&(shell.element_force(e, &x, &j) * scale));
        }
        progress(0.8 * (p + 1) as f32 / count as f32);
    }
    shell.set_cubature(saved);
    let cubature = greedy(&a, &b, size);
    progress(1.0);
    Cubature { elements: cubature.0.into_iter().map(|(k, w)| (pool[k], w)).collect(), training_error: cubature.1 }
}

/// The greedy non-negative fit of `b` by at most `size` of `a`'s columns: (column, weight) pairs
/// and the relative residual.
fn greedy(a: &DMatrix<f64>, b: &DVector<f64>, size: usize) -> (Vec<(usize, f64)>, f64) {
    let norms: Vec<f64> = a.column_iter().map(|c| c.norm()).collect();
    let total = b.norm().max(1e-300);
    let mut chosen: Vec<usize> = Vec::new();
    let mut taken = vec![false; a.ncols()];
    let (mut gram, mut d, mut w) = (DMatrix::zeros(0, 0), DVector::zeros(0), DVector::zeros(0));
    let mut residual = b.clone();
    while chosen.len() < size && residual.norm() > TOLERANCE * total {
        let scores = a.tr_mul(&residual);
        let mut order: Vec<usize> =
            (0..a.ncols()).filter(|&k| !taken[k] && norms[k] > 0.0 && scores[k] > 0.0).collect();
        if order.is_empty() {
            break;
        }
        order.sort_by(|&p, &q| (scores[q] / norms[q]).total_cmp(&(scores[p] / norms[p])));
        let batch = (chosen.len() / 8).max(1).min(size - chosen.len());
        order.truncate(batch);
        let old = chosen.len();
        order.iter().for_each(|&k| taken[k] = true);
        chosen.extend(&order);
        let n = chosen.len();
        let columns = DMatrix::from_fn(a.nrows(), n - old, |row, k| a[(row, chosen[old + k])]);
        let cross = DMatrix::from_fn(n, n - old, |i, k| a.column(chosen[i]).dot(&columns.column(k)));
        let mut grown = DMatrix::zeros(n, n);
        grown.view_mut((0, 0), (old, old)).copy_from(&gram);
        grown.view_mut((0, old), (n, n - old)).copy_from(&cross);
        grown.view_mut((old, 0), (n - old, n)).copy_from(&cross.transpose());
        gram = grown;
        d = DVector::from_fn(n, |i, _| if i < old { d[i] } else { columns.column(i - old).dot(b) });
        let start = DVector::from_fn(n, |i, _| if i < old { w[i] } else { 0.0 });
        w = nnls::solve(&gram, &d, Some(&start));
        residual = b - chosen.iter().zip(w.iter()).fold(DVector::zeros(b.len()), |s, (&k, &x)| s + a.column(k) * x);
    }
    let kept = chosen.into_iter().zip(w.iter().copied()).filter(|&(_, x)| x > 0.0).collect();
    (kept, residual.norm() / total)
}

/// Per pose of `count` drawn from `seed`, `|f_S(c) − f(c)| / |f(c)|`: the cubature's force against
/// every element's, with the same Jacobian.
pub fn relative_errors(
    shell: &mut ReducedShell,
    basis: &ReducedBasis,
    rest: &[DVec3],
    cubature: &Cubature,
    count: usize,
    seed: u64,
) -> Vec<f64> {
    let mut x = rest.to_vec();
    poses(basis, rest, count, seed)
        .iter()
        .map(|c| {
            shell.positions(c, &mut x);
            let j = shell.jacobian(c);
            let exact = shell.exact_force(&x, &j);
            let sampled = cubature
                .elements
                .iter()
                .fold(DVector::zeros(c.len()), |s, &(e, w)| s + shell.element_force(e, &x, &j) * w);
            (sampled - &exact).norm() / exact.norm().max(1e-300)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use glam::DVec3;

    use super::{Cubature, greedy};
    use crate::energy::ShellStiffness;
    use crate::linalg::random::Rng;
    use crate::mesh::generate::v_beam;
    use crate::solver::modal::compute::{ModalProblem, analyse};
    use crate::solver::reduced::basis;
    use crate::solver::reduced::energy::ReducedShell;

    #[test]
    fn every_element_at_weight_one_is_the_exact_energy_force_and_projected_hessian() {
        let mesh = v_beam(1.0, 0.2, 90.0, [10, 4]).unwrap();
        let anchors: Vec<usize> = (0..mesh.vertex_count()).filter(|&v| mesh.positions()[v].x < -0.45).collect();
        let masses: Vec<f64> = mesh.vertex_areas().iter().map(|a| a * 0.5).collect();
        let stiffness = ShellStiffness { k_area: 1000.0, k_length: 1000.0, k_bend: 0.5 };
        let p =
            ModalProblem { mesh: &mesh, anchors: &anchors, masses: &masses, stiffness, modes: 3, keep_rigid: false };
        let analysis = analyse(&p, &|_| {}).unwrap();
        let (b, _) = basis::build(&p, &analysis, None, false, 4, &|_| {}).unwrap();
        let mut shell = ReducedShell::new(&mesh, &anchors, stiffness, &b).unwrap();
        let rest = mesh.positions();
        let c = &super::poses(&b, rest, 4, 17)[3];
        let mut x = rest.to_vec();
        shell.positions(c, &mut x);
        let j = shell.jacobian(c);
        let (mut g, mut gw) = (vec![DVec3::ZERO; x.len()], vec![DVec3::ZERO; x.len()]);
        let (e, h) = (shell.gradient(&x, &mut g), shell.projected_hessian(&x, &j));
        let all = (0..shell.element_count()).map(|e| (e, 1.0)).collect();
        shell.set_cubature(Some(Cubature { elements: all, training_error: 0.0 }));
        let (ew, hw) = (shell.gradient(&x, &mut gw), shell.projected_hessian(&x, &j));
        assert!(e > 0.0 && (e - ew).abs() <= 1e-12 * e && (e - shell.energy(&x)).abs() <= 1e-12 * e, "{e} {ew}");
        assert!(g.iter().zip(&gw).all(|(a, b)| (*a - *b).length() <= 1e-10 * (1.0 + a.length())));
        let gap = (&h - &hw).amax() / h.amax();
        assert!(gap < 1e-12, "projected Hessians differ by {gap:e} of the largest entry");
    }

    #[test]
    fn the_greedy_fit_finds_a_sparse_exact_rule_and_stops_at_its_size() {
        let mut rng = Rng(3);
        let a = DMatrix::from_fn(120, 400, |_, _| rng.uniform() + 0.3);
        let rule = [(17, 0.7), (123, 1.9), (256, 0.4), (399, 1.1)];
        let b = rule.iter().fold(DVector::zeros(120), |s, &(k, w)| s + a.column(k) * w);
        let (found, residual) = greedy(&a, &b, 50);
        assert!(residual < super::TOLERANCE, "residual {residual}");
        assert!(found.len() <= 12 && found.iter().all(|&(_, w)| w > 0.0), "{found:?}");
        let (capped, worse) = greedy(&a, &b, 2);
        assert!(capped.len() <= 2 && worse > residual, "{capped:?} {worse}");
    }
}
