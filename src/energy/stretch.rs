//! Membrane terms of the discrete shell, per element: value, gradient and Hessian.
//!
//! - Edge length: `E = (|e| − L)²/L = (1 − |e|/L)² L` for `e = x₁ − x₀` and rest length `L`.
//! - Triangle area: `E = (A − Ā)²/Ā = (1 − A/Ā)² Ā` for current area `A` and rest area `Ā`.
//!
//! Both are unweighted (the stiffness multiplies them in [`super::shell`]). Hessians are returned as
//! their lower 3 × 3 blocks `∂²E/∂x_p∂x_q` (`p ≥ q`), packed by `lower_index`; the upper blocks
//! are their transposes.

use glam::{DMat3, DVec3};

use super::hinge::{cross_matrix, lower_index, outer};

/// The edge term's value, gradient `[∂E/∂x₀, ∂E/∂x₁]` and Hessian (lower blocks `(0,0), (1,0), (1,1)`).
///
/// Compressed edges (`|e| < L`) have a negative transverse stiffness `2(1 − L/|e|)/L`; with
/// `project` it is clamped to zero, which is the exact PSD projection of this element (its other
/// eigenvalue, along the edge, is `4/L > 0`).
pub fn edge(x0: DVec3, x1: DVec3, rest: f64, project: bool) -> (f64, [DVec3; 2], [DMat3; 3]) {
    let e = x1 - x0;
    let l = e.length();
    let u = e / l;
    let r = l - rest;
    let value = r * r / rest;
    let g = u * (2.0 * r / rest);
    let mut transverse = 2.0 * r / (l * rest);
    if project {
        transverse = transverse.max(0.0);
    }
    let k = outer(u, u) * (2.0 / rest - transverse) + DMat3::IDENTITY * transverse;
    (value, [-g, g], [k, -k, k])
}

/// The area of triangle `(p, q, r)` and its gradient.
pub fn area_gradient(x: &[DVec3; 3]) -> (f64, [DVec3; 3]) {
    let [p, q, r] = *x;
    let n = (q - p).cross(r - p);
    let len = n.length();
    let u = n / len;
    // ∇_p A = ½ [r − q]×ᵀ n̂ = ½ n̂ × (r − q), and cyclically.
    (0.5 * len, [u.cross(r - q) * 0.5, u.cross(p - r) * 0.5, u.cross(q - p) * 0.5])
}

/// The triangle term's value, gradient and Hessian (the six lower blocks), for rest area `rest`.
pub fn triangle(x: &[DVec3; 3], rest: f64) -> (f64, [DVec3; 3], [DMat3; 6]) {
    let [p, q, r] = *x;
    let n = (q - p).cross(r - p);
    let len = n.length();
    let u = n / len;
    let area = 0.5 * len;
    let ga = [u.cross(r - q) * 0.5, u.cross(p - r) * 0.5, u.cross(q - p) * 0.5];
    let diff = area - rest;
    let value = diff * diff / rest;
    let grad = ga.map(|g| g * (2.0 * diff / rest));
    // ∇²A = (1/(2|N|)) Jᵀ(I − n̂n̂ᵀ)J + ½ Σᵢ n̂ᵢ ∇²Nᵢ, with J_k = ∂N/∂x_k = [v_k]× (v_k the edge
    // opposite k). For J_k = [a]×, J_l = [b]×: [a]×ᵀ(I − n̂n̂ᵀ)[b]× = (a·b) I − b aᵀ − (n̂ × a)(n̂ × b)ᵀ.
    let v = [r - q, p - r, q - p];
    let uv = v.map(|a| u.cross(a));
    let c = 0.5 / len;
    let un = cross_matrix(u) * 0.5;
    let s = 2.0 / rest;
    let mut h = [DMat3::ZERO; 6];
    for k in 0..3 {
        for l in k..3 {
            let (a, b) = (v[k], v[l]);
            let first = (DMat3::from_diagonal(DVec3::splat(a.dot(b))) - outer(b, a) - outer(uv[k], uv[l])) * c;
            // Second term: block (k, l) = ∂(½ n̂ × v_k)/∂x_l with n̂ fixed.
            let second = match (l + 3 - k) % 3 {
                0 => DMat3::ZERO,
                1 => -un,
                _ => un,
            };
            // Block (k, l), k ≤ l; the lower one (l, k) is its transpose.
            let block = (outer(ga[k], ga[l]) + (first + second) * diff) * s;
            h[lower_index(l, k)] = block.transpose();
        }
    }
    (value, grad, h)
}

