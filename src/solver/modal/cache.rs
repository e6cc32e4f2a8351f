//! On-disk cache of modal analyses, keyed by a hash of everything the modes depend on (mesh,
//! anchors, masses, stiffnesses, mode count), so a scene reopens without recomputing. What is
//! built on the modes (`rds`'s basis and cubature, [`crate::solver::reduced::stored`]) is kept in
//! the same folder and file layout, under keys derived from the modes' ([`derived_key`]).
//!
//! Default location ([`Cache::from_env`]): `$SHELLWARP_CACHE_DIR`, else `$XDG_CACHE_HOME/shellwarp`,
//! else `~/.cache/shellwarp`. Files are written atomically (temporary file, then rename); an
//! unreadable or mismatched file is ignored and recomputed, never trusted.

use std::path::PathBuf;

use glam::DVec3;

use super::basis::ModalBasis;
use super::compute::{ModalAnalysis, ModalProblem, PrecomputeTimings};

const MAGIC: &[u8; 8] = b"SWMODES4";

/// FNV-1a's 64-bit offset basis.
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a, 64 bit: stable across builds and platforms (unlike `std`'s hasher).
fn fnv(bytes: impl IntoIterator<Item = u8>, mut h: u64) -> u64 {
    for b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x100_0000_01b3);
    }
    h
}

/// The cache key of a problem.
pub fn key(p: &ModalProblem<'_>) -> u64 {
    let f = |x: f64| x.to_le_bytes();
    let mut h = fnv(*MAGIC, FNV_OFFSET);
    h = fnv(p.mesh.positions().iter().flat_map(|v| v.to_array()).flat_map(f), h);
    h = fnv(p.mesh.triangles().iter().flatten().flat_map(|&i| (i as u64).to_le_bytes()), h);
    h = fnv(p.anchors.iter().flat_map(|&i| (i as u64).to_le_bytes()), h);
    h = fnv(p.masses.iter().copied().flat_map(f), h);
    let s = p.stiffness;
    h = fnv([s.k_area, s.k_length, s.k_bend].into_iter().flat_map(f), h);
    h = fnv((p.modes as u64).to_le_bytes(), h);
    fnv([u8::from(p.keep_rigid)], h)
}

/// Where analyses are cached (or that they are not).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cache {
    dir: Option<PathBuf>,
}

impl Cache {
    /// The default location from the environment (see the module documentation); none if no
    /// variable is set.
    pub fn from_env() -> Self {
        let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
        let dir = env("SHELLWARP_CACHE_DIR")
            .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("shellwarp")))
            .or_else(|| env("HOME").map(|d| d.join(".cache/shellwarp")));
        Self { dir }
    }

    /// Cache in `dir` (created on first store).
    pub fn at(dir: impl Into<PathBuf>) -> Self {
        Self { dir: Some(dir.into()) }
    }

    /// No caching: every analysis is computed.
    pub fn disabled() -> Self {
        Self { dir: None }
    }

    /// The cache's folder, if caching is on.
    pub fn dir(&self) -> Option<&std::path::Path> {
        self.dir.as_deref()
    }

    /// The file that holds (or would hold) the analysis of `p`.
    pub fn path(&self, p: &ModalProblem<'_>) -> Option<PathBuf> {
        self.file("modes", key(p))
    }

    /// A cached analysis of this problem, if there is a valid one.
    pub fn load(&self, p: &ModalProblem<'_>) -> Option<ModalAnalysis> {
        decode(p, self.read_words("modes", MAGIC, key(p))?)
    }

    /// Store an analysis (best effort: a cache that cannot be written is silently skipped).
    pub fn store(&self, p: &ModalProblem<'_>, a: &ModalAnalysis) {
        self.write_words("modes", MAGIC, key(p), &encode(a));
    }

    /// The file `{kind}-{key}.bin` in the cache's folder, if caching is on.
    pub fn file(&self, kind: &str, key: u64) -> Option<PathBuf> {
        Some(self.dir.as_ref()?.join(format!("{kind}-{key:016x}.bin")))
    }

    /// The numbers stored under `kind` and `key`, if a valid file holds them: `magic`, then `key`,
    /// then the numbers, then a checksum (FNV-1a of everything before it); every number finite.
    pub fn read_words(&self, kind: &str, magic: &[u8; 8], key: u64) -> Option<Vec<f64>> {
        let bytes = std::fs::read(self.file(kind, key)?).ok()?;
        let (body, sum) = bytes.split_at_checked(bytes.len().checked_sub(8)?)?;
        if fnv(body.iter().copied(), FNV_OFFSET).to_le_bytes() != sum {
            return None;
        }
        let rest = body.strip_prefix(magic)?.strip_prefix(&key.to_le_bytes()[..])?;
        if rest.len() % 8 != 0 {
            return None;
        }
        let words: Vec<f64> =
            rest.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8]))).collect();
        words.iter().all(|w| w.is_finite()).then_some(words)
    }

    /// Store `words` under `kind` and `key` in the layout [`Cache::read_words`] reads (best effort,
    /// written atomically: a cache that cannot be written is silently skipped).
    pub fn write_words(&self, kind: &str, magic: &[u8; 8], key: u64, words: &[f64]) {
        let Some(path) = self.file(kind, key) else { return };
        let mut bytes = magic.to_vec();
        bytes.extend(key.to_le_bytes());
        bytes.extend(words.iter().flat_map(|w| w.to_le_bytes()));
        let sum = fnv(bytes.iter().copied(), FNV_OFFSET);
        bytes.extend(sum.to_le_bytes());
        let write = || -> std::io::Result<()> {
            std::fs::create_dir_all(path.parent().ok_or(std::io::ErrorKind::NotFound)?)?;
            crate::atomic::write(&path, &bytes)
        };
        let _ = write();
    }
}

