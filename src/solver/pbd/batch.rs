//! The cloth's constraints as the sweeps read them: packed eight lanes to a batch, colour by colour,
//! with each lane's particles, constants and compliance factors side by side (a lane is one
//! constraint, or an interior edge's stretch and its hinge's bending, which share two particles); and
//! the particles as 16-byte rows (position relative to the first particle, and inverse mass, in single
//! precision), so that one load fetches everything a lane needs of a particle.
//!
//! The rows are single precision relative to the first particle, so a position in them is good to
//! half a unit in the last place of its distance from that particle (60 nm across a 1 m cloth),
//! wherever the cloth is. The positions themselves stay in double precision: reading the rows back
//! adds to each particle what the sweeps moved its row, so a particle the sweeps did not move (an
//! anchored one, say) keeps its position to the bit.
//!
//! A coordinate under a nanometre ([`FLUSHED`]) is stored as zero. The sweeps multiply coordinates
//! together, and the products of such ones fall below single precision's normal range, where
//! arithmetic costs the CPU about a hundred times as much (subnormal numbers: no flush-to-zero mode
//! here, which would take `unsafe`). A sheet hanging in its plane meets them when it first leaves it:
//! the disturbance spreads with ever smaller out-of-plane offsets, far below a nanometre. On the
//! hanging sheet, the frames where this happens measured several times slower than the others; with the
//! flush, only a little slower, as products of larger offsets still underflow now and then
//! (`BENCHMARKS.md`, *Design measurements quoted from module docs*). A nanometre
//! is under the rounding of a row a few centimetres from the first particle, and what a flushed row
//! is moved by comes back whole.

use std::marker::PhantomData;

use glam::DVec3;

use crate::linalg::isa;
use crate::linalg::real::V3;

/// Coordinates of the rows under this magnitude are stored as zero, m (2⁻³⁰, about a nanometre).
pub const FLUSHED: f64 = 1.0 / (1u64 << 30) as f64;

/// `v`, or zero if its magnitude is under [`FLUSHED`].
#[inline(always)]
fn flushed(v: f64) -> f32 {
    (if v.abs() < FLUSHED { 0.0 } else { v }) as f32
}

/// Lanes a batch holds: those of an AVX2 single-precision register.
pub const LANES: usize = 8;

/// A particle as the sweeps read it: `[x, y, z, w]` (`w` the inverse mass), aligned to 16 bytes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct Row(pub [f32; 4]);

/// The particles' rows and their origin.
#[derive(Debug, Clone, Default)]
pub struct Rows {
    /// One row per particle, then empty rows to a power of two ([`Indexed`]).
    rows: Vec<Row>,
    /// The particles.
    count: usize,
    /// Where the rows' positions are relative to, m.
    origin: DVec3,
}

impl Rows {
    /// The rows of particles `p` with inverse masses `w`, relative to the first particle (coordinates
    /// under [`FLUSHED`] zero).
    pub fn fill(&mut self, p: &[DVec3], w: &[f64]) {
        struct Fill<'a>(&'a mut Rows, &'a [DVec3], &'a [f64]);
        impl isa::Kernel for Fill<'_> {
            type Output = ();
            #[inline(always)]
            fn run(self) {
                let Fill(rows, p, w) = self;
                rows.origin = p.first().copied().unwrap_or_default();
                rows.count = p.len();
                // Written in place: the empty rows past the particles stay as they are.
                rows.rows.resize(p.len().next_power_of_two(), Row::default());
                let o = rows.origin;
                for (row, (p, &w)) in rows.rows.iter_mut().zip(p.iter().zip(w)) {
                    *row = Row([flushed(p.x - o.x), flushed(p.y - o.y), flushed(p.z - o.z), w as f32]);
                }
            }
        }
        isa::avx2(Fill(self, p, w));
    }

    /// Add to each of `p` (the positions the rows were filled from) what the sweeps moved its row.
    pub fn read(&self, p: &mut [DVec3]) {
        struct Read<'a>(&'a Rows, &'a mut [DVec3]);
        impl isa::Kernel for Read<'_> {
            type Output = ();
            #[inline(always)]
            fn run(self) {
                let Read(rows, p) = self;
                let o = rows.origin;
                for (p, r) in p.iter_mut().zip(rows.particles()) {
                    let before = [flushed(p.x - o.x), flushed(p.y - o.y), flushed(p.z - o.z)];
                    // Exact where the move is under the row's distance from the origin (Sterbenz),
                    // else good to a unit in the last place of the move.
                    let moved = [r.0[0] - before[0], r.0[1] - before[1], r.0[2] - before[2]];
                    *p += DVec3::new(f64::from(moved[0]), f64::from(moved[1]), f64::from(moved[2]));
                }
            }
        }
        isa::avx2(Read(self, p));
    }

    /// The particles' rows.
    pub fn particles(&self) -> &[Row] {
        &self.rows[..self.count]
    }

    /// The rows as the kernels index them.
    pub fn indexed(&self) -> Indexed<&[Row]> {
        Indexed { rows: &self.rows, mask: self.mask() }
    }

    /// The rows as the kernels index and move them.
    pub fn indexed_mut(&mut self) -> Indexed<&mut [Row]> {
        Indexed { mask: self.mask(), rows: &mut self.rows }
    }

    /// The rows' number (a power of two once filled) less one.
    fn mask(&self) -> usize {
        self.rows.len().saturating_sub(1)
    }
}

