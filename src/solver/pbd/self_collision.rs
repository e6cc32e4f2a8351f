//! Self-collision: which vertex–triangle pairs (the vertex not a corner of the triangle) and edge–edge
//! pairs (sharing no vertex) are near enough to need a constraint ([`super::self_contact`]), and the
//! side each keeps.
//!
//! A search lists every pair closer than the thickness plus a margin, from a hierarchy of the mesh's
//! triangles ([`TriangleTree`], its boxes refitted and grown by the margins): each pair of triangles
//! whose boxes overlap hands over the pairs of its vertices and edges — each vertex and edge through
//! one triangle that owns it, so that no pair is listed twice. The list holds while no two vertices
//! have moved, relative to each other, by their margins since the search: each vertex stays within
//! half its margin of its anchor (its position at the search less the cloth's mean position then),
//! relative to the cloth's mean position (checked at the start and the predicted end of every
//! substep; a shared translation, as in a fall, does not count). When one has not, the search
//! is made again from the substep's start; a vertex's margin is a fifth of the mean edge plus twice
//! its own relative travel in that substep, so a fast vertex gets room and a still one costs little.
//! Where searches come within four substeps of each other and list few pairs (under 2% of the
//! vertices), the travel is counted for two, then four substeps (twice each): room for a cloth that
//! flaps as a whole, paid for in pairs, and taken back by a search that lists many (on the wrinkled
//! hanging sheet this measured far fewer searches, and with the fans below less time: `BENCHMARKS.md`,
//! *Design measurements quoted from module docs*).
//!
//! Patches that are flat are not searched within, whatever the margins: the hierarchy skips a patch
//! whose normals lie within 40° of one axis and whose smallest altitude keeps its vertices and edges
//! more than the thickness plus the least margin apart (see [`crate::collision::bvh`]). Such a patch
//! stays flat, and so holds no pair within that distance (a pair that acts, within the thickness and
//! over its triangle or facing across its normal, is nearer), while none of its triangles' normals has
//! turned by more than 5° since it was taken (its cone then stays within 45°). Every triangle is
//! watched for that in every substep ([`Watch`]), and those that turned further are renewed instead of
//! searching again: their normals are taken anew, the hierarchy's nodes holding them are looked at
//! within themselves again, and a patch (or a fan, below) that was flat and is no more lists its pairs
//! at the search's anchors and margins, which still hold ([`TriangleTree::renewed_pairs`]): what a
//! search would list now. So the margins, which only widen the boxes, do not list every near neighbour
//! of a moving sheet, and a wrinkle that forms is not a search. (A tilt of 5° rather than 10°: flat
//! patches up to 40° wide instead of 35°, more renewals but cheaper searches, which measured slightly
//! faster on the wrinkled hanging sheet.)
//!
//! When the search found the whole cloth one flat patch (the hierarchy's root skipped), there is no
//! pair, and none can come while it stays flat, so the drift is not checked until a triangle turns
//! (the hanging sheet, swinging in its plane, is searched once while it stays in its plane instead of
//! several times a frame; once it wrinkles out of its plane, the drift of its swing makes the search
//! again every few substeps). Several flat patches covering the cloth are not enough: pairs between
//! them can come.
//!
//! Along the borders between flat patches, the hierarchy hands over every pair of neighbouring
//! triangles (their boxes overlap), unless the two patches share an edge and are flat together (then
//! they are one flat patch, skipped alike, which measured clearly faster on the wrinkled hanging
//! sheet). A pair of triangles round a vertex whose fan is flat by the same criterion ([`Fans`]) is
//! skipped too. Before patches were joined, most of the pairs handed over on the wrinkled hanging
//! sheet shared a vertex, and skipping flat fans measured faster (`BENCHMARKS.md`, *Design
//! measurements quoted from module docs*).
//!
//! The hierarchy's and the fans' bound on distances assumes triangles keep their rest altitudes within
//! 10%. A cloth stretched and sheared further (the hanging sheet at 16 substeps of one sweep, by its
//! clips, where some triangles lose much of their altitude) brings vertices of a flat patch within the
//! reach of each other's triangles in the patch's plane. That is no crossing: a patch within 45° of one
//! axis, compact and not wrapped round a point, is a graph over the plane across it and cannot go
//! through itself, and the search made when it stops being flat lists such pairs as they are — as long
//! as none of its triangles turns over within the plane, which edges alone allow once a triangle is
//! squeezed nearly flat (the same sheet at 8–12 substeps, beside its clips); `solver.least_area` keeps
//! every triangle from that ([`super::project::least_area`]).
//!
//! An edge pair's normal, the direction its second edge keeps from the first, follows the gap between
//! their closest points; the edges' common normal is used only when they touch (for nearly parallel
//! edges, as in the layers of a fold, it turns with their slightest twist and may lie across the gap).
//!
//! No pair that a search in every substep would find is missed, and searches are made only as often
//! as the cloth's motion needs them. (The issue asked for a spatial hash; measured on the `pile`,
//! hashing vertices and edge midpoints needed queries as large as an edge around every edge and cost
//! many times what the hierarchy costs a search: `BENCHMARKS.md`, *Design measurements quoted from
//! module docs*.)
//!
//! Sides: a vertex over its triangle and closer than the thickness keeps the side it had (so one pushed
//! through in a substep is brought back); otherwise its side is where it is. Edge pairs likewise.
//! Pairs come in a fixed order: the same scene gives the same result, bit for bit.

