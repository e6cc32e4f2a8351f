//! Modal warping on the 12,962-vertex creature (the paper's dinosaur: 4 modes, 18 s precompute,
//! ~200 frames/s): the precompute (assembly + factorisation + eigen), the extra precompute of
//! `mwts-rs` (its reconstruction's Laplacian, factor and per-triangle rows, and the adjoint of
//! gravity), and one MWTS / MWTS-RS / LMA step at 4, 8, 16, 32 and 64 modes, with gravity acting and
//! a position drag on the head. Run: `cargo bench --bench modal`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use shellwarp::energy::ShellStiffness;
use shellwarp::scene::{self, Setup};
use shellwarp::solver::modal::compute::{ModalAnalysis, ModalProblem, analyse};
use shellwarp::solver::modal::rotation_strain::RotationStrain;
use shellwarp::solver::{self, Drag, DragKind};

fn creature(modes: usize) -> (Setup, ModalProblemOwned) {
    let setup = scene::load("creature", &[format!("solver.modes={modes}")]).expect("creature scene");
    let masses = setup.masses();
    (setup, ModalProblemOwned { masses, modes })
}

/// What a [`ModalProblem`] borrows besides the setup.
struct ModalProblemOwned {
    masses: Vec<f64>,
    modes: usize,
}

fn problem<'a>(setup: &'a Setup, owned: &'a ModalProblemOwned) -> ModalProblem<'a> {
    ModalProblem {
        mesh: &setup.mesh,
        anchors: &setup.anchors,
        masses: &owned.masses,
        stiffness: ShellStiffness::from(&setup.scene.material),
        modes: owned.modes,
        keep_rigid: false,
    }
}

fn precompute(c: &mut Criterion) {
    let (setup, owned) = creature(4);
    let problem = problem(&setup, &owned);
    let mut group = c.benchmark_group("creature precompute");
    group.sample_size(10).measurement_time(Duration::from_secs(12));
    group.bench_function("4 modes (assembly + factorisation + eigen)", |b| {
        b.iter(|| black_box(analyse(&problem, &|_| {}).expect("modes").basis.eigenvalues[0]))
    });
    let analysis: ModalAnalysis = analyse(&problem, &|_| {}).expect("modes");
    let gravity: Vec<DVec3> = owned.masses.iter().map(|m| setup.gravity() * *m).collect();
    group.bench_function("mwts-rs extra, 4 modes (Laplacian, factor, triangle rows, gravity's adjoint)", |b| {
        b.iter(|| {
            let mut rs = RotationStrain::new(&setup.mesh, &setup.anchors, &analysis.basis).expect("reconstruction");
            rs.set_forces(&gravity);
            black_box(rs)
        })
    });
    group.finish();
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("creature step");
    group.sample_size(30).measurement_time(Duration::from_secs(3));
    for modes in [4, 8, 16, 32, 64] {
        for method in ["mwts", "mwts-rs", "lma"] {
            let setup = scene::load("creature", &[format!("solver.method={method}"), format!("solver.modes={modes}")])
                .expect("creature scene");
            let mut s = solver::build(&setup).expect("solver (modes cached after the first run)");
            // A drag on the head keeps the constraint path in the measurement.
            let head = (0..setup.mesh.vertex_count())
                .max_by(|&a, &b| setup.mesh.positions()[a].y.total_cmp(&setup.mesh.positions()[b].y))
                .unwrap_or(0);
            let target = setup.mesh.positions()[head] + DVec3::new(0.1, 0.2, 0.0);
            s.drags_mut().add(Drag { vertex: head, kind: DragKind::Position(target) }).expect("drag");
            group.bench_function(format!("{method} {modes} modes"), |b| b.iter(|| black_box(s.step().expect("step"))));
        }
    }
    group.finish();
}

criterion_group!(benches, precompute, steps);
criterion_main!(benches);
