//! `rds`'s basis and cubature kept in the modes' on-disk cache ([`Cache`]), so that a scene reopens
//! without computing the modal derivatives or fitting the cubature again.
//!
//! Each is keyed by the modal problem's key ([`cache::key`]: mesh, anchors, masses, stiffnesses,
//! mode count) hashed on with what else it depends on: whether the load responses join and how many
//! derivative directions are kept, and for the cubature its size. The numbers are stored as they
//! were computed (little-endian `f64`), so a basis read back is the one that was built, bit for
//! bit, and a run from it takes the same steps. A file that does not fit (wrong sizes, a mode count
//! that differs, an element number out of range) is ignored and the basis rebuilt, as in
//! [`Cache`].
//! The key does not see the code: a change to how the basis or the cubature is built must change
//! the version in `BASIS` or `CUBATURE`, or an old file would be read as the new method's.

use super::basis::ReducedBasis;
use super::energy::Cubature;
use crate::solver::modal::cache::{self, Cache, count, vectors};
use crate::solver::modal::compute::ModalProblem;

/// Identifies a stored basis (and its layout's version).
const BASIS: &[u8; 8] = b"SWRDSB01";

/// Identifies a stored cubature (and its layout's version).
const CUBATURE: &[u8; 8] = b"SWRDSC01";

/// What a basis is built of beside the modes, and its cubature's size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    /// Whether the static responses to body loads join the modes.
    pub loads: bool,
    /// Derivative directions.
    pub derivatives: usize,
    /// Cubature elements (0: every element).
    pub cubature: usize,
}

impl Sizes {
    /// The key of the basis these sizes build for `p`.
    fn basis_key(&self, p: &ModalProblem<'_>) -> u64 {
        let mut extra = BASIS.to_vec();
        extra.push(u8::from(self.loads));
        extra.extend((self.derivatives as u64).to_le_bytes());
        cache::derived_key(p, &extra)
    }

    /// The key of the cubature these sizes fit for `p`.
    fn cubature_key(&self, p: &ModalProblem<'_>) -> u64 {
        let mut extra = CUBATURE.to_vec();
        extra.extend(self.basis_key(p).to_le_bytes());
        extra.extend((self.cubature as u64).to_le_bytes());
        cache::derived_key(p, &extra)
    }
}

/// The stored basis of `p` with `sizes`, if there is a valid one.
pub fn load_basis(cache: &Cache, p: &ModalProblem<'_>, sizes: Sizes) -> Option<ReducedBasis> {
    let words = cache.read_words("rds-basis", BASIS, sizes.basis_key(p))?;
    let n = p.mesh.vertex_count();
    let most = words.len();
    let (modes, loads, len) = (count(*words.first()?, most)?, count(*words.get(1)?, 3)?, count(*words.get(2)?, most)?);
    if modes != p.modes || modes + loads > len || Some(most) != (3 * n + 1).checked_mul(len).map(|s| s + 3) {
        return None;
    }
    let stiffness = words[3..3 + len].to_vec();
    let shapes = vectors(&words[3 + len..], n);
    Some(ReducedBasis { modes, loads, stiffness, shapes })
}

/// Store the basis of `p` built with `sizes` (best effort).
pub fn store_basis(cache: &Cache, p: &ModalProblem<'_>, sizes: Sizes, basis: &ReducedBasis) {
    let mut words = vec![basis.modes as f64, basis.loads as f64, basis.len() as f64];
    words.extend(&basis.stiffness);
    words.extend(basis.shapes.iter().flatten().flat_map(|v| v.to_array()));
    cache.write_words("rds-basis", BASIS, sizes.basis_key(p), &words);
}

/// The stored cubature of `p` with `sizes`, if there is a valid one over at most `elements`
/// elements.
pub fn load_cubature(cache: &Cache, p: &ModalProblem<'_>, sizes: Sizes, elements: usize) -> Option<Cubature> {
    let words = cache.read_words("rds-cubature", CUBATURE, sizes.cubature_key(p))?;
    let (training_error, rest) = words.split_first()?;
    if rest.len() % 2 != 0 || rest.chunks_exact(2).any(|c| c[1] < 0.0) {
        return None;
    }
    let elements = rest
        .chunks_exact(2)
        .map(|c| Some((count(c[0], elements.checked_sub(1)?)?, c[1])))
        .collect::<Option<Vec<_>>>()?;
    Some(Cubature { elements, training_error: *training_error })
}

