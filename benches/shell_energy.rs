//! Energy + gradient and Hessian assembly of the discrete shell on the 12,962-vertex creature
//! (`generate::creature(2.0, 36)`, the paper's dinosaur scale). Run: `cargo bench --bench shell_energy`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use shellwarp::energy::{DiscreteShell, HessianMode, ShellStiffness};
use shellwarp::linalg::{BlockAssembler, DofMap};
use shellwarp::mesh::{TriMesh, generate};

fn bench_mesh(c: &mut Criterion, name: &str, mesh: &TriMesh) {
    let k = ShellStiffness { k_area: 1000.0, k_length: 1000.0, k_bend: 0.1 };
    let shell = DiscreteShell::new(mesh, k).expect("valid mesh");
    // A deformed state so no term is trivially zero.
    let x: Vec<DVec3> =
        mesh.positions().iter().enumerate().map(|(i, &p)| p * (1.0 + 0.01 * ((i as f64) * 0.37).sin())).collect();
    let mut g = vec![DVec3::ZERO; x.len()];
    let mut asm = BlockAssembler::for_shell(&shell, &DofMap::all(x.len())).expect("pattern");
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
    c.bench_function(&format!("{name}/energy"), |b| b.iter(|| black_box(shell.energy(black_box(&x)))));
    c.bench_function(&format!("{name}/hessian assembly (exact)"), |b| {
        b.iter(|| {
            asm.assemble_shell(&shell, black_box(&x), HessianMode::Exact);
            black_box(asm.values()[0])
        })
    });
    c.bench_function(&format!("{name}/hessian pattern (symbolic, once)"), |b| {
        b.iter(|| black_box(BlockAssembler::for_shell(&shell, &DofMap::all(x.len())).expect("pattern").nnz()))
    });
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
