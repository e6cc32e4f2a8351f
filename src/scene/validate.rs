//! Value checks that serde's typing cannot express, for what no method owns: the mesh, placement,
//! selections, tracks and skeleton, colliders, the accuracy targets and the camera. Each failure
//! names its dotted key. The material's and the solver's numbers are the methods' parameters: each
//! method checks the values it reads against its own parameter table when it is built
//! (`solver::params::check_scene`), with the same kind of message.

use super::schema::{Collider, MeshSource, Scene};
use super::script::{Key, Skeleton, Track};
use super::selection::Selection;

/// A failed check: the dotted key and the reason.
pub(crate) type Invalid = (String, String);

fn finite(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() { Ok(()) } else { Err((key.into(), "must be a finite number".into())) }
}

fn positive(key: &str, v: f64) -> Result<(), Invalid> {
    finite(key, v)?;
    if v > 0.0 { Ok(()) } else { Err((key.into(), format!("must be positive, got {v}"))) }
}

fn non_negative(key: &str, v: f64) -> Result<(), Invalid> {
    finite(key, v)?;
    if v >= 0.0 { Ok(()) } else { Err((key.into(), format!("must not be negative, got {v}"))) }
}

/// A target relative error: in (0, 1].
fn accuracy(key: &str, a: f64) -> Result<(), Invalid> {
    if a > 0.0 && a <= 1.0 { Ok(()) } else { Err((key.into(), format!("must be a relative error in (0, 1], got {a}"))) }
}

fn vec3(key: &str, v: [f64; 3]) -> Result<(), Invalid> {
    v.iter().try_for_each(|&x| finite(key, x))
}

fn at_least(key: &str, v: usize, min: usize) -> Result<(), Invalid> {
    if v >= min { Ok(()) } else { Err((key.into(), format!("must be at least {min}, got {v}"))) }
}

fn selection(key: &str, s: &Selection) -> Result<(), Invalid> {
    match (&s.aabb, &s.indices) {
        (Some(b), None) => {
            vec3(&format!("{key}.box.min"), b.min)?;
            vec3(&format!("{key}.box.max"), b.max)?;
            if (0..3).any(|k| b.min[k] > b.max[k]) {
                return Err((format!("{key}.box"), "min must not exceed max on any axis".into()));
            }
            Ok(())
        }
        (None, Some(i)) if !i.is_empty() => Ok(()),
        (None, Some(_)) => Err((format!("{key}.indices"), "is empty".into())),
        _ => Err((key.into(), "give exactly one of `box` or `indices`".into())),
    }
}

fn mesh(m: &MeshSource) -> Result<(), Invalid> {
    match m {
        MeshSource::Grid { size, segments } => {
            size.iter().try_for_each(|&s| positive("mesh.size", s))?;
            segments.iter().try_for_each(|&s| at_least("mesh.segments", s, 1))
        }
        MeshSource::DelaunaySheet { size, edge } => {
            size.iter().try_for_each(|&s| positive("mesh.size", s))?;
            positive("mesh.edge", *edge)?;
            if size.iter().any(|&s| s / edge > 2000.0) {
                return Err(("mesh.edge".into(), "too small for the sheet: over 2000 edges per side".into()));
            }
            Ok(())
        }
        MeshSource::VBeam { length, width, angle_deg, segments } => {
            positive("mesh.length", *length)?;
            positive("mesh.width", *width)?;
            finite("mesh.angle_deg", *angle_deg)?;
            if !(10.0..=180.0).contains(angle_deg) {
                return Err(("mesh.angle_deg".into(), format!("must be in [10, 180], got {angle_deg}")));
            }
            at_least("mesh.segments", segments[0], 1)?;
            at_least("mesh.segments", segments[1], 2)?;
            if segments[1] % 2 != 0 {
                return Err(("mesh.segments".into(), "cells across must be even (the crease is a vertex row)".into()));
            }
            Ok(())
        }
        MeshSource::Icosphere { radius, frequency } => {
            positive("mesh.radius", *radius)?;
            at_least("mesh.frequency", *frequency, 1)
        }
        MeshSource::UvSphere { radius, rings, sectors } => {
            positive("mesh.radius", *radius)?;
            at_least("mesh.rings", *rings, 2)?;
            at_least("mesh.sectors", *sectors, 3)
        }
        MeshSource::Creature { length, frequency } => {
            positive("mesh.length", *length)?;
            at_least("mesh.frequency", *frequency, 2)
        }
        MeshSource::Dancer { height, around } => {
            positive("mesh.height", *height)?;
            at_least("mesh.around", *around, 3)
        }
        MeshSource::Obj { path } if path.is_empty() => Err(("mesh.path".into(), "is empty".into())),
        MeshSource::Obj { .. } => Ok(()),
    }
}

