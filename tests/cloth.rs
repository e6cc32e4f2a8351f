//! Implicit particle cloth (issue: "Implicit particle cloth on triangle meshes"): the PCG against a
//! direct sparse solve, resolution independence, contact, friction, rest and stability.

use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use glam::{DMat3, DVec3};
use shellwarp::collision::Shape;
use shellwarp::linalg::filtered_pcg::{self, Operator, Stop};
use shellwarp::scene::{self, Setup};
use shellwarp::solver::Solver;
use shellwarp::solver::cloth::{Cloth, Variant};

fn load(name: &str, sets: &[&str]) -> Setup {
    scene::load(name, &sets.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The hanging sheet at rest with `segments` cells each way: how far its lowest point dropped (the
/// sag), and for information its centre of mass and the middle of its top edge, metres.
fn hanging_sag(segments: usize) -> [f64; 3] {
    let setup =
        load("hanging-sheet", &[&format!("mesh.grid.segments=[{segments},{segments}]"), "solver.tolerance=1e-6"]);
    let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
    let rest = setup.mesh.positions().to_vec();
    let masses = setup.masses();
    let total: f64 = masses.iter().sum();
    let com = |x: &[DVec3]| x.iter().zip(&masses).map(|(p, m)| p.y * m).sum::<f64>() / total;
    let lowest = |x: &[DVec3]| x.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let top_middle = (segments / 2) * (segments + 1); // vertex (n/2, 0)
    let mut steps = 0;
    while steps < 60 || (cloth.kinetic_energy() > 1e-10 && steps < 1500) {
        cloth.step().unwrap();
        steps += 1;
    }
    assert!(cloth.kinetic_energy() < 1e-8, "{segments}: not at rest after {steps} steps");
    let x = cloth.positions();
    let sag = [lowest(&rest) - lowest(x), com(&rest) - com(x), rest[top_middle].y - x[top_middle].y];
    println!(
        "{segments} × {segments} cells: rest after {steps} steps (KE {:.1e} J); drop of the lowest point {:.5} m, of the centre of mass {:.5} m, of the top edge's middle {:.5} m",
        cloth.kinetic_energy(),
        sag[0],
        sag[1],
        sag[2]
    );
    sag
}

/// Valence weights and the buckling force's `1/L²` (with the bending width) must not make the
/// cloth stiffer or softer when its mesh is refined: the sheet's sag — how far its lowest point
/// drops — changes by under 5% at 2× and 4× the resolution. (Fold patterns, and with them the centre
/// of mass, still change more: the immediate-buckling model resists in-plane compression with
/// `12 k_b/L²` per unit width, which grows as the cells shrink. They are printed, not asserted.)
#[test]
fn refining_the_hanging_sheet_changes_its_sag_by_under_five_percent() {
    let base = hanging_sag(24);
    for n in [48, 96] {
        let fine = hanging_sag(n);
        let change = |k: usize| (fine[k] - base[k]).abs() / base[k];
        println!(
            "  {n}: sag changes by {:.2}% (centre of mass {:.2}%, top middle {:.2}%)",
            100.0 * change(0),
            100.0 * change(1),
            100.0 * change(2)
        );
        assert!(change(0) < 0.05, "refining 24 → {n} cells changes the sag by {:.1}%", 100.0 * change(0));
    }
}

/// Mid-drape (cloth falling onto the ball, contacts active), the filtered PCG solved tightly matches
/// a sparse Cholesky solve of the same filtered system, reduced to the free directions:
/// `(Tᵀ A T) y = Tᵀ (b − A z)`, `Δv = z + T y`. Constrained components of Δv equal `z`.
#[test]
fn pcg_matches_a_direct_sparse_solve_of_the_filtered_system() {
    let setup = load("drape", &[]);
    let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
    for _ in 0..45 {
        cloth.step().unwrap();
    }
    let step = cloth.linearise();
    let n = cloth.positions().len();
    let kinds = [0, 1, 2].map(|free| step.constraints.iter().filter(|c| rank(c.filter) == free).count());
    println!("{} constraints: {} locked, {} sliding (2 free directions)", step.constraints.len(), kinds[0], kinds[2]);
    assert!(kinds[0] > 10, "the drape has locked contacts by now: {kinds:?}");
    let system = cloth.system();
    let mut dv = vec![DVec3::ZERO; n];
    let stop = Stop { tolerance: 1e-14, floor: 0.0, max_iterations: 20_000 };
    let mut residual = vec![DVec3::ZERO; n];
    let report = step.solve(system, &mut dv, stop, &mut residual, &mut filtered_pcg::Workspace::default());
    println!("PCG: {report:?}");
    // The reduced basis T: the filter's range for constrained particles, the axes for free ones.
    let mut basis: Vec<(usize, DVec3)> = Vec::new();
    let mut z = vec![DVec3::ZERO; n];
    for (i, zi) in z.iter_mut().enumerate() {
        match step.constraints.iter().find(|c| c.particle == i) {
            None => basis.extend([DVec3::X, DVec3::Y, DVec3::Z].map(|d| (i, d))),
            Some(c) => {
                *zi = c.z;
                basis.extend(range(c.filter).into_iter().map(|d| (i, d)));
            }
        }
    }
    // Columns of A by products with unit vectors (A is sparse: keep the non-zeros).
    let mut a_cols: Vec<Vec<(usize, DVec3)>> = Vec::with_capacity(3 * n);
    let mut e = vec![DVec3::ZERO; n];
    let mut col = vec![DVec3::ZERO; n];
    for j in 0..3 * n {
        e[j / 3][j % 3] = 1.0;
        system.apply(&e, &mut col);
        e[j / 3][j % 3] = 0.0;
        a_cols.push(col.iter().enumerate().filter(|(_, v)| **v != DVec3::ZERO).map(|(i, v)| (i, *v)).collect());
    }
    let apply_dir = |i: usize, d: DVec3| -> Vec<(usize, DVec3)> {
        // A (d at particle i) = Σ_k d_k A[:, 3i + k].
        let mut out: Vec<(usize, DVec3)> = Vec::new();
        for k in 0..3 {
            for &(r, v) in &a_cols[3 * i + k] {
                match out.iter_mut().find(|(q, _)| *q == r) {
                    Some(slot) => slot.1 += v * d[k],
                    None => out.push((r, v * d[k])),
                }
            }
        }
        out
    };
    let mut index_of: Vec<Vec<(DVec3, usize)>> = vec![Vec::new(); n];
    for (k, &(i, d)) in basis.iter().enumerate() {
        index_of[i].push((d, k));
    }
    let mut triplets = Vec::new();
    for (col_k, &(i, d)) in basis.iter().enumerate() {
        for (r, v) in apply_dir(i, d) {
            for &(dr, row_k) in &index_of[r] {
                let value = dr.dot(v);
                if value != 0.0 && row_k >= col_k {
                    triplets.push(Triplet::new(row_k, col_k, value));
                }
            }
        }
    }
    let m = basis.len();
    let reduced = SparseColMat::<usize, f64>::try_new_from_triplets(m, m, &triplets).unwrap();
    let llt = reduced.sp_cholesky(Side::Lower).expect("the filtered system is positive definite");
    let mut az = vec![DVec3::ZERO; n];
    system.apply(&z, &mut az);
    let rhs = faer::Col::<f64>::from_fn(m, |k| {
        let (i, d) = basis[k];
        d.dot(step.rhs[i] - az[i])
    });
    let y = llt.solve(&rhs);
    let mut direct = z.clone();
    for (k, &(i, d)) in basis.iter().enumerate() {
        direct[i] += d * y[k];
    }
    let scale = direct.iter().map(|v| v.length()).fold(0.0, f64::max);
    let err = dv.iter().zip(&direct).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    println!("max |Δv_pcg − Δv_direct| = {err:.2e} (max |Δv| = {scale:.3e})");
    assert!(err <= 1e-8 * scale, "PCG and direct solve differ by {err:e}");
    for c in &step.constraints {
        let constrained = (DMat3::IDENTITY - c.filter) * (dv[c.particle] - c.z);
        if c.filter == DMat3::ZERO {
            assert_eq!(dv[c.particle], c.z, "a locked particle's Δv is exactly z");
        } else {
            assert!(constrained.length() <= 1e-14 * c.z.length().max(1.0), "{constrained}");
        }
    }
}

/// Number of free directions of a filter (its trace: filters are orthogonal projections).
fn rank(filter: DMat3) -> usize {
    (filter.x_axis.x + filter.y_axis.y + filter.z_axis.z).round() as usize
}

/// An orthonormal basis of a projection's range.
fn range(filter: DMat3) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::new();
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        let mut v = filter * axis;
        for b in &out {
            v -= *b * b.dot(v);
        }
        if v.length() > 1e-6 {
            out.push(v.normalize());
        }
        if out.len() == rank(filter) {
            break;
        }
    }
    out
}

/// The signed distance of the nearest particle to the ball of the drape scene.
fn ball_clearance(setup: &Setup, x: &[DVec3]) -> f64 {
    let ball = setup.bodies.iter().find(|b| matches!(b.shape, Shape::Sphere { .. })).expect("a ball");
    x.iter().map(|p| ball.contact(*p, 0.0).distance).fold(f64::INFINITY, f64::min)
}

#[test]
fn the_drape_never_enters_the_ball_beyond_the_margin_and_comes_to_rest() {
    let setup = load("drape", &[]);
    let margin = setup.scene.solver.margin.unwrap();
    let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
    let mut worst = f64::INFINITY;
    let mut ke = Vec::new();
    for _ in 0..600 {
        cloth.step().unwrap();
        worst = worst.min(ball_clearance(&setup, cloth.positions()));
        ke.push(cloth.kinetic_energy());
    }
    let peak = ke.iter().copied().fold(0.0, f64::max);
    let last = *ke.last().unwrap();
    println!(
        "deepest point inside the ball: {:.2e} m (margin {margin}); KE peak {peak:.3e} J, final {last:.3e} J",
        -worst
    );
    assert!(worst >= -margin, "a particle went {:.4} m into the ball", -worst);
    assert!(worst < 0.5 * margin, "the cloth rests on the ball (nearest particle {worst:.4} m away)");
    assert!(last < 1e-5 * peak, "the cloth is still moving: KE {last:e} J after a peak of {peak:e} J");
}

/// The drape's cloth dropped off-centre onto the ball alone (no floor). With friction (μ = 0.8) it
/// settles and stays: between 5 s and 10 s its centre moves less than 5 mm. Without friction the same
/// cloth creeps toward its longer side like a rope over a pulley, faster and faster, until it has slid
/// off completely (no particle within 2 cm of the ball).
#[test]
fn friction_holds_the_cloth_on_a_still_ball_and_without_it_the_cloth_slides_off() {
    let ball = DVec3::new(0.0, 0.25, 0.0);
    let touching = |x: &[DVec3]| x.iter().filter(|p| (**p - ball).length() < 0.27).count();
    let mean_x = |x: &[DVec3]| x.iter().map(|p| p.x).sum::<f64>() / x.len() as f64;
    let cloth = |mu: f64| {
        let setup = load(
            "drape",
            &[
                "colliders=[{sphere={center=[0.0,0.25,0.0],radius=0.25}}]",
                "placement.translate=[0.3,0.6,0.0]",
                &format!("material.mu_s={mu}"),
                &format!("material.mu_k={mu}"),
            ],
        );
        Cloth::new(&setup, Variant::Triangles).unwrap()
    };
    let mut rough = cloth(0.8);
    let mut smooth = cloth(0.0);
    let mut centres = Vec::new();
    for k in 1..=1000 {
        rough.step().unwrap();
        smooth.step().unwrap();
        if k == 500 || k == 1000 {
            centres.push((mean_x(rough.positions()), mean_x(smooth.positions())));
        }
    }
    let (rough_drift, smooth_drift) = (centres[1].0 - centres[0].0, centres[1].1 - centres[0].1);
    let on_ball = touching(rough.positions());
    println!(
        "5 s → 10 s: with friction the centre moves {rough_drift:.4} m ({on_ball} particles on the ball), without {smooth_drift:.4} m"
    );
    assert!(rough_drift.abs() < 0.005 && on_ball > 400, "with friction the cloth stays put");
    assert!(smooth_drift.abs() > 0.01, "without friction it is sliding");
    let mut steps = 1000;
    while touching(smooth.positions()) > 0 && steps < 4000 {
        smooth.step().unwrap();
        steps += 1;
    }
    println!("without friction the cloth has left the ball after {:.1} s", steps as f64 * smooth.time_step());
    assert_eq!(touching(smooth.positions()), 0, "without friction the cloth slides off");
}

/// Backward Euler with the kept Jacobians is stable at h = 1/30 s over the paper's stiffness range
/// (k_s = 50 … 350) and at ten times it: the drape never produces a non-finite value, its energy never
/// rises above its value after the first step (by more than a thousandth of what the fall releases;
/// without the step halving of `Cloth::advance` it rose 450 times that at k_s = 3500, at the impact
/// on the ball), and it ends nearly at rest on the ball.
#[test]
fn stable_at_a_thirtieth_of_a_second_from_k_s_50_to_3500() {
    for k_s in [50.0, 200.0, 350.0, 500.0, 2000.0, 3500.0] {
        let setup = load(
            "drape",
            &["solver.step=0.0333333333333", &format!("material.k_s={k_s}"), &format!("material.c_b={k_s}")],
        );
        let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
        let first = cloth.step().unwrap().energy;
        let mut highest = first;
        let mut last = first;
        for _ in 1..150 {
            let stats = cloth.step().unwrap_or_else(|e| panic!("k_s = {k_s}: {e}"));
            highest = highest.max(stats.energy);
            last = stats.energy;
        }
        let clearance = ball_clearance(&setup, cloth.positions());
        println!(
            "k_s = {k_s:>6}: energy peak {highest:+.3e} J, final {last:+.4} J, KE {:.1e} J, nearest particle {clearance:+.4} m",
            cloth.kinetic_energy()
        );
        assert!(highest <= first + 1e-3 * last.abs(), "k_s = {k_s}: energy rose from {first} J to {highest} J");
        assert!(cloth.kinetic_energy() < 1e-3 * last.abs(), "k_s = {k_s}: still moving");
        assert!(clearance > -setup.scene.solver.margin.unwrap(), "k_s = {k_s}: inside the ball");
    }
}

/// A moving body: the ball of the `sweep` scene swings through a hanging curtain on a sinusoidal
/// path. No particle is ever inside it beyond the margin (checked against the ball's position at the
/// same time), and the curtain is pushed both ways.
#[test]
fn a_ball_on_a_scripted_path_pushes_the_curtain_without_passing_through() {
    let setup = load("sweep", &[]);
    let margin = setup.scene.solver.margin.unwrap();
    let ball = &setup.bodies[0];
    let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
    let (mut worst, mut pushed) = (f64::INFINITY, [0.0f64; 2]);
    for _ in 0..360 {
        let t = cloth.step().unwrap().sim_time;
        for p in cloth.positions() {
            worst = worst.min(ball.contact(*p, t).distance);
            pushed = [pushed[0].min(p.z), pushed[1].max(p.z)];
        }
    }
    println!(
        "6 s of sweeping: deepest particle {:.2e} m inside the ball (margin {margin}); curtain pushed to z ∈ [{:.3}, {:.3}] m",
        -worst, pushed[0], pushed[1]
    );
    assert!(worst > -margin, "a particle went {:.4} m into the moving ball", -worst);
    assert!(pushed[0] < -0.3 && pushed[1] > 0.3, "the ball pushes the curtain both ways");
}

/// A cloth dropped on a ball spinning about the vertical is carried round by friction; without
/// friction the ball turns under it and it hardly turns at all. Measured 0.6 s in, 0.4 s after
/// touching down (a frictionless cloth soon slides off the ball, as it should).
#[test]
fn friction_carries_a_cloth_round_a_spinning_ball() {
    let turn_rate = |mu: f64| {
        let setup = load("spin", &[&format!("material.mu_s={mu}"), &format!("material.mu_k={mu}")]);
        let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
        for _ in 0..60 {
            cloth.step().unwrap();
        }
        // Mean angular velocity about the vertical axis through the ball, of particles near the top.
        let (mut sum, mut count) = (0.0, 0);
        for (p, v) in cloth.positions().iter().zip(cloth.velocities()) {
            let r = DVec3::new(p.x, 0.0, p.z);
            if p.y > 0.4 && r.length() > 0.05 {
                sum += r.cross(*v).y / r.length_squared();
                count += 1;
            }
        }
        assert!(count > 50, "μ = {mu}: the cloth fell off the ball");
        let rate = sum / count as f64;
        println!("μ = {mu}: the cloth on top turns at {rate:.3} rad/s (ball: 2 rad/s)");
        rate
    };
    assert!(turn_rate(0.8) > 1.5);
    assert!(turn_rate(0.0).abs() < 0.3);
}

/// Choi & Ko's original on a 25 × 25 grid drapes the same ball: it stays outside it, comes to rest,
/// and takes the triangle version's shape: the mean height of the material in each 10 cm ring of rest
/// distance from the cloth's centre (from 0.49 m on the ball to 0.01 m on the floor) agrees within
/// 2 cm, while a cloth 100 times stiffer in bending misses by more.
#[test]
fn the_quad_grid_original_drapes_the_ball_like_the_triangle_version() {
    // Mean final height of the material within each ring of rest distance from the cloth's centre.
    let profile = |name: &str, sets: &[&str], variant: Variant| {
        let setup = load(name, sets);
        let mut cloth = Cloth::new(&setup, variant).unwrap();
        let mut worst = f64::INFINITY;
        for _ in 0..400 {
            cloth.step().unwrap();
            worst = worst.min(ball_clearance(&setup, cloth.positions()));
        }
        let rest = setup.mesh.positions();
        let centre = rest.iter().copied().sum::<DVec3>() / rest.len() as f64;
        let mut rings = [(0.0, 0usize); RINGS];
        for (r, x) in rest.iter().zip(cloth.positions()) {
            let d = (*r - centre).length();
            let ring = ((d / RING) as usize).min(RINGS - 1);
            rings[ring].0 += x.y;
            rings[ring].1 += 1;
        }
        let heights = rings.map(|(sum, count)| sum / count as f64);
        println!(
            "{name}: {} particles, deepest in ball {:.1e} m, KE {:.1e} J, ring heights {heights:.3?} m",
            rest.len(),
            -worst,
            cloth.kinetic_energy()
        );
        assert!(worst > -setup.scene.solver.margin.unwrap());
        assert!(cloth.kinetic_energy() < 1e-5);
        heights
    };
    const RING: f64 = 0.1;
    const RINGS: usize = 7;
    const TOLERANCE: f64 = 0.02;
    let tri = profile("drape", &[], Variant::Triangles);
    let quad = profile("drape-quad", &[], Variant::Quads);
    for (k, (t, q)) in tri.iter().zip(&quad).enumerate() {
        println!("ring {k}: triangles {t:.4} m, quads {q:.4} m, difference {:.4} m", (t - q).abs());
    }
    let difference =
        |a: &[f64; RINGS], b: &[f64; RINGS]| a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(difference(&tri, &quad) < TOLERANCE, "the two models drape differently: {tri:?} vs {quad:?}");
    // The comparison can tell cloths apart: 100× the bending rigidity stiffens the skirt beyond it.
    let stiff = profile("drape-quad", &["material.k_b=1e-4"], Variant::Quads);
    println!("quads with 100 × k_b: worst ring difference {:.4} m", difference(&tri, &stiff));
    assert!(difference(&tri, &stiff) > TOLERANCE);
}

/// The ball as a closed triangle mesh (an icosphere written to OBJ) instead of an analytic sphere:
/// the drape stays outside the mesh and rests like the analytic one (centre of mass within 1 cm).
#[test]
fn a_triangle_mesh_collider_drapes_like_the_analytic_sphere() {
    let dir = std::env::temp_dir().join(format!("shellwarp-mesh-collider-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ball = shellwarp::mesh::generate::icosphere(0.25, 16).unwrap();
    let obj = dir.join("ball.obj");
    shellwarp::mesh::obj::save_obj(&obj, ball.positions(), ball.triangles()).unwrap();
    let mesh_collider = format!(
        "colliders=[{{mesh={{path=\"{}\",translate=[0.0,0.25,0.0]}}}},{{plane={{point=[0,0,0],normal=[0,1,0]}}}}]",
        obj.display()
    );
    let centre = |sets: &[&str]| {
        let setup = load("drape", sets);
        let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
        let mut worst = f64::INFINITY;
        for _ in 0..300 {
            let t = cloth.step().unwrap().sim_time;
            for p in cloth.positions() {
                worst = worst.min(setup.bodies[0].contact(*p, t).distance);
            }
        }
        let x = cloth.positions();
        let c = x.iter().copied().sum::<DVec3>() / x.len() as f64;
        println!("{}: centre {c:.4}, deepest {:.1e} m", if sets.is_empty() { "sphere" } else { "mesh" }, -worst);
        assert!(worst > -setup.scene.solver.margin.unwrap());
        c
    };
    let analytic = centre(&[]);
    let meshed = centre(&[&mesh_collider]);
    std::fs::remove_dir_all(&dir).ok();
    assert!((analytic - meshed).length() < 0.01, "{analytic} vs {meshed}");
}

/// A position drag on a cloth particle brings it to the target at the end of the next step and holds
/// it there while the sheet hangs from it; removing the drag lets it go.
#[test]
fn a_drag_moves_a_cloth_particle_to_its_target_and_lets_go_when_removed() {
    use shellwarp::solver::{Drag, DragKind};
    let setup = load("hanging-sheet", &[]);
    let mut cloth = Cloth::new(&setup, Variant::Triangles).unwrap();
    let vertex = 12 * 25 + 24; // the middle of the bottom edge
    let target = setup.mesh.positions()[vertex] + DVec3::new(0.0, 0.2, 0.3);
    let id = cloth.drags_mut().add(Drag { vertex, kind: DragKind::Position(target) }).unwrap();
    for _ in 0..60 {
        cloth.step().unwrap();
        assert!((cloth.positions()[vertex] - target).length() < 1e-9, "the dragged particle is at its target");
    }
    let neighbour = 12 * 25 + 23;
    assert!(cloth.positions()[neighbour].z > 0.2, "the cloth follows the drag");
    cloth.drags_mut().remove(id).unwrap();
    for _ in 0..30 {
        cloth.step().unwrap();
    }
    assert!(cloth.positions()[vertex].y < target.y - 0.1, "released, it falls back");
    assert!(
        cloth.drags_mut().add(Drag { vertex, kind: DragKind::Orientation(DVec3::X) }).is_err(),
        "no orientation drags on cloth"
    );
}

/// `cloth-quad` needs a regular grid; on another mesh it says so.
#[test]
fn the_quad_original_refuses_a_mesh_that_is_not_a_grid() {
    let setup = load("drape", &["solver.method=cloth-quad"]);
    match shellwarp::solver::build(&setup) {
        Err(e) => assert!(e.to_string().contains("needs a regular `grid` mesh"), "{e}"),
        Ok(_) => panic!("cloth-quad ran on a Delaunay mesh"),
    }
}
