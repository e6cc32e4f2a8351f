//! Wavefront OBJ in and out: a small reader that keeps the file's vertex order, and an exact,
//! atomic writer.

mod parse;

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::generate::MAX_VERTICES;
use super::{MeshError, TriMesh};

/// Memory reading an OBJ file takes per byte of it, at most: the bytes, their text, a string per
/// statement (a `v 0 0 0` line of 8 bytes becomes a 56-byte string and a 32-byte slot), and the
/// parsed positions and faces.
const BYTES_PER_FILE_BYTE: u64 = 16;

/// Read a triangle mesh from an OBJ file.
///
/// Vertex `i` of the mesh is the file's `i`-th `v` line, so anchors and loads given by index hit the
/// vertices they name, and a file from [`save_obj`] loads back identical. Polygons are
/// fan-triangulated; all objects and groups share the file's one vertex list; texture coordinates,
/// normals, points, lines and materials are ignored. Coordinates are read as `f64`, so values
/// written by [`save_obj`] come back bit for bit.
///
/// Errors: [`MeshError::TooLarge`] for a file that would need more memory to read than the machine
/// has, [`MeshError::Io`] naming the path ("file not found", "cannot read: ...", or
/// "line N: ..." for malformed statements); otherwise whatever [`TriMesh::new`] reports for invalid
/// geometry, e.g. [`MeshError::UnreferencedVertex`] for a `v` no face uses.
pub fn load_obj(path: &Path) -> Result<TriMesh, MeshError> {
    let io = |reason: String| MeshError::Io { path: path.to_path_buf(), reason };
    let not_read = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::NotFound => io("file not found".into()),
        _ => io(format!("cannot read: {e}")),
    };
    let size = std::fs::metadata(path).map_err(not_read)?.len();
    crate::memory::check(crate::memory::times(size, BYTES_PER_FILE_BYTE), || format!("reading {}", path.display()))?;
    let bytes = std::fs::read(path).map_err(not_read)?;
    let (positions, triangles) = parse::parse(&String::from_utf8_lossy(&bytes)).map_err(io)?;
    if positions.len() > MAX_VERTICES {
        return Err(io(format!("{} vertices: more than the {MAX_VERTICES} a mesh may have", positions.len())));
    }
    TriMesh::new(positions, triangles)
}

