//! A bounding-volume hierarchy over a mesh's triangles for self-collision: built once from the rest
//! shape (each node splits its triangles at the median of their centroids along its longest axis, so
//! a node is a compact patch of the mesh), its boxes refitted from the current positions before each
//! query, and queried for every pair of triangles whose boxes overlap.
//!
//! The query descends from the root paired with itself: a node against itself is its children against
//! themselves and against each other; two nodes whose boxes are apart are skipped with everything
//! below them. Pairs come in a fixed order (depth first, left before right), the same every run.
//!
//! A node is not paired with itself when its patch is flat enough that nothing in it can be within
//! reach of anything else in it (Volino & Magnenat-Thalmann's normal-cone test, made quantitative):
//! its triangles' normals lie within 45° of one axis, so the patch is a graph over the plane across
//! that axis with slopes below 1, and two points of it are at least `cos 45°` times their distance
//! along the surface apart; vertices and edges that share no corner are at least the patch's smallest
//! triangle altitude apart along the surface (less 10% for stretch). When that bound exceeds the
//! largest reach asked of the patch's triangles, the patch cannot hold a pair within reach. A patch is
//! a subtree of the rest-shape split, compact and simply connected, so it cannot wind round onto
//! itself without shearing by far more than cloth does.
//!
//! The query can be asked for patches that stay flat while each of their triangles' normals turns by
//! up to a tilt `δ` (a patch's cone is then at most its half-angle plus `δ`, so it is skipped only if
//! that sum is within 45°): a caller that checks that no triangle has turned by more than `δ` since
//! its normal was taken knows the skipped patches are still flat, whatever else moved.
//!
//! Two nodes that are each flat, whose union is flat by the same test (the merged cone, the smaller
//! altitude, the larger reach) and that share an edge of the mesh are not paired either: together they
//! are one patch, compact and simply connected like a node's (two neighbouring blocks of the rest
//! shape's split), which holds no pair within reach while it stays flat. Without this, the hierarchy
//! descends along every border between its flat patches, wherever a border of the split crosses a
//! flat region, and hands over every pair of neighbouring triangles along it: on a wrinkled sheet
//! most of a search's work. Such pairs of nodes are remembered, and looked at again when one of their
//! triangles turns.
//!
//! When some triangles have turned further, the caller gives their normals now
//! ([`TriangleTree::turn`]) and asks for the pairs that became due ([`TriangleTree::renewed_pairs`]),
//! the boxes as they were: only the nodes holding a turned triangle are looked at within themselves
//! again (a pair of two nodes hands over what it did, whatever their normals), and a patch that was
//! skipped as flat and is flat no more hands over every overlapping pair within it. Each node
//! remembers what its last look found (flat, or open: its halves and the pair of them looked at), so
//! the pairs handed over since the last full query are those a full query with the new normals would
//! hand over, and maybe some that a patch now flat would skip.

use glam::DVec3;

use crate::mesh::sides;

/// No child: a leaf.
const LEAF: u32 = u32::MAX;

/// Each node's edges on its border (those of one of its triangles only), sorted, as vertex pairs.
#[derive(Debug, Clone, Default)]
struct Borders {
    /// Node `k`'s are `edges[start[k]..start[k + 1]]`.
    edges: Vec<[u32; 2]>,
    start: Vec<u32>,
}

impl Borders {
    /// Node `k`'s border edges.
    fn of(&self, k: u32) -> &[[u32; 2]] {
        &self.edges[self.start[k as usize] as usize..self.start[k as usize + 1] as usize]
    }

    /// Whether nodes `a` and `b` share an edge on their borders.
    fn shared(&self, a: u32, b: u32) -> bool {
        let (x, y) = (self.of(a), self.of(b));
        let (mut i, mut j) = (0, 0);
        while i < x.len() && j < y.len() {
            match x[i].cmp(&y[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => return true,
            }
        }
        false
    }
}

/// What the last look at a node's pairs within itself found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Patch {
    /// Not looked at since the last full query (it lies in a patch skipped as flat).
    Unseen,
    /// Flat: skipped.
    Flat,
    /// Not flat: its halves were looked at, and the pair of them.
    Open,
}