use std::cell::Cell;
use std::collections::HashMap;

use glam::DVec3;

#[cfg(any(doc, test))]
use super::batch::Rows;
use super::batch::{Indexed, Row};
use super::narrow_phase::{self, Near};
use super::self_contact::{self, EdgePair, Pair, over};
use super::turned::Watch;
use crate::collision::bvh::{Leaf, Tilt, TriangleTree};
use crate::collision::closest::segment_gap;
use crate::collision::fans::Fans;
use crate::energy::constraints::point_triangle;

/// How far a triangle of a patch skipped as flat may turn before the search is made again, radians.
const TILT: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// The most substeps of its travel a vertex's margin is stretched to allow for.
const MOST_STRETCH: f64 = 4.0;

/// Searches this many substeps apart or nearer are too frequent: the margins are stretched.
const TOO_SOON: u32 = 4;

/// A search that lists more pairs than this fraction of the vertices brings the margins back to one
/// substep's travel.
const FEW_PAIRS: f64 = 0.02;

/// A vertex that moves, relative to the cloth's mean, farther than this many times the cloth's size
/// within a substep is flung: no cloth moves so, and a dragged vertex that jumps with the mouse
/// (and the neighbours it pulls after it) stays well within it.
pub const FLUNG_REACH: f64 = 10.0;

/// A search refuses a substep in which more than [`FLUNG_FEW`] plus this share of the vertices are
/// flung ([`FLUNG_REACH`]).
pub const FLUNG_SHARE: f64 = 0.01;

/// See [`FLUNG_SHARE`].
pub const FLUNG_FEW: usize = 8;

/// A substep the search refused ([`SelfCollision::find`]): the cloth is flying apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Flung {
    /// How many vertices moved farther than [`FLUNG_REACH`] times the cloth's size, or to a
    /// non-finite place (every vertex when the cloth's mean position is not finite).
    pub vertices: usize,
}

/// The self-collision pairs of the cloth.
#[derive(Debug, Clone)]
pub struct SelfCollision {
    tree: TriangleTree,
    fans: Fans,
    /// The mesh's edges, and each triangle's three edges.
    edges: Vec<[usize; 2]>,
    triangle_edges: Vec<[u32; 3]>,
    /// The triangle through which each vertex and each edge is paired (the first that has it).
    vertex_owner: Vec<u32>,
    edge_owner: Vec<u32>,
    /// Each vertex's margin at the last search, and the least margin, m.
    margins: Vec<f64>,
    least_margin: f64,
    /// The cloth's size at rest (its bounding box's diagonal), m ([`FLUNG_REACH`]).
    size: f64,
    /// Each vertex's position when it was last searched or renewed, less the cloth's mean position
    /// then (so a shared translation does not count as drift).
    anchors: Vec<DVec3>,
    /// Whether the last search skipped the whole cloth as one flat patch.
    whole: bool,
    /// Every triangle, with the unit normal it had when it was last searched or renewed.
    watched: Watch,
    /// Those normals, whether each vertex's fan was flat with them (judged when first needed), and the
    /// triangles that have turned by the tilt since (scratch).
    normals: Vec<DVec3>,
    flat_fans: Vec<Cell<Option<bool>>>,
    turned: Vec<u32>,
    /// Renewals made so far (searches within the patches that turned).
    pub renewals: u64,
    /// The vertex–triangle pairs within reach at the last search, sorted by (vertex, triangle).
    pub pairs: Vec<Pair>,
    /// The edge–edge pairs likewise, sorted.
    pub edge_pairs: Vec<EdgePair>,
    /// Of those, the ones that may touch in this substep (indices).
    active: Vec<u32>,
    active_edges: Vec<u32>,
    /// Searches made so far.
    pub searches: u64,
    /// How many substeps of its travel a vertex's margin allows for (1 to [`MOST_STRETCH`]), and the
    /// substeps since the last search.
    stretch: f64,
    since: u32,
}

