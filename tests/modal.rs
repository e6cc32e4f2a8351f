//! Modal analysis and modal warping: eigenpairs against a dense solver, beam frequency ratios, and
//! MWTS under orientation drags (twisting a beam's tip by 90°, 180° and 360°).

use glam::DVec3;
use nalgebra::{DMatrix, SymmetricEigen};
use shellwarp::energy::{DiscreteShell, HessianMode, ShellStiffness};
use shellwarp::linalg::{BlockAssembler, DofMap};
use shellwarp::scene::{self, Setup};
use shellwarp::solver::modal::compute::{ModalProblem, analyse};
use shellwarp::solver::{self, Drag, DragKind};

/// A strip along x clamped at x = −L/2 (two vertex rows), as a scene with overrides.
fn strip(length: f64, width: f64, segments: [usize; 2], extra: &[&str]) -> Setup {
    let clamp = -0.5 * length + 1.01 * length / segments[0] as f64;
    let mut o = vec![
        "solver.method=mwts".to_string(),
        format!("mesh.grid.size=[{length}, {width}]"),
        format!("mesh.grid.segments=[{}, {}]", segments[0], segments[1]),
        format!("anchors=[{{ box = {{ min = [-9, -9, -9], max = [{clamp}, 9, 9] }} }}]"),
    ];
    o.extend(extra.iter().map(|s| s.to_string()));
    scene::load("cantilever", &o).unwrap()
}

fn problem<'a>(s: &'a Setup, masses: &'a [f64], modes: usize) -> ModalProblem<'a> {
    let m = &s.scene.material;
    ModalProblem { mesh: &s.mesh, anchors: &s.anchors, masses, stiffness: ShellStiffness::from(m), modes }
}

#[test]
fn eigenpairs_match_a_dense_generalized_solver() {
    let s = strip(0.4, 0.1, [8, 2], &["material.k_area=10", "material.k_length=10"]);
    let masses = s.masses();
    let p = problem(&s, &masses, 6);
    let a = analyse(&p, &|_| {}).unwrap();
    // Dense reference: K from the same energy, M lumped, both reduced to the free DOFs.
    let fixed: Vec<bool> = (0..s.mesh.vertex_count()).map(|v| s.anchors.contains(&v)).collect();
    let dofs = DofMap::without(&fixed);
    let shell = DiscreteShell::new(&s.mesh, p.stiffness).unwrap();
    let mut k = BlockAssembler::for_shell(&shell, &dofs).unwrap();
    k.assemble_shell(&shell, s.mesh.positions(), HessianMode::Exact);
    let kd = k.to_dense();
    let m: Vec<f64> = dofs.free_vertices().iter().flat_map(|&v| [masses[v]; 3]).collect();
    let n = m.len();
    let sym = DMatrix::from_fn(n, n, |i, j| kd[i][j] / (m[i] * m[j]).sqrt());
    let eig = SymmetricEigen::new(sym);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| eig.eigenvalues[x].total_cmp(&eig.eigenvalues[y]));
    for (j, &lambda) in a.basis.eigenvalues.iter().enumerate() {
        let want = eig.eigenvalues[order[j]];
        assert!((lambda - want).abs() <= 1e-8 * want, "λ{j}: {lambda} vs dense {want}");
        // Same vector up to sign: |φᵀ M φ_dense| = 1 (dense vector is M^{1/2}-scaled).
        let dense = eig.eigenvectors.column(order[j]);
        let overlap: f64 = dofs
            .free_vertices()
            .iter()
            .enumerate()
            .flat_map(|(f, &v)| (0..3).map(move |ax| (3 * f + ax, v, ax)))
            .map(|(r, v, ax)| a.basis.phi(v, ax, j) * m[r].sqrt() * dense[r])
            .sum();
        assert!((overlap.abs() - 1.0).abs() < 1e-8, "mode {j} overlap {overlap}");
        assert!(a.residuals[j] <= 1e-8, "mode {j} residual {}", a.residuals[j]);
    }
}

#[test]
fn cantilever_bending_frequency_ratio_matches_euler_bernoulli() {
    let s = strip(1.0, 0.02, [100, 2], &["material.k_area=100", "material.k_length=100", "material.k_bend=0.001"]);
    let masses = s.masses();
    let a = analyse(&problem(&s, &masses, 8), &|_| {}).unwrap();
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
    assert!((ratio / beam - 1.0).abs() < 0.03, "ω2/ω1 = {ratio:.4}, Euler–Bernoulli {beam:.4}");
}