/// Entry `(i, j)` of the symmetric `3k × 3k` matrix of an element given by its packed lower blocks.
pub(crate) fn packed_entry(lower: &[DMat3], i: usize, j: usize) -> f64 {
    let (p, q) = (i / 3, j / 3);
    if p >= q { lower[lower_index(p, q)].col(j % 3)[i % 3] } else { lower[lower_index(q, p)].col(i % 3)[j % 3] }
}

/// The dense `3k × 3k` column-major matrix of a `k`-point element from its packed lower blocks.
#[cfg(test)]
pub(crate) fn unpack<const K: usize>(lower: &[DMat3]) -> Vec<f64> {
    let n = 3 * K;
    (0..n * n).map(|t| packed_entry(lower, t % n, t / n)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::fd::{self, Rng};

    /// The relative errors of the central differences of `f`'s value and gradient (see [`fd`]).
    fn fd_check<const V: usize, const M: usize>(
        x: [DVec3; V],
        f: impl Fn(&[DVec3; V]) -> (f64, [DVec3; V], [DMat3; M]),
    ) -> (f64, f64) {
        let at = |y: &[DVec3]| f(&<[DVec3; V]>::try_from(y).expect("V points"));
        let hessian = unpack::<V>(&f(&x).2);
        fd::errors(&x, |y| at(y).0, |y| at(y).1.to_vec(), Some(&hessian))
    }

    #[test]
    fn edge_derivatives_match_finite_differences() {
        let mut r = Rng(7);
        for _ in 0..20 {
            let x = [DVec3::new(r.uniform(), r.uniform(), r.uniform()), DVec3::new(r.uniform(), 2.0, r.uniform())];
            let rest = 1.5 + r.uniform();
            let (g, h) = fd_check(x, |x| edge(x[0], x[1], rest, false));
            assert!(g < 1e-6 && h < 1e-6, "edge FD errors {g:e} {h:e}");
        }
    }

    #[test]
    fn triangle_derivatives_match_finite_differences() {
        let mut r = Rng(11);
        for _ in 0..20 {
            let x = [
                DVec3::new(r.uniform(), r.uniform(), r.uniform()),
                DVec3::new(2.0 + r.uniform(), r.uniform(), r.uniform()),
                DVec3::new(r.uniform(), 2.0 + r.uniform(), r.uniform()),
            ];
            let rest = 1.0 + 0.5 * r.uniform();
            let (g, h) = fd_check(x, |x| triangle(x, rest));
            assert!(g < 1e-6 && h < 1e-6, "triangle FD errors {g:e} {h:e}");
            let (a, ga) = area_gradient(&x);
            let (_, g2, _) = triangle(&x, rest);
            for k in 0..3 {
                assert!((ga[k] * (2.0 * (a - rest) / rest) - g2[k]).length() < 1e-14);
            }
        }
    }

    #[test]
    fn projected_edge_hessian_is_positive_semidefinite() {
        let (_, _, h) = edge(DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0), 1.0, true);
        let m = nalgebra::SMatrix::<f64, 6, 6>::from_column_slice(&unpack::<2>(&h));
        let ev = m.symmetric_eigenvalues();
        assert!(ev.iter().all(|&l| l > -1e-12), "{ev}");
        let (_, _, h) = edge(DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0), 1.0, false);
        let m = nalgebra::SMatrix::<f64, 6, 6>::from_column_slice(&unpack::<2>(&h));
        assert!(m.symmetric_eigenvalues().iter().any(|&l| l < -0.1), "a compressed edge is indefinite");
    }
}