/// `cos 45°`: the widest normal cone of a patch that can be flat.
const FLAT: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A cone of directions: an axis and the cosine and sine of the half-angle (a cosine of −1: every
/// direction).
#[derive(Debug, Clone, Copy)]
struct Cone {
    axis: DVec3,
    cos: f64,
    sin: f64,
}

impl Cone {
    const ALL: Cone = Cone { axis: DVec3::Z, cos: -1.0, sin: 0.0 };

    /// The cone of one unit normal (every direction if it is zero: a degenerate triangle).
    fn of(normal: DVec3) -> Cone {
        if normal == DVec3::ZERO { Cone::ALL } else { Cone { axis: normal, cos: 1.0, sin: 0.0 } }
    }

    /// A cone holding both, about the bisector of their axes, without trigonometric functions
    /// (angles added by their cosines and sines).
    fn merge(a: Cone, b: Cone) -> Cone {
        if a.cos <= -1.0 || b.cos <= -1.0 {
            return Cone::ALL;
        }
        // Both axes are half the angle between them from the bisector: `cos²(φ/2) = (1 + cos φ)/2`.
        let d = a.axis.dot(b.axis).clamp(-1.0, 1.0);
        if 1.0 + d < 1e-12 {
            return Cone::ALL;
        }
        let (cos_b, sin_b) = ((0.5 * (1.0 + d)).sqrt(), (0.5 * (1.0 - d)).sqrt());
        let axis = (a.axis + b.axis) * (0.5 / cos_b);
        // The half-angle reaching the wider child's far side: the angle to its axis plus its own.
        let wide = if a.cos <= b.cos { a } else { b };
        let (cos, sin) = (cos_b * wide.cos - sin_b * wide.sin, sin_b * wide.cos + cos_b * wide.sin);
        if sin < 0.0 { Cone::ALL } else { Cone { axis, cos, sin } }
    }
}

/// Trees of at least this many nodes have their root's two subtrees refitted at once where there are
/// several threads.
const REFIT_SPLIT: usize = 4096;

/// A node: its box, normal cone, largest reach and smallest altitude, and either two children or one
/// triangle.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    cone: Cone,
    reach: f64,
    altitude: f64,
    children: [u32; 2],
    /// Its parent (the root's is itself).
    parent: u32,
    triangle: u32,
    /// One past the last node of its subtree (depth-first order: the subtree is `index..end`).
    end: u32,
}

/// What a refit finds of a node: its box, normal cone and largest reach.
#[derive(Debug, Clone, Copy)]
struct Fit {
    lo: DVec3,
    hi: DVec3,
    cone: Cone,
    reach: f64,
}

/// What the query needs of a triangle at present.
#[derive(Debug, Clone, Copy)]
pub struct Leaf {
    /// Its box (grown as the caller needs).
    pub lo: DVec3,
    /// Its box's other corner.
    pub hi: DVec3,
    /// Its unit normal (zero if degenerate).
    pub normal: DVec3,
    /// How near another primitive must be to it to count (within a patch that stays flat).
    pub reach: f64,
}

/// The tilt `δ` a query allows each triangle's normal, as its cosine and sine.
#[derive(Debug, Clone, Copy)]
pub struct Tilt {
    /// `cos δ`.
    pub cos: f64,
    /// `sin δ`.
    pub sin: f64,
}

impl Tilt {
    /// No tilt: patches flat as they are.
    pub const NONE: Tilt = Tilt { cos: 1.0, sin: 0.0 };

    /// A tilt of `angle` radians (in `[0, π/4]`).
    pub fn new(angle: f64) -> Self {
        Self { cos: angle.cos(), sin: angle.sin() }
    }

    /// The cosine of the widest half-angle, `45° − δ`, a patch's normal cone may have now to stay
    /// within 45° while each normal turns by up to `δ`.
    pub fn widest(&self) -> f64 {
        FLAT * (self.cos + self.sin)
    }
}

/// Whether vertices and edges sharing no corner, in a patch of smallest triangle altitude `altitude`
/// whose normals lie within 45° of one axis, are more than `reach` apart: at least `cos 45°` times
/// their distance along the surface, which is at least the altitude less 10% for stretch.
pub fn far_apart(altitude: f64, reach: f64) -> bool {
    0.9 * FLAT * altitude > reach
}

/// A triangle's smallest altitude: twice its area over its longest side (zero if degenerate).
pub fn smallest_altitude([a, b, c]: [DVec3; 3]) -> f64 {
    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
    if longest > 0.0 { (b - a).cross(c - a).length() / longest } else { 0.0 }
}

/// The hierarchy.
#[derive(Debug, Clone, Default)]
pub struct TriangleTree {
    /// In depth-first order: a node's children come after it.
    nodes: Vec<Node>,
    /// Each triangle's leaf.
    leaves: Vec<u32>,
    /// What the last look at each node found.
    patches: Vec<Patch>,
    /// The nodes holding a triangle turned since the last query, and a flag for each node.
    turned: Vec<u32>,
    is_turned: Vec<bool>,
    /// Scratch for the query: pairs of nodes, whether every pair under them is due, and whether they
    /// are known to share no edge (nor then does any pair under them).
    stack: Vec<([u32; 2], bool, bool)>,
    /// Each node's edges on its border.
    borders: Borders,
    /// The pairs of neighbouring nodes skipped as one flat patch since the last full query.
    joined: Vec<[u32; 2]>,
}

