//! CPU side of drawing: turns a [`Frame`] into the flat vertex and index arrays the GPU buffers hold.

use bytemuck::{Pod, Zeroable};

use super::error::RenderError;
use super::frame::{Frame, MeshDraw};

/// Fraction of the distance to the eye by which wireframe edges are pulled towards the camera,
/// so they win the depth test against the surface they lie on.
pub(crate) const WIREFRAME_BIAS: f32 = 1.5e-3;

/// Vertex of the lit triangle pipeline (must match `shaders/lit.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct LitVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub front: [f32; 4],
    pub back: [f32; 4],
}

/// Vertex of the line pipeline (must match `shaders/line.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct LineVertex {
    pub position: [f32; 3],
    /// Fraction of the way towards the eye the vertex is moved (0 for plain lines).
    pub bias: f32,
    pub color: [f32; 4],
}

/// Reusable CPU arrays for one frame's geometry.
#[derive(Debug, Default)]
pub(crate) struct Geometry {
    pub lit_vertices: Vec<LitVertex>,
    pub lit_indices: Vec<u32>,
    pub line_vertices: Vec<LineVertex>,
    edges: Vec<(u32, u32)>,
}

impl Geometry {
    /// Refill all arrays from `frame`, checking every mesh first.
    pub fn build(&mut self, frame: &Frame) -> Result<(), RenderError> {
        self.lit_vertices.clear();
        self.lit_indices.clear();
        self.line_vertices.clear();
        for (i, mesh) in frame.meshes.iter().enumerate() {
            check_mesh(mesh).map_err(|reason| RenderError::BadMesh { mesh: i, reason })?;
            self.push_mesh(mesh)?;
        }
        for marker in &frame.markers {
            self.push_cube(marker.position, marker.size, marker.color)?;
        }
        for line in &frame.lines {
            self.line_vertices.push(LineVertex { position: line.start, bias: 0.0, color: line.color });
            self.line_vertices.push(LineVertex { position: line.end, bias: 0.0, color: line.color });
        }
        Ok(())
    }

    /// Index of the next vertex, checking that `adding` more still fit 32-bit indices.
    fn base_index(&self, adding: usize) -> Result<u32, RenderError> {
        let total = self.lit_vertices.len() + adding;
        u32::try_from(total).map(|_| self.lit_vertices.len() as u32).map_err(|_| RenderError::TooManyVertices(total))
    }

    fn push_mesh(&mut self, mesh: &MeshDraw) -> Result<(), RenderError> {
        let base = self.base_index(mesh.positions.len())?;
        self.lit_vertices.extend(mesh.positions.iter().zip(&mesh.normals).map(|(p, n)| LitVertex {
            position: *p,
            normal: *n,
            front: mesh.front,
            back: mesh.back,
        }));
        self.lit_indices.extend(mesh.triangles.iter().flat_map(|t| t.map(|i| base + i)));
        if let Some(color) = mesh.wireframe {
            unique_edges(&mesh.triangles, &mut self.edges);
            for &(a, b) in &self.edges {
                for v in [a, b] {
                    let position = mesh.positions[v as usize];
                    self.line_vertices.push(LineVertex { position, bias: WIREFRAME_BIAS, color });
                }
            }
        }
        Ok(())
    }

    /// A cube of edge `size` centred at `center`, with flat face normals and counter-clockwise faces.
    fn push_cube(&mut self, center: [f32; 3], size: f32, color: [f32; 4]) -> Result<(), RenderError> {
        let base = self.base_index(24)?;
        let h = 0.5 * size.abs();
        let mut k = 0;
        for axis in 0..3 {
            for sign in [1.0f32, -1.0] {
                let mut n = [0.0f32; 3];
                n[axis] = sign;
                // u x v must equal n for counter-clockwise winding seen from outside.
                let (mut u, mut v) = ([0.0f32; 3], [0.0f32; 3]);
                let (iu, iv) =
                    if sign > 0.0 { ((axis + 1) % 3, (axis + 2) % 3) } else { ((axis + 2) % 3, (axis + 1) % 3) };
                u[iu] = 1.0;
                v[iv] = 1.0;
                for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    let position = std::array::from_fn(|j| center[j] + h * (n[j] + su * u[j] + sv * v[j]));
                    self.lit_vertices.push(LitVertex { position, normal: n, front: color, back: color });
                }
                let b = base + 4 * k;
                self.lit_indices.extend([b, b + 1, b + 2, b, b + 2, b + 3]);
                k += 1;
            }
        }
        Ok(())
    }
}

