//! Energy + gradient and Hessian assembly of the discrete shell on the 12,962-vertex creature
//! (`generate::creature(2.0, 36)`, the paper's dinosaur scale). Run: `cargo bench --bench shell_energy`.
//!
//! Each of the two targets is measured twice: wall-clock time (criterion's default), and the CPU time
//! of the benchmark thread (`… (cpu)`, from `/proc/thread-self/schedstat`, read right after a yield so
//! the kernel has just accounted it). On a machine shared with other work the wall time includes the
//! time the thread waited for a core; the CPU time does not, so it is the fairer "on one core" figure.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use shellwarp::energy::{DiscreteShell, HessianMode, ShellStiffness};
use shellwarp::linalg::DofMap;
use shellwarp::mesh::{TriMesh, generate};

fn bench_mesh(c: &mut Criterion, name: &str, mesh: &TriMesh) {
    let k = ShellStiffness { k_area: 1000.0, k_length: 1000.0, k_bend: 0.1 };
    let shell = DiscreteShell::new(mesh, k).expect("valid mesh");
    // A deformed state so no term is trivially zero.
    let x: Vec<DVec3> =
        mesh.positions().iter().enumerate().map(|(i, &p)| p * (1.0 + 0.01 * ((i as f64) * 0.37).sin())).collect();
    let mut g = vec![DVec3::ZERO; x.len()];
    let mut asm = shell.hessian_pattern(&DofMap::all(x.len())).expect("pattern");
    eprintln!(
        "{name}: {} vertices, {} triangles, {} elements, Hessian {}×{} with {} stored entries",
        mesh.vertex_count(),
        mesh.triangles().len(),
        shell.element_count(),
        asm.dim(),
        asm.dim(),
        asm.nnz()
    );
    c.bench_function(&format!("{name}/energy+gradient"), |b| {
        b.iter(|| black_box(shell.gradient(black_box(&x), &mut g)))
    });
    c.bench_function(&format!("{name}/energy+gradient (cpu)"), |b| {
        b.iter_custom(|iters| {
            cpu_time(|| {
                for _ in 0..iters {
                    black_box(shell.gradient(black_box(&x), &mut g));
                }
            })
        })
    });
    c.bench_function(&format!("{name}/energy"), |b| b.iter(|| black_box(shell.energy(black_box(&x)))));
    c.bench_function(&format!("{name}/hessian assembly (exact)"), |b| {
        b.iter(|| {
            shell.assemble_hessian(&mut asm, black_box(&x), HessianMode::Exact);
            black_box(asm.values()[0])
        })
    });
    c.bench_function(&format!("{name}/hessian assembly (exact) (cpu)"), |b| {
        b.iter_custom(|iters| {
            cpu_time(|| {
                for _ in 0..iters {
                    shell.assemble_hessian(&mut asm, black_box(&x), HessianMode::Exact);
                    black_box(asm.values()[0]);
                }
            })
        })
    });
    c.bench_function(&format!("{name}/hessian pattern (symbolic, once)"), |b| {
        b.iter(|| black_box(shell.hessian_pattern(&DofMap::all(x.len())).expect("pattern").nnz()))
    });
}

/// CPU time of this thread, if the kernel reports it (`/proc/thread-self/schedstat`, nanoseconds).
fn thread_cpu() -> Option<Duration> {
    std::thread::yield_now();
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok().map(Duration::from_nanos)
}

/// The CPU time `f` takes on this thread (wall time where CPU time is not available).
fn cpu_time(f: impl FnOnce()) -> Duration {
    let (start, wall) = (thread_cpu(), Instant::now());
    f();
    match (start, thread_cpu()) {
        (Some(a), Some(b)) => b.saturating_sub(a),
        _ => wall.elapsed(),
    }
}

fn shell_energy(c: &mut Criterion) {
    let mesh = generate::creature(2.0, 36).expect("the creature generator makes a valid mesh");
    bench_mesh(c, "creature", &mesh);
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(3)).sample_size(20).warm_up_time(Duration::from_secs(1));
    targets = shell_energy
}
criterion_main!(benches);
