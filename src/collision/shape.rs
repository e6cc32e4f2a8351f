//! A collider's geometry in its own frame, and everything that depends on the geometry alone: the
//! signed distance and outward normal contact needs, the mass properties a dynamic body needs, a
//! bounding radius for broad phases, and a triangle surface to draw. Adding a collider starts here:
//! a variant, its arm in each of these, then its scene syntax (`scene::Collider`) and its realisation
//! (`scene::Setup`).
//!
//! Signed distances: a ball `|p| − r`; a plane `p·n`; a box, outside the distance to its nearest
//! surface point and inside minus the distance to its nearest face; a closed mesh by
//! [`MeshDistance`] (nearest triangle, sign by the angle-weighted pseudo-normal).

use glam::DVec3;

use super::MeshDistance;
use crate::mesh::generate;

/// A body's geometry in its own frame (origin at its centre or reference point).
#[derive(Debug, Clone)]
pub enum Shape {
    /// A ball of this radius centred on the origin.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// The half-space below the plane through the origin with this unit normal is solid.
    Plane {
        /// Unit outward normal.
        normal: DVec3,
    },
    /// A closed triangle mesh (solid inside).
    Mesh(Box<MeshDistance>),
    /// A box centred on the origin with these half extents along the body axes.
    Cuboid {
        /// Half of each side, m.
        half: DVec3,
    },
}

impl Shape {
    /// Signed distance and outward unit normal at `p` in the body frame.
    #[inline(always)]
    pub fn surface(&self, p: DVec3) -> (f64, DVec3) {
        match self {
            Shape::Sphere { radius } => {
                let r = p.length();
                (r - radius, if r > 0.0 { p / r } else { DVec3::Y })
            }
            Shape::Plane { normal } => (p.dot(*normal), *normal),
            Shape::Mesh(mesh) => mesh.signed_distance(p),
            Shape::Cuboid { half } => box_surface(*half, p),
        }
    }

    /// The principal moments of inertia of a solid of this shape and `mass`, kg m², in the body
    /// frame: `2/5 m r²` for a ball, `m (b² + c²)/12` about each axis of a box of sides `a, b, c`;
    /// `None` for the shapes that cannot move (a plane, a mesh).
    pub fn inertia(&self, mass: f64) -> Option<DVec3> {
        match self {
            Shape::Sphere { radius } => Some(DVec3::splat(0.4 * mass * radius * radius)),
            Shape::Cuboid { half } => {
                let s = *half * 2.0;
                Some(DVec3::new(s.y * s.y + s.z * s.z, s.x * s.x + s.z * s.z, s.x * s.x + s.y * s.y) * (mass / 12.0))
            }
            Shape::Plane { .. } | Shape::Mesh(_) => None,
        }
    }

    /// The radius of the smallest ball about the origin that holds the shape, m; `None` for the
    /// unbounded plane and for a mesh (whose points are not centred on the origin).
    pub fn bounding_radius(&self) -> Option<f64> {
        match self {
            Shape::Sphere { radius } => Some(*radius),
            Shape::Cuboid { half } => Some(half.length()),
            Shape::Plane { .. } | Shape::Mesh(_) => None,
        }
    }
}

/// Signed distance and outward normal of a box of half extents `half` at `p`: outside, the distance
/// to the nearest surface point; inside, minus the distance to the nearest face.
fn box_surface(half: DVec3, p: DVec3) -> (f64, DVec3) {
    let q = p.abs() - half;
    let outside = q.max(DVec3::ZERO);
    let sign = DVec3::select(p.cmplt(DVec3::ZERO), DVec3::NEG_ONE, DVec3::ONE);
    if outside.length_squared() > 0.0 {
        let d = outside.length();
        return (d, (outside * sign) / d);
    }
    let axis = if q.x >= q.y && q.x >= q.z {
        0
    } else if q.y >= q.z {
        1
    } else {
        2
    };
    let mut n = DVec3::ZERO;
    n[axis] = sign[axis];
    (q[axis], n)
}

/// A triangle surface to draw, in the body frame: positions and counter-clockwise (outward)
/// triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Corner positions, m.
    pub positions: Vec<DVec3>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[usize; 3]>,
}