/// Rows as the kernels index them: as many as a power of two, that number less one kept as a mask.
/// A particle's index `i` is `i & mask`, and indexing rows sliced to `..=mask` by `i & mask` needs no
/// bounds check (the kernel reads the mask as a number apart from the slice's length, so the
/// compiler cannot fold the check back into one against the length).
#[derive(Debug, Clone, Copy)]
pub struct Indexed<R> {
    /// The rows.
    pub rows: R,
    /// Their number less one.
    pub mask: usize,
}

/// Where the eight-lane kernels read rows from: `i & mask`, never out of bounds.
pub trait Source: Copy {
    /// The row of particle `i`.
    fn row(self, i: u32) -> [f32; 4];
}

impl Source for Indexed<&[Row]> {
    #[inline(always)]
    fn row(self, i: u32) -> [f32; 4] {
        self.rows[i as usize & self.mask].0
    }
}

/// Rows that the batches of one colour read and move from two threads at once: a colour's lanes
/// share no particle ([`Batches::separate`]), so each row is read and written by one thread only
/// within the colour, and the threads are joined before the next colour. Made only by the sweeps,
/// for the colours found separate; indices are masked to the rows' power-of-two length.
#[derive(Clone, Copy)]
pub(super) struct Shared<'a> {
    rows: *mut Row,
    mask: usize,
    borrow: PhantomData<&'a mut [Row]>,
}

// SAFETY: see the type's documentation: within a colour no row is touched by two threads.
#[allow(unsafe_code)]
unsafe impl Send for Shared<'_> {}
// SAFETY: as for `Send`.
#[allow(unsafe_code)]
unsafe impl Sync for Shared<'_> {}

impl<'a> Shared<'a> {
    /// The view of `rows`, borrowed for as long as the view lives.
    pub fn new(rows: Indexed<&'a mut [Row]>) -> Self {
        assert_eq!(rows.rows.len(), rows.mask + 1, "rows as many as a power of two");
        Self { rows: rows.rows.as_mut_ptr(), mask: rows.mask, borrow: PhantomData }
    }

    /// Store `row` as particle `i`'s.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub fn set(self, i: u32, row: [f32; 4]) {
        // SAFETY: masked into bounds; no other thread touches this row now (the type's documentation).
        unsafe { (*self.rows.add(i as usize & self.mask)).0 = row }
    }
}

impl Source for Shared<'_> {
    #[inline(always)]
    #[allow(unsafe_code)]
    fn row(self, i: u32) -> [f32; 4] {
        // SAFETY: as for `set`.
        unsafe { (*self.rows.add(i as usize & self.mask)).0 }
    }
}

/// Constants a batch keeps per lane (a rest length, a rest angle's cosine and sine).
pub const CONSTANTS: usize = 3;

/// What a batch stores of a lane: `F` constraints over `K` particles, projected one after the other.
pub trait Packable<const K: usize, const F: usize>: Copy {
    /// Its particles.
    fn particles(&self) -> [usize; K];
    /// The constants of its functions.
    fn constants(&self) -> [f64; CONSTANTS];
    /// What each constraint's compliance is, in units of the sweep's for that constraint.
    fn factors(&self) -> [f64; F];
}

/// Up to [`LANES`] lanes of one colour (so no two share a particle), each `F` constraints over `K`
/// particles.
#[derive(Debug, Clone, PartialEq)]
pub struct Batch<const K: usize, const F: usize> {
    /// Each lane's particles, particle slot by slot; lanes past `count` repeat the last lane.
    pub ids: [[u32; LANES]; K],
    /// Each lane's constants.
    pub constants: [[f32; LANES]; CONSTANTS],
    /// Each lane's compliance factors, constraint by constraint (single precision, as the sweeps
    /// multiply them).
    pub factors: [[f32; LANES]; F],
    /// How many lanes are filled (the rest, repeating the last, move its particles as it does and
    /// keep its multipliers).
    pub count: usize,
}