/// Check lengths and index ranges so the GPU never sees an inconsistent mesh.
fn check_mesh(mesh: &MeshDraw) -> Result<(), String> {
    if mesh.normals.len() != mesh.positions.len() {
        return Err(format!("{} normals for {} positions", mesh.normals.len(), mesh.positions.len()));
    }
    let n = mesh.positions.len();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(format!("triangle {t} refers to vertex {i}, but there are only {n} vertices"));
        }
    }
    Ok(())
}

/// The distinct undirected edges of `triangles`, each as `(low, high)`, written into `out` in sorted order.
pub(crate) fn unique_edges(triangles: &[[u32; 3]], out: &mut Vec<(u32, u32)>) {
    out.clear();
    for &[a, b, c] in triangles {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            out.push((p.min(q), p.max(q)));
        }
    }
    out.sort_unstable();
    out.dedup();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::frame::{Camera, Marker};
    use glam::Vec3;

    #[test]
    fn quad_has_five_unique_edges() {
        let mut edges = Vec::new();
        unique_edges(&[[0, 1, 2], [0, 2, 3]], &mut edges);
        assert_eq!(edges, vec![(0, 1), (0, 2), (0, 3), (1, 2), (2, 3)]);
    }

    #[test]
    fn cube_faces_wind_along_their_normals() {
        let mut g = Geometry::default();
        let mut frame = Frame::new(Camera::default());
        frame.markers.push(Marker { position: [1.0, 2.0, 3.0], size: 0.2, color: [1.0; 4] });
        g.build(&frame).unwrap();
        assert_eq!((g.lit_vertices.len(), g.lit_indices.len()), (24, 36));
        for tri in g.lit_indices.chunks(3) {
            let p = tri.iter().map(|&i| Vec3::from(g.lit_vertices[i as usize].position)).collect::<Vec<_>>();
            let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            let n = Vec3::from(g.lit_vertices[tri[0] as usize].normal);
            assert!(face.dot(n) > 0.99, "{face} vs {n}");
            let centre_to_face = (p[0] - Vec3::new(1.0, 2.0, 3.0)).dot(n);
            assert!((centre_to_face - 0.1).abs() < 1e-5);
        }
    }

    #[test]
    fn bad_meshes_are_refused_with_their_index() {
        let mut frame = Frame::default();
        let ok = MeshDraw::from_positions(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
            [1.0; 4],
            [1.0; 4],
        );
        let mut bad = ok.clone();
        bad.triangles.push([0, 1, 3]);
        frame.meshes = vec![ok.clone(), bad];
        let err = Geometry::default().build(&frame).unwrap_err();
        assert!(matches!(err, RenderError::BadMesh { mesh: 1, .. }), "{err}");
        let mut short = ok;
        short.normals.pop();
        frame.meshes = vec![short];
        assert!(Geometry::default().build(&frame).is_err());
    }

    #[test]
    fn second_mesh_indices_are_offset_and_wireframe_is_biased() {
        let tri = MeshDraw::from_positions(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
            [1.0; 4],
            [1.0; 4],
        );
        let mut frame =
            Frame { meshes: vec![tri.clone(), tri.with_wireframe([0.0, 0.0, 0.0, 1.0])], ..Default::default() };
        frame.line([0.0; 3], [1.0; 3], [1.0; 4]);
        let mut g = Geometry::default();
        g.build(&frame).unwrap();
        assert_eq!(g.lit_indices, vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(g.line_vertices.len(), 2 * 3 + 2);
        assert_eq!(g.line_vertices.iter().filter(|v| v.bias > 0.0).count(), 6);
    }
}
