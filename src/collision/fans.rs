//! Each vertex's fan (the triangles around it) and whether it is flat now, by the hierarchy's test
//! for a flat patch ([`super::bvh`]): its triangles' normals within `45° − δ` of one axis for a tilt
//! `δ`, and its smallest altitude far enough above the reach.
//!
//! A fan is a patch as small and compact as a patch gets: a disk round an interior vertex, half of one
//! round a vertex on the boundary. So two triangles around a vertex whose fan stays flat hold no pair
//! of vertices and edges within reach of each other, whatever the rest of the mesh does. This covers
//! the pairs of neighbours along the borders between the hierarchy's flat patches, which the
//! hierarchy alone cannot skip (two neighbouring patches together need not be flat). A vertex where
//! two separate fans meet (a mesh pinched to a point there) has none, and is never flat.

use glam::DVec3;

use super::bvh::{Tilt, far_apart, smallest_altitude};

/// The fans of a mesh's vertices.
#[derive(Debug, Clone, Default)]
pub struct Fans {
    /// Vertex `v`'s triangles are `triangles[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    triangles: Vec<u32>,
    /// Each fan's smallest triangle altitude at rest, or zero where the vertex has no single fan.
    altitude: Vec<f64>,
}

impl Fans {
    /// The fans of the vertices of these triangles, at `rest`.
    pub fn new(rest: &[DVec3], triangles: &[[usize; 3]]) -> Self {
        let mut start = vec![0u32; rest.len() + 1];
        triangles.iter().flatten().for_each(|&v| start[v + 1] += 1);
        for v in 0..rest.len() {
            start[v + 1] += start[v];
        }
        let mut next = start.clone();
        let mut around = vec![0u32; start[rest.len()] as usize];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                around[next[v] as usize] = t as u32;
                next[v] += 1;
            }
        }
        let altitude = (0..rest.len())
            .map(|v| {
                let fan = &around[start[v] as usize..start[v + 1] as usize];
                if !connected(v, fan, triangles) {
                    return 0.0;
                }
                fan.iter()
                    .map(|&t| smallest_altitude(triangles[t as usize].map(|i| rest[i])))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        Self { start, triangles: around, altitude }
    }

    /// The triangles around vertex `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.triangles[self.start[v] as usize..self.start[v + 1] as usize]
    }

    /// Into `flat`, for each vertex, whether its fan is flat with the triangles' unit `normals` now
    /// (zero if degenerate) while each turns by up to `tilt`, with nothing in it within `reach` of
    /// anything else in it.
    pub fn flat(&self, normals: &[DVec3], tilt: Tilt, reach: f64, flat: &mut Vec<bool>) {
        let widest = tilt.widest();
        flat.clear();
        flat.extend((0..self.altitude.len()).map(|v| {
            let fan = self.of(v);
            if fan.is_empty() || !far_apart(self.altitude[v], reach) {
                return false;
            }
            let axis = fan.iter().map(|&t| normals[t as usize]).sum::<DVec3>().normalize_or_zero();
            fan.iter().all(|&t| normals[t as usize].dot(axis) >= widest)
        }));
    }
}

/// Whether the triangles `fan` around vertex `v` are one fan: each reached from the first across edges
/// out of `v` that two of them share.
fn connected(v: usize, fan: &[u32], triangles: &[[usize; 3]]) -> bool {
    let others = |t: u32| {
        let tri = triangles[t as usize];
        tri.into_iter().filter(move |&w| w != v)
    };
    let mut reached = vec![false; fan.len()];
    let mut stack = vec![0usize];
    while let Some(k) = stack.pop() {
        if std::mem::replace(&mut reached[k], true) {
            continue;
        }
        for (j, &t) in fan.iter().enumerate() {
            if !reached[j] && others(t).any(|w| others(fan[k]).any(|u| u == w)) {
                stack.push(j);
            }
        }
    }
    reached.iter().all(|&r| r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid's interior and boundary fans are flat as laid out and while tilted as a whole, not once
    /// folded through the vertex beyond the tilt's room, and not where two fans meet at a point.
    #[test]
    fn fans_are_flat_until_folded_and_pinched_vertices_have_none() {
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [4, 4]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let fans = Fans::new(&rest, &triangles);
        let normals = |x: &[DVec3]| normals_of(x, &triangles);
        let tilt = Tilt::new(10f64.to_radians());
        let mut flat = Vec::new();
        fans.flat(&normals(&rest), tilt, 0.01, &mut flat);
        assert!(flat.iter().all(|&f| f), "every fan of a flat grid");
        fans.flat(&normals(&rest), tilt, 0.2, &mut flat);
        assert!(flat.iter().all(|&f| !f), "none when the reach passes its altitudes");
        // Folded along x = 0 by 80°: a normal on one side or the other is 40° or more from any axis,
        // past 45° − 10°; bent by 30°, none is more than 30° from the mean.
        let centre = rest.iter().position(|p| p.x.abs() < 1e-9 && p.z.abs() < 1e-9).unwrap();
        let crease = |deg: f64| -> Vec<DVec3> {
            let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
            rest.iter().map(|p| if p.x > 0.0 { DVec3::new(p.x * c, p.x * s, p.z) } else { *p }).collect()
        };
        fans.flat(&normals(&crease(80.0)), tilt, 0.01, &mut flat);
        assert!(!flat[centre], "a fan folded through its vertex by 80°");
        fans.flat(&normals(&crease(30.0)), tilt, 0.01, &mut flat);
        assert!(flat[centre], "a fan bent by 30°");
        // Two triangles that meet only at vertex 0.
        let pinched = [DVec3::ZERO, DVec3::X, DVec3::Z, -DVec3::X, -DVec3::Z];
        let bow = [[0, 1, 2], [0, 3, 4]];
        let fans = Fans::new(&pinched, &bow);
        fans.flat(&normals_of(&pinched, &bow), tilt, 0.01, &mut flat);
        assert_eq!(flat, [false, true, true, true, true], "a pinched vertex has no fan");
    }

    /// The unit normals of `triangles` at `x`.
    fn normals_of(x: &[DVec3], triangles: &[[usize; 3]]) -> Vec<DVec3> {
        triangles.iter().map(|t| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalize_or_zero()).collect()
    }
}
