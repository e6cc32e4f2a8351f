//! A spatial hash of points for self-collision queries: each point is entered in the one cell of a
//! uniform grid that contains it, cells are hashed into a table (Teschner et al. 2003's primes), and a
//! box query visits the cells the box overlaps and reports the points inside the box.
//!
//! Built by counting sort, so it allocates nothing once warm; each entry keeps its point and cell, so a
//! query reads one contiguous run per bucket, rejects the points of other cells that share the bucket
//! (which also reports every point once) and tests the box without touching the caller's arrays.
//! Answers come in a fixed order — cells in x, y, z order, points of a cell in increasing index — so
//! the same input gives the same output, every run.

use glam::{DVec3, IVec3};

/// The hash of a grid cell into a table of `mask + 1` buckets (Teschner et al.'s primes).
fn bucket(c: IVec3, mask: usize) -> usize {
    let h = (c.x as i64).wrapping_mul(73_856_093)
        ^ (c.y as i64).wrapping_mul(19_349_663)
        ^ (c.z as i64).wrapping_mul(83_492_791);
    (h as u64 as usize) & mask
}

/// One point in the table.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    point: DVec3,
    cell: IVec3,
    item: u32,
}

/// A spatial hash of points.
#[derive(Debug, Clone, Default)]
pub struct SpatialHash {
    inverse_cell: f64,
    mask: usize,
    /// Bucket `b` holds `entries[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    entries: Vec<Entry>,
    /// Each point's cell and bucket, between the passes of a rebuild.
    placed: Vec<(IVec3, u32)>,
}

impl SpatialHash {
    /// An empty hash with cells of side `cell` (about the mean edge length of the mesh).
    pub fn new(cell: f64) -> Self {
        Self { inverse_cell: 1.0 / cell.max(1e-12), ..Self::default() }
    }

    /// Use cells of side `cell` from the next rebuild on.
    pub fn set_cell(&mut self, cell: f64) {
        self.inverse_cell = 1.0 / cell.max(1e-12);
    }

    fn cell_of(&self, p: DVec3) -> IVec3 {
        // Clamped so that a far-away (or non-finite) point lands in an edge cell instead of wrapping.
        let c = (p * self.inverse_cell).floor().clamp(DVec3::splat(-1e9), DVec3::splat(1e9));
        c.as_ivec3()
    }

    /// Enter these points (item `i` is the `i`-th), replacing what was there.
    pub fn rebuild(&mut self, points: impl ExactSizeIterator<Item = DVec3> + Clone) {
        let n = points.len();
        let buckets = (2 * n).next_power_of_two().max(64);
        self.mask = buckets - 1;
        self.starts.clear();
        self.starts.resize(buckets + 1, 0);
        self.placed.clear();
        for p in points.clone() {
            let cell = self.cell_of(p);
            let b = bucket(cell, self.mask);
            self.starts[b + 1] += 1;
            self.placed.push((cell, b as u32));
        }
        for b in 0..buckets {
            self.starts[b + 1] += self.starts[b];
        }
        self.entries.clear();
        self.entries.resize(n, Entry::default());
        // `starts[b]` serves as bucket `b`'s fill pointer, then is shifted back.
        for (i, (p, &(cell, b))) in points.zip(&self.placed).enumerate() {
            let slot = &mut self.starts[b as usize];
            self.entries[*slot as usize] = Entry { point: p, cell, item: i as u32 };
            *slot += 1;
        }
        for b in (1..=buckets).rev() {
            self.starts[b] = self.starts[b - 1];
        }
        self.starts[0] = 0;
    }

    /// Call `found` with every point inside the box `(lo, hi)` (and its index).
    pub fn query(&self, lo: DVec3, hi: DVec3, mut found: impl FnMut(u32, DVec3)) {
        if self.entries.is_empty() {
            return;
        }
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                for z in a.z..=b.z {
                    let cell = IVec3::new(x, y, z);
                    let k = bucket(cell, self.mask);
                    for e in &self.entries[self.starts[k] as usize..self.starts[k + 1] as usize] {
                        if e.cell == cell && e.point.cmpge(lo).all() && e.point.cmple(hi).all() {
                            found(e.item, e.point);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_query_finds_exactly_the_points_inside_the_box_each_once() {
        let points: Vec<DVec3> = (0..500)
            .map(|i| DVec3::new((i % 10) as f64 * 0.13, ((i / 10) % 7) as f64 * 0.21, (i / 70) as f64 * 0.17) - 0.3)
            .collect();
        // Cells smaller than the spacing and a small table: many cells share a bucket.
        let mut hash = SpatialHash::new(0.07);
        hash.rebuild(points.iter().copied());
        for j in 0..300 {
            let lo = DVec3::new((j % 17) as f64 * 0.08, (j % 11) as f64 * 0.1, (j % 7) as f64 * 0.1) - 0.5;
            let hi = lo + DVec3::new(0.3, 0.05 * (j % 5) as f64, 0.4);
            let mut found = Vec::new();
            hash.query(lo, hi, |i, p| {
                assert_eq!(p, points[i as usize]);
                found.push(i);
            });
            found.sort_unstable();
            let brute: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| points[i as usize].cmpge(lo).all() && points[i as usize].cmple(hi).all())
                .collect();
            assert_eq!(found, brute, "box {lo} – {hi}");
        }
    }
}