impl SelfCollision {
    /// For a mesh with these triangles and edges at rest, of mean edge length `mean_edge`.
    pub fn new(rest: &[DVec3], triangles: &[[usize; 3]], edges: Vec<[usize; 2]>, mean_edge: f64) -> Self {
        let index: HashMap<[usize; 2], u32> =
            edges.iter().enumerate().map(|(k, e)| ([e[0].min(e[1]), e[0].max(e[1])], k as u32)).collect();
        let triangle_edges: Vec<[u32; 3]> =
            triangles.iter().map(|&t| crate::mesh::sides(t).map(|e| index[&e])).collect();
        let mut vertex_owner = vec![u32::MAX; rest.len()];
        let mut edge_owner = vec![u32::MAX; edges.len()];
        for (t, (tri, es)) in triangles.iter().zip(&triangle_edges).enumerate() {
            tri.iter().for_each(|&v| vertex_owner[v] = vertex_owner[v].min(t as u32));
            es.iter().for_each(|&e| edge_owner[e as usize] = edge_owner[e as usize].min(t as u32));
        }
        Self {
            tree: TriangleTree::new(rest, triangles),
            fans: Fans::new(rest, triangles),
            edges,
            triangle_edges,
            vertex_owner,
            edge_owner,
            margins: Vec::new(),
            least_margin: 0.2 * mean_edge,
            size: {
                let (lo, hi) = crate::mesh::bounds(rest);
                (hi - lo).length()
            },
            anchors: Vec::new(),
            whole: false,
            watched: Watch::new(triangles.iter().map(|t| (t.map(|i| i as u32), DVec3::ZERO))),
            normals: Vec::new(),
            flat_fans: Vec::new(),
            turned: Vec::new(),
            renewals: 0,
            pairs: Vec::new(),
            edge_pairs: Vec::new(),
            active: Vec::new(),
            active_edges: Vec::new(),
            searches: 0,
            stretch: 1.0,
            since: 0,
        }
    }

    /// This substep's pairs and sides, for the substep from `x` (start) to `p` (predicted), which
    /// `rows` hold as the sweeps read them ([`Rows`]). Refused ([`Flung`]), with the search's state
    /// untouched, when more than [`FLUNG_FEW`] plus [`FLUNG_SHARE`] of the vertices would move,
    /// relative to the cloth's mean, farther than [`FLUNG_REACH`] times the cloth's size or to a
    /// non-finite place: the margins grow with the motion, and a search of an exploding cloth would
    /// pair every vertex with every triangle.
    pub fn find(
        &mut self,
        [x, p]: [&[DVec3]; 2],
        rows: [Indexed<&[Row]>; 2],
        triangles: &[[usize; 3]],
        thickness: f64,
    ) -> Result<(), Flung> {
        // When the last search skipped the whole cloth as one flat patch, nothing can have come
        // within reach while it stays flat, however far its vertices moved.
        let searched = self.anchors.len() == x.len();
        if searched {
            self.watched.turned(rows, TILT, &mut self.turned);
        }
        // The cloth's mean positions at the substep's start and predicted end, taken once if needed.
        let means = std::cell::OnceCell::new();
        let means = || *means.get_or_init(|| [mean_position(x), mean_position(p)]);
        let stale = !searched || ((!self.whole || !self.turned.is_empty()) && self.drifted([x, p], means()));
        if stale {
            let [cx, cp] = means();
            let reach = FLUNG_REACH * self.size;
            let flung = p
                .iter()
                .zip(x)
                .map(|(a, b)| (*a - *b - (cp - cx)).length())
                .filter(|d| d.is_nan() || *d > reach)
                .count();
            if flung > FLUNG_FEW + (FLUNG_SHARE * x.len() as f64) as usize {
                return Err(Flung { vertices: flung });
            }
        }
        self.since += 1;
        if stale {
            let [cx, cp] = means();
            let (least, room, t) = (self.least_margin, 2.0 * self.stretch, cp - cx);
            self.margins.clear();
            self.margins.extend(p.iter().zip(x).map(|(a, b)| least + room * (*a - *b - t).length()));
            self.search(x, cx, triangles, thickness);
            // Searches that come soon and list few pairs: more room for the next; many pairs: less.
            let listed = (self.pairs.len() + self.edge_pairs.len()) as f64;
            if listed > FEW_PAIRS * x.len() as f64 {
                self.stretch = 1.0;
            } else if self.since <= TOO_SOON {
                self.stretch = (2.0 * self.stretch).min(MOST_STRETCH);
            }
            self.since = 0;
        } else if !self.turned.is_empty() {
            self.renew(x, triangles, thickness);
        }
        // Sides, and which pairs may touch within the substep: those whose separation along their
        // normal is less than the thickness plus twice the farthest their particles are predicted to
        // move (corrections move them too, by less).
        let travel = |ids: &[usize]| ids.iter().map(|&i| (p[i] - x[i]).length()).fold(0.0, f64::max);
        self.active.clear();
        for (k, pair) in self.pairs.iter_mut().enumerate() {
            let (v, t) = (pair.vertex as usize, triangles[pair.triangle as usize]);
            let (q, tri) = (x[v], t.map(|i| x[i]));
            let (d, _) = point_triangle(q, tri, 0.0, 1.0);
            let kept = pair.side != 0.0 && d.abs() < thickness && over(q, tri);
            if !kept && d.is_finite() {
                pair.side = if d >= 0.0 { 1.0 } else { -1.0 };
            }
            let reach = thickness + 2.0 * travel(&[v, t[0], t[1], t[2]]);
            if pair.side * d < reach {
                self.active.push(k as u32);
            }
        }
        self.active_edges.clear();
        for (k, pair) in self.edge_pairs.iter_mut().enumerate() {
            let (e, f) = (self.edges[pair.edges[0] as usize], self.edges[pair.edges[1] as usize]);
            let (i, j) = ([x[e[0]], x[e[1]]], [x[f[0]], x[f[1]]]);
            let reach = thickness + 2.0 * travel(&[e[0], e[1], f[0], f[1]]);
            // Along any unit direction the closest points are apart by at least the second edge's
            // lowest end less the first edge's highest: a pair that far along its last normal is far.
            let apart = |n: DVec3| j[0].dot(n).min(j[1].dot(n)) - i[0].dot(n).max(i[1].dot(n));
            if pair.normal != DVec3::ZERO && apart(pair.normal) >= reach {
                continue;
            }
            let gap = segment_gap(i, j);
            let cross = (i[1] - i[0]).cross(j[1] - j[0]);
            let parallel =
                cross.length_squared() <= 1e-12 * (i[1] - i[0]).length_squared() * (j[1] - j[0]).length_squared();
            let towards = if pair.normal != DVec3::ZERO && gap.length() < thickness { pair.normal } else { gap };
            // Across the pair: the gap between the closest points, while it is clear of round-off (for
            // nearly parallel edges, as the layers of a fold, the edges' common normal turns with
            // their slightest twist and may lie across the gap); else the common normal.
            let across = if gap.length() > 1e-3 * thickness {
                Some(gap.normalize())
            } else if !parallel {
                Some(cross.normalize())
            } else if pair.normal == DVec3::ZERO && gap.length_squared() > 0.0 {
                Some(gap.normalize())
            } else {
                None
            };
            if let Some(n) = across {
                pair.normal = if n.dot(towards) >= 0.0 { n } else { -n };
            }
            if pair.normal != DVec3::ZERO && apart(pair.normal) < reach {
                self.active_edges.push(k as u32);
            }
        }
        Ok(())
    }

