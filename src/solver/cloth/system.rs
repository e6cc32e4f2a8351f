//! The cloth's forces and their linearisation for one backward Euler step (Baraff & Witkin 1998).
//!
//! Particle `i` feels `fᵢ = wᵢ Σⱼ (f_ij^s + f_ij^b + f_ij^d) + mᵢ g` (Noh & Jung's eq. 3). The valence
//! weight `wᵢ` scales every spring force on `i` but not its partner's, so `∂f/∂x` is not symmetric.
//! Dividing row `i` of the step equation by `wᵢ` restores symmetry exactly: the system is
//! `(M̃ − h ∂f̃/∂v − h² ∂f̃/∂x) Δv = h (f̃₀ + h ∂f̃/∂x v₀)` with `M̃ = diag(mᵢ/wᵢ)` and the *unweighted*
//! spring forces `f̃ = Σⱼ f_ij + m̃ g`, which is symmetric positive definite with Choi & Ko's kept
//! Jacobians (stretch: exact; buckling: longitudinal only; damping `k_d I`). The same dynamics are
//! the motion of particles of mass `m̃ᵢ` in the unweighted springs, so `½ vᵀM̃v + E_springs − m̃ g·u` is
//! the energy these steps dissipate ([`ClothSystem::linearise`] reports the springs' part,
//! [`ClothSystem::particle_energy`] the rest).
//!
//! Each spring contributes `G = h k_d I + h² (a x̂x̂ᵀ + b I)` to the system matrix (`+G` on both
//! diagonal blocks, `−G` off the diagonal), stored as `(x̂, h² a, h k_d + h² b)` (`RankOne`): a
//! product with the matrix is one pass over the springs, about 15 flops each. The pass that
//! linearises the springs also accumulates the right side and the diagonal blocks, and yields the
//! springs' energy and their strain growth since the linearisation before: a step ends by
//! linearising the next one at the state it reached, which is how it measures that state.
//!
//! **Two sides.** The particles are halved by index, `..h` and `h..` with `h = n/2` (a generated
//! sheet is numbered across it, so each half is a patch), and the springs are taken in three groups
//! (`Split`): those within the first side, those within the second, and the few across. Each side's
//! rows of the product and of the linearisation are its own springs' terms and then the crossing
//! springs' terms on its particles, so two threads can each own one side's rows (the product's through
//! [`filtered_pcg`]'s pair of workers, the linearisation's through a join) and each row takes its
//! terms in one order on any number of threads: the results are the same to the bit. The crossing
//! springs are linearised once, before the sides, and each side's product evaluates them for its own
//! ends.
//!
//! [`filtered_pcg`]: crate::linalg::filtered_pcg

use std::ops::Range;

use glam::{DMat3, DVec3};

use super::graph::SpringGraph;
use crate::energy::springs::{self, Buckling};
use crate::linalg::filtered_pcg::Operator;
use crate::linalg::isa;
use crate::linalg::padded::{Padded, PaddedMat3};
use crate::threads;

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
    dir: Padded,
    a: f64,
    c: f64,
}

impl RankOne {
    #[inline(always)]
    fn times(&self, d: Padded) -> Padded {
        d * self.c + self.dir * (self.a * self.dir.dot(d))
    }

    #[inline(always)]
    fn matrix(&self) -> PaddedMat3 {
        let (x, a, c) = (self.dir, self.a, self.c);
        let [e0, e1, e2] = [DVec3::X, DVec3::Y, DVec3::Z].map(Padded::from);
        PaddedMat3::from_cols(x * (a * x.lane(0)) + e0 * c, x * (a * x.lane(1)) + e1 * c, x * (a * x.lane(2)) + e2 * c)
    }
}

/// Springs each side must have for the sides to be worked on by two threads.
const PARALLEL_SPRINGS: usize = 1000;