impl TriangleTree {
    /// The hierarchy of these triangles, split by their centroids at `rest`.
    pub fn new(rest: &[DVec3], triangles: &[[usize; 3]]) -> Self {
        let centroids: Vec<DVec3> = triangles.iter().map(|t| (rest[t[0]] + rest[t[1]] + rest[t[2]]) / 3.0).collect();
        let altitudes: Vec<f64> = triangles.iter().map(|t| smallest_altitude(t.map(|i| rest[i]))).collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut tree = Self { nodes: Vec::with_capacity(2 * triangles.len()), ..Self::default() };
        if !order.is_empty() {
            tree.split(&mut order, &centroids, &altitudes);
        }
        tree.leaves = vec![0; triangles.len()];
        for (k, node) in tree.nodes.iter().enumerate() {
            if node.children[0] == LEAF {
                tree.leaves[node.triangle as usize] = k as u32;
            }
        }
        tree.patches = vec![Patch::Unseen; tree.nodes.len()];
        tree.is_turned = vec![false; tree.nodes.len()];
        tree.find_borders(triangles);
        tree
    }

    /// Each node's border edges: a leaf's three, and a parent's those that only one of its children
    /// has on its border (the edges both have are inside it).
    fn find_borders(&mut self, triangles: &[[usize; 3]]) {
        let mut borders: Vec<Vec<[u32; 2]>> = vec![Vec::new(); self.nodes.len()];
        for k in (0..self.nodes.len()).rev() {
            let node = &self.nodes[k];
            borders[k] = if node.children[0] == LEAF {
                let mut edges = sides(triangles[node.triangle as usize]).map(|e| e.map(|v| v as u32));
                edges.sort_unstable();
                edges.to_vec()
            } else {
                let [l, r] = node.children.map(|c| &borders[c as usize]);
                let mut both: Vec<[u32; 2]> = l.iter().chain(r).copied().collect();
                both.sort_unstable();
                both.chunk_by(|a, b| a == b).filter(|run| run.len() == 1).map(|run| run[0]).collect()
            };
        }
        let start = std::iter::once(0)
            .chain(borders.iter().scan(0u32, |n, b| {
                *n += b.len() as u32;
                Some(*n)
            }))
            .collect();
        self.borders = Borders { edges: borders.concat(), start };
    }

    /// Whether nodes `a` and `b` are flat together as one patch (see the module's notes) while their
    /// normals turn by up to `tilt`: each flat, their union flat, and sharing an edge.
    fn flat_together(nodes: &[Node], borders: &Borders, [a, b]: [u32; 2], tilt: Tilt) -> bool {
        Self::flat_as_one(nodes, [a, b], tilt) && borders.shared(a, b)
    }

    /// Whether nodes `a` and `b` are each flat and flat as one (their union's cone, smaller altitude
    /// and larger reach): flat together if they also share an edge.
    fn flat_as_one(nodes: &[Node], [a, b]: [u32; 2], tilt: Tilt) -> bool {
        let (na, nb) = (&nodes[a as usize], &nodes[b as usize]);
        if !(Self::flat(na, tilt) && Self::flat(nb, tilt)) {
            return false;
        }
        let union = Node {
            cone: Cone::merge(na.cone, nb.cone),
            reach: na.reach.max(nb.reach),
            altitude: na.altitude.min(nb.altitude),
            ..*na
        };
        Self::flat(&union, tilt)
    }

