//! One formula for a number and for a vector of numbers: the arithmetic that the constraint functions
//! of position-based dynamics are written in ([`Real`]), implemented by `f64` (one constraint) and by
//! [`Lanes32`] (one constraint per SIMD lane in single precision, in the instruction set [`pulp`]
//! chose at run time). The scalar instance is what the finite-difference tests check; the vector
//! instance is what the sweeps run, so both are the same source. Every method is `#[inline(always)]`
//! so that a dispatched kernel compiles it with the wide instructions.

use std::ops::{Add, Div, Mul, Neg, Sub};

use pulp::Simd;

/// Arithmetic on a number or on lanes of numbers.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// The result of a comparison (per lane).
    type Mask: Copy;
    /// How many times the arctangent ([`crate::energy::constraints::atan2`]) halves its argument
    /// after bringing it to `|z| ≤ tan(π/8)`: once in double precision (to `tan(π/16)`), which a
    /// root and a division buy more cheaply than the series' terms; not in single precision.
    const ATAN_HALVINGS: usize;
    /// The last term `k` of the arctangent's series that this precision can see: the next,
    /// `z²ᵏ⁺³/(2k + 3)` at the largest `|z|`, is below its roundoff relative to `z` (2⁻⁶⁰ after
    /// `k = 11` at `tan(π/16)` in double precision, 2⁻²⁶ after `k = 8` at `tan(π/8)` in single).
    const ATAN_LAST_TERM: usize;
    /// The constant `c` (in every lane), of the kind of `self`.
    fn constant(self, c: f64) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// `self < other`.
    fn less(self, other: Self) -> Self::Mask;
    /// `yes` where `mask` holds, else `no`.
    fn select(mask: Self::Mask, yes: Self, no: Self) -> Self;
    /// The magnitude of `self` with the sign of `sign`.
    fn copysign(self, sign: Self) -> Self;
    /// `self × b + c`: rounded once where the lanes have a fused multiply-add (the same bits on
    /// every path of the lanes), and `self * b + c` for a number.
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        self * b + c
    }
}

impl Real for f64 {
    type Mask = bool;
    const ATAN_HALVINGS: usize = 1;
    const ATAN_LAST_TERM: usize = 11;
    #[inline(always)]
    fn constant(self, c: f64) -> Self {
        c
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn less(self, other: Self) -> bool {
        self < other
    }
    #[inline(always)]
    fn select(mask: bool, yes: Self, no: Self) -> Self {
        if mask { yes } else { no }
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f64::copysign(self, sign)
    }
}

/// One `f32` per lane of the SIMD registers of `S` (twice the lanes an `f64` would have), for
/// formulas whose inputs are small differences (a constraint's particles relative to its first).
#[derive(Debug, Clone, Copy)]
pub struct Lanes32<S: Simd> {
    /// The instruction set.
    pub simd: S,
    /// The values.
    pub v: S::f32s,
}

impl<S: Simd> Lanes32<S> {
    /// The lanes' values from the first `S::F32_LANES` entries of `values` (which has at least that
    /// many).
    #[inline(always)]
    pub fn load(simd: S, values: &[f32]) -> Self {
        Self { simd, v: bytemuck::pod_read_unaligned(bytemuck::cast_slice(&values[..S::F32_LANES])) }
    }

    /// Write the lanes' values into the first `S::F32_LANES` entries of `out`.
    #[inline(always)]
    pub fn store(self, out: &mut [f32]) {
        out[..S::F32_LANES].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(&self.v)));
    }
}

macro_rules! binary {
    ($trait:ident, $method:ident, $op:ident) => {
        impl<S: Simd> $trait for Lanes32<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                Self { simd: self.simd, v: self.simd.$op(self.v, other.v) }
            }
        }
    };
}

binary!(Add, add, add_f32s);
binary!(Sub, sub, sub_f32s);
binary!(Mul, mul, mul_f32s);
binary!(Div, div, div_f32s);

