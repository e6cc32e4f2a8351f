//! The discrete shell energy `W = k_A E_A + k_L E_L + k_B E_B` (Grinspun, Hirani, Desbrun & Schröder 2003, "Discrete shells") on any
//! triangle mesh, as a pure function of the current positions.
//!
//! - `E_A = Σ_t (1 − A_t/Ā_t)² Ā_t` over triangles,
//! - `E_L = Σ_e (1 − |e|/|ē|)² |ē|` over all edges,
//! - `E_B = Σ_e (θ_e − θ̄_e)² · 3|ē|²/(Ā₁ + Ā₂)` over interior edges, with the signed atan2 angle of
//!   [`super::hinge`] and `θ − θ̄` wrapped to `[−π, π)` so curved rest shapes (the V-beam) are safe.
//!
//! Element numbering (used by [`DiscreteShell::for_each_stencil`] and
//! [`DiscreteShell::element_hessians`]): all triangles, then all edges, then all hinges.
//! [`DiscreteShell::element_hessians`] *visits* them interleaved, sorted by their smallest vertex, so
//! consecutive elements touch neighbouring matrix columns and assembly stays in cache.

use glam::{DMat3, DVec3};
use nalgebra::SMatrix;

use super::EnergyError;
use super::hinge::{angle_gradient, angle_hessian_lower, lower_index, outer, wrapped_difference};
use super::stretch::{area_gradient, edge, packed_entry, triangle};
use crate::linalg::{BlockAssembler, DofMap, LinalgError};
use crate::mesh::TriMesh;

/// The three stiffnesses of the shell energy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellStiffness {
    /// Area (stretch) stiffness `k_A`.
    pub k_area: f64,
    /// Edge-length (shear) stiffness `k_L`.
    pub k_length: f64,
    /// Bending stiffness `k_B`.
    pub k_bend: f64,
}

impl From<&crate::scene::Material> for ShellStiffness {
    /// The shell stiffnesses a scene's material names.
    fn from(m: &crate::scene::Material) -> Self {
        Self { k_area: m.k_area, k_length: m.k_length, k_bend: m.k_bend }
    }
}

impl ShellStiffness {
    fn check(&self) -> Result<(), EnergyError> {
        for (name, value) in [("k_area", self.k_area), ("k_length", self.k_length), ("k_bend", self.k_bend)] {
            if !value.is_finite() || value < 0.0 {
                return Err(EnergyError::BadStiffness { name, value });
            }
        }
        Ok(())
    }
}

/// The unweighted energy terms `E_A`, `E_L`, `E_B`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyTerms {
    /// `E_A`.
    pub area: f64,
    /// `E_L`.
    pub length: f64,
    /// `E_B`.
    pub bend: f64,
}

/// Which Hessian to produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HessianMode {
    /// The exact second derivative (indefinite away from rest in general).
    Exact,
    /// Per-element projection onto the positive semidefinite cone: each element's block is
    /// eigen-decomposed (12 × 12 hinge, 9 × 9 triangle; the 6 × 6 edge block analytically) and negative
    /// eigenvalues are clamped to zero. The sum is then PSD, which Newton methods need for a descent
    /// direction far from equilibrium.
    Projected,
}

#[derive(Debug, Clone, Copy)]
struct Tri {
    v: [usize; 3],
    rest_area: f64,
}

#[derive(Debug, Clone, Copy)]
struct EdgeElem {
    v: [usize; 2],
    rest_length: f64,
}

#[derive(Debug, Clone, Copy)]
struct HingeElem {
    v: [usize; 4],
    weight: f64,
    rest_angle: f64,
}

/// The discrete shell energy of one rest mesh: rest lengths, areas, angles and hinge weights
/// precomputed; positions are passed to every call.
#[derive(Debug, Clone)]
pub struct DiscreteShell {
    vertex_count: usize,
    stiffness: ShellStiffness,
    tris: Vec<Tri>,
    edges: Vec<EdgeElem>,
    hinges: Vec<HingeElem>,
    /// Element numbers in visiting order (sorted by smallest vertex).
    visit: Vec<u32>,
}