/// Every value fits TOML's types (its whole numbers are 64-bit signed), so that every key can be read
/// back ([`Scene::numbers`]): the first whole number that does not, by its key.
fn representable(scene: &Scene) -> Result<(), Invalid> {
    if toml::Value::try_from(scene).is_ok() {
        return Ok(());
    }
    let unwritable = || (String::new(), "the scene cannot be written back as TOML".to_string());
    let tree = serde_json::to_value(scene).map_err(|_| unwritable())?;
    Err(too_large(&tree, String::new()).unwrap_or_else(unwritable))
}

/// The first whole number past `i64::MAX` in `value` (at `key`), with the reason.
fn too_large(value: &serde_json::Value, key: String) -> Option<Invalid> {
    use serde_json::Value;
    match value {
        Value::Number(n) if n.is_u64() && n.as_i64().is_none() => {
            Some((key, format!("{n} is larger than the largest whole number, 2^63 − 1")))
        }
        Value::Array(items) => items.iter().enumerate().find_map(|(i, v)| too_large(v, format!("{key}[{i}]"))),
        Value::Object(fields) => {
            fields.iter().find_map(|(k, v)| too_large(v, if key.is_empty() { k.clone() } else { format!("{key}.{k}") }))
        }
        _ => None,
    }
}

impl Scene {
    /// Check every value; the error names the first offending key.
    pub(crate) fn validate(&self) -> Result<(), Invalid> {
        representable(self)?;
        mesh(&self.mesh)?;
        positive("placement.scale", self.placement.scale)?;
        vec3("placement.rotate_deg", self.placement.rotate_deg)?;
        vec3("placement.translate", self.placement.translate)?;
        at_least("placement.copies", self.placement.copies, 1)?;
        vec3("placement.copy_offset", self.placement.copy_offset)?;
        script(&self.tracks, &self.skeleton)?;
        for (i, p) in self.parts.iter().enumerate() {
            let key = |k: &str| format!("parts[{i}].{k}");
            selection(&key("select"), &p.select)?;
            if p.method.as_deref() == Some("") {
                return Err((key("method"), "is empty".into()));
            }
            if let Some(a) = p.accuracy {
                accuracy(&key("accuracy"), a)?;
            }
        }
        for (i, a) in self.anchors.iter().enumerate() {
            selection(&format!("anchors[{i}]"), a)?;
        }
        vec3("gravity", self.gravity)?;
        for (i, l) in self.loads.iter().enumerate() {
            selection(&format!("loads[{i}].select"), &l.select)?;
            vec3(&format!("loads[{i}].force"), l.force)?;
        }
        for (i, c) in self.colliders.iter().enumerate() {
            let key = |k: &str| format!("colliders[{i}].{k}");
            let motion = match c {
                Collider::Sphere { center, radius, motion, mass } => {
                    vec3(&key("center"), *center)?;
                    positive(&key("radius"), *radius)?;
                    if let Some(m) = mass {
                        positive(&key("mass"), *m)?;
                    }
                    motion
                }
                Collider::Box { center, half_extents, rotate_deg, motion, mass } => {
                    vec3(&key("center"), *center)?;
                    half_extents.iter().try_for_each(|&h| positive(&key("half_extents"), h))?;
                    vec3(&key("rotate_deg"), *rotate_deg)?;
                    if let Some(m) = mass {
                        positive(&key("mass"), *m)?;
                    }
                    motion
                }
                Collider::Plane { point, normal, motion } => {
                    vec3(&key("point"), *point)?;
                    vec3(&key("normal"), *normal)?;
                    if normal.iter().all(|&x| x == 0.0) {
                        return Err((key("normal"), "must not be zero".into()));
                    }
                    motion
                }
                Collider::Mesh { path, scale, translate, motion } => {
                    if path.is_empty() {
                        return Err((key("path"), "is empty".into()));
                    }
                    positive(&key("scale"), *scale)?;
                    vec3(&key("translate"), *translate)?;
                    motion
                }
            };
            vec3(&key("motion.velocity"), motion.velocity)?;
            vec3(&key("motion.amplitude"), motion.amplitude)?;
            non_negative(&key("motion.frequency"), motion.frequency)?;
            vec3(&key("motion.spin"), motion.spin)?;
        }
        let s = &self.solver;
        match s.accuracy {
            Some(a) => accuracy("solver.accuracy", a)?,
            None if s.method.is_empty() => {
                return Err(("solver.method".into(), "is required unless solver.accuracy is given".into()));
            }
            None => {}
        }
        vec3("camera.eye", self.camera.eye)?;
        vec3("camera.target", self.camera.target)?;
        if !(1.0..=170.0).contains(&self.camera.fov_deg) {
            return Err(("camera.fov_deg".into(), format!("must be in [1, 170], got {}", self.camera.fov_deg)));
        }
        Ok(())
    }
}

