//! A spatial hash for self-collision queries: boxes (e.g. triangles' bounding boxes grown by a
//! thickness) are entered into every cell of a uniform grid they overlap, cells are hashed into a
//! fixed table, and a point's query returns the boxes entered in its cell's bucket that contain it.
//!
//! Built by counting sort, so it allocates nothing once warm and its answers do not depend on any
//! iteration order but the items' own: a query lists candidates in increasing item order, every run
//! the same (Teschner et al. 2003 hash the cells the same way; the table here is rebuilt, not
//! updated, each time).

use glam::{DVec3, IVec3};

/// The hash of a grid cell into a table of `mask + 1` buckets (Teschner et al.'s primes).
fn bucket(c: IVec3, mask: usize) -> usize {
    let h = (c.x as i64).wrapping_mul(73_856_093)
        ^ (c.y as i64).wrapping_mul(19_349_663)
        ^ (c.z as i64).wrapping_mul(83_492_791);
    (h as u64 as usize) & mask
}

/// A spatial hash of boxes.
#[derive(Debug, Clone, Default)]
pub struct SpatialHash {
    cell: f64,
    mask: usize,
    /// Bucket `b` holds `entries[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    entries: Vec<u32>,
    boxes: Vec<(DVec3, DVec3)>,
    /// Per item, the query that last returned it (to return each once).
    seen: Vec<u32>,
    stamp: u32,
}

impl SpatialHash {
    /// An empty hash with cells of side `cell` (about the mean edge length of the mesh).
    pub fn new(cell: f64) -> Self {
        Self { cell: cell.max(f64::MIN_POSITIVE), ..Self::default() }
    }

    fn cell_of(&self, p: DVec3) -> IVec3 {
        (p / self.cell).floor().as_ivec3()
    }

    /// Enter these boxes (item `i` is the `i`-th), replacing what was there.
    pub fn rebuild(&mut self, boxes: impl IntoIterator<Item = (DVec3, DVec3)>) {
        self.boxes.clear();
        self.boxes.extend(boxes);
        let buckets = (2 * self.boxes.len()).next_power_of_two().max(64);
        self.mask = buckets - 1;
        self.starts.clear();
        self.starts.resize(buckets + 1, 0);
        // Pass 1 counts, pass 2 places: entries of a bucket in increasing item order.
        for pass in 0..2 {
            if pass == 1 {
                let mut sum = 0;
                for s in self.starts.iter_mut() {
                    let count = *s;
                    *s = sum;
                    sum += count;
                }
                self.entries.clear();
                self.entries.resize(sum as usize, 0);
            }
            let mut fill = if pass == 1 { self.starts.clone() } else { Vec::new() };
            for (i, &(lo, hi)) in self.boxes.iter().enumerate() {
                let (a, b) = (self.cell_of(lo), self.cell_of(hi));
                for x in a.x..=b.x {
                    for y in a.y..=b.y {
                        for z in a.z..=b.z {
                            let k = bucket(IVec3::new(x, y, z), self.mask);
                            if pass == 0 {
                                self.starts[k] += 1;
                            } else {
                                self.entries[fill[k] as usize] = i as u32;
                                fill[k] += 1;
                            }
                        }
                    }
                }
            }
        }
        self.seen.clear();
        self.seen.resize(self.boxes.len(), 0);
        self.stamp = 0;
    }

    /// The boxes that contain `p` (candidates from `p`'s bucket, tested), in increasing item order,
    /// each once, into `out` (cleared first).
    pub fn query(&mut self, p: DVec3, out: &mut Vec<u32>) {
        self.query_box(p, p, out);
    }

    /// The boxes that overlap the box `(lo, hi)` (candidates from the buckets of its cells, tested), in
    /// increasing item order, each once, into `out` (cleared first).
    pub fn query_box(&mut self, lo: DVec3, hi: DVec3, out: &mut Vec<u32>) {
        out.clear();
        if self.boxes.is_empty() {
            return;
        }
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.seen.fill(0);
            self.stamp = 1;
        }
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                for z in a.z..=b.z {
                    let k = bucket(IVec3::new(x, y, z), self.mask);
                    for &i in &self.entries[self.starts[k] as usize..self.starts[k + 1] as usize] {
                        let (blo, bhi) = self.boxes[i as usize];
                        if self.seen[i as usize] != self.stamp && lo.cmple(bhi).all() && blo.cmple(hi).all() {
                            self.seen[i as usize] = self.stamp;
                            out.push(i);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_query_finds_exactly_the_boxes_that_contain_the_point() {
        let boxes: Vec<(DVec3, DVec3)> = (0..200)
            .map(|i| {
                let c = DVec3::new((i % 10) as f64 * 0.13, ((i / 10) % 5) as f64 * 0.21, (i / 50) as f64 * 0.17);
                (c - 0.09, c + 0.11 + DVec3::splat((i % 3) as f64 * 0.05))
            })
            .collect();
        let mut hash = SpatialHash::new(0.1);
        hash.rebuild(boxes.iter().copied());
        let mut out = Vec::new();
        for j in 0..300 {
            let p = DVec3::new((j % 17) as f64 * 0.08, (j % 11) as f64 * 0.1, (j % 7) as f64 * 0.1) - 0.05;
            hash.query(p, &mut out);
            let brute: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| p.cmpge(boxes[i as usize].0).all() && p.cmple(boxes[i as usize].1).all())
                .collect();
            assert_eq!(out, brute, "at {p}");
        }
    }
}
