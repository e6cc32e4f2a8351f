//! The cloth's constraints as the sweeps read them: packed eight lanes to a batch, colour by colour,
//! with each lane's particles, constants and compliance factors side by side (a lane is one
//! constraint, or an interior edge's stretch and its hinge's bending, which share two particles); and
//! the particles as 32-byte rows (position and inverse mass), so that one load fetches everything a
//! lane needs of a particle.

use glam::DVec3;

/// Lanes a batch holds: those of an AVX2 single-precision register.
pub const LANES: usize = 8;

/// A particle as the sweeps read it: `[x, y, z, w]` (`w` the inverse mass), aligned to 32 bytes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Row(pub [f64; 4]);

/// The rows of particles `p` with inverse masses `w`, into `rows` (resized to fit).
pub fn fill_rows(p: &[DVec3], w: &[f64], rows: &mut Vec<Row>) {
    rows.clear();
    rows.extend(p.iter().zip(w).map(|(p, &w)| Row([p.x, p.y, p.z, w])));
}

/// The positions the sweeps left in `rows`, back into `p`.
pub fn read_rows(rows: &[Row], p: &mut [DVec3]) {
    p.iter_mut().zip(rows).for_each(|(p, r)| *p = DVec3::new(r.0[0], r.0[1], r.0[2]));
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
    /// How many lanes are filled (the rest are neither projected nor counted).
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
}

impl<const K: usize, const F: usize> Batches<K, F> {
    /// `items` (ordered by colour) packed into batches that do not cross the colours (`colours`:
    /// where each begins, and the end).
    pub fn new<T: Packable<K, F>>(items: &[T], colours: &[usize]) -> Self {
        let (mut batches, mut starts) = (Vec::new(), vec![0]);
        for colour in colours.windows(2) {
            for group in items[colour[0]..colour[1]].chunks(LANES) {
                let lane = |k: usize| &group[k.min(group.len() - 1)];
                let ids = std::array::from_fn(|j| std::array::from_fn(|k| index(lane(k).particles()[j])));
                let constants = std::array::from_fn(|c| std::array::from_fn(|k| lane(k).constants()[c] as f32));
                let factors = std::array::from_fn(|f| std::array::from_fn(|k| lane(k).factors()[f] as f32));
                batches.push(Batch { ids, constants, factors, count: group.len() });
            }
            starts.push(batches.len());
        }
        Self { batches, colours: starts }
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

    /// Rows carry positions and inverse masses and give the positions back unchanged.
    #[test]
    fn rows_round_trip_positions_and_carry_inverse_masses() {
        let p: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 0.1 / (i as f64 + 1.0), -1e9 * i as f64)).collect();
        let w = [0.0, 1.0, 2.5, 1e6, 3.0];
        let mut rows = vec![Row::default(); 2];
        fill_rows(&p, &w, &mut rows);
        assert_eq!(rows.iter().map(|r| r.0[3]).collect::<Vec<_>>(), w.to_vec());
        let mut back = vec![DVec3::NAN; 5];
        read_rows(&rows, &mut back);
        assert_eq!(back, p);
    }
}
