//! Matrix Market files (`coordinate real symmetric`, the lower triangle, one-based), to hand the
//! modal analysis' matrices to other programs (e.g. SciPy, to time a peer eigen solver on exactly
//! the same problem), and to read them back.

use std::fmt::Write as _;
use std::path::Path;

use faer::sparse::SparseColMatRef;

use super::LinalgError;

/// The text of a symmetric matrix given as CSC with both triangles (only the lower one is written).
pub fn symmetric_text(a: SparseColMatRef<'_, usize, f64>, comment: &str) -> String {
    let sym = a.symbolic();
    let (col_ptr, row_idx, values) = (sym.col_ptr(), sym.row_idx(), a.val());
    let lower: Vec<(usize, usize, f64)> = (0..a.ncols())
        .flat_map(|j| (col_ptr[j]..col_ptr[j + 1]).map(move |k| (row_idx[k], j, values[k])))
        .filter(|&(i, j, _)| i >= j)
        .collect();
    let mut s = String::with_capacity(32 * lower.len() + 128);
    let _ = writeln!(s, "%%MatrixMarket matrix coordinate real symmetric");
    for line in comment.lines() {
        let _ = writeln!(s, "% {line}");
    }
    let _ = writeln!(s, "{} {} {}", a.nrows(), a.ncols(), lower.len());
    for (i, j, v) in lower {
        let _ = writeln!(s, "{} {} {v:e}", i + 1, j + 1);
    }
    s
}

/// The text of a diagonal matrix.
pub fn diagonal_text(d: &[f64], comment: &str) -> String {
    let mut s = String::with_capacity(32 * d.len() + 128);
    let _ = writeln!(s, "%%MatrixMarket matrix coordinate real symmetric");
    for line in comment.lines() {
        let _ = writeln!(s, "% {line}");
    }
    let _ = writeln!(s, "{} {} {}", d.len(), d.len(), d.len());
    for (i, v) in d.iter().enumerate() {
        let _ = writeln!(s, "{} {} {v:e}", i + 1, i + 1);
    }
    s
}

/// One stored entry: zero-based `(row, column, value)`.
pub type Entry = (usize, usize, f64);

/// Read a `coordinate real symmetric` file: its size and the entries of both triangles.
pub fn read_symmetric(path: &Path) -> Result<(usize, Vec<Entry>), LinalgError> {
    let bad = |why: String| LinalgError::Input(format!("{}: {why}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    if !header.starts_with("%%MatrixMarket matrix coordinate real symmetric") {
        return Err(bad(format!("not a coordinate real symmetric matrix: `{header}`")));
    }
    let mut data = lines.filter(|l| !l.starts_with('%') && !l.trim().is_empty());
    let size: Vec<usize> = data
        .next()
        .unwrap_or_default()
        .split_whitespace()
        .map(|w| w.parse().map_err(|_| bad(format!("size `{w}`"))))
        .collect::<Result<_, _>>()?;
    let [n, m, count] = size[..] else { return Err(bad("the size line needs three numbers".into())) };
    if n != m {
        return Err(bad(format!("{n} × {m} is not square")));
    }
    let mut entries = Vec::with_capacity(2 * count);
    for line in data {
        let w: Vec<&str> = line.split_whitespace().collect();
        let [i, j, v] = w[..] else { return Err(bad(format!("entry `{line}`"))) };
        let parse = |s: &str| {
            s.parse::<usize>().ok().filter(|&k| (1..=n).contains(&k)).ok_or_else(|| bad(format!("index `{s}`")))
        };
        let (i, j) = (parse(i)? - 1, parse(j)? - 1);
        let v: f64 = v.parse().map_err(|_| bad(format!("value `{v}`")))?;
        entries.push((i, j, v));
        if i != j {
            entries.push((j, i, v));
        }
    }
    if entries.iter().filter(|e| e.0 >= e.1).count() != count {
        return Err(bad(format!("the size line says {count} entries")));
    }
    Ok((n, entries))
}
