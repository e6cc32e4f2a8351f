//! TEMPORARY placeholders until the generator branch lands.
#![allow(missing_docs, unused_variables)]
use crate::mesh::{MeshError, TriMesh};
fn no() -> Result<TriMesh, MeshError> {
    Err(MeshError::BadParameter { name: "generator", reason: "pending".into() })
}
pub fn v_beam(length: f64, width: f64, angle_deg: f64, segments: [usize; 2]) -> Result<TriMesh, MeshError> {
    no()
}
pub fn delaunay_sheet(size: [f64; 2], edge: f64) -> Result<TriMesh, MeshError> {
    no()
}
pub fn icosphere(radius: f64, frequency: usize) -> Result<TriMesh, MeshError> {
    no()
}
pub fn uv_sphere(radius: f64, rings: usize, sectors: usize) -> Result<TriMesh, MeshError> {
    no()
}
pub fn creature(length: f64, frequency: usize) -> Result<TriMesh, MeshError> {
    no()
}
pub mod obj {
    pub fn load_obj(p: &std::path::Path) -> Result<crate::mesh::TriMesh, crate::mesh::MeshError> {
        super::no()
    }
}
