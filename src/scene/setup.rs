//! Realising a validated scene: make the mesh, place it, and resolve anchors and loads to vertices.

use glam::{DMat3, DQuat, DVec3, EulerRot};

use super::schema::{Collider, MeshSource, Motion, Placement, Scene};
use super::selection::Selection;
use super::{Origin, SceneError};
use crate::collision::{self, Body, MeshDistance, Shape};
use crate::mesh::{MeshError, TriMesh, generate};

/// A scene made concrete: what every solver is built from.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The parsed scene.
    pub scene: Scene,
    /// Where it came from (for messages).
    pub origin: Origin,
    /// The placed rest mesh.
    pub mesh: TriMesh,
    /// Anchored (fixed) vertices, sorted, without repeats.
    pub anchors: Vec<usize>,
    /// Constant external point force on each vertex (gravity not included), newtons.
    pub loads: Vec<DVec3>,
    /// The colliders, ready for contact queries (in the scene's order).
    pub bodies: Vec<Body>,
    /// The vertices of each constraint track (in the scene's order).
    pub tracks: Vec<Vec<usize>>,
    /// The vertices of each part (whole connected components, sorted; in the scene's order).
    pub parts: Vec<Vec<usize>>,
}

impl Setup {
    /// Make the mesh and resolve selections. Fails if the mesh cannot be made or a selection is empty.
    pub fn new(scene: Scene, origin: Origin) -> Result<Self, SceneError> {
        let mesh_err = |error: MeshError| SceneError::Mesh { file: origin.label.clone(), error };
        let raw = make_mesh(&scene.mesh, &origin).map_err(mesh_err)?;
        let mesh = place(&raw, &scene.placement).map_err(mesh_err)?;
        let invalid = |key: String, reason: String| SceneError::Invalid { file: origin.label.clone(), key, reason };
        let open = mesh.topology().boundary_edges.len();
        if scene.material.k_pressure.is_some() && open > 0 {
            let reason = format!("needs a closed mesh, but this mesh is not closed ({open} boundary edges)");
            return Err(invalid("material.k_pressure".into(), reason));
        }
        let mut anchors = Vec::new();
        for (i, a) in scene.anchors.iter().enumerate() {
            anchors.extend(select(&mesh, a).map_err(|r| invalid(format!("anchors[{i}]"), r))?);
        }
        anchors.sort_unstable();
        anchors.dedup();
        let mut loads = vec![DVec3::ZERO; mesh.vertex_count()];
        for (i, l) in scene.loads.iter().enumerate() {
            for v in select(&mesh, &l.select).map_err(|r| invalid(format!("loads[{i}].select"), r))? {
                loads[v] += DVec3::from(l.force);
            }
        }
        let mut bodies = Vec::with_capacity(scene.colliders.len());
        for (i, c) in scene.colliders.iter().enumerate() {
            bodies.push(body(c, &origin).map_err(|reason| invalid(format!("colliders[{i}]"), reason))?);
        }
        let mut tracks = Vec::with_capacity(scene.tracks.len());
        for (i, t) in scene.tracks.iter().enumerate() {
            tracks.push(select(&mesh, &t.select).map_err(|r| invalid(format!("tracks[{i}].select"), r))?);
        }
        let parts = parts(&mesh, &scene.parts.iter().map(|p| &p.select).collect::<Vec<_>>())
            .map_err(|(i, r)| invalid(format!("parts[{i}].select"), r))?;
        Ok(Self { scene, origin, mesh, anchors, loads, bodies, tracks, parts })
    }

    /// Lumped vertex masses: density × one third of the area of each incident triangle, kg.
    pub fn masses(&self) -> Vec<f64> {
        self.mesh.vertex_areas().into_iter().map(|a| a * self.scene.material.density).collect()
    }

    /// Gravity as a vector, m/s².
    pub fn gravity(&self) -> DVec3 {
        DVec3::from(self.scene.gravity)
    }

    /// Whether each vertex is anchored.
    pub fn anchored_mask(&self) -> Vec<bool> {
        let mut mask = vec![false; self.mesh.vertex_count()];
        self.anchors.iter().for_each(|&i| mask[i] = true);
        mask
    }
}

