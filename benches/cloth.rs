//! Implicit particle cloth, one backward Euler step (forces, linearisation, contacts, filtered PCG):
//! the paper's drape of a 958-particle triangulated cloth on a ball at h = 0.01 s (the paper: 1.014 s
//! per step on a Core 2 Duo) and its 625-particle quad twin, mid-fall and at rest on the ball; and a
//! 10,000-particle sheet swinging from two clips; and the filtered PCG alone, 20 iterations on the
//! drape's system at its impact. Run: `cargo bench --bench cloth`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use shellwarp::linalg::filtered_pcg::{self, Stop};
use shellwarp::scene;
use shellwarp::solver::cloth::{Cloth, Variant};
use shellwarp::solver::{Solver, supersede};

/// The cloth of `scene` (with `sets`) after `steps` steps.
fn state(scene_name: &str, sets: &[&str], variant: Variant, steps: usize) -> Cloth {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let setup = scene::load(scene_name, &sets).expect("scene");
    let mut cloth = Cloth::new(&setup, variant).expect("cloth");
    for _ in 0..steps {
        cloth.step().expect("step");
    }
    cloth
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("cloth step");
    group.sample_size(30).measurement_time(Duration::from_secs(5));
    let cases = [
        ("drape, 961 particles, falling onto the ball", state("drape", &[], Variant::Triangles, 30)),
        ("drape, 961 particles, at rest on the ball", state("drape", &[], Variant::Triangles, 300)),
        ("drape-quad, 625 particles, falling onto the ball", state("drape-quad", &[], Variant::Quads, 30)),
        ("drape-quad, 625 particles, at rest on the ball", state("drape-quad", &[], Variant::Quads, 300)),
        (
            "hanging sheet, 10,000 particles, h = 0.01 s, swinging",
            state("hanging-sheet", &["mesh.grid.segments=[99,99]", "solver.step=0.01"], Variant::Triangles, 20),
        ),
    ];
    for (name, cloth) in cases {
        group.bench_function(name, |b| {
            b.iter_batched(
                || cloth.clone(),
                |mut c| black_box(c.step().expect("step").iterations),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

/// The filtered PCG alone: 20 iterations from a cold start (no stopping test) on the drape's system
/// after 40 steps (the impact: contacts locking and sliding), so the time per iteration is about a
/// twentieth (the start costs two products), with the pool's threads kept awake as a step keeps them.
fn pcg(c: &mut Criterion) {
    let mut cloth = state("drape", &[], Variant::Triangles, 40);
    let step = cloth.linearise();
    let n = cloth.positions().len();
    let stop = Stop { tolerance: 0.0, floor: 0.0, max_iterations: 20 };
    let (mut residual, mut work) = (vec![DVec3::ZERO; n], filtered_pcg::Workspace::default());
    c.bench_function("filtered PCG, drape at impact, 20 iterations", |b| {
        b.iter(|| {
            supersede::awake(cloth.system().parallel(), || {
                let mut dv = vec![DVec3::ZERO; n];
                let report = step.solve(cloth.system(), &mut dv, stop, &mut residual, &mut work);
                black_box(report.iterations)
            })
        })
    });
}

criterion_group!(benches, step, pcg);
criterion_main!(benches);
