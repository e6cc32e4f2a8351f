//! Finite-difference and invariance tests of the whole shell energy on irregular, curved and closed meshes.

use std::collections::HashMap;

use glam::{DQuat, DVec3};

use super::fd::{self, Rng};
use super::stretch::packed_entry;
use super::{DiscreteShell, HessianMode, ShellStiffness};
use crate::linalg::DofMap;
use crate::mesh::{TriMesh, generate};

/// An irregular, curved rest shape: a jittered 5 × 4 grid folded 70° about the line x = 0.1, with a
/// bump, so rest angles are non-zero and of both signs.
fn curved_mesh(rng: &mut Rng) -> TriMesh {
    let g = generate::grid([1.0, 0.8], [5, 4]).unwrap();
    let fold = 70f64.to_radians();
    let p = g
        .positions()
        .iter()
        .map(|&p| {
            let mut q = p + DVec3::new(0.04 * rng.uniform(), 0.0, 0.04 * rng.uniform());
            q.y = 0.1 * (3.0 * q.z).sin() + 0.03 * rng.uniform();
            if q.x > 0.1 {
                let r = q.x - 0.1;
                q = DVec3::new(0.1 + r * fold.cos(), q.y + r * fold.sin(), q.z);
            }
            q
        })
        .collect();
    g.with_positions(p).unwrap()
}

/// A closed convex mesh: a cube with `n × n` cells per face projected onto the unit sphere.
pub(crate) fn cube_sphere(n: i64) -> TriMesh {
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..3 {
        for s in [-1i64, 1] {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let mut id = |i: i64, j: i64| {
                let mut key = [0i64; 3];
                key[k] = s * n;
                key[a] = 2 * i - n;
                key[b] = 2 * j - n;
                *index.entry(key).or_insert_with(|| {
                    positions.push(DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64).normalize());
                    positions.len() - 1
                })
            };
            for i in 0..n {
                for j in 0..n {
                    let (p00, p10, p11, p01) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                    if s > 0 {
                        triangles.extend([[p00, p10, p11], [p00, p11, p01]]);
                    } else {
                        triangles.extend([[p00, p11, p10], [p00, p01, p11]]);
                    }
                }
            }
        }
    }
    TriMesh::new(positions, triangles).unwrap()
}

fn dense_hessian(shell: &DiscreteShell, x: &[DVec3], mode: HessianMode) -> Vec<Vec<f64>> {
    let mut asm = shell.hessian_pattern(&DofMap::all(x.len())).unwrap();
    shell.assemble_hessian(&mut asm, x, mode);
    asm.to_dense()
}

/// Relative errors of the FD gradient (from energies) and FD Hessian (from gradients), see [`fd`].
fn fd_errors(shell: &DiscreteShell, x: &[DVec3]) -> (f64, f64) {
    let hessian = dense_hessian(shell, x, HessianMode::Exact).concat();
    let gradient = |y: &[DVec3]| {
        let mut g = vec![DVec3::ZERO; y.len()];
        shell.gradient(y, &mut g);
        g
    };
    fd::errors(x, |y| shell.energy(y), gradient, Some(&hessian))
}

const K: ShellStiffness = ShellStiffness { k_area: 3.0, k_length: 2.0, k_bend: 0.7 };

#[test]
fn each_term_and_the_total_match_finite_differences_on_a_curved_irregular_mesh() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let rest = curved_mesh(&mut rng);
    let x: Vec<DVec3> = rest.positions().iter().map(|&p| p + rng.vec() * 0.08).collect();
    let only = [
        ShellStiffness { k_area: 1.0, k_length: 0.0, k_bend: 0.0 },
        ShellStiffness { k_area: 0.0, k_length: 1.0, k_bend: 0.0 },
        ShellStiffness { k_area: 0.0, k_length: 0.0, k_bend: 1.0 },
        K,
    ];
    for k in only {
        let shell = DiscreteShell::new(&rest, k).unwrap();
        let (g, h) = fd_errors(&shell, &x);
        eprintln!("FD relative errors {k:?}: gradient {g:.2e}, Hessian {h:.2e}");
        assert!(g < 1e-6 && h < 1e-6, "{k:?}: gradient error {g:e}, Hessian error {h:e}");
    }
    // The curved rest shape really has non-zero rest angles of both signs.
    let shell = DiscreteShell::new(&rest, K).unwrap();
    let angles = shell.rest_angles();
    assert!(angles.iter().any(|&a| a.abs() > 1.0), "the fold line has rest angles near 70°: {angles:?}");
    assert!(angles.iter().any(|&a| a > 0.1) && angles.iter().any(|&a| a < -0.1), "{angles:?}");
}

