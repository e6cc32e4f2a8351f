//! Position-based cloth, one frame of 1/60 s (all its substeps): the 961-particle drape by `xpbd` and
//! by `pbd`, falling onto the ball (and xpbd 3 s in); the `pile` (715 particles, self-collision) while
//! it folds onto the ground and at rest; and 10,000-particle sheets with self-collision on, at settings
//! that keep them from going through themselves: the hanging sheet (edges of 1 cm, thickness 2 mm)
//! swinging from its two clips at 12 substeps × 1 sweep, each triangle keeping a fifth of its rest area
//! (`tests/self_collision.rs` checks 300 frames of it with the exact intersection test; at the pile's
//! 4 × 2 it goes through itself by frame 21) — in
//! still air, where it swings in its plane, and in a breeze, where it billows — and
//! the pile itself refined (segments 38 × 255, thickness scaled with the edges, 16 substeps) just
//! after it lands (frame 14, no intersection; by frame 31 even 16 substeps let it through the
//! ground, reported as a divergence).
//! Run: `cargo bench --bench pbd`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use shellwarp::scene;
use shellwarp::solver::Solver;
use shellwarp::solver::pbd::{Pbd, Variant};

/// The scene with `sets`, after `frames` frames.
fn state(scene_name: &str, sets: &[&str], variant: Variant, frames: usize) -> Pbd {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let setup = scene::load(scene_name, &sets).expect("scene");
    let mut cloth = Pbd::new(&setup, variant).expect("cloth");
    for _ in 0..frames {
        cloth.step().expect("step");
    }
    cloth
}

/// `xpbd` on the drape: 1/60 s frames of 10 substeps of one iteration.
const DRAPE_XPBD: [&str; 4] =
    ["solver.step=0.0166666666666667", "solver.substeps=10", "solver.sweeps=1", "solver.method=xpbd"];

/// A sheet of 10,000 particles at the settings of `tests/self_collision.rs` that keep it whole.
const SHEET: [&str; 7] = [
    "mesh.grid.segments=[99,99]",
    "solver.step=0.0166666666666667",
    "solver.substeps=12",
    "solver.sweeps=1",
    "solver.self_collision=true",
    "solver.thickness=0.002",
    "solver.least_area=0.2",
];

/// The wind that makes the sheet billow (0.5 m/s across it), so that self-collision searches: in still
/// air it swings in its plane and is searched once.
const BREEZE: &str = "wind.velocity=[0.0,0.0,0.5]";

/// The pile refined to 9,984 particles: at its 4 substeps the impact moves particles two edges a
/// substep and the strip crumples through the ground; 16 keep it above through the impact.
const PILE_FINE: [&str; 3] = ["mesh.grid.segments=[38,255]", "solver.thickness=0.0016", "solver.substeps=16"];

fn frames(c: &mut Criterion) {
    let mut group = c.benchmark_group("pbd frame");
    group.sample_size(10).measurement_time(Duration::from_secs(5));
    // Each state is built only when its benchmark is selected (the 10,000-particle pile takes minutes).
    type Build = Box<dyn Fn() -> Pbd>;
    let cases: [(&str, Build); 8] = [
        (
            "drape, 961 particles, xpbd, falling onto the ball",
            Box::new(|| state("drape", &DRAPE_XPBD, Variant::Xpbd, 18)),
        ),
        ("drape, 961 particles, xpbd, 3 s in", Box::new(|| state("drape", &DRAPE_XPBD, Variant::Xpbd, 180))),
        (
            "pbd-drape, 961 particles, pbd, falling onto the ball",
            Box::new(|| state("pbd-drape", &[], Variant::Pbd, 18)),
        ),
        ("pile, 715 particles, folding", Box::new(|| state("pile", &[], Variant::Xpbd, 40))),
        ("pile, 715 particles, at rest", Box::new(|| state("pile", &[], Variant::Xpbd, 300))),
        (
            "hanging sheet, 10,000 particles, self-collision, swinging",
            Box::new(|| state("hanging-sheet", &SHEET, Variant::Xpbd, 20)),
        ),
        (
            "hanging sheet, 10,000 particles, self-collision, in a breeze (frame 60)",
            Box::new(|| state("hanging-sheet", &[&SHEET[..], &[BREEZE]].concat(), Variant::Xpbd, 60)),
        ),
        (
            "pile, 9,984 particles, 16 substeps, after impact (frame 14)",
            Box::new(|| state("pile", &PILE_FINE, Variant::Xpbd, 14)),
        ),
    ];
    for (name, build) in cases {
        // Criterion calls the closure once per sample: build once.
        let built = std::cell::OnceCell::new();
        group.bench_function(name, |b| {
            let cloth = built.get_or_init(&build);
            b.iter_batched(
                || cloth.clone(),
                |mut c| black_box(c.step().expect("step").iterations),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, frames);
criterion_main!(benches);
