//! Modal analysis: eigenpairs against a dense generalized eigensolver (an anchored and a free shell),
//! the cantilever's Euler–Bernoulli frequency ratio, and relative residuals ≤ 1e-8 for every pair of
//! the tests and of the built-in shell scenes, and progress reported within the eigen solve (where a
//! superseded background analysis stops). (MWTS dynamics: `tests/modal_dynamics.rs`.)

mod modal_common;

use glam::DVec3;
use modal_common::strip;
use nalgebra::{DMatrix, SymmetricEigen};
use shellwarp::energy::{DiscreteShell, HessianMode, ShellStiffness};
use shellwarp::linalg::DofMap;
use shellwarp::scene::{self, Setup};
use shellwarp::solver::modal::compute::{MAX_RESIDUAL, ModalAnalysis, ModalProblem, analyse};

/// Numbers to two significant digits, for the printed reports.
fn short(values: &[f64]) -> Vec<String> {
    values.iter().map(|v| format!("{v:.1e}")).collect()
}

fn analysis(s: &Setup, modes: usize) -> ModalAnalysis {
    let masses = s.masses();
    let stiffness = ShellStiffness::from(&s.scene.material);
    let p = ModalProblem { mesh: &s.mesh, anchors: &s.anchors, masses: &masses, stiffness, modes, keep_rigid: false };
    analyse(&p, &|_| {}).unwrap()
}

/// Compare every returned pair with the dense solution of the same reduced `K φ = λ M φ`, the
/// returned mode `j` against dense mode `j + skip` (`skip` rigid modes of a free shell).
fn compare_with_dense(s: &Setup, a: &ModalAnalysis, skip: usize) {
    let fixed = s.anchored_mask();
    let dofs = DofMap::without(&fixed);
    let shell = DiscreteShell::new(&s.mesh, ShellStiffness::from(&s.scene.material)).unwrap();
    let mut k = shell.hessian_pattern(&dofs).unwrap();
    shell.assemble_hessian(&mut k, s.mesh.positions(), HessianMode::Exact);
    let kd = k.to_dense();
    let masses = s.masses();
    let m: Vec<f64> = dofs.free_vertices().iter().flat_map(|&v| [masses[v]; 3]).collect();
    let n = m.len();
    let eig = SymmetricEigen::new(DMatrix::from_fn(n, n, |i, j| kd[i][j] / (m[i] * m[j]).sqrt()));
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| eig.eigenvalues[x].total_cmp(&eig.eigenvalues[y]));
    let lambda_max = eig.eigenvalues[order[n - 1]];
    assert_eq!(a.rigid_modes, skip, "rigid modes found and skipped");
    for (j, &lambda) in a.basis.eigenvalues.iter().enumerate() {
        let want = eig.eigenvalues[order[j + skip]];
        // The dense solver is backward stable: its own error on λ is about ε λ_max, so the comparison
        // at 1e-8 needs (a generous 64×) ε λ_max / λ at a fifth of that or less.
        let reference_error = 64.0 * f64::EPSILON * lambda_max / want;
        let rel = (lambda - want).abs() / want;
        // Same vector up to sign: |φᵀ M φ_dense| = 1 (the dense vector is M^{1/2}-scaled).
        let dense = eig.eigenvectors.column(order[j + skip]);
        let overlap: f64 = dofs
            .free_vertices()
            .iter()
            .enumerate()
            .flat_map(|(f, &v)| (0..3).map(move |ax| (3 * f + ax, v, ax)))
            .map(|(r, v, ax)| a.basis.phi(v, ax, j) * m[r].sqrt() * dense[r])
            .sum();
        eprintln!(
            "mode {j}: λ {lambda:.10e}, dense {want:.10e} (relative {rel:.1e}, dense's own error ≲ {reference_error:.0e}), \
             overlap − 1 {:.1e}, residual {:.1e}",
            overlap.abs() - 1.0,
            a.residuals[j]
        );
        assert!(reference_error <= 2e-9, "the dense reference is not accurate enough for mode {j}");
        assert!(rel <= 1e-8, "λ{j}: {lambda} vs dense {want}");
        assert!((overlap.abs() - 1.0).abs() < 1e-8, "mode {j} overlap {overlap}");
        assert!(a.residuals[j] <= MAX_RESIDUAL, "mode {j} residual {}", a.residuals[j]);
    }
}