/// The springs in the order every pass takes them: those within the first side (particles `..h`),
/// those within the second (`h..`), then those across.
#[derive(Debug, Clone)]
struct Split {
    /// The first particle of the second side.
    half: usize,
    /// The graph's index of each spring, in pass order.
    springs: Vec<usize>,
    /// Their particles.
    pairs: Vec<[usize; 2]>,
    /// Their particles numbered within their side (the crossing springs': as in `pairs`).
    local: Vec<[usize; 2]>,
    /// Where the second side's springs and the crossing ones begin.
    bounds: [usize; 2],
}

impl Split {
    /// The split of `graph`'s springs among `n` particles (each group in the graph's order).
    fn new(graph: &SpringGraph, n: usize) -> Self {
        let half = n / 2;
        let group = |[i, j]: [usize; 2]| if (i < half) == (j < half) { usize::from(i >= half) } else { 2 };
        let mut springs: Vec<usize> = (0..graph.pairs.len()).collect();
        springs.sort_by_key(|&s| group(graph.pairs[s]));
        let pairs: Vec<[usize; 2]> = springs.iter().map(|&s| graph.pairs[s]).collect();
        let first_of = |g| pairs.iter().position(|p| group(*p) >= g).unwrap_or(pairs.len());
        let local =
            pairs.iter().map(|&[i, j]| if group([i, j]) == 1 { [i - half, j - half] } else { [i, j] }).collect();
        Self { half, bounds: [first_of(1), first_of(2)], springs, pairs, local }
    }

    /// The three groups' places in pass order: the two sides' springs and the crossing ones.
    fn groups(&self) -> [Range<usize>; 3] {
        let [a, b] = self.bounds;
        [0..a, a..b, b..self.pairs.len()]
    }

    /// Whether each side has enough springs to be worked on by a thread of its own.
    fn two_sided(&self) -> bool {
        let [a, b] = self.bounds;
        a.min(b - a) >= PARALLEL_SPRINGS
    }
}

/// `x` (an entry per spring, in pass order) cut into the split's three groups.
fn in_three<'a, T>(x: &'a mut [T], split: &Split) -> [&'a mut [T]; 3] {
    let [a, b] = split.bounds;
    let (first, rest) = x.split_at_mut(a);
    let (second, across) = rest.split_at_mut(b - a);
    [first, second, across]
}

/// Springs whose lengths [`lengths`] takes at once.
const LANES: usize = 4;

/// The lengths `r = |xⱼ − xᵢ|` of up to [`LANES`] springs and their inverses (0 at `r = 0`), the
/// square roots taken together (one vector instruction where the CPU has one).
#[inline(always)]
fn lengths(pairs: &[[usize; 2]], x: &[DVec3]) -> [(f64, f64); LANES] {
    let mut squared = [0.0; LANES];
    for (q, &[i, j]) in squared.iter_mut().zip(pairs) {
        *q = (x[j] - x[i]).length_squared();
    }
    let r = squared.map(f64::sqrt);
    let inverse = r.map(|r| if r > 0.0 { 1.0 / r } else { 0.0 });
    [0, 1, 2, 3].map(|k| (r[k], inverse[k]))
}

/// The springs at the state a linearisation was made at ([`ClothSystem::linearise`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringState {
    /// The springs' energy, J.
    pub energy: f64,
    /// The largest growth of a stretch spring's strain `(|x'| − |x|)/L` since the last linearisation.
    pub strain_jump: f64,
}

/// The cloth's springs, masses and the current step's matrix.
#[derive(Debug, Clone)]
pub struct ClothSystem {
    graph: SpringGraph,
    params: SpringParams,
    /// The buckling springs' responses (spring `graph.stretch + k` is entry `k`).
    buckling: Vec<Buckling>,
    /// `m̃ᵢ = mᵢ / wᵢ`.
    scaled_mass: Vec<f64>,
    /// The order of the springs' passes.
    split: Split,
    /// The step's block `G = h k_d I + h² K` with the kept stiffness `K = a x̂x̂ᵀ + b I`, per spring
    /// in pass order.
    step_matrix: Vec<RankOne>,
    /// Spring lengths at the last linearisation, in pass order.
    length: Vec<f64>,
    /// The crossing springs' terms of the right side at the last linearisation (on their first particle).
    across_force: Vec<DVec3>,
}

