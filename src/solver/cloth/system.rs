//! The cloth's forces and their linearisation for one backward Euler step (Baraff & Witkin 1998).
//!
//! Particle `i` feels `fᵢ = wᵢ Σⱼ (f_ij^s + f_ij^b + f_ij^d) + mᵢ g` (Noh & Jung's eq. 3). The valence
//! weight `wᵢ` scales every spring force on `i` but not its partner's, so `∂f/∂x` is not symmetric.
//! Dividing row `i` of the step equation by `wᵢ` restores symmetry exactly: the system is
//! `(M̃ − h ∂f̃/∂v − h² ∂f̃/∂x) Δv = h (f̃₀ + h ∂f̃/∂x v₀)` with `M̃ = diag(mᵢ/wᵢ)` and the *unweighted*
//! spring forces `f̃ = Σⱼ f_ij + m̃ g`, which is symmetric positive definite with Choi & Ko's kept
//! Jacobians (stretch: exact; buckling: longitudinal only; damping `k_d I`). The same dynamics are
//! the motion of particles of mass `m̃ᵢ` in the unweighted springs, so `½ vᵀM̃v + E_springs − m̃ g·u` is
//! the energy these steps dissipate (it is what [`ClothSystem::energy`] reports).
//!
//! Each spring contributes `G = h k_d I + h² (a x̂x̂ᵀ + b I)` to the system matrix (`+G` on both
//! diagonal blocks, `−G` off the diagonal), stored as `(x̂, h² a, h k_d + h² b)` ([`RankOne`]): a
//! product with the matrix is one pass over the springs, about 15 flops each.

use glam::{DMat3, DVec3};

use super::graph::{SpringGraph, SpringKind};
use crate::energy::springs::{self, Buckling};
use crate::linalg::filtered_pcg::Operator;
use crate::linalg::isa;

/// Spring stiffnesses and damping, per spring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringParams {
    /// Stretch stiffness k_s, N/m.
    pub k_s: f64,
    /// Bending rigidity per unit width k_b, N·m (a spring's flexural rigidity is `k_b ×` its bending width).
    pub k_b: f64,
    /// Buckling linear branch c_b, N/m.
    pub c_b: f64,
    /// Damping k_d, N·s/m.
    pub k_d: f64,
}

/// A spring's symmetric 3 × 3 block `a x̂x̂ᵀ + c I`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct RankOne {
    dir: DVec3,
    a: f64,
    c: f64,
}

impl RankOne {
    #[inline(always)]
    fn times(&self, d: DVec3) -> DVec3 {
        d * self.c + self.dir * (self.a * self.dir.dot(d))
    }

    /// Upper triangle (xx, xy, xz, yy, yz, zz).
    fn upper(&self) -> [f64; 6] {
        let (x, a, c) = (self.dir, self.a, self.c);
        [a * x.x * x.x + c, a * x.x * x.y, a * x.x * x.z, a * x.y * x.y + c, a * x.y * x.z, a * x.z * x.z + c]
    }
}

/// The cloth's springs, masses and the current step's linear system.
#[derive(Debug, Clone)]
pub struct ClothSystem {
    graph: SpringGraph,
    params: SpringParams,
    /// One entry per spring; only buckling springs' entries are used.
    buckling: Vec<Buckling>,
    /// `m̃ᵢ = mᵢ / wᵢ`.
    scaled_mass: Vec<f64>,
    /// Per spring, the kept stiffness `K = a x̂x̂ᵀ + b I` and the step's block `G = h k_d I + h² K`.
    stiffness: Vec<RankOne>,
    step_matrix: Vec<RankOne>,
    /// Spring lengths at the last linearisation.
    length: Vec<f64>,
    h: f64,
}

impl ClothSystem {
    /// Springs of `graph` with `params`.
    pub fn new(graph: SpringGraph, params: SpringParams) -> Self {
        let scaled_mass = graph.masses.iter().zip(&graph.weights).map(|(m, w)| m / w).collect();
        let mut system = Self {
            stiffness: vec![RankOne::default(); graph.pairs.len()],
            step_matrix: vec![RankOne::default(); graph.pairs.len()],
            length: vec![0.0; graph.pairs.len()],
            graph,
            params,
            buckling: Vec::new(),
            scaled_mass,
            h: 0.0,
        };
        system.set_params(params);
        system
    }