#[test]
fn eigenpairs_match_a_dense_generalized_solver() {
    // Membrane stiffness 10 rather than the scene's 1000, for the dense reference's sake: its own
    // relative error on the lowest λ, 64 ε λ_max/λ, is 1e-9 here and would be 1e-7 at 1000.
    let s = strip(0.4, 0.1, [8, 2], true, &["material.k_area=10", "material.k_length=10"]);
    compare_with_dense(&s, &analysis(&s, 6), 0);
}

#[test]
fn a_free_shell_skips_its_six_rigid_modes_and_matches_the_dense_solver() {
    let s = strip(0.4, 0.1, [8, 2], false, &["material.k_area=10", "material.k_length=10"]);
    assert!(s.anchors.is_empty());
    compare_with_dense(&s, &analysis(&s, 6), 6);
}

#[test]
fn cantilever_bending_frequency_ratio_matches_euler_bernoulli() {
    // A 1 m × 5 cm strip of 40 × 2 cells, membrane 1000× stiffer than bending: a beam (its in-plane
    // modes lie far above), with λ_max/λ_1 small enough that every residual meets 1e-8.
    let s = strip(1.0, 0.05, [40, 2], true, &["material.k_area=10", "material.k_length=10", "material.k_bend=0.01"]);
    let a = analysis(&s, 8);
    // Vertical bending modes: displacement mostly along y.
    let vertical: Vec<f64> = (0..a.basis.modes())
        .filter(|&j| {
            let (mut y, mut all) = (0.0, 0.0);
            for v in 0..s.mesh.vertex_count() {
                let u = DVec3::new(a.basis.phi(v, 0, j), a.basis.phi(v, 1, j), a.basis.phi(v, 2, j));
                y += u.y * u.y;
                all += u.length_squared();
            }
            y > 0.9 * all
        })
        .map(|j| a.basis.eigenvalues[j].sqrt())
        .collect();
    assert!(vertical.len() >= 2, "found {} vertical bending modes", vertical.len());
    let ratio = vertical[1] / vertical[0];
    let beam = (4.6941f64 / 1.8751).powi(2);
    eprintln!(
        "ω2/ω1 = {ratio:.4}, Euler–Bernoulli {beam:.4} ({:+.2}%); residuals {:?}",
        100.0 * (ratio / beam - 1.0),
        short(&a.residuals)
    );
    assert!((ratio / beam - 1.0).abs() < 0.03, "ω2/ω1 = {ratio:.4}, Euler–Bernoulli {beam:.4}");
    assert!(a.residuals.iter().all(|&r| r <= MAX_RESIDUAL), "{:?}", a.residuals);
}

#[test]
fn every_pair_of_the_shell_scenes_meets_the_residual_target() {
    for (name, modes) in [("cantilever", 8), ("v-beam", 8), ("creature", 4)] {
        let s = scene::load(name, &[]).unwrap();
        let a = analysis(&s, modes);
        eprintln!("{name}: residuals {:?} (λ_max ≤ {:.2e})", short(&a.residuals), a.lambda_max);
        assert_eq!(a.residuals.len(), modes);
        assert!(a.residuals.iter().all(|&r| r <= MAX_RESIDUAL), "{name}: {:?}", a.residuals);
    }
}

/// The documented exception to the residual target: a stiff membrane with a soft bending mode on a
/// fine strip (`λ_max/λ₁ ≈ 4e10`) cannot get its first mode below 1e-8 in f64. The analysis accepts
/// it, but only within the round-off floor, and flags it.
#[test]
fn a_mode_past_the_target_but_within_round_off_is_flagged() {
    let overrides =
        ["mesh.grid.size=[1.0, 0.02]", "mesh.grid.segments=[100, 2]", "material.k_area=100", "material.k_bend=0.001"];
    let s = scene::load("cantilever", &overrides.map(String::from)).unwrap();
    let a = analysis(&s, 4);
    let flagged = a.above_target();
    eprintln!("residuals {:?}, flagged (mode, floor) {flagged:?}", short(&a.residuals));
    assert!(flagged.iter().any(|&(j, _)| j == 0), "mode 0 is past the target: {:?}", a.residuals);
    for (j, floor) in flagged {
        assert!(
            a.residuals[j] > MAX_RESIDUAL && a.residuals[j] <= floor,
            "mode {j}: {} vs floor {floor}",
            a.residuals[j]
        );
    }
}