/// Twist angle of each cross-section row about the beam axis, unwrapped from the clamp outwards.
fn twist_profile(x: &[DVec3], rows: usize, per_row: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(rows);
    let mut prev = 0.0;
    for i in 0..rows {
        let d = x[i * per_row + per_row - 1] - x[i * per_row];
        let mut a = (-d.y).atan2(d.z);
        while a - prev > std::f64::consts::PI {
            a -= std::f64::consts::TAU;
        }
        while a - prev < -std::f64::consts::PI {
            a += std::f64::consts::TAU;
        }
        out.push(a);
        prev = a;
    }
    out
}

#[test]
fn mwts_twists_a_beam_smoothly_by_90_180_and_360_degrees() {
    let segments = [40, 4];
    let setup = strip(1.0, 0.1, segments, &["solver.modes=12", "gravity=[0, 0, 0]", "solver.rayleigh_alpha=4"]);
    let per_row = segments[1] + 1;
    let tip = segments[0] * per_row + segments[1] / 2;
    for degrees in [90.0f64, 180.0, 360.0] {
        let mut s = solver::build(&setup).unwrap();
        let target = DVec3::X * degrees.to_radians();
        s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Orientation(target) }).unwrap();
        for _ in 0..90 {
            s.step().unwrap_or_else(|e| panic!("{degrees}°: {e}"));
        }
        let x = s.positions();
        assert!(x.iter().all(|p| p.is_finite()), "{degrees}°: finite");
        let profile = twist_profile(x, segments[0] + 1, per_row);
        let end = *profile.last().unwrap();
        assert!((end.to_degrees() - degrees).abs() < 0.1 * degrees, "{degrees}°: tip twisted {:.1}°", end.to_degrees());
        for w in profile.windows(2) {
            let step = (w[1] - w[0]).to_degrees();
            assert!(
                step > -1.0 && step < 3.0 * degrees / segments[0] as f64,
                "{degrees}°: jump of {step:.2}° between rows"
            );
        }
        // The cross-sections keep their width: no collapse or inflation.
        for i in 0..=segments[0] {
            let w = (x[i * per_row + per_row - 1] - x[i * per_row]).length();
            assert!((w - 0.1).abs() < 0.01, "{degrees}°: row {i} width {w}");
        }
    }
}

#[test]
fn changing_the_mode_count_recomputes_in_the_background_and_carries_the_state_over() {
    use shellwarp::solver::Solver;
    use shellwarp::solver::modal::method::ModalSolver;
    let setup = scene::load("cantilever", &["solver.modes=6".into()]).unwrap();
    let mut s = ModalSolver::new(&setup, true).unwrap();
    assert_eq!(s.analysis().basis.modes(), 6);
    for _ in 0..20 {
        s.step().unwrap();
    }
    let before = s.positions().to_vec();
    s.set_param("modes", 10.0).unwrap();
    let mut swapped_after = None;
    for k in 0..2000 {
        let prev = s.positions().to_vec();
        s.step().expect("the step loop keeps running on the old modes meanwhile");
        if k == 0 {
            assert!(s.progress().is_some(), "a background recompute is reported");
        }
        if s.progress().is_none() {
            // The swap happened in this step: the shape moves by no more than a normal step would.
            let jump = prev.iter().zip(s.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            let sag = before.iter().zip(setup.mesh.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            assert!(jump < 0.05 * sag, "jump {jump} at the swap, sag {sag}");
            swapped_after = Some(k);
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(swapped_after.is_some(), "the new basis arrived");
    assert_eq!(s.analysis().basis.modes(), 10, "the new basis is in use");
}

#[test]
fn an_unreachable_drag_stays_calm_under_the_default_damping() {
    // Pulling the tip sideways and toward the clamp asks the bending modes for what they cannot do.
    let setup = scene::load("cantilever", &[]).unwrap();
    let mut s = solver::build(&setup).unwrap();
    let tip = 204;
    let target = DVec3::new(0.35, 0.2, 0.15);
    s.drags_mut().add(Drag { vertex: tip, kind: DragKind::Position(target) }).unwrap();
    let mut energies = Vec::new();
    for _ in 0..240 {
        energies.push(s.step().unwrap().energy);
    }
    let late = &energies[120..];
    let (lo, hi) = late.iter().fold((f64::MAX, 0.0f64), |(l, h), &e| (l.min(e), h.max(e)));
    assert!(hi < 10.0 && hi - lo < 0.05 * hi, "settled, not thrashing: energy in [{lo}, {hi}] J");
    let gap = (s.positions()[tip] - target).length();
    assert!(gap < 0.1, "the tip comes as close as the modes allow: {gap} m");
}