    /// Append the subtree of `items` (depth first); returns its index.
    fn split(&mut self, items: &mut [u32], centroids: &[DVec3], altitudes: &[f64]) -> u32 {
        let index = self.nodes.len() as u32;
        let empty = Node {
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            cone: Cone::ALL,
            reach: 0.0,
            altitude: f64::INFINITY,
            children: [LEAF; 2],
            parent: index,
            triangle: 0,
            end: index + 1,
        };
        if let [only] = items {
            self.nodes.push(Node { triangle: *only, altitude: altitudes[*only as usize], ..empty });
            return index;
        }
        self.nodes.push(empty);
        let (lo, hi) = items.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &t| {
            (lo.min(centroids[t as usize]), hi.max(centroids[t as usize]))
        });
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let middle = items.len() / 2;
        items.select_nth_unstable_by(middle, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b))
        });
        let (left, right) = items.split_at_mut(middle);
        let l = self.split(left, centroids, altitudes);
        let r = self.split(right, centroids, altitudes);
        let altitude = self.nodes[l as usize].altitude.min(self.nodes[r as usize].altitude);
        let end = self.nodes.len() as u32;
        self.nodes[l as usize].parent = index;
        self.nodes[r as usize].parent = index;
        let node = &mut self.nodes[index as usize];
        (node.children, node.altitude, node.end) = ([l, r], altitude, end);
        index
    }

    /// Refit every node from its triangles as they are now (`leaf(triangle)`): the root's two
    /// subtrees at once where there are several threads and the tree is large (`REFIT_SPLIT` nodes; they
    /// are ranges of nodes, written apart), then the root. Each node's fit is the same either way.
    pub fn refit(&mut self, leaf: impl Fn(usize) -> Leaf + Sync) {
        let split = match self.nodes.first() {
            Some(root) if root.children[0] != LEAF && crate::threads::threads() > 1 => self.nodes.len() >= REFIT_SPLIT,
            _ => false,
        };
        if split {
            let [l, r] = self.nodes[0].children;
            let (root, below) = self.nodes.split_at_mut(1);
            let (left, right) = below.split_at_mut((r - l) as usize);
            crate::threads::join(|| Self::refit_nodes(left, l, &leaf), || Self::refit_nodes(right, r, &leaf));
            let (a, b) = (left[0], right[0]);
            let root = &mut root[0];
            (root.lo, root.hi, root.cone, root.reach) =
                (a.lo.min(b.lo), a.hi.max(b.hi), Cone::merge(a.cone, b.cone), a.reach.max(b.reach));
        } else {
            Self::refit_nodes(&mut self.nodes, 0, &leaf);
        }
        self.turned.iter().for_each(|&k| self.is_turned[k as usize] = false);
        self.turned.clear();
    }

    /// Refit `nodes`, a subtree whose root is node `first` of the tree, from its triangles.
    fn refit_nodes(nodes: &mut [Node], first: u32, leaf: &impl Fn(usize) -> Leaf) {
        // From the last node back, so that children come before their parents. A node's first child
        // is the node after it, refitted just before: it is carried over in registers, as read back
        // from memory just after being written it waited for the stores to land.
        let mut last = Fit { lo: DVec3::ZERO, hi: DVec3::ZERO, cone: Cone::ALL, reach: 0.0 };
        for k in (0..nodes.len()).rev() {
            let [l, r] = nodes[k].children;
            let fit = if l == LEAF {
                let f = leaf(nodes[k].triangle as usize);
                Fit { lo: f.lo, hi: f.hi, cone: Cone::of(f.normal), reach: f.reach }
            } else {
                debug_assert_eq!((l - first) as usize, k + 1, "a first child follows its parent");
                let b = &nodes[(r - first) as usize];
                Fit {
                    lo: last.lo.min(b.lo),
                    hi: last.hi.max(b.hi),
                    cone: Cone::merge(last.cone, b.cone),
                    reach: last.reach.max(b.reach),
                }
            };
            let n = &mut nodes[k];
            (n.lo, n.hi, n.cone, n.reach) = (fit.lo, fit.hi, fit.cone, fit.reach);
            last = fit;
        }
    }

    /// Take `triangle`'s unit normal now (zero if degenerate), its box as it was.
    pub fn turn(&mut self, triangle: u32, normal: DVec3) {
        let mut k = self.leaves[triangle as usize];
        self.nodes[k as usize].cone = Cone::of(normal);
        while !self.is_turned[k as usize] {
            self.is_turned[k as usize] = true;
            self.turned.push(k);
            k = self.nodes[k as usize].parent;
        }
    }

    /// Whether nothing in node `n`'s patch can be within reach of anything else in it, while each
    /// normal turns by up to `tilt` (the cone's half-angle plus the tilt within 45°).
    fn flat(n: &Node, tilt: Tilt) -> bool {
        n.cone.cos * tilt.cos - n.cone.sin * tilt.sin >= FLAT && far_apart(n.altitude, n.reach)
    }

    /// Call `found` with every pair of distinct triangles whose boxes overlap, each pair once, except
    /// pairs within a patch that stays flat while its normals turn by up to `tilt` (see the module's
    /// notes).
    pub fn overlapping_pairs(&mut self, tilt: Tilt, found: impl FnMut(u32, u32)) {
        self.patches.fill(Patch::Unseen);
        self.joined.clear();
        self.query(tilt, true, &[], found);
    }

    /// After [`Self::turn`], call `found` with the pairs [`Self::overlapping_pairs`] would now hand
    /// over that it has not handed over since it was last called: those within the patches that the
    /// turned triangles opened (each pair maybe more than once).
    pub fn renewed_pairs(&mut self, tilt: Tilt, found: impl FnMut(u32, u32)) {
        if self.turned.is_empty() {
            return;
        }
        // Children come after their parents: merge the cones from the leaves up.
        self.turned.sort_unstable_by(|a, b| b.cmp(a));
        for &k in &self.turned {
            let [l, r] = self.nodes[k as usize].children;
            if l != LEAF {
                self.nodes[k as usize].cone = Cone::merge(self.nodes[l as usize].cone, self.nodes[r as usize].cone);
            }
        }
        // Neighbours skipped as one flat patch are looked at again if either has a turned triangle: no
        // longer flat together, every pair under them is due.
        let (nodes, borders, is_turned) = (&self.nodes, &self.borders, &self.is_turned);
        let mut reopened = Vec::new();
        self.joined.retain(|&[a, b]| {
            let kept =
                !(is_turned[a as usize] || is_turned[b as usize]) || Self::flat_together(nodes, borders, [a, b], tilt);
            if !kept {
                reopened.push([a, b]);
            }
            kept
        });
        self.query(tilt, false, &reopened, found);
        self.turned.iter().for_each(|&k| self.is_turned[k as usize] = false);
        self.turned.clear();
    }

    /// The descent from the root paired with itself: every pair under a node pair marked due is
    /// handed over (all of them if `all`); otherwise only the nodes with a turned triangle are looked
    /// at within themselves, and a node that was not open before makes every pair within it due.
    fn query(&mut self, tilt: Tilt, all: bool, reopened: &[[u32; 2]], mut found: impl FnMut(u32, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let (nodes, patches, is_turned, borders) = (&self.nodes, &mut self.patches, &self.is_turned, &self.borders);
        let (stack, joined) = (&mut self.stack, &mut self.joined);
        stack.clear();
        stack.extend(reopened.iter().rev().map(|&pair| (pair, true, false)));
        stack.push(([0, 0], all, false));
        while let Some(([a, b], due, mut unshared)) = stack.pop() {
            let (na, nb) = (&nodes[a as usize], &nodes[b as usize]);
            if a == b {
                if na.children[0] == LEAF || !(due || is_turned[a as usize]) {
                    continue;
                }
                if Self::flat(na, tilt) {
                    patches[a as usize] = Patch::Flat;
                } else {
                    let below = due || patches[a as usize] != Patch::Open;
                    patches[a as usize] = Patch::Open;
                    let [l, r] = na.children;
                    stack.push(([l, r], below, false));
                    stack.push(([r, r], below, false));
                    stack.push(([l, l], below, false));
                }
                continue;
            }
            if !due {
                continue;
            }
            if na.lo.cmpgt(nb.hi).any() || nb.lo.cmpgt(na.hi).any() {
                continue;
            }
            // Two neighbours flat together are one flat patch. Two that share no edge have no pairs
            // under them that do (an edge two of their triangles share is on both their borders).
            if !unshared && Self::flat_as_one(nodes, [a, b], tilt) {
                if borders.shared(a, b) {
                    joined.push([a, b]);
                    continue;
                }
                unshared = true;
            }
            match (na.children[0] == LEAF, nb.children[0] == LEAF) {
                (true, true) => found(na.triangle, nb.triangle),
                // Descend the node with the larger box (or the one that is not a leaf).
                (false, leaf_b) if leaf_b || (na.hi - na.lo).length_squared() >= (nb.hi - nb.lo).length_squared() => {
                    stack.push(([na.children[1], b], true, unshared));
                    stack.push(([na.children[0], b], true, unshared));
                }
                _ => {
                    stack.push(([a, nb.children[1]], true, unshared));
                    stack.push(([a, nb.children[0]], true, unshared));
                }
            }
        }
    }

    /// Whether the last query skipped the whole mesh as one flat patch (the root).
    pub fn all_flat(&self) -> bool {
        self.patches.first() == Some(&Patch::Flat)
    }

    /// The patches skipped as flat now (the nodes reached from the root through open ones), each as
    /// its triangles.
    #[cfg(test)]
    fn flat_patches(&self) -> Vec<Vec<u32>> {
        let mut open = vec![0u32];
        let mut flat = Vec::new();
        while let Some(k) = open.pop() {
            let node = &self.nodes[k as usize];
            match self.patches[k as usize] {
                Patch::Flat => flat.push(
                    self.nodes[k as usize..node.end as usize]
                        .iter()
                        .filter(|n| n.children[0] == LEAF)
                        .map(|n| n.triangle)
                        .collect(),
                ),
                Patch::Open => open.extend(node.children),
                Patch::Unseen => {}
            }
        }
        flat
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A unit vector from two angles.
    fn direction(polar: f64, azimuth: f64) -> DVec3 {
        DVec3::new(polar.sin() * azimuth.cos(), polar.sin() * azimuth.sin(), polar.cos())
    }

    proptest! {
        /// A merged cone holds every direction of both cones (sampled on their rims), and is no wider
        /// than the two cones and the angle between their axes allow.
        #[test]
        fn a_merged_cone_holds_both(
            first in (0.0..std::f64::consts::PI, 0.0..std::f64::consts::TAU, 0.0..1.2f64),
            second in (0.0..std::f64::consts::PI, 0.0..std::f64::consts::TAU, 0.0..1.2f64),
        ) {
            let (axes, halves) = ([(first.0, first.1), (second.0, second.1)], [first.2, second.2]);
            let cones = [0, 1].map(|k| {
                let axis = direction(axes[k].0, axes[k].1);
                Cone { axis, cos: halves[k].cos(), sin: halves[k].sin() }
            });
            let merged = Cone::merge(cones[0], cones[1]);
            let between = cones[0].axis.angle_between(cones[1].axis);
            let widest = (0.5 * between + halves[0].max(halves[1])).min(std::f64::consts::PI);
            if merged.cos > -1.0 {
                prop_assert!((merged.axis.length() - 1.0).abs() < 1e-12);
                prop_assert!((merged.cos.acos() - widest).abs() < 1e-6, "{} against {widest}", merged.cos.acos());
                for (k, cone) in cones.iter().enumerate() {
                    // Two directions across the cone's axis, and the rim at twelve azimuths about it.
                    let across = cone.axis.any_orthonormal_pair();
                    for j in 0..12 {
                        let turn = j as f64 * std::f64::consts::TAU / 12.0;
                        let side = across.0 * turn.cos() + across.1 * turn.sin();
                        let rim = cone.axis * halves[k].cos() + side * halves[k].sin();
                        prop_assert!(rim.dot(merged.axis) >= merged.cos - 1e-12, "cone {k}, azimuth {j}");
                    }
                }
            } else {
                prop_assert!(widest > std::f64::consts::PI - 1e-5, "only cones spanning everything merge to all");
            }
        }
    }

    /// Refit `tree` to the triangles at `x`, each box grown by half of `reach` (every triangle's reach).
    fn refit_at(tree: &mut TriangleTree, triangles: &[[usize; 3]], x: &[DVec3], reach: f64) {
        tree.refit(|t| {
            let c = triangles[t].map(|i| x[i]);
            let (lo, hi) = crate::mesh::bounds(&c);
            let normal = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
            Leaf { lo: lo - 0.5 * reach, hi: hi + 0.5 * reach, normal, reach }
        });
    }

    /// Every overlapping pair, each once, against all pairs tested by hand.
    #[test]
    fn the_pairs_are_exactly_the_overlapping_ones() {
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [9, 7]).unwrap();
        let rest = mesh.positions().to_vec();
        let triangles = mesh.triangles().to_vec();
        let mut tree = TriangleTree::new(&rest, &triangles);
        // The grid lies in the xz-plane. Fold the sheet over itself, so that far-apart triangles overlap, and grow boxes a little.
        let x: Vec<DVec3> = rest.iter().map(|p| DVec3::new(p.x.abs(), p.z, 0.01 * p.x.signum())).collect();
        let bounds = |t: usize| {
            let (lo, hi) = triangles[t]
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| (lo.min(x[i]), hi.max(x[i])));
            (lo - 0.02, hi + 0.02)
        };
        // Reaches too large for any patch to be flat: every overlapping pair must come out.
        tree.refit(|t| {
            let (lo, hi) = bounds(t);
            Leaf { lo, hi, normal: DVec3::Z, reach: 1.0 }
        });
        let mut found = Vec::new();
        tree.overlapping_pairs(Tilt::NONE, |a, b| found.push([a.min(b), a.max(b)]));
        let count = found.len();
        found.sort_unstable();
        found.dedup();
        assert_eq!(found.len(), count, "each pair once");
        let mut brute = Vec::new();
        for a in 0..triangles.len() {
            for b in a + 1..triangles.len() {
                let ((la, ha), (lb, hb)) = (bounds(a), bounds(b));
                if la.cmple(hb).all() && lb.cmple(ha).all() {
                    brute.push([a as u32, b as u32]);
                }
            }
        }
        assert_eq!(found, brute);
        assert!(
            found.iter().any(|&[a, b]| (triangles[a as usize].iter().all(|&i| rest[i].x < 0.0))
                && triangles[b as usize].iter().all(|&i| rest[i].x > 0.0)),
            "the folded halves meet"
        );
    }

    /// A V of two planes at ±15° is one flat patch while its normals may turn by 25° more, and two
    /// (its halves) when they may turn by 35°; the skipped patches hold each triangle once.
    #[test]
    fn a_tilt_narrows_the_flat_patches_and_they_are_recorded() {
        let mesh = crate::mesh::generate::grid([2.0, 1.0], [16, 12]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let mut tree = TriangleTree::new(&rest, &triangles);
        let (cos, sin) = (15f64.to_radians().cos(), 15f64.to_radians().sin());
        let x: Vec<DVec3> = rest.iter().map(|p| DVec3::new(p.x * cos, p.x.abs() * sin, p.z)).collect();
        refit_at(&mut tree, &triangles, &x, 0.001);
        let all: Vec<u32> = (0..triangles.len() as u32).collect();
        for (tilt, patches, pairs) in [(25.0, 1, false), (35.0, 2, true)] {
            let mut found = 0;
            tree.overlapping_pairs(Tilt::new(f64::to_radians(tilt)), |_, _| found += 1);
            let flat = tree.flat_patches();
            let mut covered: Vec<u32> = flat.concat();
            covered.sort_unstable();
            assert_eq!(covered, all, "tilt {tilt}°: every triangle once");
            assert_eq!(flat.len(), patches, "tilt {tilt}°");
            assert_eq!(found > 0, pairs, "tilt {tilt}°: {found} pairs");
        }
    }

    /// Renewing after some triangles turned hands over exactly the pairs a full query with the new
    /// normals hands over that the query with the old ones did not: a sheet searched flat, then its
    /// triangles beyond a line given the normals of a sharp fold there (the boxes as they were), and
    /// again with the fold undone.
    #[test]
    fn renewed_pairs_are_what_a_full_query_adds() {
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [16, 12]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let (cos, sin) = (150f64.to_radians().cos(), 150f64.to_radians().sin());
        let folded: Vec<DVec3> = rest
            .iter()
            .map(|p| if p.x > 0.1 { DVec3::new(0.1 + (p.x - 0.1) * cos, (p.x - 0.1) * sin, p.z) } else { *p })
            .collect();
        let normals = |x: &[DVec3]| -> Vec<DVec3> {
            triangles.iter().map(|t| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalize()).collect()
        };
        let (flat, bent) = (normals(&rest), normals(&folded));
        // Normals curling through 180° across the sheet (neighbouring patches flat together), and the
        // same with a band of them turned 100° further (those patches no longer flat together).
        let curl = |kink: f64| -> Vec<DVec3> {
            triangles
                .iter()
                .map(|t| {
                    let x = t.iter().map(|&i| rest[i].x).sum::<f64>() / 3.0;
                    let angle = std::f64::consts::PI * x + if (0.1..0.25).contains(&x) { kink } else { 0.0 };
                    DVec3::new(angle.sin(), angle.cos(), 0.0)
                })
                .collect()
        };
        let (curled, kinked) = (curl(0.0), curl(100f64.to_radians()));
        // Boxes of the rest shape grown by 4 cm (the reach), so that neighbours overlap.
        let query = |tree: &mut TriangleTree, n: &[DVec3]| {
            tree.refit(|t| {
                let (lo, hi) = crate::mesh::bounds(&triangles[t].map(|i| rest[i]));
                Leaf { lo: lo - 0.02, hi: hi + 0.02, normal: n[t], reach: 0.001 }
            });
            let mut found = std::collections::BTreeSet::new();
            tree.overlapping_pairs(Tilt::NONE, |a, b| {
                found.insert([a.min(b), a.max(b)]);
            });
            found
        };
        let mut tree = TriangleTree::new(&rest, &triangles);
        for (from, to, opens) in [(&flat, &bent, true), (&bent, &flat, false), (&curled, &kinked, true)] {
            let before = query(&mut tree, from);
            let after = query(&mut TriangleTree::new(&rest, &triangles), to);
            let mut renewed = std::collections::BTreeSet::new();
            for t in (0..triangles.len()).filter(|&t| from[t] != to[t]) {
                tree.turn(t as u32, to[t]);
            }
            tree.renewed_pairs(Tilt::NONE, |a, b| {
                renewed.insert([a.min(b), a.max(b)]);
            });
            let added: std::collections::BTreeSet<[u32; 2]> = after.difference(&before).copied().collect();
            assert!(
                renewed.is_subset(&after) && added.is_subset(&renewed),
                "{} added, {} renewed",
                added.len(),
                renewed.len()
            );
            assert_eq!(added.is_empty(), !opens);
            assert_eq!(tree.all_flat(), to == &flat);
        }
    }

    /// Two disjoint nodes share an edge on their borders exactly when a triangle of one and a
    /// triangle of the other share an edge (checked over every such pair of a grid's hierarchy).
    #[test]
    fn nodes_share_a_border_edge_exactly_when_their_triangles_do() {
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [9, 7]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let tree = TriangleTree::new(&rest, &triangles);
        let edges = |k: usize| -> std::collections::BTreeSet<[usize; 2]> {
            let node = &tree.nodes[k];
            tree.nodes[k..node.end as usize]
                .iter()
                .filter(|n| n.children[0] == LEAF)
                .flat_map(|n| sides(triangles[n.triangle as usize]))
                .collect()
        };
        let all: Vec<_> = (0..tree.nodes.len()).map(edges).collect();
        let (mut shared, mut apart) = (0, 0);
        for a in 0..tree.nodes.len() {
            for b in tree.nodes[a].end as usize..tree.nodes.len() {
                let expected = !all[a].is_disjoint(&all[b]);
                assert_eq!(tree.borders.shared(a as u32, b as u32), expected, "nodes {a} and {b}");
                *if expected { &mut shared } else { &mut apart } += 1;
            }
        }
        assert!(shared > 100 && apart > 100, "{shared} sharing, {apart} not");
    }

    /// A sheet whose normals curl through 180° has no flat patch as wide as itself, but its
    /// neighbouring patches are flat together: no pair of its triangles is handed over (its boxes
    /// overlap only where it is one flat patch). A sheet folded twice into three flat layers, the first and
    /// the last facing the same way and within reach of each other, is not one flat patch there: they
    /// share no edge, and every pair of triangles within reach across them is handed over.
    #[test]
    fn neighbouring_flat_patches_are_skipped_together_and_layers_are_not() {
        use crate::collision::closest::{at, closest_on_triangle};
        let mesh = crate::mesh::generate::grid([1.2, 0.4], [24, 8]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let normal = |x: &[DVec3], t: &[usize; 3]| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalize();
        let query = |x: &[DVec3], n: &[DVec3], reach: f64| {
            let mut tree = TriangleTree::new(&rest, &triangles);
            tree.refit(|t| {
                let (lo, hi) = crate::mesh::bounds(&triangles[t].map(|i| x[i]));
                Leaf { lo: lo - 0.5 * reach, hi: hi + 0.5 * reach, normal: n[t], reach }
            });
            let mut found = std::collections::BTreeSet::new();
            tree.overlapping_pairs(Tilt::NONE, |a, b| {
                found.insert([a.min(b), a.max(b)]);
            });
            found
        };
        // Rolled round a cylinder through 180° (radius 1.2 m / π).
        let radius = 1.2 / std::f64::consts::PI;
        let rolled: Vec<DVec3> = rest
            .iter()
            .map(|p| DVec3::new(radius * (p.x / radius).sin(), radius * (1.0 - (p.x / radius).cos()), p.z))
            .collect();
        let n: Vec<DVec3> = triangles.iter().map(|t| normal(&rolled, t)).collect();
        assert!(query(&rolled, &n, 0.01).is_empty(), "neighbouring flat patches skipped together");
        // Folded into three layers of 0.4 m, 5 mm apart: x → x, then back, then forth again. A reach of
        // 1.5 cm leaves each layer flat (altitudes of 3.5 cm).
        let layer = |x: f64| ((x + 0.6) / 0.4).floor().clamp(0.0, 2.0);
        let folded: Vec<DVec3> = rest
            .iter()
            .map(|p| {
                let (k, along) = (layer(p.x), p.x + 0.6 - 0.4 * layer(p.x));
                let x = if k == 1.0 { 0.4 - along } else { along };
                DVec3::new(x, 0.005 * k, p.z)
            })
            .collect();
        let n: Vec<DVec3> = triangles.iter().map(|t| normal(&folded, t)).collect();
        let reach = 0.015;
        let found = query(&folded, &n, reach);
        let of = |t: &[usize; 3]| layer(t.iter().map(|&i| rest[i].x).sum::<f64>() / 3.0);
        let mut across = 0;
        for (a, ta) in triangles.iter().enumerate().filter(|(_, t)| of(t) == 0.0) {
            for (b, tb) in triangles.iter().enumerate().filter(|(_, t)| of(t) == 2.0) {
                let corners = tb.map(|i| folded[i]);
                let near = ta.iter().any(|&v| {
                    let q = folded[v];
                    (q - at(corners, closest_on_triangle(q, corners).0)).length() <= reach
                });
                if near {
                    across += 1;
                    assert!(found.contains(&[a.min(b) as u32, a.max(b) as u32]), "{a} and {b}, 1 cm apart");
                }
            }
        }
        assert!(across > 100, "the outer layers face each other: {across} pairs");
    }

    /// With small reaches, flat patches are not searched within, yet every pair of triangles sharing
    /// no corner that is truly within reach (by its vertices' and edges' distances) still comes out.
    #[test]
    fn flat_patches_are_skipped_and_near_pairs_are_not() {
        use crate::collision::closest::{at, closest_on_triangle, segment_gap};
        let mesh = crate::mesh::generate::grid([1.0, 1.0], [16, 12]).unwrap();
        let (rest, triangles) = (mesh.positions().to_vec(), mesh.triangles().to_vec());
        let mut tree = TriangleTree::new(&rest, &triangles);
        // Folded over at x = 0, the halves 2 cm apart; reach 3 cm against altitudes of about 4 cm.
        let x: Vec<DVec3> = rest.iter().map(|p| DVec3::new(p.x.abs(), p.z, 0.01 * p.x.signum())).collect();
        let reach = 0.03;
        refit_at(&mut tree, &triangles, &x, reach);
        let mut found = std::collections::HashSet::new();
        tree.overlapping_pairs(Tilt::NONE, |a, b| {
            found.insert([a.min(b), a.max(b)]);
        });
        let distance = |a: usize, b: usize| {
            let (ta, tb) = (triangles[a].map(|i| x[i]), triangles[b].map(|i| x[i]));
            let vt = |p: DVec3, t: [DVec3; 3]| (p - at(t, closest_on_triangle(p, t).0)).length();
            let mut d = f64::INFINITY;
            for k in 0..3 {
                d = d.min(vt(ta[k], tb)).min(vt(tb[k], ta));
                for j in 0..3 {
                    d = d.min(segment_gap([ta[k], ta[(k + 1) % 3]], [tb[j], tb[(j + 1) % 3]]).length());
                }
            }
            d
        };
        let mut overlapping = 0;
        for a in 0..triangles.len() {
            for b in a + 1..triangles.len() {
                if triangles[a].iter().any(|v| triangles[b].contains(v)) {
                    continue;
                }
                overlapping += 1;
                if distance(a, b) <= reach {
                    assert!(found.contains(&[a as u32, b as u32]), "triangles {a} and {b} are within reach");
                }
            }
        }
        assert!(found.len() * 4 < overlapping, "flat patches skipped: {} pairs of {overlapping}", found.len());
    }
}
