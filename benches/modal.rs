//! Modal warping on the 12,962-vertex creature (the paper's dinosaur: 4 modes, 18 s precompute,
//! ~200 frames/s): the precompute (assembly + factorisation + eigen) and one MWTS / LMA step at
//! 4, 8, 16, 32 and 64 modes, with gravity acting. Run: `cargo bench --bench modal`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use shellwarp::energy::ShellStiffness;
use shellwarp::scene;
use shellwarp::solver::modal::compute::{ModalProblem, analyse};
use shellwarp::solver::{self, Drag, DragKind};

fn precompute(c: &mut Criterion) {
    let setup = scene::load("creature", &[]).expect("creature scene");
    let m = &setup.scene.material;
    let masses = setup.masses();
    let problem = ModalProblem {
        mesh: &setup.mesh,
        anchors: &setup.anchors,
        masses: &masses,
        stiffness: ShellStiffness::from(m),
        modes: 4,
        keep_rigid: false,
    };
    let mut group = c.benchmark_group("creature precompute");
    group.sample_size(10).measurement_time(Duration::from_secs(12));
    group.bench_function("4 modes (assembly + factorisation + eigen)", |b| {
        b.iter(|| black_box(analyse(&problem, &|_| {}).expect("modes").basis.eigenvalues[0]))
    });
    group.finish();
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("creature step");
    group.sample_size(30).measurement_time(Duration::from_secs(3));
    for modes in [4, 8, 16, 32, 64] {
        for method in ["mwts", "lma"] {
            let setup = scene::load("creature", &[format!("solver.method={method}"), format!("solver.modes={modes}")])
                .expect("creature scene");
            let mut s = solver::build(&setup).expect("solver (modes cached after the first run)");
            // A drag on the head keeps the constraint path in the measurement.
            let head = (0..setup.mesh.vertex_count())
                .max_by(|&a, &b| setup.mesh.positions()[a].y.total_cmp(&setup.mesh.positions()[b].y))
                .unwrap_or(0);
            let target = setup.mesh.positions()[head] + glam::DVec3::new(0.1, 0.2, 0.0);
            s.drags_mut().add(Drag { vertex: head, kind: DragKind::Position(target) }).expect("drag");
            group.bench_function(format!("{method} {modes} modes"), |b| b.iter(|| black_box(s.step().expect("step"))));
        }
    }
    group.finish();
}

criterion_group!(benches, precompute, steps);
criterion_main!(benches);