impl DiscreteShell {
    /// Precompute the rest state of `rest`. Fails on a bad stiffness or a degenerate rest element.
    pub fn new(rest: &TriMesh, stiffness: ShellStiffness) -> Result<Self, EnergyError> {
        stiffness.check()?;
        let x = rest.positions();
        let areas = rest.triangle_areas();
        if let Some((triangle, &area)) = areas.iter().enumerate().find(|(_, a)| !(a.is_finite() && **a > 0.0)) {
            return Err(EnergyError::DegenerateTriangle { triangle, area });
        }
        let tris = rest.triangles().iter().zip(&areas).map(|(&v, &rest_area)| Tri { v, rest_area }).collect();
        let topo = rest.topology();
        let mut edges = Vec::with_capacity(topo.edges.len());
        for (i, e) in topo.edges.iter().enumerate() {
            let length = (x[e.v[1]] - x[e.v[0]]).length();
            if !(length.is_finite() && length > 0.0) {
                return Err(EnergyError::DegenerateEdge { edge: i, length });
            }
            edges.push(EdgeElem { v: e.v, rest_length: length });
        }
        let hinges = topo
            .hinges
            .iter()
            .map(|h| {
                let l = edges[h.edge].rest_length;
                let p = h.v.map(|i| x[i]);
                let (rest_angle, _) = angle_gradient(&p);
                HingeElem { v: h.v, weight: 3.0 * l * l / (areas[h.faces[0]] + areas[h.faces[1]]), rest_angle }
            })
            .collect();
        let mut shell = Self { vertex_count: rest.vertex_count(), stiffness, tris, edges, hinges, visit: Vec::new() };
        let mut keyed = Vec::with_capacity(shell.element_count());
        let mut e = 0u32;
        shell.for_each_stencil(|s| {
            keyed.push((s.iter().copied().min().unwrap_or(0), e));
            e += 1;
        });
        keyed.sort_unstable();
        shell.visit = keyed.into_iter().map(|(_, e)| e).collect();
        Ok(shell)
    }

    /// Number of vertices the positions must have.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// The current stiffnesses.
    pub fn stiffness(&self) -> ShellStiffness {
        self.stiffness
    }

    /// Change the stiffnesses (the rest state is kept).
    pub fn set_stiffness(&mut self, stiffness: ShellStiffness) -> Result<(), EnergyError> {
        stiffness.check()?;
        self.stiffness = stiffness;
        Ok(())
    }

    /// Number of elements (triangles + edges + hinges), the length of the stencil sequence.
    pub fn element_count(&self) -> usize {
        self.tris.len() + self.edges.len() + self.hinges.len()
    }

    /// Rest dihedral angle of every hinge, in [`crate::mesh::Topology::hinges`] order.
    pub fn rest_angles(&self) -> Vec<f64> {
        self.hinges.iter().map(|h| h.rest_angle).collect()
    }

    /// Call `f` with the vertices of every element, in element order.
    pub fn for_each_stencil(&self, mut f: impl FnMut(&[usize])) {
        self.tris.iter().for_each(|t| f(&t.v));
        self.edges.iter().for_each(|e| f(&e.v));
        self.hinges.iter().for_each(|h| f(&h.v));
    }

    fn check_len(&self, x: &[DVec3]) {
        assert_eq!(x.len(), self.vertex_count, "positions must have one entry per vertex");
    }

    /// The unweighted terms `E_A`, `E_L`, `E_B` at positions `x`.
    ///
    /// # Panics
    /// If `x.len()` is not [`DiscreteShell::vertex_count`] (likewise for every method taking positions).
    pub fn terms(&self, x: &[DVec3]) -> EnergyTerms {
        self.check_len(x);
        let area = self
            .tris
            .iter()
            .map(|t| {
                let a = 0.5 * (x[t.v[1]] - x[t.v[0]]).cross(x[t.v[2]] - x[t.v[0]]).length();
                (a - t.rest_area).powi(2) / t.rest_area
            })
            .sum();
        let length =
            self.edges.iter().map(|e| ((x[e.v[1]] - x[e.v[0]]).length() - e.rest_length).powi(2) / e.rest_length).sum();
        let bend = self
            .hinges
            .iter()
            .map(|h| {
                let p = h.v.map(|i| x[i]);
                wrapped_difference(super::hinge::angle(&p), h.rest_angle).powi(2) * h.weight
            })
            .sum();
        EnergyTerms { area, length, bend }
    }