/// A key for what is derived from problem `p` with the further settings `extra` (e.g. `rds`'s
/// basis sizes): `p`'s key, hashed on with them.
pub fn derived_key(p: &ModalProblem<'_>, extra: &[u8]) -> u64 {
    fnv(extra.iter().copied(), key(p))
}

/// A count stored as a number: `Some` if it is a whole number from 0 to `max`.
pub fn count(word: f64, max: usize) -> Option<usize> {
    (word >= 0.0 && word.fract() == 0.0 && word <= max as f64).then_some(word as usize)
}

/// Per-vertex vectors stored one after another, `3n` numbers each.
pub fn vectors(words: &[f64], n: usize) -> Vec<Vec<DVec3>> {
    words
        .chunks_exact(3 * n.max(1))
        .map(|s| s.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect())
        .collect()
}

/// The analysis in `words`, if they are one of `p`'s: sizes that fit `p`.
fn decode(p: &ModalProblem<'_>, words: Vec<f64>) -> Option<ModalAnalysis> {
    let n = p.mesh.vertex_count();
    let most = words.len();
    let (m, rigid, solves) =
        (count(*words.first()?, most)?, count(*words.get(1)?, most)?, count(*words.get(2)?, usize::MAX)?);
    let expected = p.modes + if p.keep_rigid { rigid } else { 0 };
    if m != expected || Some(words.len()) != (3 * n).checked_mul(m).and_then(|s| s.checked_add(7 + 2 * m)) {
        return None;
    }
    let timings = PrecomputeTimings { assembly: words[3], factorisation: words[4], eigen: words[5] };
    let lambda_max = words[6];
    let values = words[7..7 + m].to_vec();
    let residuals = words[7 + m..7 + 2 * m].to_vec();
    let shapes = vectors(&words[7 + 2 * m..], n);
    let basis = ModalBasis::new(p.mesh, values, &shapes);
    Some(ModalAnalysis { basis, residuals, lambda_max, rigid_modes: rigid, timings, solves })
}