impl ClothSystem {
    /// Springs of `graph` with `params`.
    pub fn new(graph: SpringGraph, params: SpringParams) -> Self {
        let scaled_mass = graph.masses.iter().zip(&graph.weights).map(|(m, w)| m / w).collect();
        let split = Split::new(&graph, graph.masses.len());
        let mut system = Self {
            step_matrix: vec![RankOne::default(); graph.pairs.len()],
            length: vec![0.0; graph.pairs.len()],
            across_force: vec![DVec3::ZERO; split.groups()[2].len()],
            split,
            graph,
            params,
            buckling: Vec::new(),
            scaled_mass,
        };
        system.set_params(params);
        system
    }

    /// Change the spring parameters (recomputes the buckling branches).
    pub fn set_params(&mut self, params: SpringParams) {
        self.params = params;
        let g = &self.graph;
        self.buckling =
            (g.stretch..g.pairs.len()).map(|s| Buckling::new(g.rest[s], params.k_b * g.width[s], params.c_b)).collect();
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

    /// Whether a step's work runs on two threads: there are several, and each side of the cloth
    /// has enough springs.
    pub fn parallel(&self) -> bool {
        self.split.two_sided() && threads::threads() > 1
    }

    /// `m̃ᵢ = mᵢ/wᵢ` at the current density.
    pub fn scaled_masses(&self) -> &[f64] {
        &self.scaled_mass
    }

    /// Linearise the forces at `(x, v)` with gravity `g` (scaled by `1/w`) for a step of `h`: the
    /// step's matrix `A` (kept for its [`Operator`] product), its right side `rhs = h f̃₀ − h² K v₀` and
    /// `preconditioner`, the inverses of `A`'s 3 × 3 diagonal blocks (block Jacobi). Returns the
    /// springs' energy at `x` and their strain growth since the linearisation before.
    pub fn linearise(
        &mut self,
        (x, v): (&[DVec3], &[DVec3]),
        g: DVec3,
        h: f64,
        rhs: &mut [DVec3],
        preconditioner: &mut [PaddedMat3],
    ) -> SpringState {
        let parallel = self.parallel();
        let springs = Springs { graph: &self.graph, params: self.params, buckling: &self.buckling, split: &self.split };
        let [first, second, across] = self.split.groups();
        let [step_first, step_second, step_across] = in_three(&mut self.step_matrix, &self.split);
        let [length_first, length_second, length_across] = in_three(&mut self.length, &self.split);
        let crossing = isa::avx2(Across {
            springs,
            range: across.clone(),
            state: (x, v),
            h,
            out: (&mut *step_across, &mut *length_across, &mut self.across_force),
        });
        let across = Crossing { pairs: &self.split.pairs[across], step: step_across, force: &self.across_force };
        let half = self.split.half;
        let (rhs_first, rhs_second) = rhs.split_at_mut(half);
        let (diagonal_first, diagonal_second) = preconditioner.split_at_mut(half);
        let mass = &self.scaled_mass;
        let side = |range, rows: Range<usize>, step, length, rhs, diagonal| {
            isa::avx2(Side {
                springs,
                range,
                rows,
                mass,
                across,
                state: (x, v),
                g,
                h,
                out: (step, length, rhs, diagonal),
            })
        };
        let first_side = || side(first, 0..half, step_first, length_first, rhs_first, diagonal_first);
        let second_side = || side(second, half..x.len(), step_second, length_second, rhs_second, diagonal_second);
        let (a, b) = if parallel { threads::join(first_side, second_side) } else { (first_side(), second_side()) };
        // The groups' sums added in one order: the same on any number of threads.
        SpringState {
            energy: a.energy + b.energy + crossing.energy,
            strain_jump: a.strain_jump.max(b.strain_jump).max(crossing.strain_jump),
        }
    }

    /// Add external forces `f` (N per particle, held over a step of `h`) to a right side made by
    /// [`Self::linearise`] (whose rows are scaled by the particles' valence weights, as gravity's are).
    pub fn add_forces(&self, f: &[DVec3], h: f64, rhs: &mut [DVec3]) {
        let weights = &self.graph.weights;
        rhs.iter_mut().zip(f).zip(weights).for_each(|((b, f), w)| *b += *f * (h / w));
    }

    /// `½ Σ m̃ |v|²` minus the work of gravity `Σ m̃ g·(x − rest)`, J.
    pub fn particle_energy(&self, x: &[DVec3], v: &[DVec3], rest: &[DVec3], g: DVec3) -> f64 {
        let mut e = 0.0;
        for (((x, v), r), m) in x.iter().zip(v).zip(rest).zip(&self.scaled_mass) {
            e += 0.5 * m * v.length_squared() - m * g.dot(*x - *r);
        }
        e
    }
}

impl Operator for ClothSystem {
    /// Rows `first..first + out.len()` of `A v` with the step's matrix `A = M̃ + h D + h² K`: the
    /// springs of each side within the rows, then the crossing springs' terms on their ends within them.
    #[inline(always)]
    fn apply_rows(&self, v: &[Padded], first: usize, out: &mut [Padded]) {
        let split = &self.split;
        let [side_first, side_second, across] = split.groups();
        for (side, springs) in [(0..split.half, side_first), (split.half..v.len(), side_second)] {
            if first <= side.start && side.end <= first + out.len() {
                let (v, mass) = (&v[side.clone()], &self.scaled_mass[side.clone()]);
                let out = &mut out[side.start - first..side.end - first];
                for ((o, v), m) in out.iter_mut().zip(v).zip(mass) {
                    *o = *v * *m;
                }
                for (&[i, j], g) in split.local[springs.clone()].iter().zip(&self.step_matrix[springs]) {
                    let y = g.times(v[i] - v[j]);
                    out[i] += y;
                    out[j] -= y;
                }
            }
        }
        let rows = first..first + out.len();
        for (&[i, j], g) in split.pairs[across.clone()].iter().zip(&self.step_matrix[across]) {
            let y = g.times(v[i] - v[j]);
            if rows.contains(&i) {
                out[i - first] += y;
            }
            if rows.contains(&j) {
                out[j - first] -= y;
            }
        }
    }