fn make_mesh(source: &MeshSource, origin: &Origin) -> Result<TriMesh, MeshError> {
    // A sphere's or a creature's vertex count follows from its frequency: one no method could run
    // in this machine's memory is refused before seconds are spent generating it.
    if let MeshSource::Icosphere { frequency, .. } | MeshSource::Creature { frequency, .. } = *source {
        let vertices = frequency.saturating_mul(frequency).saturating_mul(10).saturating_add(2);
        let needed = crate::memory::times(vertices, crate::memory::LEAST_PER_VERTEX);
        crate::memory::check(needed, || format!("a mesh of frequency {frequency} ({vertices} vertices)"))?;
    }
    match *source {
        MeshSource::Grid { size, segments } => generate::grid(size, segments),
        MeshSource::VBeam { length, width, angle_deg, segments } => {
            generate::v_beam(length, width, angle_deg, segments)
        }
        MeshSource::DelaunaySheet { size, edge } => generate::delaunay_sheet(size, edge),
        MeshSource::Icosphere { radius, frequency } => generate::icosphere(radius, frequency),
        MeshSource::UvSphere { radius, rings, sectors } => generate::uv_sphere(radius, rings, sectors),
        MeshSource::Creature { length, frequency } => generate::creature(length, frequency),
        MeshSource::Dancer { height, around } => generate::dancer(height, around),
        MeshSource::Obj { ref path } => crate::mesh::obj::load_obj(&origin.dir.join(path)),
    }
}

/// The collision body of a collider; a mesh collider's file is read and checked here.
fn body(collider: &Collider, origin: &Origin) -> Result<Body, String> {
    let motion = |m: &Motion| collision::Motion {
        velocity: DVec3::from(m.velocity),
        amplitude: DVec3::from(m.amplitude),
        frequency: m.frequency,
        spin: DVec3::from(m.spin),
    };
    Ok(match collider {
        Collider::Sphere { center, radius, motion: m, mass } => {
            Body { mass: *mass, ..Body::scripted(Shape::Sphere { radius: *radius }, DVec3::from(*center), motion(m)) }
        }
        Collider::Box { center, half_extents, rotate_deg, motion: m, mass } => {
            let [rx, ry, rz] = rotate_deg.map(f64::to_radians);
            Body {
                orientation: DQuat::from_euler(EulerRot::XYZ, rx, ry, rz),
                mass: *mass,
                ..Body::scripted(Shape::Cuboid { half: DVec3::from(*half_extents) }, DVec3::from(*center), motion(m))
            }
        }
        Collider::Plane { point, normal, motion: m } => {
            Body::scripted(Shape::Plane { normal: DVec3::from(*normal).normalize() }, DVec3::from(*point), motion(m))
        }
        Collider::Mesh { path, scale, translate, motion: m } => {
            let file = origin.dir.join(path);
            let mesh = crate::mesh::obj::load_obj(&file)
                .and_then(|mesh| mesh.transformed(|x| x * *scale))
                .map_err(|e| e.to_string())?;
            let distance = MeshDistance::new(&mesh).map_err(|e| format!("{}: {e}", file.display()))?;
            Body::scripted(Shape::Mesh(Box::new(distance)), DVec3::from(*translate), motion(m))
        }
    })
}

/// The rotation by `deg` about x, then y, then z in the body frame (glam's `EulerRot::XYZ`), exact for
/// right angles: a mesh turned by 90° lies exactly in its new plane, not 6e-17 out of it (which a
/// hanging sheet's buckling would otherwise grow into a visible, asymmetric fold).
fn rotation(deg: [f64; 3]) -> DMat3 {
    let cos_sin = |d: f64| {
        if d.rem_euclid(90.0) == 0.0 {
            [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][(d.rem_euclid(360.0) / 90.0) as usize]
        } else {
            let r = d.to_radians();
            (r.cos(), r.sin())
        }
    };
    let [(cx, sx), (cy, sy), (cz, sz)] = deg.map(cos_sin);
    let rx = DMat3::from_cols(DVec3::X, DVec3::new(0.0, cx, sx), DVec3::new(0.0, -sx, cx));
    let ry = DMat3::from_cols(DVec3::new(cy, 0.0, -sy), DVec3::Y, DVec3::new(sy, 0.0, cy));
    let rz = DMat3::from_cols(DVec3::new(cz, sz, 0.0), DVec3::new(-sz, cz, 0.0), DVec3::Z);
    rx * ry * rz
}