    /// `W(x)`.
    pub fn energy(&self, x: &[DVec3]) -> f64 {
        let t = self.terms(x);
        let k = self.stiffness;
        k.k_area * t.area + k.k_length * t.length + k.k_bend * t.bend
    }

    /// Write `∂W/∂x` into `out` (overwritten) and return `W(x)`.
    ///
    /// # Panics
    /// If `x` or `out` does not have one entry per vertex.
    pub fn gradient(&self, x: &[DVec3], out: &mut [DVec3]) -> f64 {
        self.check_len(x);
        assert_eq!(out.len(), self.vertex_count, "gradient must have one entry per vertex");
        out.fill(DVec3::ZERO);
        (0..self.element_count()).map(|e| self.element_gradient(e, x, |v, g| out[v] += g)).sum()
    }

    /// `Σ w_e W_e(x)` over a weighted set of elements (a cubature): its gradient into `out`
    /// (overwritten), its value returned.
    ///
    /// # Panics
    /// If `x` or `out` does not have one entry per vertex, or an element number is out of range.
    pub fn weighted_gradient(&self, x: &[DVec3], elements: &[(usize, f64)], out: &mut [DVec3]) -> f64 {
        self.check_len(x);
        assert_eq!(out.len(), self.vertex_count, "gradient must have one entry per vertex");
        out.fill(DVec3::ZERO);
        elements.iter().map(|&(e, w)| w * self.element_gradient(e, x, |v, g| out[v] += g * w)).sum()
    }

    /// `Σ w_e W_e(x)` over a weighted set of elements (a cubature).
    ///
    /// # Panics
    /// If `x` does not have one entry per vertex, or an element number is out of range.
    pub fn weighted_energy(&self, x: &[DVec3], elements: &[(usize, f64)]) -> f64 {
        self.check_len(x);
        elements.iter().map(|&(e, w)| w * self.element_gradient(e, x, |_, _| {})).sum()
    }

    /// One element's energy `W_e(x)` (stiffness included), with `add(vertex, ∂W_e/∂x_vertex)` called
    /// for each vertex of its stencil. Elements are numbered as in [`Self::for_each_stencil`].
    ///
    /// # Panics
    /// If `index` is not below [`Self::element_count`].
    pub fn element_gradient(&self, index: usize, x: &[DVec3], mut add: impl FnMut(usize, DVec3)) -> f64 {
        let k = self.stiffness;
        let (nt, ne) = (self.tris.len(), self.edges.len());
        if index < nt {
            let t = &self.tris[index];
            let (a, g) = area_gradient(&t.v.map(|i| x[i]));
            let diff = a - t.rest_area;
            let s = k.k_area * 2.0 * diff / t.rest_area;
            t.v.iter().zip(g).for_each(|(&i, g)| add(i, g * s));
            k.k_area * diff * diff / t.rest_area
        } else if index < nt + ne {
            let e = &self.edges[index - nt];
            let d = x[e.v[1]] - x[e.v[0]];
            let l = d.length();
            let r = l - e.rest_length;
            let g = d * (k.k_length * 2.0 * r / (e.rest_length * l));
            add(e.v[0], -g);
            add(e.v[1], g);
            k.k_length * r * r / e.rest_length
        } else {
            let h = &self.hinges[index - nt - ne];
            let (theta, g) = angle_gradient(&h.v.map(|i| x[i]));
            let delta = wrapped_difference(theta, h.rest_angle);
            let s = k.k_bend * h.weight * 2.0 * delta;
            h.v.iter().zip(g).for_each(|(&i, g)| add(i, g * s));
            k.k_bend * h.weight * delta * delta
        }
    }

    /// Compute every element's Hessian (already multiplied by its stiffness) and hand it to
    /// `sink(element, vertices, lower)`, in element order, as its lower 3 × 3 blocks `(p, q)`, `p ≥ q`,
    /// packed by `lower_index` (`k(k + 1)/2` blocks for `k` vertices; the upper blocks are their
    /// transposes). Assemblers (see `crate::linalg`) scatter these into a sparse matrix.
    pub fn element_hessians(&self, x: &[DVec3], mode: HessianMode, mut sink: impl FnMut(usize, &[usize], &[DMat3])) {
        self.check_len(x);
        for &index in &self.visit {
            let index = index as usize;
            self.element_hessian(index, x, mode, |v, h| sink(index, v, h));
        }
    }

