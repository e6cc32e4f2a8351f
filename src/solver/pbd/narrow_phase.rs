//! The narrow phase of self-collision's search ([`super::self_collision`]): the vertex–triangle and
//! edge–edge pairs that two triangles whose boxes overlap hand over, judged at the search's positions
//! against the thickness plus the margins, and the boxes those margins give.

use std::cell::Cell;

use glam::DVec3;

use crate::collision::bvh::Tilt;
use crate::collision::closest::{self, closest_on_triangle, segment_gap};
use crate::collision::fans::Fans;
use crate::mesh::bounds;

/// What decides the pairs of two triangles: positions and margins at the search, and the mesh.
pub struct Near<'a> {
    /// Positions (the search's anchors), margins and the thickness.
    pub x: &'a [DVec3],
    /// The mesh's triangles.
    pub triangles: &'a [[usize; 3]],
    /// Each vertex's margin.
    pub margins: &'a [f64],
    /// The thickness.
    pub thickness: f64,
    /// Whether each vertex's fan is flat, where judged already since the search.
    pub flat_fans: &'a [Cell<Option<bool>>],
    /// The fans (judged, with the three fields below, when first asked about).
    pub fans: &'a Fans,
    /// The triangles' unit normals.
    pub normals: &'a [DVec3],
    /// The tilt each normal may turn by.
    pub tilt: Tilt,
    /// The reach a flat patch keeps its vertices and edges apart by.
    pub flat_reach: f64,
    /// The mesh's edges.
    pub edges: &'a [[usize; 2]],
    /// Each triangle's edges.
    pub triangle_edges: &'a [[u32; 3]],
    /// The triangle through which each vertex is paired.
    pub vertex_owner: &'a [u32],
    /// The triangle through which each edge is paired.
    pub edge_owner: &'a [u32],
}

impl Near<'_> {
    /// Whether vertex `v`'s fan is flat, judged the first time it is asked after the search (most fans
    /// lie within patches the hierarchy skips, and are never asked).
    fn fan_flat(&self, v: usize) -> bool {
        self.flat_fans[v].get().unwrap_or_else(|| self.judge_fan(v))
    }

    /// Judge whether vertex `v`'s fan is flat with the normals as they are now, and keep the verdict.
    pub fn judge_fan(&self, v: usize) -> bool {
        let flat = self.fans.flat_at(v, self.normals, self.tilt, self.flat_reach);
        self.flat_fans[v].set(Some(flat));
        flat
    }

    /// Add to `vertices` and `edges` the pairs that triangles `a` and `b` hand over (each vertex and
    /// edge through the triangle that owns it) closer than the thickness plus half their sides'
    /// margins, unless the triangles lie round a vertex whose fan is flat (no pair within reach).
    pub fn pairs(&self, a: u32, b: u32, vertices: &mut Vec<[u32; 2]>, edges: &mut Vec<[u32; 2]>) {
        let (x, triangles, thickness) = (self.x, self.triangles, self.thickness);
        let (ta, tb) = (triangles[a as usize], triangles[b as usize]);
        if ta.iter().any(|&v| tb.contains(&v) && self.fan_flat(v)) {
            return;
        }
        for (s, t) in [(a, b), (b, a)] {
            let (ts, tt) = (triangles[s as usize], triangles[t as usize]);
            let corners = tt.map(|i| x[i]);
            let (lo, hi) = bounds(&corners);
            let mt = side(self.margins, &tt);
            for &v in ts.iter().filter(|&&v| self.vertex_owner[v] == s && !tt.contains(&v)) {
                let reach = thickness + 0.5 * (self.margins[v] + mt);
                // A vertex within reach of the triangle is within reach of its box.
                if x[v].cmplt(lo - reach).any() || x[v].cmpgt(hi + reach).any() {
                    continue;
                }
                let on = closest::at(corners, closest_on_triangle(x[v], corners).0);
                if (x[v] - on).length_squared() <= reach * reach {
                    vertices.push([v as u32, t]);
                }
            }
        }
        let owned =
            |t: u32| self.triangle_edges[t as usize].into_iter().filter(move |&e| self.edge_owner[e as usize] == t);
        for e in owned(a) {
            for f in owned(b) {
                let (ee, ff) = (self.edges[e as usize], self.edges[f as usize]);
                if ff.contains(&ee[0]) || ff.contains(&ee[1]) {
                    continue;
                }
                let reach = thickness + 0.5 * (side(self.margins, &ee) + side(self.margins, &ff));
                let (i, j) = (ee.map(|k| x[k]), ff.map(|k| x[k]));
                // Edges within reach of each other have boxes within reach.
                if i[0].min(i[1]).cmpgt(j[0].max(j[1]) + reach).any()
                    || j[0].min(j[1]).cmpgt(i[0].max(i[1]) + reach).any()
                {
                    continue;
                }
                if segment_gap(i, j).length_squared() <= reach * reach {
                    edges.push([e.min(f), e.max(f)]);
                }
            }
        }
    }
}

/// The margin of a side made of vertices `ids`: the largest of their `margins`.
fn side(margins: &[f64], ids: &[usize]) -> f64 {
    ids.iter().map(|&i| margins[i]).fold(0.0, f64::max)
}

/// The box of `triangle` at `x`, grown by half its reach (the thickness and its side's margin, the
/// largest of its vertices' `margins`): two that overlap may hold a pair within reach, and no pair
/// within reach lies in two that do not.
#[inline]
pub fn triangle_box(x: &[DVec3], margins: &[f64], thickness: f64, triangle: [usize; 3]) -> (DVec3, DVec3) {
    let reach = thickness + side(margins, &triangle);
    let (lo, hi) = bounds(&triangle.map(|i| x[i]));
    (lo - 0.5 * reach, hi + 0.5 * reach)
}