    /// List, at `x`, every pair closer than the thickness plus half the sum of its two sides' margins
    /// (a side's margin: the largest of its vertices'); pairs found again keep their sides.
    fn search(&mut self, x: &[DVec3], mean: DVec3, triangles: &[[usize; 3]], thickness: f64) {
        self.searches += 1;
        self.anchors.resize(x.len(), DVec3::ZERO);
        crate::threads::halves(&mut self.anchors, SPLIT, |first, anchors| {
            anchors.iter_mut().zip(&x[first..]).for_each(|(a, q)| *a = *q - mean);
        });
        self.normals.resize(triangles.len(), DVec3::ZERO);
        crate::threads::halves(&mut self.normals, SPLIT, |first, normals| {
            normals.iter_mut().zip(&triangles[first..]).for_each(|(n, &t)| *n = unit_normal(t, x));
        });
        self.watched.set_all(&self.normals);
        self.flat_fans.clear();
        self.flat_fans.resize(x.len(), Cell::new(None));
        // The hierarchy is taken out while the pairs' judge borrows the rest.
        let mut tree = std::mem::take(&mut self.tree);
        let near = self.near(triangles, thickness);
        let (x, margins, normals, reach) = (&self.anchors, &self.margins, &self.normals, near.flat_reach);
        tree.refit(|t| {
            let (lo, hi) = narrow_phase::triangle_box(x, margins, thickness, triangles[t]);
            Leaf { lo, hi, normal: normals[t], reach }
        });
        let (mut vertices, mut edges) = (Vec::new(), Vec::new());
        tree.overlapping_pairs(near.tilt, |a, b| near.pairs(a, b, &mut vertices, &mut edges));
        (self.whole, self.tree) = (tree.all_flat(), tree);
        self.list(vertices, edges, false);
    }

