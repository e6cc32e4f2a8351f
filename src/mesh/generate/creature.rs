//! A closed, organic-looking shell (a four-legged creature) for the modal-warping demos.

use glam::DVec3;

use super::sphere::unit_icosphere;
use crate::mesh::{MeshError, TriMesh};

/// Semi-axes of the body ellipsoid before scaling (x is the long axis, y is up).
const BODY: DVec3 = DVec3::new(1.0, 0.5, 0.45);

/// One Gaussian-like bump of the radial function: `amplitude · exp((d̂·dir − 1) / width)`.
struct Lobe {
    dir: DVec3,
    amplitude: f64,
    width: f64,
}

fn lobes() -> Vec<Lobe> {
    let lobe = |d: [f64; 3], amplitude, width| Lobe { dir: DVec3::from_array(d).normalize(), amplitude, width };
    let mut l = vec![
        lobe([1.0, 0.6, 0.0], 0.55, 0.03),   // head, forward and up
        lobe([1.0, 0.45, 0.0], 0.25, 0.008), // snout
        lobe([-1.0, 0.3, 0.0], 1.0, 0.004),  // tail, back, long and thin
        lobe([0.0, 1.0, 0.0], 0.12, 0.15),   // back ridge
        lobe([0.0, -1.0, 0.0], 0.08, 0.2),   // belly
    ];
    for (sx, sz) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        l.push(lobe([0.5 * sx, -1.0, 0.55 * sz], 1.4, 0.015)); // legs, down at the corners
    }
    for sz in [1.0, -1.0] {
        l.push(lobe([0.8, 1.0, 0.3 * sz], 0.5, 0.004)); // ears
    }
    l
}

/// Star-shaped radius along unit direction `d`: the ellipsoid radius times `1 + Σ lobes`.
fn radius(d: DVec3, lobes: &[Lobe]) -> f64 {
    let ellipsoid = 1.0 / (d / BODY).length();
    let bumps: f64 = lobes.iter().map(|l| l.amplitude * ((d.dot(l.dir) - 1.0) / l.width).exp()).sum();
    ellipsoid * (1.0 + bumps)
}

/// Unscaled creature: positions `r(d̂)·d̂` about the origin, and the icosphere's triangles.
fn star_shape(frequency: usize) -> Result<(Vec<DVec3>, Vec<[usize; 3]>), MeshError> {
    let (dirs, triangles) = unit_icosphere(frequency)?;
    let lobes = lobes();
    Ok((dirs.into_iter().map(|d| d * radius(d, &lobes)).collect(), triangles))
}

/// A closed, organic-looking shell: a four-legged creature with a head (forward, +x, and up),
/// two ears, a long thin tail (−x) and four legs, `length` long along x, standing on y = 0
/// (lowest point at y = 0) and centred on x = z = 0.
///
/// Built from [`super::icosphere`] of `frequency` (so `10·frequency² + 2` vertices; 12,962 for
/// frequency 36) by moving each vertex along its direction `d̂` to radius
/// `r(d̂) = ellipsoid(d̂) · (1 + Σ_k a_k exp((d̂·c_k − 1)/σ_k))` with fixed lobes `c_k`. The surface is
/// star-shaped about the body centre, so it can never self-intersect and every triangle stays
/// outward-facing. Deterministic. Low frequencies give a blobby shape; lobes resolve from ~16 up.
pub fn creature(length: f64, frequency: usize) -> Result<TriMesh, MeshError> {
    if !(length.is_finite() && length > 0.0) {
        return Err(MeshError::BadParameter { name: "length", reason: format!("must be positive, got {length}") });
    }
    let (positions, triangles) = star_shape(frequency)?;
    let (lo, hi) = crate::mesh::bounds(&positions);
    let scale = length / (hi.x - lo.x);
    let shift = DVec3::new(-(lo.x + hi.x) / 2.0, -lo.y, -(lo.z + hi.z) / 2.0);
    TriMesh::new(positions.into_iter().map(|p| (p + shift) * scale).collect(), triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn creature_at_frequency_36_is_closed_and_sized() {
        let length = 2.0;
        let m = creature(length, 36).unwrap();
        assert_eq!(m.vertex_count(), 12_962);
        assert!(m.topology().boundary_edges.is_empty());
        let euler = m.vertex_count() as isize - m.topology().edges.len() as isize + m.triangles().len() as isize;
        assert_eq!(euler, 2);
        let (lo, hi) = m.bounding_box();
        assert!(((hi.x - lo.x) / length - 1.0).abs() < 0.1, "x extent {}", hi.x - lo.x);
        assert!(lo.y.abs() < 1e-12, "stands on y = 0, min y {}", lo.y);
        assert!((lo.x + hi.x).abs() < 1e-12 && (lo.z + hi.z).abs() < 1e-12);
        // Deterministic.
        assert_eq!(m, creature(length, 36).unwrap());
    }

    #[test]
    fn lobes_exist() {
        let length = 2.0;
        let m = creature(length, 36).unwrap();
        let p = m.positions();
        let max_y = |keep: &dyn Fn(&DVec3) -> bool| p.iter().filter(|q| keep(q)).map(|q| q.y).fold(f64::MIN, f64::max);
        let head = max_y(&|q| q.x > 0.25 * length);
        let middle = max_y(&|q| q.x.abs() < 0.1 * length);
        assert!(head > middle + 0.02 * length, "head top {head} vs back {middle}");
        // Four legs: each quadrant reaches the ground, the middle of the belly does not.
        for (sx, sz) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let low = p.iter().filter(|q| q.x * sx > 0.0 && q.z * sz > 0.0).map(|q| q.y).fold(f64::MAX, f64::min);
            assert!(low < 0.01 * length, "leg ({sx}, {sz}) bottom at {low}");
        }
        let belly = p.iter().filter(|q| q.x.abs() < 0.05 * length && q.z.abs() < 0.05 * length);
        assert!(belly.map(|q| q.y).fold(f64::MAX, f64::min) > 0.1 * length, "legs should be long");
        // Tail: the rear tenth is thin.
        let rear = p.iter().filter(|q| q.x < -0.4 * length);
        let half_width = rear.map(|q| q.z.abs()).fold(0.0, f64::max);
        assert!(half_width < 0.05 * length, "tail half-width {half_width}");
    }

    #[test]
    fn star_shaped_so_every_face_is_outward() {
        // Every triangle spans a positive cone from the star centre: no folds, no self-intersection.
        let (p, t) = star_shape(36).unwrap();
        for tri in &t {
            let [a, b, c] = tri.map(|i| p[i]);
            assert!(a.dot(b.cross(c)) > 0.0);
        }
    }

    #[test]
    fn low_frequency_still_valid_and_bad_parameters_refused() {
        for f in 1..=4 {
            let m = creature(1.0, f).unwrap();
            assert_eq!(m.vertex_count(), 10 * f * f + 2);
        }
        assert!(creature(0.0, 8).is_err());
        assert!(creature(f64::NAN, 8).is_err());
        assert!(creature(1.0, 0).is_err());
        assert!(matches!(creature(1.0, 1000), Err(MeshError::BadParameter { name: "frequency", .. })));
    }
}
