//! Procedural meshes for every scene the papers use. Each returns a validated [`super::TriMesh`].

mod creature;
mod dancer;
mod delaunay;
mod grid;
mod sphere;
mod v_beam;

pub use creature::creature;
pub use dancer::dancer;
pub use delaunay::delaunay_sheet;
pub use grid::grid;
pub use sphere::{icosphere, uv_sphere};
pub use v_beam::v_beam;

use super::MeshError;

/// The most vertices a generator makes: far beyond real time, far below exhausting memory.
pub const MAX_VERTICES: usize = 4_000_000;

/// Check a generator's vertex count, `None` meaning it overflowed `usize`; `name` is the parameter to blame.
pub(crate) fn vertex_budget(name: &'static str, count: Option<usize>) -> Result<usize, MeshError> {
    match count {
        Some(n) if n <= MAX_VERTICES => Ok(n),
        _ => Err(MeshError::BadParameter {
            name,
            reason: format!(
                "too large: {} vertices (at most {MAX_VERTICES})",
                count.map_or_else(|| "more than usize::MAX".to_string(), |n| n.to_string())
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_budget_accepts_up_to_the_limit() {
        assert_eq!(vertex_budget("n", Some(MAX_VERTICES)), Ok(MAX_VERTICES));
        for count in [Some(MAX_VERTICES + 1), None] {
            assert!(matches!(vertex_budget("n", count), Err(MeshError::BadParameter { name: "n", .. })));
        }
    }
}
