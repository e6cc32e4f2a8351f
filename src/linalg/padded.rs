//! Per-particle 3-vectors padded to four lanes, for the hot loops over particles and springs.
//!
//! A [`DVec3`] takes two loads and two stores (16 + 8 bytes); a [`Padded`] is 32 bytes, 32-byte
//! aligned, so a kernel compiled for AVX2 ([`super::isa`]) moves it with one instruction and does its
//! arithmetic on all lanes at once. The fourth lane is zero in every vector built by [`Padded::from`],
//! and the operations keep it zero (sums, differences and finite scalings of zeros), so dot products over
//! four lanes are the 3-vector ones.

use glam::{DMat3, DVec3};

/// A 3-vector in four lanes, the last one zero.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C, align(32))]
pub struct Padded([f64; 4]);

impl Padded {
    /// The zero vector.
    pub const ZERO: Self = Self([0.0; 4]);

    /// `self · other`.
    #[inline(always)]
    pub fn dot(self, other: Self) -> f64 {
        let ([a, b, c, d], [e, g, h, k]) = (self.0, other.0);
        (a * e + c * h) + (b * g + d * k)
    }

    /// `self − v s`, each lane one fused multiply-add: a single instruction in a kernel compiled
    /// for AVX2 + FMA ([`super::isa`]), a (slow, equally exact) library call outside one.
    #[inline(always)]
    pub fn minus_scaled(self, v: Self, s: f64) -> Self {
        let ([a, b, c, d], [e, g, h, k]) = (self.0, v.0);
        Self([(-e).mul_add(s, a), (-g).mul_add(s, b), (-h).mul_add(s, c), (-k).mul_add(s, d)])
    }

    /// Lane `k` (`k < 3` for the vector's components).
    #[inline(always)]
    pub fn lane(self, k: usize) -> f64 {
        self.0[k]
    }
}

/// A 3 × 3 matrix as three padded columns.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PaddedMat3([Padded; 3]);

impl PaddedMat3 {
    /// The matrix with these columns.
    #[inline(always)]
    pub fn from_cols(c0: Padded, c1: Padded, c2: Padded) -> Self {
        Self([c0, c1, c2])
    }

    /// `self v`.
    #[inline(always)]
    pub fn times(&self, v: Padded) -> Padded {
        let [c0, c1, c2] = self.0;
        c0 * v.lane(0) + c1 * v.lane(1) + c2 * v.lane(2)
    }
}

impl From<DMat3> for PaddedMat3 {
    fn from(m: DMat3) -> Self {
        Self([m.x_axis.into(), m.y_axis.into(), m.z_axis.into()])
    }
}

impl From<PaddedMat3> for DMat3 {
    fn from(m: PaddedMat3) -> Self {
        let [c0, c1, c2] = m.0;
        DMat3::from_cols(c0.into(), c1.into(), c2.into())
    }
}

impl std::ops::AddAssign for PaddedMat3 {
    #[inline(always)]
    fn add_assign(&mut self, other: Self) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }
}

impl From<DVec3> for Padded {
    #[inline(always)]
    fn from(v: DVec3) -> Self {
        Self([v.x, v.y, v.z, 0.0])
    }
}

impl From<Padded> for DVec3 {
    #[inline(always)]
    fn from(v: Padded) -> Self {
        DVec3::new(v.0[0], v.0[1], v.0[2])
    }
}

impl std::ops::Add for Padded {
    type Output = Self;
    #[inline(always)]
    fn add(self, other: Self) -> Self {
        let ([a, b, c, d], [e, g, h, k]) = (self.0, other.0);
        Self([a + e, b + g, c + h, d + k])
    }
}

impl std::ops::Sub for Padded {
    type Output = Self;
    #[inline(always)]
    fn sub(self, other: Self) -> Self {
        let ([a, b, c, d], [e, g, h, k]) = (self.0, other.0);
        Self([a - e, b - g, c - h, d - k])
    }
}

impl std::ops::Mul<f64> for Padded {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: f64) -> Self {
        let [a, b, c, d] = self.0;
        Self([a * s, b * s, c * s, d * s])
    }
}

impl std::ops::AddAssign for Padded {
    #[inline(always)]
    fn add_assign(&mut self, other: Self) {
        *self = *self + other;
    }
}

impl std::ops::SubAssign for Padded {
    #[inline(always)]
    fn sub_assign(&mut self, other: Self) {
        *self = *self - other;
    }
}

/// `v` padded.
pub fn pad(v: &[DVec3]) -> Vec<Padded> {
    v.iter().map(|&v| v.into()).collect()
}

/// `out = v` unpadded.
pub fn unpad(v: &[Padded], out: &mut [DVec3]) {
    for (o, v) in out.iter_mut().zip(v) {
        *o = (*v).into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operations_match_the_3_vector_ones_and_keep_the_pad_zero() {
        let (a, b) = (DVec3::new(0.3, -1.2, 2.5), DVec3::new(-0.7, 0.4, 1.1));
        let m = DMat3::from_cols_array(&[1.0, 2.0, -3.0, 0.5, -1.5, 2.5, 4.0, 0.25, -0.75]);
        let (pa, pb) = (Padded::from(a), Padded::from(b));
        assert_eq!(DVec3::from(pa + pb), a + b);
        assert_eq!(DVec3::from(pa - pb), a - b);
        assert_eq!(DVec3::from(pa * 1.5), a * 1.5);
        assert!((pa.dot(pb) - a.dot(b)).abs() < 1e-15);
        let pm = PaddedMat3::from(m);
        assert!((DVec3::from(pm.times(pa)) - m * a).length() < 1e-14);
        let mut sum = pm;
        sum += PaddedMat3::from_cols(pa, pb, pa);
        assert_eq!(DMat3::from(sum), m + DMat3::from_cols(a, b, a));
        for v in [pa + pb, pa - pb, pa * 1.5, pm.times(pa)] {
            assert_eq!(v.0[3], 0.0);
        }
    }
}