/// Store the cubature of `p` fitted with `sizes` (best effort).
pub fn store_cubature(cache: &Cache, p: &ModalProblem<'_>, sizes: Sizes, cubature: &Cubature) {
    let mut words = vec![cubature.training_error];
    words.extend(cubature.elements.iter().flat_map(|&(e, w)| [e as f64, w]));
    cache.write_words("rds-cubature", CUBATURE, sizes.cubature_key(p), &words);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::ShellStiffness;
    use crate::mesh::generate::grid;
    use crate::solver::modal::compute::analyse;
    use crate::solver::reduced::basis;

    #[test]
    fn a_basis_and_a_cubature_come_back_exactly_and_only_for_their_sizes() {
        let dir = std::env::temp_dir().join(format!("shellwarp-rds-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let cache = Cache::at(&dir);
        let mesh = grid([0.4, 0.1], [8, 2]).unwrap();
        let masses: Vec<f64> = mesh.vertex_areas().iter().map(|a| 0.5 * a).collect();
        let stiffness = ShellStiffness { k_area: 10.0, k_length: 10.0, k_bend: 0.05 };
        let anchors: Vec<usize> = (0..3).collect();
        let p =
            ModalProblem { mesh: &mesh, anchors: &anchors, masses: &masses, stiffness, modes: 3, keep_rigid: false };
        let analysis = analyse(&p, &|_| {}).unwrap();
        let (built, _) = basis::build(&p, &analysis, None, true, 4, &|_| {}).unwrap();
        let sizes = Sizes { loads: true, derivatives: 4, cubature: 2 };
        assert!(load_basis(&cache, &p, sizes).is_none(), "empty cache");
        store_basis(&cache, &p, sizes, &built);
        assert_eq!(load_basis(&cache, &p, sizes), Some(built.clone()), "bit for bit");
        for other in [Sizes { loads: false, ..sizes }, Sizes { derivatives: 3, ..sizes }] {
            assert!(load_basis(&cache, &p, other).is_none(), "{other:?}");
        }
        let q = ModalProblem { modes: 2, ..p };
        assert!(load_basis(&cache, &q, sizes).is_none(), "another mode count");
        // A damaged file is ignored (the basis is then built again), never trusted.
        let path = cache.file("rds-basis", sizes.basis_key(&p)).unwrap();
        let good = std::fs::read(&path).unwrap();
        for at in [0, 12, 30, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x04;
            std::fs::write(&path, &bad).unwrap();
            assert!(load_basis(&cache, &p, sizes).is_none(), "flipped byte {at} of {}", good.len());
        }
        std::fs::write(&path, &good[..good.len() - 9]).unwrap();
        assert!(load_basis(&cache, &p, sizes).is_none(), "truncated");
        // A whole file under the right key that describes another basis is refused too.
        store_basis(&cache, &p, sizes, &ReducedBasis { modes: 2, ..built.clone() });
        assert!(load_basis(&cache, &p, sizes).is_none(), "a basis of another mode count");
        store_basis(&cache, &p, sizes, &ReducedBasis { loads: 4, ..built.clone() });
        assert!(load_basis(&cache, &p, sizes).is_none(), "load responses along more than three axes");

        let cubature = Cubature { elements: vec![(5, 0.5), (17, 2.25)], training_error: 1e-3 };
        store_cubature(&cache, &p, sizes, &cubature);
        assert_eq!(load_cubature(&cache, &p, sizes, 18), Some(cubature));
        assert!(load_cubature(&cache, &p, sizes, 17).is_none(), "an element out of range");
        assert!(load_cubature(&cache, &p, Sizes { cubature: 3, ..sizes }, 18).is_none(), "another size");
        assert!(load_cubature(&cache, &p, Sizes { derivatives: 3, ..sizes }, 18).is_none(), "another basis");
        let _ = std::fs::remove_dir_all(dir);
    }
}