#[test]
fn energy_and_gradient_vanish_at_rest_and_are_invariant_under_rigid_motion() {
    let mut rng = Rng(42);
    let rest = curved_mesh(&mut rng);
    let shell = DiscreteShell::new(&rest, K).unwrap();
    let mut g = vec![DVec3::ZERO; rest.vertex_count()];
    assert!(shell.gradient(rest.positions(), &mut g).abs() < 1e-24);
    assert!(g.iter().all(|v| v.length() < 1e-12), "{g:?}");
    assert!(shell.energy(rest.positions()).abs() < 1e-24);

    let x: Vec<DVec3> = rest.positions().iter().map(|&p| p + rng.vec() * 0.1).collect();
    let q = DQuat::from_axis_angle(DVec3::new(0.3, -1.0, 0.7).normalize(), 2.4);
    let t = DVec3::new(5.0, -2.0, 1.5);
    let y: Vec<DVec3> = x.iter().map(|&p| q * p + t).collect();
    let (wx, wy) = (shell.energy(&x), shell.energy(&y));
    assert!(wx > 1e-3, "the deformed state stores energy");
    eprintln!("rigid motion: relative change of W {:.1e}", ((wx - wy) / wx).abs());
    assert!(((wx - wy) / wx).abs() < 1e-10, "W changed under rigid motion: {wx} vs {wy}");
    // The gradient rotates with the mesh.
    let mut gy = vec![DVec3::ZERO; y.len()];
    shell.gradient(&x, &mut g);
    shell.gradient(&y, &mut gy);
    let scale = g.iter().map(|v| v.length()).fold(0.0, f64::max);
    assert!(g.iter().zip(&gy).all(|(a, b)| (q * *a - *b).length() < 1e-10 * scale));
    // Also a rotated *rest* shape gives zero energy for its own rest state and the same energy for a
    // rotated deformation.
    let rotated_rest = rest.with_positions(rest.positions().iter().map(|&p| q * p + t).collect()).unwrap();
    let shell2 = DiscreteShell::new(&rotated_rest, K).unwrap();
    assert!(((shell2.energy(&y) - wx) / wx).abs() < 1e-10);
}