    /// Change the spring parameters (recomputes the buckling branches).
    pub fn set_params(&mut self, params: SpringParams) {
        self.params = params;
        let (rest, width) = (&self.graph.rest, &self.graph.width);
        self.buckling = rest.iter().zip(width).map(|(&l, &w)| Buckling::new(l, params.k_b * w, params.c_b)).collect();
    }

    /// The spring parameters.
    pub fn params(&self) -> SpringParams {
        self.params
    }

    /// Scale every mass by `factor` (a density change).
    pub fn scale_masses(&mut self, factor: f64) {
        self.graph.masses.iter_mut().for_each(|m| *m *= factor);
        self.scaled_mass.iter_mut().for_each(|m| *m *= factor);
    }

    /// The spring graph.
    pub fn graph(&self) -> &SpringGraph {
        &self.graph
    }

    /// `m̃ᵢ = mᵢ/wᵢ` at the current density.
    pub fn scaled_masses(&self) -> &[f64] {
        &self.scaled_mass
    }

    /// Evaluate forces at `(x, v)` with gravity `g` into `force` (scaled by `1/w`) and linearise them
    /// for a step of `h`.
    pub fn linearise(&mut self, x: &[DVec3], v: &[DVec3], g: DVec3, h: f64, force: &mut [DVec3]) {
        struct Linearise<'a> {
            system: &'a mut ClothSystem,
            state: (&'a [DVec3], &'a [DVec3]),
            g: DVec3,
            h: f64,
            force: &'a mut [DVec3],
        }
        impl isa::Kernel for Linearise<'_> {
            type Output = ();
            #[inline(always)]
            fn run(self) {
                self.system.linearise_here(self.state.0, self.state.1, self.g, self.h, self.force);
            }
        }
        isa::best(Linearise { system: self, state: (x, v), g, h, force });
    }

    /// [`Self::linearise`], compiled for whatever instruction set its caller is.
    #[inline(always)]
    fn linearise_here(&mut self, x: &[DVec3], v: &[DVec3], g: DVec3, h: f64, force: &mut [DVec3]) {
        self.h = h;
        for (f, m) in force.iter_mut().zip(&self.scaled_mass) {
            *f = g * *m;
        }
        let (k_s, k_d) = (self.params.k_s, self.params.k_d);
        for s in 0..self.graph.pairs.len() {
            let [i, j] = self.graph.pairs[s];
            let d = x[j] - x[i];
            let r = d.length();
            self.length[s] = r;
            let (tension, stiffness) = match self.graph.kinds[s] {
                SpringKind::Stretch => springs::stretch(r, self.graph.rest[s], k_s).tension_stiffness(),
                SpringKind::Buckling => self.buckling[s].tension_stiffness(r),
            };
            let dir = if r > 0.0 { d / r } else { DVec3::ZERO };
            let f = dir * tension + (v[j] - v[i]) * k_d;
            force[i] += f;
            force[j] -= f;
            let (a, b) = match self.graph.kinds[s] {
                // Stretched: the exact Jacobian k_s x̂x̂ᵀ + (T/r)(I − x̂x̂ᵀ). Slack (T = 0): still k_s x̂x̂ᵀ
                // along the spring — see the module doc.
                SpringKind::Stretch if r > 0.0 => (k_s - tension / r, tension / r),
                // Longitudinal term only (Choi & Ko), S ≥ 0.
                _ => (stiffness, 0.0),
            };
            // K = a x̂x̂ᵀ + b I, and G = h k_d I + h² K.
            let h2 = h * h;
            self.stiffness[s] = RankOne { dir, a, c: b };
            self.step_matrix[s] = RankOne { dir, a: h2 * a, c: h2 * b + h * k_d };
        }
    }

    /// The largest growth of a stretch spring's strain `(|x'| − |x|)/L` from the last linearisation to `x`.
    pub fn strain_jump(&self, x: &[DVec3]) -> f64 {
        let g = &self.graph;
        (0..g.pairs.len())
            .filter(|&s| g.kinds[s] == SpringKind::Stretch)
            .map(|s| ((x[g.pairs[s][1]] - x[g.pairs[s][0]]).length() - self.length[s]) / g.rest[s])
            .fold(0.0, f64::max)
    }

    /// `out += Σ_springs` of the blocks `blocks` applied to `v` as a Laplacian: `+B (vᵢ − vⱼ)` on `i`,
    /// `−B (vᵢ − vⱼ)` on `j`.
    #[inline(always)]
    fn add_spring_product(&self, blocks: &[RankOne], v: &[DVec3], out: &mut [DVec3]) {
        for (&[i, j], g) in self.graph.pairs.iter().zip(blocks) {
            let y = g.times(v[i] - v[j]);
            out[i] += y;
            out[j] -= y;
        }
    }

    /// `out = A v` with the step's matrix `A = M̃ + h D + h² K`.
    #[inline(always)]
    pub fn apply(&self, v: &[DVec3], out: &mut [DVec3]) {
        for ((o, v), m) in out.iter_mut().zip(v).zip(&self.scaled_mass) {
            *o = *v * *m;
        }
        self.add_spring_product(&self.step_matrix, v, out);
    }

    /// The step's right side `b = h f̃₀ − h² K v₀`.
    pub fn rhs(&self, force: &[DVec3], v: &[DVec3]) -> Vec<DVec3> {
        let mut kv = vec![DVec3::ZERO; v.len()];
        self.add_spring_product(&self.stiffness, v, &mut kv);
        force.iter().zip(&kv).map(|(f, kv)| *f * self.h - *kv * (self.h * self.h)).collect()
    }

    /// Inverses of the 3 × 3 diagonal blocks of `A` (the block-Jacobi preconditioner).
    pub fn block_jacobi(&self) -> Vec<DMat3> {
        let mut diag: Vec<[f64; 6]> = self.scaled_mass.iter().map(|&m| [m, 0.0, 0.0, m, 0.0, m]).collect();
        for (&[i, j], g) in self.graph.pairs.iter().zip(&self.step_matrix) {
            let g = g.upper();
            for k in 0..6 {
                diag[i][k] += g[k];
                diag[j][k] += g[k];
            }
        }
        diag.iter()
            .map(|d| DMat3::from_cols_array(&[d[0], d[1], d[2], d[1], d[3], d[4], d[2], d[4], d[5]]).inverse())
            .collect()
    }

    /// Springs' energy at `x` plus `½ Σ m̃ |v|²` minus the work of gravity `Σ m̃ g·(x − rest)`, J.
    pub fn energy(&self, x: &[DVec3], v: &[DVec3], rest: &[DVec3], g: DVec3) -> f64 {
        struct Energy<'a> {
            system: &'a ClothSystem,
            state: [&'a [DVec3]; 3],
            g: DVec3,
        }
        impl isa::Kernel for Energy<'_> {
            type Output = f64;
            #[inline(always)]
            fn run(self) -> f64 {
                let [x, v, rest] = self.state;
                self.system.energy_here(x, v, rest, self.g)
            }
        }
        isa::best(Energy { system: self, state: [x, v, rest], g })
    }

    /// [`Self::energy`], compiled for whatever instruction set its caller is.
    #[inline(always)]
    fn energy_here(&self, x: &[DVec3], v: &[DVec3], rest: &[DVec3], g: DVec3) -> f64 {
        let graph = &self.graph;
        // A plain loop: an iterator's `sum` is a separate function, not inlined into the kernel.
        let mut e = 0.0;
        for (s, &[i, j]) in graph.pairs.iter().enumerate() {
            let r = (x[j] - x[i]).length();
            e += match graph.kinds[s] {
                SpringKind::Stretch => springs::stretch(r, graph.rest[s], self.params.k_s).energy,
                SpringKind::Buckling => self.buckling[s].energy(r),
            };
        }
        for (((x, v), r), m) in x.iter().zip(v).zip(rest).zip(&self.scaled_mass) {
            e += 0.5 * m * v.length_squared() - m * g.dot(*x - *r);
        }
        e
    }
}