/// The numbers that store analysis `a`.
fn encode(a: &ModalAnalysis) -> Vec<f64> {
    let n = a.basis.vertex_count();
    let m = a.basis.modes();
    let mut words = vec![m as f64, a.rigid_modes as f64, a.solves as f64];
    words.extend([a.timings.assembly, a.timings.factorisation, a.timings.eigen, a.lambda_max]);
    words.extend(&a.basis.eigenvalues);
    words.extend(&a.residuals);
    for j in 0..m {
        for v in 0..n {
            words.extend((0..3).map(|ax| a.basis.phi(v, ax, j)));
        }
    }
    words
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::ShellStiffness;
    use crate::mesh::TriMesh;
    use crate::mesh::generate::grid;
    use crate::solver::modal::compute::analyse;

    fn temp_cache(name: &str) -> (Cache, PathBuf) {
        let dir = std::env::temp_dir().join(format!("shellwarp-cache-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        (Cache::at(&dir), dir)
    }

    struct Case {
        mesh: TriMesh,
        anchors: Vec<usize>,
        masses: Vec<f64>,
        stiffness: ShellStiffness,
        modes: usize,
    }

    impl Case {
        fn new() -> Self {
            let mesh = grid([0.4, 0.1], [8, 2]).unwrap();
            let masses = mesh.vertex_areas().iter().map(|a| 0.5 * a).collect();
            let stiffness = ShellStiffness { k_area: 10.0, k_length: 10.0, k_bend: 0.05 };
            Self { mesh, anchors: (0..6).collect(), masses, stiffness, modes: 3 }
        }

        fn problem(&self) -> ModalProblem<'_> {
            let (mesh, anchors, masses) = (&self.mesh, &self.anchors, &self.masses);
            ModalProblem { mesh, anchors, masses, stiffness: self.stiffness, modes: self.modes, keep_rigid: false }
        }
    }

    #[test]
    fn an_analysis_comes_back_exactly() {
        let (cache, dir) = temp_cache("round-trip");
        let case = Case::new();
        let p = case.problem();
        assert!(cache.load(&p).is_none(), "empty cache");
        let a = analyse(&p, &|_| {}).unwrap();
        cache.store(&p, &a);
        assert_eq!(cache.load(&p), Some(a), "bit for bit, Ψ rebuilt from Φ included");
        assert!(Cache::disabled().load(&p).is_none() && Cache::disabled().path(&p).is_none());
        let _ = std::fs::remove_dir_all(dir);
    }

    /// A named change to a problem.
    type Change = (&'static str, fn(&mut Case));

    /// The same vertices with every triangle's winding reversed.
    fn flipped(mesh: &TriMesh) -> TriMesh {
        TriMesh::new(mesh.positions().to_vec(), mesh.triangles().iter().map(|&[a, b, c]| [a, c, b]).collect()).unwrap()
    }

    #[test]
    fn the_key_follows_everything_the_modes_depend_on() {
        let base = Case::new();
        let k0 = key(&base.problem());
        assert_eq!(k0, key(&Case::new().problem()), "deterministic");
        let changes: [Change; 8] = [
            ("anchors", |c| c.anchors.push(6)),
            ("k_area", |c| c.stiffness.k_area *= 1.0 + 1e-12),
            ("k_length", |c| c.stiffness.k_length = 11.0),
            ("k_bend", |c| c.stiffness.k_bend = 0.06),
            ("density", |c| c.masses.iter_mut().for_each(|m| *m *= 2.0)),
            ("mode count", |c| c.modes = 4),
            ("positions", |c| c.mesh = c.mesh.transformed(|p| p * 1.001).unwrap()),
            ("triangles", |c| c.mesh = flipped(&c.mesh)),
        ];
        for (what, change) in changes {
            let mut case = Case::new();
            change(&mut case);
            assert_ne!(key(&case.problem()), k0, "{what} changes the key");
        }
    }

    #[test]
    fn corrupt_or_foreign_files_are_rejected() {
        let (cache, dir) = temp_cache("corrupt");
        let case = Case::new();
        let p = case.problem();
        let a = analyse(&p, &|_| {}).unwrap();
        cache.store(&p, &a);
        let path = cache.path(&p).unwrap();
        let good = std::fs::read(&path).unwrap();
        // One flipped bit anywhere (magic, key, sizes, eigenvalues, shapes, checksum), or a truncation.
        for at in [0, 9, 20, 80, good.len() / 2, good.len() - 9, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&path, &bad).unwrap();
            assert!(cache.load(&p).is_none(), "flipped byte {at} of {}", good.len());
        }
        for len in [0, 7, good.len() - 8, good.len() - 1] {
            std::fs::write(&path, &good[..len]).unwrap();
            assert!(cache.load(&p).is_none(), "truncated to {len}");
        }
        // A valid file of another problem under this problem's name.
        let mut other = Case::new();
        other.stiffness.k_bend = 0.07;
        let q = other.problem();
        cache.store(&q, &analyse(&q, &|_| {}).unwrap());
        std::fs::copy(cache.path(&q).unwrap(), &path).unwrap();
        assert!(cache.load(&p).is_none(), "another problem's analysis");
        std::fs::write(&path, &good).unwrap();
        assert!(cache.load(&p).is_some(), "the intact file loads");
        let _ = std::fs::remove_dir_all(dir);
    }
}