impl Shape {
    /// Its surface to draw, moved `inset` inwards (so that cloth lying on it is not hidden in it); a
    /// plane as a square of half side `extent` about its origin; `None` for a ball no larger than
    /// `inset`. A ball is an icosphere of 1,442 corners; a box has four corners per face, so that its
    /// faces shade flat.
    pub fn drawn(&self, inset: f64, extent: f64) -> Option<Surface> {
        Some(match self {
            Shape::Sphere { radius } => {
                let ball = generate::icosphere(radius - inset, 12).ok()?;
                Surface { positions: ball.positions().to_vec(), triangles: ball.triangles().to_vec() }
            }
            Shape::Plane { normal } => {
                let (t, b) = normal.any_orthonormal_pair();
                let e = extent;
                let positions = [-t * e - b * e, t * e - b * e, t * e + b * e, -t * e + b * e]
                    .map(|c| c - *normal * inset)
                    .to_vec();
                let triangles =
                    if t.cross(b).dot(*normal) > 0.0 { vec![[0, 1, 2], [0, 2, 3]] } else { vec![[0, 2, 1], [0, 3, 2]] };
                Surface { positions, triangles }
            }
            Shape::Mesh(mesh) => {
                let inward = mesh.vertex_normals().iter().map(|n| n.normalize_or_zero() * inset);
                let positions = mesh.positions().iter().zip(inward).map(|(&x, d)| x - d).collect();
                Surface { positions, triangles: mesh.triangles().to_vec() }
            }
            Shape::Cuboid { half } => cuboid(*half - DVec3::splat(inset)),
        })
    }
}

/// A box of half extents `half`: four corners per face, two outward triangles each.
fn cuboid(half: DVec3) -> Surface {
    let mut positions = Vec::with_capacity(24);
    let mut triangles = Vec::with_capacity(12);
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            let (u, v) = (DVec3::AXES[(axis + 1) % 3], DVec3::AXES[(axis + 2) % 3]);
            let base = positions.len();
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push((n + u * a + v * b) * half);
            }
            // Counter-clockwise seen from outside: u × v is +n for the positive face.
            let quad = if sign > 0.0 { [[0, 1, 2], [0, 2, 3]] } else { [[0, 2, 1], [0, 3, 2]] };
            triangles.extend(quad.map(|t| t.map(|k| base + k)));
        }
    }
    Surface { positions, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every drawn triangle faces out: its normal points away from the shape (the signed distance
    /// grows along it), and its corners lie `inset` inside the surface (a mesh's corners, moved along
    /// their pseudonormals, lie inside by at most `inset`: the nearest surface may be a face).
    #[test]
    fn drawn_surfaces_face_out_and_lie_inset_inside() {
        let inset = 0.01;
        let ball = generate::icosphere(0.5, 3).unwrap();
        let mesh = Shape::Mesh(Box::new(MeshDistance::new(&ball).unwrap()));
        for shape in [
            Shape::Sphere { radius: 0.5 },
            Shape::Cuboid { half: DVec3::new(0.3, 0.2, 0.1) },
            Shape::Plane { normal: DVec3::new(0.0, 0.6, 0.8) },
            mesh,
        ] {
            let s = shape.drawn(inset, 2.0).unwrap();
            assert!(!s.triangles.is_empty(), "{shape:?}");
            for t in &s.triangles {
                let [a, b, c] = t.map(|i| s.positions[i]);
                let centre = (a + b + c) / 3.0;
                let n = (b - a).cross(c - a).normalize();
                let (d, _) = shape.surface(centre + n * 1e-3);
                assert!(d > shape.surface(centre).0, "{shape:?}: a triangle faces in");
            }
            for p in &s.positions {
                let (d, _) = shape.surface(*p);
                // A ball's icosphere corners lie on its sphere; the chords between them lie inside.
                match shape {
                    Shape::Mesh(_) => assert!(d < -0.5 * inset && d >= -inset - 1e-12, "mesh corner at {d}"),
                    _ => assert!((d + inset).abs() < 1e-9, "{shape:?}: corner at distance {d}"),
                }
            }
        }
        assert!(Shape::Sphere { radius: inset }.drawn(inset, 2.0).is_none(), "nothing left of the ball");
    }
}