    /// Take the normals of the triangles that turned by the tilt ([`Self::turned`]) at `x`, and list
    /// the pairs within the patches and fans they opened, at the anchors and margins of the last
    /// search: the pairs a search would list now, the boxes as they are.
    fn renew(&mut self, x: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        self.renewals += 1;
        for &t in &self.turned {
            let n = unit_normal(triangles[t as usize], x);
            self.normals[t as usize] = n;
            self.watched.set(t as usize, n);
            self.tree.turn(t, n);
        }
        let mut corners: Vec<usize> = self.turned.iter().flat_map(|&t| triangles[t as usize]).collect();
        corners.sort_unstable();
        corners.dedup();
        let mut tree = std::mem::take(&mut self.tree);
        let near = self.near(triangles, thickness);
        let mut opened = Vec::new();
        for v in corners {
            let was_flat = self.flat_fans[v].get() == Some(true);
            if !near.judge_fan(v) && was_flat {
                opened.push(v);
            }
        }
        let (mut vertices, mut edges) = (Vec::new(), Vec::new());
        tree.renewed_pairs(near.tilt, |a, b| near.pairs(a, b, &mut vertices, &mut edges));
        for v in opened {
            let fan = self.fans.of(v);
            for (k, &a) in fan.iter().enumerate() {
                fan[k + 1..].iter().for_each(|&b| near.pairs(a, b, &mut vertices, &mut edges));
            }
        }
        (self.whole, self.tree) = (tree.all_flat(), tree);
        if self.whole {
            // The whole cloth flat again holds no pair, as a search would find.
            self.pairs.clear();
            self.edge_pairs.clear();
        } else {
            self.list(vertices, edges, true);
        }
    }

    /// What the pairs of two triangles are judged by: the last search's positions and margins.
    fn near<'a>(&'a self, triangles: &'a [[usize; 3]], thickness: f64) -> Near<'a> {
        Near {
            x: &self.anchors,
            triangles,
            margins: &self.margins,
            thickness,
            flat_fans: &self.flat_fans,
            fans: &self.fans,
            normals: &self.normals,
            tilt: Tilt::new(TILT),
            flat_reach: thickness + self.least_margin,
            edges: &self.edges,
            triangle_edges: &self.triangle_edges,
            vertex_owner: &self.vertex_owner,
            edge_owner: &self.edge_owner,
        }
    }

    /// The pairs with these keys (unsorted, maybe repeated), with those listed already if `kept`;
    /// pairs listed before keep their sides.
    fn list(&mut self, mut vertices: Vec<[u32; 2]>, mut edges: Vec<[u32; 2]>, kept: bool) {
        if kept {
            vertices.extend(self.pairs.iter().map(|p| [p.vertex, p.triangle]));
            edges.extend(self.edge_pairs.iter().map(|p| p.edges));
        }
        for keys in [&mut vertices, &mut edges] {
            keys.sort_unstable();
            keys.dedup();
        }
        self.pairs = carry(
            &vertices,
            &self.pairs,
            |p| [p.vertex, p.triangle],
            |[vertex, triangle]| Pair { vertex, triangle, side: 0.0 },
        );
        self.edge_pairs = carry(&edges, &self.edge_pairs, |p| p.edges, |edges| EdgePair { edges, normal: DVec3::ZERO });
    }

    /// Project every pair that may touch in this substep once (vertex–triangle, then edge–edge).
    pub fn project(&self, p: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
        for &k in &self.active {
            self_contact::project_vertex(&self.pairs[k as usize], p, w, triangles, thickness);
        }
        for &k in &self.active_edges {
            self_contact::project_edges(&self.edge_pairs[k as usize], &self.edges, p, w, thickness);
        }
    }

    /// Leave every touching pair at `x` no separating speed (in `v`) along its normal.
    pub fn settle(&self, x: &[DVec3], v: &mut [DVec3], w: &[f64], triangles: &[[usize; 3]], thickness: f64) {
        for &k in &self.active {
            self_contact::settle_vertex(&self.pairs[k as usize], x, v, w, triangles, thickness);
        }
        for &k in &self.active_edges {
            self_contact::settle_edges(&self.edge_pairs[k as usize], &self.edges, x, v, w, thickness);
        }
    }

    /// Whether a vertex has moved from its anchor at `x` or `p`, relative to the cloth's mean
    /// position there (`cx`, `cp`), by half its margin or more.
    fn drifted(&self, [x, p]: [&[DVec3]; 2], [cx, cp]: [DVec3; 2]) -> bool {
        let (anchors, margins) = (&self.anchors, &self.margins);
        crate::threads::any(x.len(), SPLIT, |i| {
            let a = anchors[i];
            let drift2 = (x[i] - cx - a).length_squared().max((p[i] - cp - a).length_squared());
            4.0 * drift2 >= margins[i] * margins[i]
        })
    }