    fn sides(&self) -> Option<usize> {
        self.split.two_sided().then_some(self.split.half)
    }
}

/// What the passes over the springs read.
#[derive(Clone, Copy)]
struct Springs<'a> {
    graph: &'a SpringGraph,
    params: SpringParams,
    buckling: &'a [Buckling],
    split: &'a Split,
}

impl Springs<'_> {
    /// Spring `place` (in pass order) between `i` and `j`, of length `r` (`inverse = 1/r`, 0 at
    /// `r = 0`) at `(x, v)`, for a step of `h`: its block `G`, its term `y` of the right side at `i`
    /// (`−y` at `j`), and the spring's [`Measured`] state against its length `before` at the last
    /// linearisation.
    #[inline(always)]
    fn terms(
        &self,
        place: usize,
        [i, j]: [usize; 2],
        (r, inverse): (f64, f64),
        (x, v): (&[DVec3], &[DVec3]),
        h: f64,
        before: f64,
    ) -> (RankOne, DVec3, Measured) {
        let (s, stretch) = (self.split.springs[place], self.graph.stretch);
        let (k_s, k_d, h2) = (self.params.k_s, self.params.k_d, h * h);
        let dir = Padded::from(x[j] - x[i]) * inverse;
        let (tension, stiffness, measured) = if s < stretch {
            // Stretched: the exact Jacobian k_s x̂x̂ᵀ + (T/r)(I − x̂x̂ᵀ). Slack (T = 0): still k_s x̂x̂ᵀ
            // along the spring — see the module doc.
            let rest = self.graph.rest[s];
            let spring = springs::stretch(r, rest, k_s);
            let (tension, measured) = (spring.tension, Measured { energy: spring.energy, jump: (r - before) / rest });
            (tension, RankOne { dir, a: k_s - tension * inverse, c: tension * inverse }, measured)
        } else {
            // Longitudinal term only (Choi & Ko), S ≥ 0.
            let spring = self.buckling[s - stretch].eval(r);
            (
                spring.tension,
                RankOne { dir, a: spring.stiffness, c: 0.0 },
                Measured { energy: spring.energy, jump: 0.0 },
            )
        };
        // Force on i (spring and damping), and the right side's −h² K (vᵢ − vⱼ).
        let dv = Padded::from(v[i] - v[j]);
        let y = DVec3::from((dir * tension - dv * k_d) * h - stiffness.times(dv) * h2);
        (RankOne { dir, a: h2 * stiffness.a, c: h2 * stiffness.c + h * k_d }, y, measured)
    }
}