    /// One element's Hessian (stiffness included), handed to `sink(vertices, lower)` as in
    /// [`Self::element_hessians`].
    ///
    /// # Panics
    /// If `index` is not below [`Self::element_count`].
    pub fn element_hessian(&self, index: usize, x: &[DVec3], mode: HessianMode, sink: impl FnOnce(&[usize], &[DMat3])) {
        let k = self.stiffness;
        let project = mode == HessianMode::Projected;
        let (nt, ne) = (self.tris.len(), self.edges.len());
        if index < nt {
            let t = &self.tris[index];
            let (_, _, mut h) = triangle(&t.v.map(|i| x[i]), t.rest_area);
            h.iter_mut().for_each(|b| *b *= k.k_area);
            if project {
                project_psd_triangle(&mut h);
            }
            sink(&t.v, &h);
        } else if index < nt + ne {
            let e = &self.edges[index - nt];
            let (_, _, mut h) = edge(x[e.v[0]], x[e.v[1]], e.rest_length, project);
            h.iter_mut().for_each(|b| *b *= k.k_length);
            sink(&e.v, &h);
        } else {
            let hg = &self.hinges[index - nt - ne];
            let mut h = hinge_hessian(&hg.v.map(|i| x[i]), hg.rest_angle, hg.weight * k.k_bend);
            if project {
                project_psd_hinge(&mut h);
            }
            sink(&hg.v, &h);
        }
    }

    /// The sparsity pattern of this shell's Hessian over `dofs`, ready for [`Self::assemble_hessian`].
    pub fn hessian_pattern(&self, dofs: &DofMap) -> Result<BlockAssembler, LinalgError> {
        let mut stencils = Vec::with_capacity(self.element_count());
        self.for_each_stencil(|s| stencils.push(s.to_vec()));
        BlockAssembler::new(dofs, stencils.iter().map(Vec::as_slice))
    }

    /// Overwrite `asm`'s values with this shell's Hessian at positions `x` (a full-mesh position
    /// vector); `asm` must come from [`Self::hessian_pattern`].
    pub fn assemble_hessian(&self, asm: &mut BlockAssembler, x: &[DVec3], mode: HessianMode) {
        asm.begin();
        let mut bad = None;
        self.element_hessians(x, mode, |e, _, h| {
            if let Err(err) = asm.add_element(e, h) {
                bad.get_or_insert(err);
            }
        });
        asm.finish();
        debug_assert!(bad.is_none(), "assembler built for a different shell: {bad:?}");
    }
}

/// Hessian of `weight (θ − θ̄)²`, `2 weight (∇θ ∇θᵀ + (θ − θ̄) ∇²θ)`, as its packed lower blocks.
fn hinge_hessian(p: &[DVec3; 4], rest: f64, weight: f64) -> [DMat3; 10] {
    let (theta, grad, mut lower) = angle_hessian_lower(p);
    let delta = wrapped_difference(theta, rest);
    let s = 2.0 * weight;
    for a in 0..4 {
        for b in 0..=a {
            let m = &mut lower[lower_index(a, b)];
            *m = outer(grad[a] * s, grad[b]) + *m * (s * delta);
        }
    }
    lower
}

/// Clamp the negative eigenvalues of a `k`-point element's Hessian (`3k × 3k`, given by its packed
/// lower blocks) to zero; one function per size, since nalgebra's fixed-size eigen solver needs
/// concrete dimensions.
macro_rules! project_psd_fn {
    ($name:ident, $k:literal, $n:literal) => {
        fn $name(lower: &mut [DMat3]) {
            let m = SMatrix::<f64, $n, $n>::from_fn(|i, j| packed_entry(lower, i, j));
            let eig = m.symmetric_eigen();
            if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
                return;
            }
            let clamped = eig.eigenvalues.map(|l| l.max(0.0));
            let r = eig.eigenvectors * SMatrix::<f64, $n, $n>::from_diagonal(&clamped) * eig.eigenvectors.transpose();
            for p in 0..$k {
                for q in 0..=p {
                    lower[lower_index(p, q)] =
                        DMat3::from_cols_array(&std::array::from_fn(|t| r[(3 * p + t % 3, 3 * q + t / 3)]));
                }
            }
        }
    };
}
project_psd_fn!(project_psd_triangle, 3, 9);
project_psd_fn!(project_psd_hinge, 4, 12);