impl<S: Simd> Neg for Lanes32<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self { simd: self.simd, v: self.simd.xor_f32s(self.v, self.simd.splat_f32s(-0.0)) }
    }
}

impl<S: Simd> Real for Lanes32<S> {
    type Mask = S::m32s;
    const ATAN_HALVINGS: usize = 0;
    const ATAN_LAST_TERM: usize = 8;
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        Self { simd: self.simd, v: self.simd.mul_add_f32s(self.v, b.v, c.v) }
    }
    #[inline(always)]
    fn constant(self, c: f64) -> Self {
        Self { simd: self.simd, v: self.simd.splat_f32s(c as f32) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Self { simd: self.simd, v: self.simd.sqrt_f32s(self.v) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Self { simd: self.simd, v: self.simd.abs_f32s(self.v) }
    }
    #[inline(always)]
    fn less(self, other: Self) -> S::m32s {
        self.simd.less_than_f32s(self.v, other.v)
    }
    #[inline(always)]
    fn select(mask: S::m32s, yes: Self, no: Self) -> Self {
        Self { simd: yes.simd, v: yes.simd.select_f32s(mask, yes.v, no.v) }
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        let s = self.simd;
        let bit = s.and_f32s(sign.v, s.splat_f32s(-0.0));
        Self { simd: s, v: s.or_f32s(s.abs_f32s(self.v), bit) }
    }
}

/// A 3-vector of [`Real`]s.
pub type V3<N> = [N; 3];

/// `a + b`.
#[inline(always)]
pub fn add<N: Real>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
#[inline(always)]
pub fn sub<N: Real>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `−a`.
#[inline(always)]
pub fn neg<N: Real>(a: V3<N>) -> V3<N> {
    [-a[0], -a[1], -a[2]]
}

/// `s a`.
#[inline(always)]
pub fn scale<N: Real>(a: V3<N>, s: N) -> V3<N> {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a · b`.
#[inline(always)]
pub fn dot<N: Real>(a: V3<N>, b: V3<N>) -> N {
    // For a number, `(a₀b₀ + a₁b₁) + a₂b₂`: addition commutes exactly.
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// `a × b`.
#[inline(always)]
pub fn cross<N: Real>(a: V3<N>, b: V3<N>) -> V3<N> {
    // For a number, `x + (−y)` is exactly `x − y`.
    [a[1].mul_add(b[2], -(a[2] * b[1])), a[2].mul_add(b[0], -(a[0] * b[2])), a[0].mul_add(b[1], -(a[1] * b[0]))]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same formula gives in every lane what it gives for one number, to single precision.
    #[test]
    fn lanes_agree_with_numbers() {
        struct Check;
        impl pulp::WithSimd for Check {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                let n = S::F32_LANES;
                // Inputs exact in single precision; both signs, and both branches of the select.
                let xs: Vec<f32> = (0..n).map(|k| k as f32 * 0.75 - 1.25).collect();
                let ys: Vec<f32> = (0..n).map(|k| 2.0 - k as f32 * 0.875).collect();
                let f = |x: f64, y: f64| {
                    let m = x.abs().less(y);
                    f64::select(m, (x * y).sqrt(), -(x / y)).copysign(y) + x.constant(0.5)
                };
                let (x, y) = (Lanes32::load(simd, &xs), Lanes32::load(simd, &ys));
                let m = x.abs().less(y);
                let out = Lanes32::select(m, (x * y).sqrt(), -(x / y)).copysign(y) + x.constant(0.5);
                let mut got = vec![0.0f32; n];
                out.store(&mut got);
                for k in 0..n {
                    let want = f(f64::from(xs[k]), f64::from(ys[k]));
                    let got = f64::from(got[k]);
                    let close = (got - want).abs() <= 1e-6 * want.abs().max(1.0);
                    assert!(close || (got.is_nan() && want.is_nan()), "lane {k}: {got} vs {want}");
                }
            }
        }
        pulp::Arch::new().dispatch(Check);
    }
}