/// Lanes in batches; each constraint's multiplier is kept at its batch, constraint and lane
/// (`[[[f64; LANES]; F]]`, one entry per batch).
#[derive(Debug, Clone, PartialEq)]
pub struct Batches<const K: usize, const F: usize> {
    /// The batches, colour after colour.
    pub batches: Vec<Batch<K, F>>,
    /// Where each colour's batches begin, and the end (batches of a colour are independent).
    pub colours: Vec<usize>,
    /// Whether each colour's lanes are checked to share no particle (the colouring's last colour
    /// takes what the others could not, [`super::model`], and may not be), so that its batches may
    /// be projected on several threads at once.
    pub separate: Vec<bool>,
}

impl<const K: usize, const F: usize> Batches<K, F> {
    /// `items` (ordered by colour) packed into batches that do not cross the colours (`colours`:
    /// where each begins, and the end).
    pub fn new<T: Packable<K, F>>(items: &[T], colours: &[usize]) -> Self {
        let (mut batches, mut starts, mut separate) = (Vec::new(), vec![0], Vec::new());
        let mut seen = std::collections::HashSet::new();
        for colour in colours.windows(2) {
            seen.clear();
            let items = &items[colour[0]..colour[1]];
            separate.push(items.iter().flat_map(|item| item.particles()).all(|i| seen.insert(i)));
            for group in items.chunks(LANES) {
                let lane = |k: usize| &group[k.min(group.len() - 1)];
                let ids = std::array::from_fn(|j| std::array::from_fn(|k| index(lane(k).particles()[j])));
                let constants = std::array::from_fn(|c| std::array::from_fn(|k| lane(k).constants()[c] as f32));
                let factors = std::array::from_fn(|f| std::array::from_fn(|k| lane(k).factors()[f] as f32));
                batches.push(Batch { ids, constants, factors, count: group.len() });
            }
            starts.push(batches.len());
        }
        Self { batches, colours: starts, separate }
    }

    /// Zeroed multipliers for these batches.
    pub fn multipliers(&self) -> Vec<[[f64; LANES]; F]> {
        vec![[[0.0; LANES]; F]; self.batches.len()]
    }
}

/// A particle index as a batch stores it ([`super::model::Model::new`] refuses meshes whose indices do
/// not fit in 32 bits).
fn index(i: usize) -> u32 {
    debug_assert!(u32::try_from(i).is_ok(), "particle {i} beyond 32 bits");
    i as u32
}

/// What a batch's lanes read: each particle relative to the lane's first, and its inverse mass; the
/// constants, and each constraint's multiplier and scaled compliance.
pub(super) struct Read<N, const K: usize, const F: usize> {
    /// The particles, relative to the first.
    pub x: [V3<N>; K],
    /// Their inverse masses.
    pub w: [N; K],
    /// The lane's constants.
    pub constants: [N; CONSTANTS],
    /// Each constraint's multiplier so far.
    pub lambda: [N; F],
    /// Each constraint's compliance over `h²`.
    pub compliance: [N; F],
}