    /// The pairs that may touch in this substep.
    pub fn active(&self) -> usize {
        self.active.len() + self.active_edges.len()
    }
}

/// Passes over the vertices or triangles (the search's anchors and normals, the drift check) go in
/// two halves at once where there are several threads and each half has at least this many.
const SPLIT: usize = 2048;

/// The unit normal of `triangle` at `x`, along `(c₁ − c₀) × (c₂ − c₀)` (zero if degenerate).
#[inline(always)]
fn unit_normal(triangle: [usize; 3], x: &[DVec3]) -> DVec3 {
    let c = triangle.map(|i| x[i]);
    (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero()
}

/// The mean of the positions `y`.
fn mean_position(y: &[DVec3]) -> DVec3 {
    y.iter().sum::<DVec3>() / y.len().max(1) as f64
}

/// The pairs with these (sorted) keys: those in `old` (sorted by key) as they were, new ones made.
fn carry<P: Copy>(keys: &[[u32; 2]], old: &[P], key: impl Fn(&P) -> [u32; 2], new: impl Fn([u32; 2]) -> P) -> Vec<P> {
    let mut k = 0;
    keys.iter()
        .map(|&wanted| {
            while k < old.len() && key(&old[k]) < wanted {
                k += 1;
            }
            if k < old.len() && key(&old[k]) == wanted { old[k] } else { new(wanted) }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::closest::{self, closest_on_triangle};

    /// A grid sheet of `size` (m) and `cells` in the xz-plane, with its edges and mean edge length.
    struct Sheet {
        rest: Vec<DVec3>,
        triangles: Vec<[usize; 3]>,
        edges: Vec<[usize; 2]>,
        mean: f64,
    }

    impl Sheet {
        fn new(size: [f64; 2], cells: [usize; 2]) -> Self {
            let mesh = crate::mesh::generate::grid(size, cells).expect("grid");
            let edges: Vec<[usize; 2]> = mesh.topology().edges.iter().map(|e| e.v).collect();
            let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
            let mean = edges.iter().map(|e| (rest[e[0]] - rest[e[1]]).length()).sum::<f64>() / edges.len() as f64;
            Self { rest, triangles, edges, mean }
        }
    }

    /// `sc`'s pairs for the substep from `x` to `p`.
    fn find(sc: &mut SelfCollision, x: &[DVec3], p: &[DVec3], triangles: &[[usize; 3]], thickness: f64) {
        let mut rows = [Rows::default(), Rows::default()];
        rows[0].fill(x, &vec![1.0; x.len()]);
        rows[1].fill(p, &vec![1.0; p.len()]);
        sc.find([x, p], [rows[0].indexed(), rows[1].indexed()], triangles, thickness).expect("not flung apart");
    }

    /// A sheet that is one flat patch is searched once while it stays flat, however far it moves,
    /// and again as soon as a fold turns its triangles; a sheet that is not one flat patch is searched
    /// again when its vertices drift apart, as before.
    #[test]
    fn a_flat_sheet_is_searched_again_only_when_it_folds() {
        // A 1 m sheet of 2 cm cells.
        let Sheet { rest, triangles, edges, mean } = Sheet::new([1.0, 1.0], [50, 50]);
        let thickness = 0.1 * mean;
        let mut sc = SelfCollision::new(&rest, &triangles, edges.clone(), mean);
        find(&mut sc, &rest, &rest, &triangles, thickness);
        assert_eq!((sc.searches, sc.whole), (1, true), "one flat patch");
        // Stretched by 5% along x, sheared, and carried 3 m: still flat, no search.
        let moved = |f: f64| {
            rest.iter().map(|p| DVec3::new(p.x * (1.0 + 0.05 * f) + 0.1 * f * p.z + 3.0 * f, 0.0, p.z)).collect()
        };
        let (a, b): (Vec<DVec3>, Vec<DVec3>) = (moved(0.5), moved(1.0));
        find(&mut sc, &a, &b, &triangles, thickness);
        assert_eq!(sc.searches, 1, "a flat sheet moved in its plane needs no search");
        // Folded along x = 3 m by 120°: the triangles on one side turn past the tilt.
        let (c, s) = (120f64.to_radians().cos(), 120f64.to_radians().sin());
        let folded: Vec<DVec3> = b
            .iter()
            .map(|p| if p.x > 3.0 { DVec3::new(3.0 + (p.x - 3.0) * c, (p.x - 3.0) * s, p.z) } else { *p })
            .collect();
        find(&mut sc, &b, &folded, &triangles, thickness);
        assert_eq!(sc.searches, 2, "a fold makes the search again (from the substep's start)");
        find(&mut sc, &folded, &folded, &triangles, thickness);
        assert_eq!((sc.searches, sc.renewals), (2, 1), "within that search's margins the fold is renewed");
        assert!(!sc.whole, "the folded sheet is not one flat patch");
        find(&mut sc, &folded, &folded, &triangles, thickness);
        assert_eq!((sc.searches, sc.renewals), (2, 1), "nothing moved");
        assert!(!sc.pairs.is_empty(), "pairs by the fold (the margins allow for it)");
        // Unfolded to where it was searched: renewed, one flat patch again, and no pair.
        find(&mut sc, &b, &b, &triangles, thickness);
        assert_eq!((sc.searches, sc.renewals, sc.whole), (2, 2, true));
        assert!(sc.pairs.is_empty() && sc.edge_pairs.is_empty(), "a flat sheet holds no pair");
        find(&mut sc, &folded, &folded, &triangles, thickness);
        assert_eq!((sc.searches, sc.renewals, sc.whole), (2, 3, false), "folded again");
        // Not one flat patch: a shear in its plane beyond the margins makes the search again.
        let drifted: Vec<DVec3> = folded.iter().map(|p| *p + DVec3::new(0.0, 0.0, 0.2 * (p.x - 3.0))).collect();
        find(&mut sc, &folded, &drifted, &triangles, thickness);
        assert_eq!(sc.searches, 3, "drift counts where the sheet is not one flat patch");
    }

    /// A sheet folded almost flat onto itself along a line of vertices: the fans on the crease are
    /// not flat, so every vertex–triangle and edge–edge pair within the thickness across it is listed
    /// (checked against every pair of the mesh). A sheet rolled through 150°: flat patches, and the
    /// neighbours along their borders skipped round flat fans.
    #[test]
    fn pairs_across_a_crease_are_listed_and_flat_fans_skipped() {
        let Sheet { rest, triangles, edges, mean } = Sheet::new([0.4, 0.2], [20, 10]);
        let (c, s) = (175f64.to_radians().cos(), 175f64.to_radians().sin());
        let folded: Vec<DVec3> =
            rest.iter().map(|p| if p.x > 0.0 { DVec3::new(p.x * c, p.x * s, p.z) } else { *p }).collect();
        // 0.4 m round a cylinder of radius 0.4 m / (150° in radians).
        let radius = 0.4 / 150f64.to_radians();
        let rolled: Vec<DVec3> = rest
            .iter()
            .map(|p| DVec3::new(radius * (p.x / radius).sin(), radius * (1.0 - (p.x / radius).cos()), p.z))
            .collect();
        let thickness = 0.1 * mean;
        for (x, crease) in [(folded, true), (rolled, false)] {
            let mut sc = SelfCollision::new(&rest, &triangles, edges.clone(), mean);
            find(&mut sc, &x, &x, &triangles, thickness);
            let near = all_near_pairs_listed(&sc, &x, &triangles, &edges, thickness);
            if crease {
                assert!(near > 20, "the layers touch by the crease: {near} pairs");
            } else {
                let judged: Vec<bool> = sc.flat_fans.iter().filter_map(Cell::get).collect();
                assert!(!sc.whole && !judged.is_empty(), "neighbours handed over round fans");
                assert!(judged.iter().all(|&f| f), "and skipped: every fan judged is flat");
            }
        }
    }

    /// Every vertex–triangle and edge–edge pair of the mesh within `thickness` at `x` is listed in
    /// `sc` (checked against every pair); returns how many there are.
    fn all_near_pairs_listed(
        sc: &SelfCollision,
        x: &[DVec3],
        triangles: &[[usize; 3]],
        edges: &[[usize; 2]],
        thickness: f64,
    ) -> usize {
        let mut near = 0;
        for (v, q) in x.iter().enumerate() {
            for (t, tri) in triangles.iter().enumerate() {
                let corners = tri.map(|i| x[i]);
                let on = closest::at(corners, closest_on_triangle(*q, corners).0);
                if !tri.contains(&v) && (*q - on).length() <= thickness {
                    near += 1;
                    let listed = sc.pairs.iter().any(|p| (p.vertex, p.triangle) == (v as u32, t as u32));
                    assert!(listed, "vertex {v} within the thickness of triangle {t}");
                }
            }
        }
        for (k, e) in edges.iter().enumerate() {
            for (j, f) in edges.iter().enumerate().skip(k + 1) {
                let gap = segment_gap(e.map(|i| x[i]), f.map(|i| x[i])).length();
                if !f.contains(&e[0]) && !f.contains(&e[1]) && gap <= thickness {
                    near += 1;
                    assert!(sc.edge_pairs.iter().any(|p| p.edges == [k as u32, j as u32]), "edges {k}, {j}");
                }
            }
        }
        near
    }

    /// A V whose one arm, a flat patch at the search, folds onto itself within the margins that search
    /// allowed for: its turned triangles are renewed, not searched, and every pair the fold brings
    /// within the thickness is listed (against every pair of the mesh).
    #[test]
    fn a_patch_folding_within_the_margins_is_renewed_and_its_pairs_listed() {
        let Sheet { rest, triangles, edges, mean } = Sheet::new([0.8, 0.2], [40, 10]);
        // The arm x > 0 at 90° to the other; in it, the part beyond 0.2 m folded back by `degrees`
        // about the line 0.2 m out.
        let shape = |degrees: f64| -> Vec<DVec3> {
            let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
            rest.iter()
                .map(|p| {
                    let along = if p.x > 0.2 {
                        DVec3::new(0.2 + (p.x - 0.2) * c, (p.x - 0.2) * s, 0.0)
                    } else {
                        p.x * DVec3::X
                    };
                    if p.x > 0.0 { DVec3::new(0.0, along.x, -along.y) + p.z * DVec3::Z } else { *p }
                })
                .collect()
        };
        let thickness = 0.1 * mean;
        let (open, folded) = (shape(0.0), shape(178.0));
        let mut sc = SelfCollision::new(&rest, &triangles, edges.clone(), mean);
        // Searched at the open V, with the fold as the substep's predicted end: margins for it.
        find(&mut sc, &open, &folded, &triangles, thickness);
        // (Pairs across the V, for the margins are wide; none within the arm, a flat patch.)
        let across = sc.pairs.len();
        assert_eq!((sc.searches, sc.renewals), (1, 0));
        find(&mut sc, &folded, &folded, &triangles, thickness);
        assert_eq!((sc.searches, sc.renewals), (1, 1), "the fold is renewed");
        let near = all_near_pairs_listed(&sc, &folded, &triangles, &edges, thickness);
        assert!(near > 20 && sc.pairs.len() > across, "the fold's layers touch: {near} pairs");
    }

    /// A V of two flat halves sheared steadily along its fold: searches two substeps apart at first,
    /// then the margins stretch to four substeps' travel and they come five apart; a search that lists
    /// many pairs (the V closed flat) brings the margins back.
    #[test]
    fn frequent_searches_that_list_few_pairs_stretch_the_margins() {
        let Sheet { rest, triangles, edges, mean } = Sheet::new([2.0, 1.0], [100, 50]);
        let fold = |degrees: f64, step: f64| -> Vec<DVec3> {
            let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
            let shear = |p: &DVec3| DVec3::Z * (0.002 * step * p.x);
            rest.iter().map(|p| if p.x > 0.0 { DVec3::new(p.x * c, p.x * s, p.z) } else { *p } + shear(p)).collect()
        };
        let mut sc = SelfCollision::new(&rest, &triangles, edges, mean);
        let mut at = Vec::new();
        for n in 0..40 {
            find(&mut sc, &fold(90.0, n as f64), &fold(90.0, n as f64 + 1.0), &triangles, 0.1 * mean);
            if at.len() < sc.searches as usize {
                at.push(n);
            }
        }
        let gaps: Vec<i32> = at.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!((gaps[0], *gaps.last().unwrap()), (2, 5), "searches at substeps {at:?}");
        assert_eq!(sc.stretch, MOST_STRETCH);
        find(&mut sc, &fold(179.0, 40.0), &fold(179.0, 40.0), &triangles, 0.1 * mean);
        assert!(sc.pairs.len() + sc.edge_pairs.len() > 103, "{} pairs", sc.pairs.len() + sc.edge_pairs.len());
        assert_eq!(sc.stretch, 1.0, "many pairs: margins of one substep's travel again");
    }

    /// A cloth covered by flat patches but not one (a V of two flat halves) still counts its drift:
    /// closing the V by 8°, under the tilt, brings its arms centimetres nearer and needs a search.
    #[test]
    fn two_flat_halves_are_not_one_flat_patch() {
        // 2 m × 1 m of 2 cm cells, folded square at x = 0 (the hierarchy's first split).
        let Sheet { rest, triangles, edges, mean } = Sheet::new([2.0, 1.0], [100, 50]);
        let fold = |degrees: f64| -> Vec<DVec3> {
            let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
            rest.iter().map(|p| if p.x > 0.0 { DVec3::new(p.x * c, p.x * s, p.z) } else { *p }).collect()
        };
        let (open, closed) = (fold(90.0), fold(98.0));
        let mut sc = SelfCollision::new(&rest, &triangles, edges, mean);
        find(&mut sc, &open, &open, &triangles, 0.1 * mean);
        assert!(!sc.whole, "but not one patch");
        find(&mut sc, &open, &closed, &triangles, 0.1 * mean);
        assert_eq!(sc.searches, 2, "the V closing needs a search");
    }
}