/// Keys in strictly increasing, non-negative, finite time, each giving the same fields as the first
/// (a position, a rotation or both; only a rotation when `rotation_only`).
fn keys(key: &str, keys: &[Key], rotation_only: bool) -> Result<(), Invalid> {
    let mut last = f64::NEG_INFINITY;
    for (i, k) in keys.iter().enumerate() {
        let key = format!("{key}[{i}]");
        non_negative(&format!("{key}.time"), k.time)?;
        if k.time <= last {
            return Err((format!("{key}.time"), format!("must come after the previous key's {last} s")));
        }
        last = k.time;
        if let Some(p) = k.position {
            vec3(&format!("{key}.position"), p)?;
        }
        if let Some(r) = k.rotation {
            vec3(&format!("{key}.rotation"), r)?;
        }
        if rotation_only && k.position.is_some() {
            return Err((format!("{key}.position"), "a joint key gives only a rotation".into()));
        }
        if k.position.is_none() && k.rotation.is_none() {
            return Err((key, "give a position, a rotation or both".into()));
        }
        let first = &keys[0];
        if (k.position.is_some(), k.rotation.is_some()) != (first.position.is_some(), first.rotation.is_some()) {
            return Err((key, "every key of a track gives the same fields as its first".into()));
        }
    }
    Ok(())
}

fn script(tracks: &[Track], skeleton: &Skeleton) -> Result<(), Invalid> {
    let mut names: Vec<&str> = Vec::new();
    for (i, j) in skeleton.joints.iter().enumerate() {
        let key = format!("skeleton.joints[{i}]");
        if j.name.is_empty() || names.contains(&j.name.as_str()) {
            return Err((format!("{key}.name"), format!("`{}` is empty or used twice", j.name)));
        }
        if let Some(p) = &j.parent
            && !names.contains(&p.as_str())
        {
            return Err((format!("{key}.parent"), format!("no joint `{p}` before this one")));
        }
        vec3(&format!("{key}.offset"), j.offset)?;
        keys(&format!("{key}.keys"), &j.keys, true)?;
        names.push(&j.name);
    }
    for (i, t) in tracks.iter().enumerate() {
        let key = format!("tracks[{i}]");
        selection(&format!("{key}.select"), &t.select)?;
        if let Some(p) = t.pivot {
            vec3(&format!("{key}.pivot"), p)?;
        }
        match (&t.joint, t.keys.is_empty()) {
            (Some(j), true) if names.contains(&j.as_str()) => {}
            (Some(j), true) => return Err((format!("{key}.joint"), format!("no skeleton joint `{j}`"))),
            (None, false) => keys(&format!("{key}.keys"), &t.keys, false)?,
            _ => return Err((key, "give exactly one of `keys` or `joint`".into())),
        }
    }
    Ok(())
}