/// `modes --export` writes the very eigenproblem the analysis solves: read back, `K` and `M` give the
/// same products as the assembled ones, and the lowest eigenvalue of the exported pencil (a dense
/// solve) is the one shellwarp reports.
#[test]
fn the_exported_matrices_are_the_analysed_problem() {
    use shellwarp::linalg::matrix_market::read_symmetric;
    let dir = std::env::temp_dir().join(format!("shellwarp-export-{}", std::process::id()));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shellwarp"))
        .args(["modes", "--scene", "cantilever", "--modes", "4", "--json", "--export"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (n, k) = read_symmetric(&dir.join("K.mtx")).unwrap();
    let (m_n, m) = read_symmetric(&dir.join("M.mtx")).unwrap();
    assert_eq!((n, m_n), (3 * 195, 3 * 195), "free DOFs of the 205-vertex strip with 10 anchored");
    let info: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("shellwarp.json")).unwrap()).unwrap();
    // The same products as the assembled matrix.
    let s = scene::load("cantilever", &[]).unwrap();
    let masses = s.masses();
    let p = ModalProblem {
        mesh: &s.mesh,
        anchors: &s.anchors,
        masses: &masses,
        stiffness: ShellStiffness::from(&s.scene.material),
        modes: 4,
        keep_rigid: false,
    };
    let sys = shellwarp::solver::modal::compute::system(&p).unwrap();
    let x: Vec<f64> = (0..n).map(|i| (0.37 * i as f64).sin()).collect();
    let mut assembled = vec![0.0; n];
    sys.k.multiply(None, &x, 1, &mut assembled);
    let mut exported = vec![0.0; n];
    k.iter().for_each(|&(i, j, v)| exported[i] += v * x[j]);
    let scale = assembled.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(assembled.iter().zip(&exported).all(|(a, b)| (a - b).abs() <= 1e-14 * scale));
    assert!(m.iter().all(|&(i, j, v)| i == j && v == sys.mass[i]));
    // The lowest eigenvalue of M^{-1/2} K M^{-1/2}, densely.
    let mut dense = nalgebra::DMatrix::<f64>::zeros(n, n);
    k.iter().for_each(|&(i, j, v)| dense[(i, j)] = v / (sys.mass[i] * sys.mass[j]).sqrt());
    let lowest = dense.symmetric_eigen().eigenvalues.iter().copied().fold(f64::INFINITY, f64::min);
    let reported = info["eigenvalues"][0].as_f64().unwrap();
    assert!((lowest - reported).abs() <= 1e-8 * reported, "{lowest} vs {reported}");
    assert!(info["shift"].as_f64().unwrap() < 0.0);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_eigen_solve_reports_as_it_goes_so_a_superseded_analysis_stops_inside_it() {
    use std::cell::RefCell;

    use shellwarp::solver::supersede::{Generation, unless_superseded};

    let s = scene::load("creature", &[]).unwrap();
    let masses = s.masses();
    let stiffness = ShellStiffness::from(&s.scene.material);
    let p =
        ModalProblem { mesh: &s.mesh, anchors: &s.anchors, masses: &masses, stiffness, modes: 16, keep_rigid: false };
    let seen = RefCell::new(Vec::new());
    analyse(&p, &|f| seen.borrow_mut().push(f)).unwrap();
    let seen = seen.into_inner();
    let inside: Vec<f32> = seen.iter().copied().filter(|f| (0.3..0.9).contains(f)).collect();
    assert!(inside.len() >= 5, "reports within the eigen solve: {seen:?}");
    assert!(seen.windows(2).all(|w| w[0] <= w[1]) && seen.last() == Some(&1.0), "{seen:?}");
    // Superseded at its third report within the eigen solve: nothing is reported after it.
    let generation = Generation::default();
    let ticket = generation.next();
    let after = RefCell::new(0);
    let stopped = unless_superseded(
        &ticket,
        &|f| {
            if f > 0.3 {
                *after.borrow_mut() += 1;
                if *after.borrow() == 3 {
                    generation.cancel_all();
                }
            }
        },
        |report| analyse(&p, report),
    );
    assert!(stopped.is_none());
    assert_eq!(after.into_inner(), 3);
}
