//! On-disk cache of modal analyses, keyed by a hash of everything the modes depend on (mesh,
//! anchors, masses, stiffnesses, mode count), so a scene reopens without recomputing.
//!
//! Location: `$SHELLWARP_CACHE_DIR`, else `$XDG_CACHE_HOME/shellwarp`, else `~/.cache/shellwarp`.
//! Files are written atomically (temporary file, then rename); an unreadable or mismatched file is
//! ignored and recomputed, never trusted.

use std::io::Write;
use std::path::PathBuf;

use glam::DVec3;

use super::basis::ModalBasis;
use super::compute::{ModalAnalysis, ModalProblem, PrecomputeTimings};

const MAGIC: &[u8; 8] = b"SWMODES4";

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
    let mut h = fnv(*MAGIC, 0xcbf2_9ce4_8422_2325);
    h = fnv(p.mesh.positions().iter().flat_map(|v| v.to_array()).flat_map(f), h);
    h = fnv(p.mesh.triangles().iter().flatten().flat_map(|&i| (i as u64).to_le_bytes()), h);
    h = fnv(p.anchors.iter().flat_map(|&i| (i as u64).to_le_bytes()), h);
    h = fnv(p.masses.iter().copied().flat_map(f), h);
    let s = p.stiffness;
    h = fnv([s.k_area, s.k_length, s.k_bend].into_iter().flat_map(f), h);
    fnv((p.modes as u64).to_le_bytes(), h)
}

fn dir() -> Option<PathBuf> {
    let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    env("SHELLWARP_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("shellwarp")))
        .or_else(|| env("HOME").map(|d| d.join(".cache/shellwarp")))
}

fn path(p: &ModalProblem<'_>) -> Option<PathBuf> {
    Some(dir()?.join(format!("modes-{:016x}.bin", key(p))))
}

/// A cached analysis of this problem, if there is a valid one.
pub fn load(p: &ModalProblem<'_>) -> Option<ModalAnalysis> {
    let bytes = std::fs::read(path(p)?).ok()?;
    let rest = bytes.strip_prefix(MAGIC)?;
    let words: Vec<f64> = rest.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8]))).collect();
    let n = p.mesh.vertex_count();
    let (m, rigid, solves) = (*words.first()? as usize, *words.get(1)? as usize, *words.get(2)? as usize);
    if m != p.modes || words.len() != 7 + 2 * m + 3 * n * m || rest.len() % 8 != 0 {
        return None;
    }
    let timings = PrecomputeTimings { assembly: words[3], factorisation: words[4], eigen: words[5] };
    let lambda_max = words[6];
    let values = words[7..7 + m].to_vec();
    let residuals = words[7 + m..7 + 2 * m].to_vec();
    let shapes: Vec<Vec<DVec3>> = words[7 + 2 * m..]
        .chunks_exact(3 * n)
        .map(|s| s.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect())
        .collect();
    if !words.iter().all(|w| w.is_finite()) {
        return None;
    }
    let basis = ModalBasis::new(p.mesh, values, &shapes);
    Some(ModalAnalysis { basis, residuals, lambda_max, rigid_modes: rigid, timings, solves })
}

/// Store an analysis (best effort: a cache that cannot be written is silently skipped).
pub fn store(p: &ModalProblem<'_>, a: &ModalAnalysis) {
    let Some(path) = path(p) else { return };
    let n = p.mesh.vertex_count();
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
    let mut bytes = MAGIC.to_vec();
    bytes.extend(words.iter().flat_map(|w| w.to_le_bytes()));
    let write = || -> std::io::Result<()> {
        let parent = path.parent().ok_or(std::io::ErrorKind::NotFound)?;
        std::fs::create_dir_all(parent)?;
        let tmp = parent.join(format!(".{}.{}.tmp", key(p), std::process::id()));
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, &path)
    };
    let _ = write();
}
