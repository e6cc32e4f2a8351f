//! Each vertex's fan (the triangles around it) and whether it is flat now, by the hierarchy's
//! criterion for a flat patch ([`super::bvh`]): its triangles' normals within `45° − δ` of one axis
//! for a tilt `δ` (here the axis is their mean, where the hierarchy merges cones), and its smallest
//! altitude far enough above the reach.
//!
//! A fan is a patch as small and compact as a patch gets: a disk round an interior vertex, a wedge
//! round a vertex on the boundary. Flat, it is a graph over the plane across its axis: its triangles
//! project with one orientation, and their angles at the vertex grow by at most `1/cos 45° ≈ 1.41` in
//! projection, so they cannot wrap round the vertex twice if they add up to at most 2.5π at rest, nor
//! overlap at all for a wedge of at most π (a straight boundary; a slit's tip or a reflex corner is
//! wider, and its vertex gets no flat fan). So two triangles round a vertex whose fan stays flat hold
//! no vertices and edges sharing no corner within reach of each other (at least `cos 45°` times the
//! fan's smallest altitude apart, less 10% for stretch), whatever the rest of the mesh does. This
//! covers the pairs of neighbours along the borders between the hierarchy's flat patches, which the
//! hierarchy skips only where the two patches are flat together. A vertex where
//! two separate fans meet (a mesh pinched to a point there) has none either.

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
                if !spreads_once(v, fan, triangles, rest) {
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

    /// Into `flat`, for each vertex, whether its fan is flat ([`Self::flat_at`]).
    #[cfg(test)]
    pub fn flat(&self, normals: &[DVec3], tilt: Tilt, reach: f64, flat: &mut Vec<bool>) {
        flat.clear();
        flat.extend((0..self.altitude.len()).map(|v| self.flat_at(v, normals, tilt, reach)));
    }

    /// Whether vertex `v`'s fan is flat with the triangles' unit `normals` now (zero if degenerate)
    /// while each turns by up to `tilt`, with no vertices and edges in it that share no corner within
    /// `reach` of each other.
    pub fn flat_at(&self, v: usize, normals: &[DVec3], tilt: Tilt, reach: f64) -> bool {
        let fan = self.of(v);
        if fan.is_empty() || !far_apart(self.altitude[v], reach) {
            return false;
        }
        let axis = fan.iter().map(|&t| normals[t as usize]).sum::<DVec3>().normalize_or_zero();
        let widest = tilt.widest();
        fan.iter().all(|&t| normals[t as usize].dot(axis) >= widest)
    }
}

/// Whether the triangles `fan` around vertex `v` are one fan (each reached from the first across
/// edges out of `v` that two of them share) whose angles at `v` add up to at most 2.5π, or to at most
/// π if it has an edge out of `v` that only one of them has (a wedge on the boundary).
fn spreads_once(v: usize, fan: &[u32], triangles: &[[usize; 3]], rest: &[DVec3]) -> bool {
    let others = |t: u32| triangles[t as usize].into_iter().filter(move |&w| w != v);
    let shared = |s: u32, t: u32| others(s).any(|w| others(t).any(|u| u == w));
    let mut reached = vec![false; fan.len()];
    let mut stack = Vec::new();
    if !fan.is_empty() {
        (reached[0], stack) = (true, vec![0]);
    }
    while let Some(k) = stack.pop() {
        for j in 0..fan.len() {
            if !reached[j] && shared(fan[k], fan[j]) {
                reached[j] = true;
                stack.push(j);
            }
        }
    }
    let wedge = fan.iter().any(|&s| others(s).any(|w| fan.iter().filter(|&&t| others(t).any(|u| u == w)).count() == 1));
    let angle: f64 = fan
        .iter()
        .map(|&t| {
            let [a, b] = [0, 1].map(|k| others(t).nth(k).map_or(DVec3::ZERO, |w| rest[w] - rest[v]));
            a.angle_between(b)
        })
        .sum();
    let widest = if wedge { std::f64::consts::PI } else { 2.5 * std::f64::consts::PI };
    !fan.is_empty() && reached.iter().all(|&r| r) && angle <= widest * (1.0 + 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid's interior and boundary fans are flat as laid out and bent a little, not once folded
    /// through the vertex beyond the tilt's room nor when the reach passes their altitudes, and not
    /// where two fans meet at a point.
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

    /// A fan turned as a whole stays flat (its axis is its own); a wedge wider than a half-turn (the
    /// tip of a slit) and a vertex of no triangle have no flat fan.
    #[test]
    fn turned_fans_stay_flat_and_slits_and_lone_vertices_have_none() {
        let tilt = Tilt::new(10f64.to_radians());
        let mut flat = Vec::new();
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [4, 4]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let turned: Vec<DVec3> = rest.iter().map(|p| glam::DQuat::from_rotation_x(1.0) * *p).collect();
        Fans::new(&rest, &triangles).flat(&normals_of(&turned, &triangles), tilt, 0.01, &mut flat);
        assert!(flat.iter().all(|&f| f), "every fan of the grid turned by 1 rad");
        // Eight triangles round the origin in the xz-plane, less one: a wedge of 315°, and one vertex
        // of no triangle.
        let rim = |k: usize| {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            DVec3::new(a.cos(), 0.0, -a.sin())
        };
        let mut points: Vec<DVec3> = std::iter::once(DVec3::ZERO).chain((0..8).map(rim)).collect();
        points.push(DVec3::splat(5.0));
        let slit: Vec<[usize; 3]> = (0..7).map(|k| [0, 1 + k, 1 + (k + 1) % 8]).collect();
        Fans::new(&points, &slit).flat(&normals_of(&points, &slit), tilt, 0.01, &mut flat);
        assert!(!flat[0], "a 315° wedge");
        assert!(flat[1..9].iter().all(|&f| f), "its rim");
        assert!(!flat[9], "a vertex of no triangle");
        let half: Vec<[usize; 3]> = (0..4).map(|k| [0, 1 + k, 2 + k]).collect();
        Fans::new(&points, &half).flat(&normals_of(&points, &half), tilt, 0.01, &mut flat);
        assert!(flat[0], "a 180° wedge (a straight boundary)");
    }

    /// The unit normals of `triangles` at `x`.
    fn normals_of(x: &[DVec3], triangles: &[[usize; 3]]) -> Vec<DVec3> {
        triangles.iter().map(|t| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalize_or_zero()).collect()
    }
}