/// Write `positions` and `triangles` as an OBJ file (`v x y z` lines, then 1-based `f a b c` lines).
///
/// Coordinates are printed with Rust's shortest round-trip `f64` formatting, so reading them back is
/// exact. The write is atomic ([`crate::atomic`]): on failure `path` is untouched.
///
/// Errors: [`MeshError::NonFinite`] or [`MeshError::IndexOutOfRange`] for data that would make a
/// broken file (checked before touching the disk); [`MeshError::Io`] naming the path otherwise.
pub fn save_obj(path: &Path, positions: &[DVec3], triangles: &[[usize; 3]]) -> Result<(), MeshError> {
    if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
        return Err(MeshError::NonFinite { vertex });
    }
    for (triangle, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i >= positions.len()) {
            return Err(MeshError::IndexOutOfRange { triangle, index, vertex_count: positions.len() });
        }
    }
    crate::atomic::write_with(path, |w| {
        writeln!(w, "# shellwarp: {} vertices, {} triangles", positions.len(), triangles.len())?;
        for p in positions {
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for t in triangles {
            writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        Ok(())
    })
    .map_err(|e| MeshError::Io { path: path.to_path_buf(), reason: format!("cannot write: {e}") })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::{creature, delaunay_sheet};
    use std::path::PathBuf;

    /// A fresh, empty directory for one test.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("shellwarp-obj-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = scratch("round-trip");
        let path = dir.join("creature.obj");
        // Awkward values: many digits, tiny, huge and negative zero all survive.
        let m = creature(1.7, 12)
            .unwrap()
            .transformed(|p| p * std::f64::consts::PI + DVec3::new(1e-300, -0.0, 1e12))
            .unwrap();
        save_obj(&path, m.positions(), m.triangles()).unwrap();
        let back = load_obj(&path).unwrap();
        // Same vertex order, same triangles, every coordinate bit for bit.
        assert_eq!(back.triangles(), m.triangles());
        for (a, b) in back.positions().iter().zip(m.positions()) {
            assert_eq!(a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits));
        }
        assert_eq!(back, m);
        // No temporary left behind; saving again overwrites.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        let sheet = delaunay_sheet([1.0, 0.5], 0.2).unwrap();
        save_obj(&path, sheet.positions(), sheet.triangles()).unwrap();
        assert_eq!(load_obj(&path).unwrap().triangles().len(), sheet.triangles().len());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn vertex_order_is_the_files_even_when_faces_use_vertices_out_of_order() {
        let dir = scratch("order");
        // Faces use vertex 4 first; vertex i must still be the i-th `v` line.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 4 1 3\nf 3 1 2\n";
        let m = load_obj(&write(&dir, "order.obj", text)).unwrap();
        assert_eq!(m.positions(), &[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
        assert_eq!(m.triangles(), &[[3, 0, 2], [2, 0, 1]]);
        // A `v` no face uses is reported, not silently dropped.
        let unused = "v 0 0 0\nv 9 9 9\nv 1 0 0\nv 0 1 0\nf 1 3 4\n";
        assert_eq!(load_obj(&write(&dir, "unused.obj", unused)), Err(MeshError::UnreferencedVertex { vertex: 1 }));
        // A vertex shared by two objects stays one vertex.
        let shared = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\no a\nf 1 2 3\no b\nf 1 3 4\n";
        assert_eq!(load_obj(&write(&dir, "shared.obj", shared)).unwrap().vertex_count(), 4);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn polygons_objects_and_comments_load() {
        let dir = scratch("polygons");
        let text = "# a quad and a pentagon, in two objects\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    o first\nf 1 2 3 4\no second\nv 2 0 0\nv 3 0 0\nv 3 1 0\nv 2.5 1.5 0\nv 2 1 0\nf 5/1 6 7 8 9\n";
        let m = load_obj(&write(&dir, "poly.obj", text)).unwrap();
        assert_eq!(m.vertex_count(), 9);
        assert_eq!(m.triangles().len(), 2 + 3);
        assert!((m.triangle_areas().iter().sum::<f64>() - 2.25).abs() < 1e-12);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_file_names_the_path() {
        let path = std::env::temp_dir().join("shellwarp-definitely-missing/none.obj");
        match load_obj(&path) {
            Err(MeshError::Io { path: p, reason }) => {
                assert_eq!(p, path);
                assert_eq!(reason, "file not found");
            }
            other => panic!("expected Io error, got {other:?}"),
        }
        let msg = load_obj(&path).unwrap_err().to_string();
        assert!(msg.contains("none.obj") && msg.contains("file not found"), "{msg}");
    }

    #[test]
    fn malformed_files_give_clear_errors() {
        let dir = scratch("malformed");
        let cases = [
            ("garbage.obj", "v 0 0 0\nv 1 banana 0\nv 0 1 0\nf 1 2 3\n", "line 2: vertex coordinate `banana`"),
            ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "line 4: face refers to vertex 7"),
            ("face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n", "line 4: face vertex `two`"),
        ];
        for (name, text, expect) in cases {
            let path = write(&dir, name, text);
            match load_obj(&path) {
                Err(MeshError::Io { path: p, reason }) => {
                    assert_eq!(p, path);
                    assert!(reason.contains(expect), "{name}: {reason}");
                }
                other => panic!("{name}: expected Io error, got {other:?}"),
            }
        }
        // Empty file: no geometry.
        assert!(matches!(load_obj(&write(&dir, "empty.obj", "")), Err(MeshError::Empty { .. })));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn invalid_geometry_reports_the_validation_error() {
        let dir = scratch("invalid");
        // Three triangles on edge 1–2.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n";
        assert_eq!(load_obj(&write(&dir, "fan.obj", text)), Err(MeshError::NonManifoldEdge { a: 0, b: 1, count: 3 }));
        let degenerate = "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
        assert!(matches!(load_obj(&write(&dir, "flat.obj", degenerate)), Err(MeshError::DegenerateTriangle { .. })));
        let pillow = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n";
        assert_eq!(
            load_obj(&write(&dir, "pillow.obj", pillow)),
            Err(MeshError::DuplicateTriangle { first: 0, second: 1 })
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failed_write_is_an_io_error_and_leaves_nothing() {
        let dir = scratch("failed-write");
        let missing = dir.join("no-such-dir");
        let path = missing.join("out.obj");
        let m = delaunay_sheet([1.0, 1.0], 0.5).unwrap();
        match save_obj(&path, m.positions(), m.triangles()) {
            Err(MeshError::Io { path: p, reason }) => {
                assert_eq!(p, path);
                assert!(reason.starts_with("cannot write"), "{reason}");
            }
            other => panic!("expected Io error, got {other:?}"),
        }
        assert!(!missing.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "no temporary file left behind");
        // Rename onto a directory fails after the temporary was written: it must be cleaned up.
        let blocker = dir.join("blocker.obj");
        std::fs::create_dir_all(blocker.join("inside")).unwrap();
        assert!(matches!(save_obj(&blocker, m.positions(), m.triangles()), Err(MeshError::Io { .. })));
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("blocker.obj")]);
        // Bad data is refused before touching the disk.
        assert_eq!(save_obj(&dir.join("x.obj"), &[DVec3::NAN], &[]), Err(MeshError::NonFinite { vertex: 0 }));
        assert!(matches!(
            save_obj(&dir.join("x.obj"), &[DVec3::ZERO], &[[0, 0, 1]]),
            Err(MeshError::IndexOutOfRange { .. })
        ));
        assert!(!dir.join("x.obj").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
