//! A clamped strip built from a scene text, shared by the discrete-shell physics tests.

use std::path::PathBuf;

use glam::DVec3;
use shellwarp::scene::{self, Origin, Setup};

/// A strip along x: `cells` cells of length `dx` (so `cells + 1` vertex rows), `across` cells across a
/// width `width`, clamped by fixing the first two vertex rows. Beam length from the second row is
/// `(cells − 1) dx`.
pub struct Strip {
    /// Cells along x.
    pub cells: usize,
    /// Cells across.
    pub across: usize,
    /// Cell length along x, m.
    pub dx: f64,
    /// Width, m.
    pub width: f64,
}

impl Strip {
    /// The scene: `material` and `solver` are the bodies of those tables, `tables` extra TOML tables
    /// (e.g. `[[loads]]`) placed before `[solver]`.
    pub fn setup_with(&self, method: &str, material: &str, tables: &str, solver: &str) -> Setup {
        let total = self.cells as f64 * self.dx;
        let clamp = -total / 2.0 + 1.5 * self.dx;
        let text = format!(
            r#"
name = "test strip"
[mesh.grid]
size = [{total}, {width}]
segments = [{cells}, {across}]
[material]
{material}
[[anchors]]
box = {{ min = [-10.0, -1.0, -1.0], max = [{clamp}, 1.0, 1.0] }}
{tables}
[solver]
method = "{method}"
{solver}
"#,
            width = self.width,
            cells = self.cells,
            across = self.across,
        );
        let origin = Origin { label: "test".into(), dir: PathBuf::from(".") };
        let setup = Setup::new(scene::parse(&text, &origin, &[]).unwrap(), origin).unwrap();
        assert_eq!(setup.anchors.len(), 2 * (self.across + 1), "exactly two rows clamped");
        setup
    }

    /// [`Strip::setup_with`] without extra tables.
    pub fn setup(&self, method: &str, material: &str, solver: &str) -> Setup {
        self.setup_with(method, material, "", solver)
    }

    /// Beam length from the clamp (the second vertex row) to the tip row, m.
    pub fn length(&self) -> f64 {
        (self.cells - 1) as f64 * self.dx
    }

    /// Mean (over the row) downward deflection and horizontal (x) shortening of vertex row `i`.
    pub fn row_displacement(&self, rest: &[DVec3], x: &[DVec3], i: usize) -> (f64, f64) {
        let n = self.across + 1;
        let (mut dy, mut dxs) = (0.0, 0.0);
        for j in 0..n {
            let v = i * n + j;
            dy += rest[v].y - x[v].y;
            dxs += rest[v].x - x[v].x;
        }
        (dy / n as f64, dxs / n as f64)
    }
}
