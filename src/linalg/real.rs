//! One formula for a number and for a vector of numbers: the arithmetic that the constraint functions
//! of position-based dynamics are written in ([`Real`]), implemented by `f64` (one constraint) and by
//! [`Lanes`] (one constraint per SIMD lane, in the instruction set [`pulp`] chose at run time). The
//! scalar instance is what the finite-difference tests check; the vector instance is what the sweeps
//! run, so both are the same source. Every method is `#[inline(always)]` so that a dispatched kernel
//! compiles it with the wide instructions.

use std::ops::{Add, Div, Mul, Neg, Sub};

use pulp::Simd;

/// Arithmetic on a number or on lanes of numbers.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// The result of a comparison (per lane).
    type Mask: Copy;
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
}

impl Real for f64 {
    type Mask = bool;
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

/// One `f64` per lane of the SIMD registers of `S`.
#[derive(Debug, Clone, Copy)]
pub struct Lanes<S: Simd> {
    /// The instruction set.
    pub simd: S,
    /// The values.
    pub v: S::f64s,
}

impl<S: Simd> Lanes<S> {
    /// The lanes' values from the first `S::F64_LANES` entries of `values` (which has at least that
    /// many).
    #[inline(always)]
    pub fn load(simd: S, values: &[f64]) -> Self {
        Self { simd, v: bytemuck::pod_read_unaligned(bytemuck::cast_slice(&values[..S::F64_LANES])) }
    }

    /// Write the lanes' values into the first `S::F64_LANES` entries of `out`.
    #[inline(always)]
    pub fn store(self, out: &mut [f64]) {
        out[..S::F64_LANES].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(&self.v)));
    }
}

macro_rules! binary {
    ($trait:ident, $method:ident, $op:ident) => {
        impl<S: Simd> $trait for Lanes<S> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                Self { simd: self.simd, v: self.simd.$op(self.v, other.v) }
            }
        }
    };
}

binary!(Add, add, add_f64s);
binary!(Sub, sub, sub_f64s);
binary!(Mul, mul, mul_f64s);
binary!(Div, div, div_f64s);

impl<S: Simd> Neg for Lanes<S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self { simd: self.simd, v: self.simd.xor_f64s(self.v, self.simd.splat_f64s(-0.0)) }
    }
}

impl<S: Simd> Real for Lanes<S> {
    type Mask = S::m64s;
    #[inline(always)]
    fn constant(self, c: f64) -> Self {
        Self { simd: self.simd, v: self.simd.splat_f64s(c) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Self { simd: self.simd, v: self.simd.sqrt_f64s(self.v) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Self { simd: self.simd, v: self.simd.abs_f64s(self.v) }
    }
    #[inline(always)]
    fn less(self, other: Self) -> S::m64s {
        self.simd.less_than_f64s(self.v, other.v)
    }
    #[inline(always)]
    fn select(mask: S::m64s, yes: Self, no: Self) -> Self {
        Self { simd: yes.simd, v: yes.simd.select_f64s(mask, yes.v, no.v) }
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        let s = self.simd;
        let bit = s.and_f64s(sign.v, s.splat_f64s(-0.0));
        Self { simd: s, v: s.or_f64s(s.abs_f64s(self.v), bit) }
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
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[inline(always)]
pub fn cross<N: Real>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same formula gives the same numbers in every lane as for one number.
    #[test]
    fn lanes_agree_with_numbers() {
        struct Check;
        impl pulp::WithSimd for Check {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                let n = S::F64_LANES;
                let xs: Vec<f64> = (0..n).map(|k| k as f64 * 0.7 - 1.3).collect();
                let ys: Vec<f64> = (0..n).map(|k| 2.1 - k as f64 * 0.9).collect();
                let f = |x: f64, y: f64| {
                    let m = x.abs().less(y);
                    f64::select(m, (x * y).sqrt(), -(x / y)).copysign(y) + x.constant(0.5)
                };
                let (x, y) = (Lanes::load(simd, &xs), Lanes::load(simd, &ys));
                let m = x.abs().less(y);
                let out = Lanes::select(m, (x * y).sqrt(), -(x / y)).copysign(y) + x.constant(0.5);
                let mut got = vec![0.0; n];
                out.store(&mut got);
                for k in 0..n {
                    let want = f(xs[k], ys[k]);
                    assert!(got[k] == want || (got[k].is_nan() && want.is_nan()), "lane {k}: {} vs {want}", got[k]);
                }
            }
        }
        pulp::Arch::new().dispatch(Check);
    }
}