/// One spring at the state it is linearised at: its energy and, for a stretch spring, its strain
/// growth `(r − r₀)/L` since the last linearisation (0 for a buckling spring).
#[derive(Clone, Copy)]
struct Measured {
    energy: f64,
    jump: f64,
}

impl SpringState {
    /// No springs yet.
    const NONE: Self = Self { energy: 0.0, strain_jump: 0.0 };

    /// Add one spring's state (energies summed in the order they come, growths by their largest).
    #[inline(always)]
    fn add(&mut self, m: Measured) {
        self.energy += m.energy;
        self.strain_jump = self.strain_jump.max(m.jump);
    }
}

/// The crossing springs linearised: their blocks and lengths into `out`'s first two (that group's
/// entries), their terms of the right side into its third.
struct Across<'a> {
    springs: Springs<'a>,
    range: Range<usize>,
    state: (&'a [DVec3], &'a [DVec3]),
    h: f64,
    out: (&'a mut [RankOne], &'a mut [f64], &'a mut [DVec3]),
}

impl isa::Kernel for Across<'_> {
    type Output = SpringState;
    #[inline(always)]
    fn run(self) -> SpringState {
        let Self { springs, range, state, h, out: (step, length, force) } = self;
        let (start, mut measured) = (range.start, SpringState::NONE);
        for (chunk, pairs) in springs.split.pairs[range].chunks(LANES).enumerate() {
            let r = lengths(pairs, state.0);
            for (k, &pair) in pairs.iter().enumerate() {
                let local = chunk * LANES + k;
                let (g, y, m) = springs.terms(start + local, pair, r[k], state, h, length[local]);
                (step[local], length[local], force[local]) = (g, r[k].0, y);
                measured.add(m);
            }
        }
        measured
    }
}

/// The crossing springs as linearised ([`Across`]), for the sides to add on their ends.
#[derive(Clone, Copy)]
struct Crossing<'a> {
    pairs: &'a [[usize; 2]],
    step: &'a [RankOne],
    force: &'a [DVec3],
}

/// One side linearised: its rows of the right side and of the diagonal (gravity, its springs, the
/// crossing springs' terms on its particles, then inverted), its springs' blocks and lengths.
struct Side<'a> {
    springs: Springs<'a>,
    range: Range<usize>,
    rows: Range<usize>,
    mass: &'a [f64],
    across: Crossing<'a>,
    state: (&'a [DVec3], &'a [DVec3]),
    g: DVec3,
    h: f64,
    out: (&'a mut [RankOne], &'a mut [f64], &'a mut [DVec3], &'a mut [PaddedMat3]),
}

