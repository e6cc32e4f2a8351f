//! The rotate gizmo of an orientation constraint, drawn with the frame's line primitives: three
//! rings (red, green, blue) around the vertex, each perpendicular to one axis of the target rotation,
//! with that axis drawn through the centre. At rest the rings lie in the world's coordinate planes;
//! as the pointer turns the constraint, they turn with it.

use glam::{DQuat, DVec3};

use crate::render::Frame;

/// Ring colours for the rotated x, y and z axes.
const AXIS_COLOURS: [[f32; 4]; 3] = [[0.9, 0.15, 0.1, 1.0], [0.15, 0.75, 0.2, 1.0], [0.15, 0.35, 0.95, 1.0]];
/// Segments per ring.
const SEGMENTS: usize = 48;

/// Add the gizmo for an orientation target `rotation` (axis × angle, radians) at `centre`.
pub fn rotate_gizmo(frame: &mut Frame, centre: DVec3, rotation: DVec3, radius: f64) {
    let q = DQuat::from_scaled_axis(rotation);
    let axes = [q * DVec3::X, q * DVec3::Y, q * DVec3::Z];
    for (i, colour) in AXIS_COLOURS.into_iter().enumerate() {
        // The ring around axis i spans the other two axes.
        let (u, v) = (axes[(i + 1) % 3] * radius, axes[(i + 2) % 3] * radius);
        let point = |k: usize| {
            let t = std::f64::consts::TAU * k as f64 / SEGMENTS as f64;
            centre + u * t.cos() + v * t.sin()
        };
        for k in 0..SEGMENTS {
            frame.line(point(k).as_vec3().to_array(), point(k + 1).as_vec3().to_array(), colour);
        }
        frame.line(
            (centre - axes[i] * radius * 0.5).as_vec3().to_array(),
            (centre + axes[i] * radius * 1.3).as_vec3().to_array(),
            colour,
        );
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// Every endpoint of the lines drawn in `colour`.
    fn points(frame: &Frame, colour: [f32; 4]) -> Vec<Vec3> {
        frame
            .lines
            .iter()
            .filter(|l| l.color == colour)
            .flat_map(|l| [Vec3::from(l.start), Vec3::from(l.end)])
            .collect()
    }

    #[test]
    fn rings_surround_the_vertex_in_the_rotated_planes() {
        let centre = DVec3::new(0.2, 0.1, -0.3);
        let mut frame = Frame::default();
        // A quarter turn about z takes x to y: the red ring (around the rotated x axis) lies in the
        // plane y = const, where the unrotated one would lie in x = const.
        rotate_gizmo(&mut frame, centre, DVec3::Z * std::f64::consts::FRAC_PI_2, 0.1);
        assert_eq!(frame.lines.len(), 3 * (SEGMENTS + 1));
        let red = points(&frame, AXIS_COLOURS[0]);
        let c = centre.as_vec3();
        let on_ring: Vec<&Vec3> = red.iter().filter(|p| ((**p - c).length() - 0.1).abs() < 1e-5).collect();
        assert_eq!(on_ring.len(), 2 * SEGMENTS, "every ring segment is on the circle");
        assert!(on_ring.iter().all(|p| (p.y - c.y).abs() < 1e-6), "the red ring lies in the rotated plane");
        assert!(on_ring.iter().any(|p| (p.x - c.x).abs() > 0.09), "and not in the rest plane");
        // The red axis line points along the rotated x axis, i.e. world y.
        let axis_tip = red.iter().copied().max_by(|a, b| (a.y).total_cmp(&b.y)).unwrap();
        assert!((axis_tip - (c + Vec3::Y * 0.13)).length() < 1e-5, "{axis_tip}");
    }
}