impl Operator for ClothSystem {
    #[inline(always)]
    fn apply(&self, x: &[DVec3], y: &mut [DVec3]) {
        ClothSystem::apply(self, x, y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    fn system() -> (ClothSystem, Vec<DVec3>, Vec<DVec3>) {
        let mesh = generate::delaunay_sheet([0.3, 0.2], 0.06).unwrap();
        let graph = SpringGraph::triangle_mesh(&mesh, 0.2);
        let params = SpringParams { k_s: 150.0, k_b: 2e-5, c_b: 150.0, k_d: 0.01 };
        // A crumpled state: some springs stretched, some buckled.
        let x: Vec<DVec3> = mesh
            .positions()
            .iter()
            .map(|p| DVec3::new(p.x * 0.93 + 0.01 * (17.0 * p.z).sin(), 0.05 * (9.0 * p.x).sin(), p.z * 1.04))
            .collect();
        let v: Vec<DVec3> = x.iter().map(|p| DVec3::new(p.z, -p.x, 0.5 * p.x * p.z)).collect();
        (ClothSystem::new(graph, params), x, v)
    }

    /// With every stretch spring taut (where the matrix keeps their exact Jacobian) and buckling off,
    /// the step matrix is the exact derivative of the forces, `f(x + dx, v + dv) ≈ f + ∂f/∂x dx +
    /// ∂f/∂v dv`; and it is symmetric.
    #[test]
    fn matrix_is_symmetric_and_matches_the_derivative_of_the_stretch_and_damping_forces() {
        let (mut sys, _, v) = system();
        sys.set_params(SpringParams { k_b: 0.0, ..sys.params() });
        // Stretched by 8% and rippled out of plane: every edge longer than at rest.
        let rest = generate::delaunay_sheet([0.3, 0.2], 0.06).unwrap();
        let x: Vec<DVec3> =
            rest.positions().iter().map(|p| DVec3::new(p.x * 1.08, 0.02 * (11.0 * p.x).sin(), p.z * 1.08)).collect();
        let g = sys.graph();
        for (s, &[i, j]) in g.pairs.iter().enumerate() {
            if g.kinds[s] == SpringKind::Stretch {
                assert!((x[j] - x[i]).length() > g.rest[s], "spring {s} is taut");
            }
        }
        let n = x.len();
        let mut f0 = vec![DVec3::ZERO; n];
        sys.linearise(&x, &v, DVec3::ZERO, 1.0, &mut f0);
        // With h = 1: A = M̃ + D + K, so (A − M̃) dx = −∂f/∂x dx − ∂f/∂v dx for the same dx.
        let dx: Vec<DVec3> = (0..n).map(|i| DVec3::new((i as f64).sin(), (i as f64 * 0.7).cos(), 0.3)).collect();
        let mut a_dx = vec![DVec3::ZERO; n];
        sys.apply(&dx, &mut a_dx);
        let e = 1e-7;
        let plus: Vec<DVec3> = x.iter().zip(&dx).map(|(x, d)| *x + *d * e).collect();
        let minus: Vec<DVec3> = x.iter().zip(&dx).map(|(x, d)| *x - *d * e).collect();
        let vp: Vec<DVec3> = v.iter().zip(&dx).map(|(v, d)| *v + *d * e).collect();
        let vm: Vec<DVec3> = v.iter().zip(&dx).map(|(v, d)| *v - *d * e).collect();
        let (mut fp, mut fm) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
        let mut probe = sys.clone();
        probe.linearise(&plus, &vp, DVec3::ZERO, 1.0, &mut fp);
        probe.linearise(&minus, &vm, DVec3::ZERO, 1.0, &mut fm);
        let scale = a_dx.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * e);
            let want = a_dx[i] - dx[i] * sys.scaled_masses()[i];
            assert!((fd + want).abs().max_element() < 1e-6 * scale, "particle {i}: {fd} vs {}", -want);
        }
        // Symmetry: uᵀ A w = wᵀ A u.
        let u: Vec<DVec3> = (0..n).map(|i| DVec3::new(0.2, (i as f64).cos(), -(i as f64 * 0.3).sin())).collect();
        let mut a_u = vec![DVec3::ZERO; n];
        sys.apply(&u, &mut a_u);
        let (uaw, wau): (f64, f64) =
            (u.iter().zip(&a_dx).map(|(a, b)| a.dot(*b)).sum(), dx.iter().zip(&a_u).map(|(a, b)| a.dot(*b)).sum());
        assert!((uaw - wau).abs() < 1e-12 * uaw.abs().max(1.0));
    }

    /// Forces are minus the gradient of the springs' energy (both spring kinds active).
    #[test]
    fn forces_are_minus_the_energy_gradient() {
        let (mut sys, x, _) = system();
        let n = x.len();
        let still = vec![DVec3::ZERO; n];
        let mut f = vec![DVec3::ZERO; n];
        sys.linearise(&x, &still, DVec3::ZERO, 1.0, &mut f);
        let probe = sys.clone();
        let scale = f.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
        for i in (0..n).step_by(3) {
            for a in 0..3 {
                let e = 1e-7;
                let mut p = x.clone();
                p[i][a] += e;
                let ep = probe.energy(&p, &still, &x, DVec3::ZERO);
                p[i][a] -= 2.0 * e;
                let em = probe.energy(&p, &still, &x, DVec3::ZERO);
                let fd = -(ep - em) / (2.0 * e);
                assert!((fd - f[i][a]).abs() < 1e-6 * scale, "particle {i}[{a}]: {} vs fd {fd}", f[i][a]);
            }
        }
    }
}