impl isa::Kernel for Side<'_> {
    type Output = SpringState;
    #[inline(always)]
    fn run(self) -> SpringState {
        let Self { springs, range, rows, mass, across, state, g, h, out: (step, length, rhs, diagonal) } = self;
        let first = rows.start;
        for (k, (b, d)) in rhs.iter_mut().zip(diagonal.iter_mut()).enumerate() {
            let m = mass[first + k];
            *b = g * (h * m);
            *d = DMat3::from_diagonal(DVec3::splat(m)).into();
        }
        let (start, mut measured) = (range.start, SpringState::NONE);
        for (chunk, pairs) in springs.split.pairs[range].chunks(LANES).enumerate() {
            let r = lengths(pairs, state.0);
            for (k, &[i, j]) in pairs.iter().enumerate() {
                let local = chunk * LANES + k;
                let (block, y, m) = springs.terms(start + local, [i, j], r[k], state, h, length[local]);
                (step[local], length[local]) = (block, r[k].0);
                measured.add(m);
                rhs[i - first] += y;
                rhs[j - first] -= y;
                let matrix = block.matrix();
                diagonal[i - first] += matrix;
                diagonal[j - first] += matrix;
            }
        }
        for ((&[i, j], block), y) in across.pairs.iter().zip(across.step).zip(across.force) {
            for (end, sign) in [(i, 1.0), (j, -1.0)] {
                if rows.contains(&end) {
                    rhs[end - first] += *y * sign;
                    diagonal[end - first] += block.matrix();
                }
            }
        }
        for d in diagonal.iter_mut() {
            *d = DMat3::from(*d).inverse().into();
        }
        measured
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

    /// `linearise` at `(x, v)` with gravity `g` and step `h`: the linearised system, its right side
    /// and the block-Jacobi preconditioner.
    fn linearised_with(
        sys: &ClothSystem,
        (x, v): (&[DVec3], &[DVec3]),
        g: DVec3,
        h: f64,
    ) -> (ClothSystem, Vec<DVec3>, Vec<PaddedMat3>) {
        let (mut sys, n) = (sys.clone(), x.len());
        let (mut rhs, mut preconditioner) = (vec![DVec3::ZERO; n], vec![PaddedMat3::default(); n]);
        sys.linearise((x, v), g, h, &mut rhs, &mut preconditioner);
        (sys, rhs, preconditioner)
    }

    /// [`linearised_with`] without gravity and with `h = 1`: the right side is `f(x, v) − K v`.
    fn linearised(sys: &ClothSystem, x: &[DVec3], v: &[DVec3]) -> (ClothSystem, Vec<DVec3>, Vec<PaddedMat3>) {
        linearised_with(sys, (x, v), DVec3::ZERO, 1.0)
    }

    /// `(A − M̃) u` for the linearised system `sys`.
    fn spring_part(sys: &ClothSystem, u: &[DVec3]) -> Vec<DVec3> {
        let mut a_u = vec![DVec3::ZERO; u.len()];
        sys.apply(u, &mut a_u);
        a_u.iter().zip(u).zip(sys.scaled_masses()).map(|((a, u), m)| *a - *u * *m).collect()
    }

    fn largest(v: &[DVec3]) -> f64 {
        v.iter().map(|b| b.abs().max_element()).fold(0.0, f64::max)
    }

    /// The step of `h` scales the linearisation at `h = 1` as backward Euler says: the right side is
    /// `h f(x, 0) + h m̃ g` at rest velocities and changes by `−(A − M̃) v` with the velocities, where
    /// `A − M̃ = h D + h² K` (without damping: `h²` times the matrix at `h = 1`).
    #[test]
    fn the_step_scales_with_h_and_carries_gravity() {
        let (sys, x, v) = system();
        let (h, g) = (0.01, DVec3::new(0.5, -9.81, 0.0));
        let still = vec![DVec3::ZERO; x.len()];
        let (_, force, _) = linearised(&sys, &x, &still);
        let (_, at_rest, _) = linearised_with(&sys, (&x, &still), g, h);
        let (lin, moving, _) = linearised_with(&sys, (&x, &v), g, h);
        let scale = largest(&at_rest).max(largest(&moving));
        let damping_and_stiffness = spring_part(&lin, &v);
        for (i, m) in sys.scaled_masses().iter().enumerate() {
            let want = force[i] * h + g * (h * m);
            assert!((at_rest[i] - want).abs().max_element() < 1e-12 * scale, "particle {i}: {} vs {want}", at_rest[i]);
            let change = moving[i] - at_rest[i];
            assert!((change + damping_and_stiffness[i]).abs().max_element() < 1e-12 * scale, "particle {i}: {change}");
        }
        let mut undamped = sys.clone();
        undamped.set_params(SpringParams { k_d: 0.0, ..sys.params() });
        let (one, _, _) = linearised(&undamped, &x, &v);
        let (small, _, _) = linearised_with(&undamped, (&x, &v), g, h);
        let (k_h, k_1) = (spring_part(&small, &v), spring_part(&one, &v));
        let scale = largest(&k_1) * h * h;
        for (i, (a, b)) in k_h.iter().zip(&k_1).enumerate() {
            assert!((*a - *b * (h * h)).abs().max_element() < 1e-12 * scale, "particle {i}: {a} vs {}", *b * h * h);
        }
    }

    /// With every stretch spring taut (where the matrix keeps their exact Jacobian) and buckling off,
    /// the step matrix is the exact linearisation of the forces. With `h = 1` the right side is
    /// `f(x, v) − K v` and `A = M̃ + D + K`: at `v = 0` and without damping its derivative along `dx` is
    /// `∂f/∂x dx = −K dx = −(A − M̃) dx`; along a velocity change `dv` it is `∂f/∂v dv − K dv =
    /// −(A − M̃) dv`. The matrix is symmetric and the preconditioner inverts its diagonal blocks.
    #[test]
    fn matrix_is_symmetric_and_matches_the_derivative_of_the_stretch_and_damping_forces() {
        let (mut sys, _, v) = system();
        sys.set_params(SpringParams { k_b: 0.0, ..sys.params() });
        // Stretched by 8% and rippled out of plane: every edge longer than at rest.
        let rest = generate::delaunay_sheet([0.3, 0.2], 0.06).unwrap();
        let x: Vec<DVec3> =
            rest.positions().iter().map(|p| DVec3::new(p.x * 1.08, 0.02 * (11.0 * p.x).sin(), p.z * 1.08)).collect();
        let g = sys.graph();
        for (s, &[i, j]) in g.pairs[..g.stretch].iter().enumerate() {
            assert!((x[j] - x[i]).length() > g.rest[s], "spring {s} is taut");
        }
        let n = x.len();
        let dx: Vec<DVec3> = (0..n).map(|i| DVec3::new((i as f64).sin(), (i as f64 * 0.7).cos(), 0.3)).collect();
        let e = 1e-7;
        let along = |a: &[DVec3], s: f64| -> Vec<DVec3> { a.iter().zip(&dx).map(|(a, d)| *a + *d * s).collect() };
        let still = vec![DVec3::ZERO; n];
        let undamped = {
            let mut s = sys.clone();
            s.set_params(SpringParams { k_d: 0.0, ..sys.params() });
            s
        };
        // (system, x, v, direction of the derivative: positions or velocities)
        for (base, x, v, positions) in [(&undamped, &x, &still, true), (&sys, &x, &v, false)] {
            let (lin, _, preconditioner) = linearised(base, x, v);
            let mut a_dx = vec![DVec3::ZERO; n];
            lin.apply(&dx, &mut a_dx);
            let ((_, bp, _), (_, bm, _)) = if positions {
                (linearised(base, &along(x, e), v), linearised(base, &along(x, -e), v))
            } else {
                (linearised(base, x, &along(v, e)), linearised(base, x, &along(v, -e)))
            };
            let scale = a_dx.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
            for i in 0..n {
                let fd = (bp[i] - bm[i]) / (2.0 * e);
                let want = -(a_dx[i] - dx[i] * lin.scaled_masses()[i]);
                assert!((fd - want).abs().max_element() < 1e-6 * scale, "particle {i}: {fd} vs {want}");
            }
            // Symmetry: uᵀ A w = wᵀ A u.
            let u: Vec<DVec3> = (0..n).map(|i| DVec3::new(0.2, (i as f64).cos(), -(i as f64 * 0.3).sin())).collect();
            let mut a_u = vec![DVec3::ZERO; n];
            lin.apply(&u, &mut a_u);
            let (uaw, wau): (f64, f64) =
                (u.iter().zip(&a_dx).map(|(a, b)| a.dot(*b)).sum(), dx.iter().zip(&a_u).map(|(a, b)| a.dot(*b)).sum());
            assert!((uaw - wau).abs() < 1e-12 * uaw.abs().max(1.0));
            // The diagonal block of particle i is read off A's product with unit vectors at i.
            for i in (0..n).step_by(7) {
                let column = |k: usize| {
                    let mut unit = vec![DVec3::ZERO; n];
                    unit[i][k] = 1.0;
                    let mut a_unit = vec![DVec3::ZERO; n];
                    lin.apply(&unit, &mut a_unit);
                    a_unit[i]
                };
                let block = DMat3::from_cols(column(0), column(1), column(2));
                let product = DMat3::from(preconditioner[i]) * block;
                let off = (product - DMat3::IDENTITY).abs().to_cols_array();
                assert!(off.iter().all(|d| *d < 1e-12), "particle {i}: P⁻¹ A_ii = {product}");
            }
        }
    }

    /// Forces are minus the gradient of the springs' energy (both spring kinds active).
    #[test]
    fn forces_are_minus_the_energy_gradient() {
        let (sys, x, _) = system();
        let n = x.len();
        let still = vec![DVec3::ZERO; n];
        // At rest velocities and with h = 1 the right side is the force.
        let (_, f, _) = linearised(&sys, &x, &still);
        let energy = |p: &[DVec3]| {
            let (mut rhs, mut preconditioner) = (vec![DVec3::ZERO; n], vec![PaddedMat3::default(); n]);
            sys.clone().linearise((p, &still), DVec3::ZERO, 1.0, &mut rhs, &mut preconditioner).energy
        };
        let scale = f.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
        for i in (0..n).step_by(3) {
            for a in 0..3 {
                let e = 1e-7;
                let mut p = x.clone();
                p[i][a] += e;
                let ep = energy(&p);
                p[i][a] -= 2.0 * e;
                let em = energy(&p);
                let fd = -(ep - em) / (2.0 * e);
                assert!((fd - f[i][a]).abs() < 1e-6 * scale, "particle {i}[{a}]: {} vs fd {fd}", f[i][a]);
            }
        }
    }

    /// A linearisation measures the springs where it is made: the strain growth since the one before
    /// is the largest `(r′ − r)/L` over the stretch springs (buckling springs have none), whichever
    /// side of the split the spring is in.
    #[test]
    fn a_linearisation_measures_the_strain_growth_since_the_last() {
        let (sys, x, v) = system();
        let n = x.len();
        let (mut rhs, mut preconditioner) = (vec![DVec3::ZERO; n], vec![PaddedMat3::default(); n]);
        let mut lin = sys.clone();
        lin.linearise((&x, &v), DVec3::ZERO, 0.01, &mut rhs, &mut preconditioner);
        let g = sys.graph();
        let length = |x: &[DVec3], s: usize| (x[g.pairs[s][1]] - x[g.pairs[s][0]]).length();
        // Each particle moved by its own amount, so every spring's growth differs.
        let moved: Vec<DVec3> = x.iter().enumerate().map(|(i, p)| *p * (1.0 + 0.001 * (i % 13) as f64)).collect();
        let state = lin.linearise((&moved, &v), DVec3::ZERO, 0.01, &mut rhs, &mut preconditioner);
        let want = (0..g.stretch).map(|s| (length(&moved, s) - length(&x, s)) / g.rest[s]).fold(0.0, f64::max);
        assert!(want > 1e-3, "{want}");
        assert_eq!(state.strain_jump, want);
        // The energy is that of the state it was made at, whatever came before.
        let fresh = sys.clone().linearise((&moved, &v), DVec3::ZERO, 0.01, &mut rhs, &mut preconditioner);
        assert_eq!(state.energy, fresh.energy);
    }
}