fn place(mesh: &TriMesh, p: &Placement) -> Result<TriMesh, MeshError> {
    if *p == Placement::default() {
        return Ok(mesh.clone());
    }
    let q = rotation(p.rotate_deg);
    let t = DVec3::from(p.translate);
    let placed: Vec<DVec3> = mesh.positions().iter().map(|&x| q * (x * p.scale) + t).collect();
    if p.copies <= 1 {
        return mesh.with_positions(placed);
    }
    let n = placed.len();
    crate::mesh::generate::vertex_budget("placement.copies", n.checked_mul(p.copies))?;
    let shift = DVec3::from(p.copy_offset);
    let positions = (0..p.copies).flat_map(|k| placed.iter().map(move |&x| x + shift * k as f64)).collect();
    let triangles = (0..p.copies).flat_map(|k| mesh.triangles().iter().map(move |t| t.map(|i| i + k * n))).collect();
    TriMesh::new(positions, triangles)
}

/// The vertices of every connected component each selection touches, or (which selection, why) not.
fn parts(mesh: &TriMesh, selections: &[&Selection]) -> Result<Vec<Vec<usize>>, (usize, String)> {
    let (component, _) = mesh.components();
    let mut owner: Vec<Option<usize>> = vec![None; mesh.vertex_count()];
    let mut parts = Vec::with_capacity(selections.len());
    for (i, s) in selections.iter().enumerate() {
        let picked = select(mesh, s).map_err(|r| (i, r))?;
        let mut touched: Vec<usize> = picked.iter().map(|&v| component[v]).collect();
        touched.sort_unstable();
        touched.dedup();
        let vertices: Vec<usize> =
            (0..mesh.vertex_count()).filter(|&v| touched.binary_search(&component[v]).is_ok()).collect();
        if let Some(j) = vertices.iter().find_map(|&v| owner[v]) {
            return Err((i, format!("shares a connected component with parts[{j}]")));
        }
        vertices.iter().for_each(|&v| owner[v] = Some(i));
        parts.push(vertices);
    }
    Ok(parts)
}

/// The vertices a selection picks, or why it picks none.
fn select(mesh: &TriMesh, s: &Selection) -> Result<Vec<usize>, String> {
    let n = mesh.vertex_count();
    let picked: Vec<usize> = match (&s.aabb, &s.indices) {
        (Some(b), _) => {
            let (lo, hi) = (DVec3::from(b.min), DVec3::from(b.max));
            (0..n).filter(|&i| mesh.positions()[i].cmpge(lo).all() && mesh.positions()[i].cmple(hi).all()).collect()
        }
        (None, Some(idx)) => {
            if let Some(&bad) = idx.iter().find(|&&i| i >= n) {
                return Err(format!("vertex {bad} does not exist (the mesh has {n})"));
            }
            idx.clone()
        }
        (None, None) => Vec::new(),
    };
    if picked.is_empty() {
        return Err("selects no vertex".into());
    }
    Ok(picked)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotations_match_glam_and_are_exact_at_right_angles() {
        for deg in [[90.0, 0.0, 0.0], [30.0, -45.0, 120.0], [84.0, 10.0, 0.0], [-90.0, 180.0, 270.0]] {
            let [rx, ry, rz] = deg.map(f64::to_radians);
            let want = DMat3::from_quat(DQuat::from_euler(EulerRot::XYZ, rx, ry, rz));
            assert!(rotation(deg).abs_diff_eq(want, 1e-15), "{deg:?}");
        }
        let turned = rotation([90.0, 0.0, 0.0]) * DVec3::new(0.3, 0.0, 0.7);
        assert_eq!(turned, DVec3::new(0.3, -0.7, 0.0), "exactly in the xy plane");
    }
}