/// Each constraint's `Δλ` in a batch's lanes, and each particle's move (the sum of `w_i ∇_i C Δλ`).
pub(super) type Projected<N, const K: usize, const F: usize> = ([N; F], [V3<N>; K]);

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy)]
    struct Pair(usize, usize, f64);

    impl Packable<2, 2> for Pair {
        fn particles(&self) -> [usize; 2] {
            [self.0, self.1]
        }
        fn constants(&self) -> [f64; CONSTANTS] {
            [self.2, -self.2, 3.0 * self.2]
        }
        fn factors(&self) -> [f64; 2] {
            [2.0 * self.2, 0.5 * self.2]
        }
    }

    /// Every item lands in exactly one lane of a batch of its own colour, with its particles,
    /// constants and factors; the tails repeat the colour's last item.
    #[test]
    fn packing_keeps_every_constraint_and_the_colours_apart() {
        let items: Vec<Pair> = (0..21).map(|i| Pair(2 * i, 2 * i + 1, 0.5 + i as f64)).collect();
        let colours = [0, 11, 21];
        let packed = Batches::new(&items, &colours);
        assert_eq!(packed.batches.iter().map(|b| b.count).collect::<Vec<_>>(), vec![8, 3, 8, 2]);
        assert_eq!(packed.colours, vec![0, 2, 4]);
        let mut seen = Vec::new();
        for (b, batch) in packed.batches.iter().enumerate() {
            for k in 0..LANES {
                let item = batch.ids[0][k] as usize / 2;
                let colour = usize::from(item >= 11);
                assert_eq!(colour, usize::from(b >= 2), "batch {b} lane {k} crosses a colour");
                assert_eq!(batch.ids[1][k] as usize, 2 * item + 1);
                assert_eq!(batch.constants[0][k], items[item].2 as f32);
                assert_eq!(batch.constants[1][k], -items[item].2 as f32);
                assert_eq!(batch.constants[2][k], 3.0 * items[item].2 as f32);
                assert_eq!(batch.factors[0][k], (2.0 * items[item].2) as f32);
                assert_eq!(batch.factors[1][k], (0.5 * items[item].2) as f32);
                if k < batch.count {
                    seen.push(item);
                } else {
                    assert_eq!(item, batch.ids[0][batch.count - 1] as usize / 2, "a tail repeats the last");
                }
            }
        }
        assert_eq!(seen, (0..21).collect::<Vec<_>>());
    }

    /// A colour is separate (its batches may be projected on several threads at once) only when no
    /// two of its lanes share a particle.
    #[test]
    fn a_colour_is_separate_only_if_its_lanes_share_no_particle() {
        let items = [Pair(0, 1, 1.0), Pair(2, 3, 1.0), Pair(4, 5, 1.0), Pair(5, 6, 1.0), Pair(7, 8, 1.0)];
        let packed = Batches::new(&items, &[0, 2, 4, 5]);
        assert_eq!(packed.separate, vec![true, false, true]);
    }

    /// Rows carry inverse masses; positions the sweeps did not move come back to the bit, wherever
    /// the cloth is, and a move comes back to within a unit in the last place of the moved particle's
    /// distance from the first.
    #[test]
    fn rows_give_back_unmoved_positions_exactly_and_moves_to_the_cloths_precision() {
        let p: Vec<DVec3> =
            (0..5).map(|i| DVec3::new(1e3 + 0.1 * i as f64, 0.1 / (i as f64 + 1.0), -1e5 - 0.3 * i as f64)).collect();
        let w = [0.0, 1.0, 2.5, 1e6, 3.0];
        let mut rows = Rows::default();
        rows.fill(&p, &w);
        assert_eq!(rows.particles().iter().map(|r| f64::from(r.0[3])).collect::<Vec<_>>(), w.to_vec());
        let indexed = rows.indexed();
        assert_eq!((indexed.rows.len(), indexed.mask), (8, 7), "five rows and three empty ones");
        let mut back = p.clone();
        rows.read(&mut back);
        assert_eq!(back, p, "unmoved rows");
        let step = DVec3::new(1e-4, -2e-5, 3e-3);
        rows.indexed_mut().rows[2].0[..3].iter_mut().zip(step.to_array()).for_each(|(r, s)| *r += s as f32);
        rows.read(&mut back);
        let far = (p[2] + step - p[0]).abs().max_element();
        let error = (back[2] - p[2] - step).abs().max_element();
        assert!(error <= far * f64::from(f32::EPSILON), "moved by {:?}: off by {error:e}", back[2] - p[2]);
        assert_eq!([back[0], back[1], back[3], back[4]], [p[0], p[1], p[3], p[4]], "the others");
    }

    /// Offsets from the first particle too small for single precision's normal range (and up to a
    /// nanometre) are rows of zero; unmoved, they come back to the bit, and a move of such a row comes
    /// back to within the flushed nanometre.
    #[test]
    fn offsets_under_a_nanometre_are_zero_in_the_rows_and_come_back() {
        let p: Vec<DVec3> = [0.0, 1e-40, 0.9 * FLUSHED, 1.1 * FLUSHED, -1e-20]
            .iter()
            .enumerate()
            .map(|(i, &z)| DVec3::new(0.01 * i as f64, 1.0, z))
            .collect();
        let mut rows = Rows::default();
        rows.fill(&p, &[1.0; 5]);
        let z: Vec<f32> = rows.particles().iter().map(|r| r.0[2]).collect();
        assert_eq!(z, [0.0, 0.0, 0.0, (1.1 * FLUSHED) as f32, 0.0]);
        assert!(rows.particles().iter().flat_map(|r| r.0).all(|c| c == 0.0 || c.is_normal()), "no subnormal row");
        let mut back = p.clone();
        rows.read(&mut back);
        assert_eq!(back, p, "unmoved rows");
        rows.indexed_mut().rows[2].0[2] += 1e-3;
        rows.read(&mut back);
        assert!((back[2].z - p[2].z - 1e-3).abs() <= FLUSHED, "moved by {:e}", back[2].z - p[2].z);
    }
}
