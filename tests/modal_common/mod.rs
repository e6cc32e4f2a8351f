//! Shared by the modal tests: a clamped (or free) strip built from the cantilever scene.

use shellwarp::scene::{self, Setup};

/// A strip along x, clamped at x = −L/2 by its first two vertex rows (or free if not `clamped`), as
/// the cantilever scene with overrides (`extra`, e.g. `"material.k_bend=0.01"`).
pub fn strip(length: f64, width: f64, segments: [usize; 2], clamped: bool, extra: &[&str]) -> Setup {
    let clamp = -0.5 * length + 1.01 * length / segments[0] as f64;
    let anchors =
        if clamped { format!("[{{ box = {{ min = [-9, -9, -9], max = [{clamp}, 9, 9] }} }}]") } else { "[]".into() };
    let mut o = vec![
        format!("mesh.grid.size=[{length}, {width}]"),
        format!("mesh.grid.segments=[{}, {}]", segments[0], segments[1]),
        format!("anchors={anchors}"),
    ];
    o.extend(extra.iter().map(|s| s.to_string()));
    scene::load("cantilever", &o).unwrap()
}