#[test]
fn rest_hessian_of_a_closed_mesh_has_exactly_six_zero_eigenvalues() {
    let mesh = cube_sphere(2);
    assert_eq!(mesh.topology().boundary_edges.len(), 0);
    let shell = DiscreteShell::new(&mesh, ShellStiffness { k_area: 1.0, k_length: 1.0, k_bend: 0.05 }).unwrap();
    let h = dense_hessian(&shell, mesh.positions(), HessianMode::Exact);
    let n = h.len();
    let m = nalgebra::DMatrix::from_fn(n, n, |i, j| h[i][j]);
    assert!((&m - m.transpose()).amax() < 1e-12 * m.amax());
    let ev = m.symmetric_eigenvalues();
    let max = ev.amax();
    let mut sorted: Vec<f64> = ev.iter().copied().collect();
    sorted.sort_by(f64::total_cmp);
    let zeros = sorted.iter().filter(|l| l.abs() < 1e-9 * max).count();
    eprintln!(
        "closed cube-sphere ({} DOFs): |λ₁..λ₆|/λmax ≤ {:.1e}, λ₇/λmax = {:.2e}",
        n,
        sorted[..6].iter().map(|l| l.abs()).fold(0.0, f64::max) / max,
        sorted[6] / max
    );
    assert_eq!(zeros, 6, "eigenvalues {:?}", &sorted[..10]);
    assert!(sorted[0] > -1e-9 * max, "the rest Hessian is positive semidefinite");
    assert!(sorted[6] > 1e-5 * max, "the 7th eigenvalue {} is clearly non-zero", sorted[6]);
    // The projected Hessian equals the exact one at rest (it is already PSD there).
    let hp = dense_hessian(&shell, mesh.positions(), HessianMode::Projected);
    let diff = h.iter().flatten().zip(hp.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(diff < 1e-10 * max, "{diff}");
}

#[test]
fn projected_hessian_is_positive_semidefinite_far_from_rest() {
    let mut rng = Rng(99);
    let rest = curved_mesh(&mut rng);
    let shell = DiscreteShell::new(&rest, K).unwrap();
    let x: Vec<DVec3> = rest.positions().iter().map(|&p| p + rng.vec() * 0.3).collect();
    let eig = |mode| {
        let h = dense_hessian(&shell, &x, mode);
        let n = h.len();
        nalgebra::DMatrix::from_fn(n, n, |i, j| h[i][j]).symmetric_eigenvalues()
    };
    let exact = eig(HessianMode::Exact);
    let projected = eig(HessianMode::Projected);
    assert!(exact.min() < -1e-3 * exact.amax(), "the exact Hessian is indefinite here");
    assert!(projected.min() > -1e-10 * projected.amax(), "min eigenvalue {}", projected.min());
}

#[test]
fn bad_stiffness_is_refused() {
    let mesh = cube_sphere(1);
    assert!(DiscreteShell::new(&mesh, ShellStiffness { k_area: -1.0, ..K }).is_err());
    let mut s = DiscreteShell::new(&mesh, K).unwrap();
    assert!(s.set_stiffness(ShellStiffness { k_bend: f64::NAN, ..K }).is_err());
    assert_eq!(s.stiffness(), K);
}

/// Two triangles on the edge 0 → 1 (along x); the second wing rotated by `fold` about the edge.
fn folded_pair(fold: f64) -> Vec<DVec3> {
    let (s, c) = fold.sin_cos();
    vec![
        DVec3::new(-0.4, 0.0, 0.0),
        DVec3::new(0.6, 0.0, 0.0),
        DVec3::new(0.1, 0.0, -0.8),
        DVec3::new(0.2, -0.9 * s, 0.9 * c),
    ]
}

#[test]
fn rest_angle_near_pi_is_wrapped_branch_safely() {
    let tris = vec![[0, 1, 2], [1, 0, 3]];
    let rest = TriMesh::new(folded_pair(3.0), tris).unwrap();
    let shell = DiscreteShell::new(&rest, ShellStiffness { k_area: 0.0, k_length: 0.0, k_bend: 1.0 }).unwrap();
    let rest_angle = shell.rest_angles()[0];
    assert!((rest_angle.abs() - 3.0).abs() < 1e-12, "{rest_angle}");
    // Fold on through ±π to the other side: the angle jumps by 2π but θ − θ̄ must not.
    let x = folded_pair(3.3);
    let theta = super::hinge::angle(&x.clone().try_into().unwrap());
    assert!((theta - rest_angle).abs() > 5.0, "the raw angle wrapped: θ = {theta}, θ̄ = {rest_angle}");
    let h = rest.topology().hinges[0];
    let areas = rest.triangle_areas();
    let weight = 3.0 * (x[1] - x[0]).length_squared() / (areas[h.faces[0]] + areas[h.faces[1]]);
    let expected = weight * 0.3f64.powi(2);
    assert!((shell.energy(&x) - expected).abs() < 1e-12 * expected, "{} vs {expected}", shell.energy(&x));
    let (g, hs) = fd_errors(&shell, &x);
    assert!(g < 1e-6 && hs < 1e-6, "FD errors across ±π: {g:e} {hs:e}");
}

#[test]
fn a_weighted_element_set_sums_its_elements_and_its_gradient_matches_finite_differences() {
    let mut rng = Rng(7);
    let rest = curved_mesh(&mut rng);
    let shell = DiscreteShell::new(&rest, K).unwrap();
    let x: Vec<DVec3> = rest.positions().iter().map(|&p| p + rng.vec() * 0.08).collect();
    let n = x.len();
    // Every element at weight 1 is the whole energy.
    let all: Vec<(usize, f64)> = (0..shell.element_count()).map(|e| (e, 1.0)).collect();
    let (mut g, mut gw) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
    let w = shell.gradient(&x, &mut g);
    let ww = shell.weighted_gradient(&x, &all, &mut gw);
    assert!((w - ww).abs() <= 1e-12 * w && (w - shell.energy(&x)).abs() <= 1e-12 * w, "{w} {ww}");
    assert!(g.iter().zip(&gw).all(|(a, b)| (*a - *b).length() <= 1e-12 * (1.0 + a.length())));
    // A subset of every kind at random weights: its gradient and its Hessian (summed from the
    // elements' own) against central differences.
    let some: Vec<(usize, f64)> =
        (0..shell.element_count()).step_by(3).map(|e| (e, 0.5 + rng.uniform().abs())).collect();
    let mut h = vec![vec![0.0; 3 * n]; 3 * n];
    for &(e, weight) in &some {
        shell.element_hessian(e, &x, HessianMode::Exact, |v, lower| {
            for (i, j) in (0..3 * v.len()).flat_map(|i| (0..3 * v.len()).map(move |j| (i, j))) {
                h[3 * v[i / 3] + i % 3][3 * v[j / 3] + j % 3] += weight * packed_entry(lower, i, j);
            }
        });
    }
    let gradient = |y: &[DVec3]| {
        let mut g = vec![DVec3::ZERO; y.len()];
        shell.weighted_gradient(y, &some, &mut g);
        g
    };
    let (ge, he) = fd::errors(&x, |y| shell.weighted_energy(y, &some), gradient, Some(&h.concat()));
    eprintln!("weighted set: FD relative errors gradient {ge:.2e}, Hessian {he:.2e}");
    assert!(ge < 1e-6 && he < 1e-6, "gradient {ge:e}, Hessian {he:e}");
}
