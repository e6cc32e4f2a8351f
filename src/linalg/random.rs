//! A small deterministic pseudo-random generator (xorshift64): the same numbers on every machine,
//! for the tests' random configurations and the cubature's training poses.

use glam::DVec3;

/// xorshift64 state; any non-zero seed.
#[derive(Debug, Clone)]
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in `[−1, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// A point with uniform coordinates in `[−1, 1)`.
    pub fn vec(&mut self) -> DVec3 {
        DVec3::new(self.uniform(), self.uniform(), self.uniform())
    }

    /// A standard normal sample (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = 0.5 * (self.uniform() + 1.0);
        let v = 0.5 * (self.uniform() + 1.0);
        (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::Rng;

    #[test]
    fn normal_samples_have_zero_mean_and_unit_variance() {
        let mut rng = Rng(99);
        let n = 20_000;
        let s: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mean = s.iter().sum::<f64>() / n as f64;
        let var = s.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.03 && (var - 1.0).abs() < 0.03, "mean {mean}, variance {var}");
        assert!(s.iter().all(|x| x.is_finite()));
    }
}
