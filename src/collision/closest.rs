//! Closest points: of a triangle to a point (Ericson, *Real-Time Collision Detection*, §5.1.5, by
//! Voronoi regions) and of two segments to each other (§5.1.9), for contacts and self-collision.

use glam::DVec3;

/// The part of a triangle `[a, b, c]` a closest point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Corner `k` (`a`, `b`, `c`).
    Vertex(usize),
    /// Edge `k`: 0 is `ab`, 1 is `bc`, 2 is `ca`.
    Edge(usize),
    /// The interior.
    Face,
}

/// The barycentric coordinates of the point of triangle `[a, b, c]` closest to `p`, and its feature.
pub fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> ([f64; 3], Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], Feature::Vertex(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return ([1.0 - v, v, 0.0], Feature::Edge(0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return ([1.0 - w, 0.0, w], Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return ([0.0, 1.0 - w, w], Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    ([1.0 - v - w, v, w], Feature::Face)
}

/// The point with barycentric coordinates `b` in the triangle `t`.
pub fn at(t: [DVec3; 3], b: [f64; 3]) -> DVec3 {
    t[0] * b[0] + t[1] * b[1] + t[2] * b[2]
}

/// Parameters `(s, t)` of the closest points `a₀ + s(a₁ − a₀)`, `b₀ + t(b₁ − b₀)` of two segments.
pub fn closest_on_segments([a0, a1]: [DVec3; 2], [b0, b1]: [DVec3; 2]) -> (f64, f64) {
    let (d1, d2, r) = (a1 - a0, b1 - b0, a0 - b0);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    if a <= 1e-300 || e <= 1e-300 {
        return (0.0, 0.0);
    }
    let (b, c) = (d1.dot(d2), d1.dot(r));
    let denom = a * e - b * b;
    let mut s = if denom > 1e-14 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// The vector from the closest point of segment `a` to that of segment `b`.
pub fn segment_gap(a: [DVec3; 2], b: [DVec3; 2]) -> DVec3 {
    let (s, t) = closest_on_segments(a, b);
    (b[0] + (b[1] - b[0]) * t) - (a[0] + (a[1] - a[0]) * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_points_on_a_triangle_in_each_region() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let near = |p: DVec3| {
            let (b, feature) = closest_on_triangle(p, t);
            (at(t, b), feature)
        };
        let close =
            |(p, f): (DVec3, Feature), want: DVec3, feature: Feature| (p - want).length() < 1e-15 && f == feature;
        assert!(close(near(DVec3::new(0.2, 0.3, 1.0)), DVec3::new(0.2, 0.3, 0.0), Feature::Face));
        assert!(close(near(DVec3::new(-1.0, -1.0, 0.0)), t[0], Feature::Vertex(0)));
        assert!(close(near(DVec3::new(0.5, -1.0, 0.0)), DVec3::new(0.5, 0.0, 0.0), Feature::Edge(0)));
        assert!(close(near(DVec3::new(1.0, 1.0, 0.0)), DVec3::new(0.5, 0.5, 0.0), Feature::Edge(1)));
        assert!(close(near(DVec3::new(-1.0, 0.5, 0.0)), DVec3::new(0.0, 0.5, 0.0), Feature::Edge(2)));
    }

    #[test]
    fn closest_points_of_crossing_parallel_and_end_to_end_segments() {
        let (s, t) =
            closest_on_segments([DVec3::ZERO, DVec3::X], [DVec3::new(0.3, 1.0, -1.0), DVec3::new(0.3, 1.0, 1.0)]);
        assert!((s - 0.3).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
        let (s, _) =
            closest_on_segments([DVec3::ZERO, DVec3::X], [DVec3::new(2.0, 1.0, 0.0), DVec3::new(3.0, 1.0, 0.0)]);
        assert_eq!(s, 1.0);
        let gap = segment_gap([DVec3::ZERO, DVec3::X], [DVec3::new(0.5, 2.0, 0.0), DVec3::new(0.5, 3.0, 0.0)]);
        assert!((gap - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-15);
    }
}
