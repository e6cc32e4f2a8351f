//! Wind: a uniform air velocity with optional gusts, acting on every triangle as aerodynamic drag on
//! the normal component of the relative velocity — the one implementation every method uses (cloth,
//! position-based cloth, and the shells, whose modal methods project it onto their modes like gravity).
//!
//! For a triangle of area `A`, unit normal `n̂` and mean velocity `v`, with the air at `w`:
//! `v_n = (v − w)·n̂` and `F = −½ ρ C_d A |v_n| v_n n̂`, a third to each vertex. A sheet facing the
//! wind is pushed along it, one edge-on (`(v − w) ⟂ n̂`) feels nothing, and a sheet moving with the
//! air feels nothing either. Gusts scale the wind speed by `1 + g s(t)`, `s` a smooth, seeded sum of
//! four sines of incommensurate frequencies (values in about [−1, 1]), so a run is reproducible.

use glam::DVec3;

use crate::scene::{Setup, WindSpec};
use crate::solver::params::{self, Param, Redo};
use crate::solver::{ParamSpec, ParamValue, SolverError};

const fn spec(name: &'static str, label: &'static str, unit: &'static str, help: &'static str) -> ParamSpec {
    ParamSpec::linear(name, label, unit, help, -100.0, 100.0)
}

const WIND_X: ParamSpec =
    spec("wind_x", "wind x", "m/s", "Mean air velocity, x component (drag on the cloth's or shell's triangles).")
        .in_scene("wind.velocity[0]");
const WIND_Y: ParamSpec =
    spec("wind_y", "wind y", "m/s", "Mean air velocity, y component.").in_scene("wind.velocity[1]");
const WIND_Z: ParamSpec =
    spec("wind_z", "wind z", "m/s", "Mean air velocity, z component.").in_scene("wind.velocity[2]");
const GUST: ParamSpec =
    ParamSpec::linear("wind_gust", "gusts", "", "Relative amplitude of the gusts (0: steady).", 0.0, 1.0)
        .in_scene("wind.gust");

/// What the scene sets once and the panel does not tune: the air's drag coefficient and density, and
/// the gusts' base frequency.
const SCENE_ONLY: [ParamSpec; 3] = [
    ParamSpec::linear("wind_drag", "drag coefficient", "", "Drag coefficient of the normal flow.", 0.0, 100.0)
        .in_scene("wind.drag"),
    ParamSpec::linear("air_density", "air density", "kg/m³", "Density of the air.", 0.0, 1e3)
        .in_scene("wind.air_density"),
    ParamSpec::linear("gust_frequency", "gust frequency", "Hz", "Base frequency of the gusts.", 0.0, 1e3)
        .in_scene("wind.gust_frequency"),
];

/// The wind's parameters, the same in every method's panel: the mean air velocity and the gusts.
pub const PARAMS: &[Param<Wind>] = &[
    Param::new(WIND_X, |w| w.velocity.x, |w, v| w.velocity.x = v, Redo::Nothing),
    Param::new(WIND_Y, |w| w.velocity.y, |w, v| w.velocity.y = v, Redo::Nothing),
    Param::new(WIND_Z, |w| w.velocity.z, |w, v| w.velocity.z = v, Redo::Nothing),
    Param::new(GUST, |w| w.gust, |w, v| w.gust = v, Redo::Nothing),
];

/// The wind of a scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wind {
    /// Mean air velocity, m/s.
    pub velocity: DVec3,
    /// Drag coefficient `C_d` of the normal flow.
    pub drag: f64,
    /// Air density `ρ`, kg/m³.
    pub density: f64,
    /// Relative gust amplitude `g` (0: steady).
    pub gust: f64,
    /// Base frequency of the gusts, Hz.
    pub gust_frequency: f64,
    /// Phases of the four gust components (from the seed).
    phases: [f64; 4],
}

/// Frequencies of the gust components, as multiples of the base frequency.
const GUST_HARMONICS: [f64; 4] = [1.0, 1.93, 3.71, 7.13];

impl Wind {
    /// The scene's wind, its values checked against the parameters' ranges.
    pub fn of(setup: &Setup) -> Result<Self, SolverError> {
        params::check_scene(params::specs(PARAMS).chain(&SCENE_ONLY), setup)?;
        Ok(Self::new(&setup.scene.wind))
    }

