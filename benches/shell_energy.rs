//! Energy + gradient and Hessian assembly of the discrete shell on a ~13,000-vertex closed mesh.
//!
//! Uses `generate::creature(2.0, 36)` when the generator is available and always also measures a
//! cube-sphere of 12,698 vertices built here (a cube with 46 × 46 cells per face projected onto a
//! sphere), so the numbers exist even while the creature generator is a placeholder.
//! Run: `cargo bench --bench shell_energy`.

use std::collections::HashMap;
use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use shellwarp::energy::{DiscreteShell, HessianMode, ShellStiffness};
use shellwarp::linalg::{BlockAssembler, DofMap};
use shellwarp::mesh::{TriMesh, generate};

/// A cube with `n × n` cells per face projected onto a sphere of radius 1 (6n² + 2 vertices).
fn cube_sphere(n: i64) -> TriMesh {
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
    TriMesh::new(positions, triangles).expect("cube sphere is a valid closed mesh")
}

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
    match generate::creature(2.0, 36) {
        Ok(mesh) => bench_mesh(c, "creature", &mesh),
        Err(e) => eprintln!("creature generator unavailable ({e}); measuring the cube-sphere only"),
    }
    bench_mesh(c, "cube-sphere-12698", &cube_sphere(46));
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(3)).sample_size(20).warm_up_time(Duration::from_secs(1));
    targets = shell_energy
}
criterion_main!(benches);