    /// From the scene's `[wind]` table.
    fn new(spec: &WindSpec) -> Self {
        let mut state = spec.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1);
        let phases = [0.0; 4].map(|_: f64| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            std::f64::consts::TAU * ((state >> 11) as f64 / (1u64 << 53) as f64)
        });
        Self {
            velocity: DVec3::from(spec.velocity),
            drag: spec.drag,
            density: spec.air_density,
            gust: spec.gust,
            gust_frequency: spec.gust_frequency,
            phases,
        }
    }

    /// Whether there is any wind.
    pub fn is_calm(&self) -> bool {
        self.velocity == DVec3::ZERO || self.drag == 0.0 || self.density == 0.0
    }

    /// The air velocity at time `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        if self.gust == 0.0 {
            return self.velocity;
        }
        let s: f64 = GUST_HARMONICS
            .iter()
            .zip(&self.phases)
            .map(|(m, p)| (std::f64::consts::TAU * self.gust_frequency * m * t + p).sin() / m.sqrt())
            .sum::<f64>()
            / GUST_HARMONICS.iter().map(|m| 1.0 / m.sqrt()).sum::<f64>();
        self.velocity * (1.0 + self.gust * s)
    }

    /// Current values of [`PARAMS`].
    pub fn params(&self) -> Vec<ParamValue> {
        params::values(PARAMS, self)
    }

    /// Set one of [`PARAMS`] (checked against its range); `Ok(false)` if `name` is not one of them.
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<bool, SolverError> {
        Ok(params::assign(PARAMS, self, name, value)?.is_some())
    }

    /// `base` plus the wind's force on every vertex (N), for the mesh at `positions` moving with
    /// `velocities`, at time `t`.
    pub fn forces(
        &self,
        t: f64,
        (positions, velocities): (&[DVec3], &[DVec3]),
        triangles: &[[usize; 3]],
        base: &[DVec3],
    ) -> Vec<DVec3> {
        let mut f = base.to_vec();
        self.add_forces(t, positions, velocities, triangles, &mut f);
        f
    }

    /// Add the wind's force on every vertex (N) to `forces`, for the mesh at `positions` moving with
    /// `velocities`, at time `t`.
    pub fn add_forces(
        &self,
        t: f64,
        positions: &[DVec3],
        velocities: &[DVec3],
        triangles: &[[usize; 3]],
        forces: &mut [DVec3],
    ) {
        if self.is_calm() {
            return;
        }
        let air = self.at(t);
        for tri in triangles {
            let [a, b, c] = tri.map(|i| positions[i]);
            let n2 = (b - a).cross(c - a); // twice the area times the unit normal
            let area2 = n2.length();
            if area2 == 0.0 {
                continue;
            }
            let n = n2 / area2;
            let v = (velocities[tri[0]] + velocities[tri[1]] + velocities[tri[2]]) / 3.0;
            let vn = (v - air).dot(n);
            let f = n * (-0.5 * self.density * self.drag * 0.5 * area2 * vn.abs() * vn / 3.0);
            tri.iter().for_each(|&i| forces[i] += f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(velocity: [f64; 3], gust: f64, seed: u64) -> WindSpec {
        WindSpec { velocity, drag: 1.2, air_density: 1.2, gust, gust_frequency: 0.5, seed }
    }

    fn square(normal_axis: usize) -> Vec<DVec3> {
        let (u, v) = match normal_axis {
            0 => (DVec3::Y, DVec3::Z),
            1 => (DVec3::Z, DVec3::X),
            _ => (DVec3::X, DVec3::Y),
        };
        vec![DVec3::ZERO, u, u + v, v]
    }

    const QUAD: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    #[test]
    fn a_sheet_facing_the_wind_is_pushed_one_edge_on_is_not_and_calm_air_does_nothing() {
        let wind = Wind::new(&spec([5.0, 0.0, 0.0], 0.0, 1));
        let still = vec![DVec3::ZERO; 4];
        let total = |x: &[DVec3], w: &Wind| {
            let mut f = vec![DVec3::ZERO; 4];
            w.add_forces(0.0, x, &still, &QUAD, &mut f);
            f.iter().sum::<DVec3>()
        };
        // Facing (normal along x): ½ ρ C_d A v² = 0.5 × 1.2 × 1.2 × 1 × 25 = 18 N along the wind.
        let facing = total(&square(0), &wind);
        assert!((facing - DVec3::new(18.0, 0.0, 0.0)).length() < 1e-12, "{facing}");
        // Edge-on (normal along y or z): nothing.
        assert_eq!(total(&square(1), &wind), DVec3::ZERO);
        assert_eq!(total(&square(2), &wind), DVec3::ZERO);
        assert_eq!(total(&square(0), &Wind::new(&spec([0.0; 3], 0.0, 1))), DVec3::ZERO);
        // A sheet moving with the air feels nothing.
        let mut f = vec![DVec3::ZERO; 4];
        wind.add_forces(0.0, &square(0), &[DVec3::new(5.0, 0.0, 0.0); 4], &QUAD, &mut f);
        assert!(f.iter().all(|f| f.length() < 1e-12));
    }

    #[test]
    fn gusts_are_smooth_bounded_and_reproducible_from_their_seed() {
        let (a, b, c) = (
            Wind::new(&spec([4.0, 0.0, 0.0], 0.5, 7)),
            Wind::new(&spec([4.0, 0.0, 0.0], 0.5, 7)),
            Wind::new(&spec([4.0, 0.0, 0.0], 0.5, 8)),
        );
        let samples: Vec<f64> = (0..1000).map(|i| a.at(i as f64 * 0.01).x).collect();
        assert!(samples.iter().all(|s| (2.0..=6.0).contains(s)), "within 1 ± 0.5 of the mean");
        assert!(samples.windows(2).all(|w| (w[1] - w[0]).abs() < 0.2), "smooth in time");
        assert!(samples.iter().any(|s| (s - 4.0).abs() > 0.5), "gusty");
        assert!((0..100).all(|i| a.at(i as f64 * 0.1) == b.at(i as f64 * 0.1)), "the same seed, the same gusts");
        assert!((0..100).any(|i| a.at(i as f64 * 0.1) != c.at(i as f64 * 0.1)), "another seed, other gusts");
    }
}
