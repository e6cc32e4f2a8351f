//! Drag (manipulation) constraints: position and orientation targets on single vertices.

use glam::DVec3;

use super::SolverError;

/// Handle of a drag constraint, stable until it is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DragId(pub u64);

/// What a drag pins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DragKind {
    /// The vertex follows a target point (world coordinates, metres).
    Position(DVec3),
    /// The vertex's rotation follows a target rotation vector (axis × angle, radians, relative to rest).
    Orientation(DVec3),
}

/// One drag constraint on one vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drag {
    /// The constrained vertex.
    pub vertex: usize,
    /// Its target.
    pub kind: DragKind,
}

/// The drag constraints of one solver: validated on entry, with a revision counter so a solver can
/// rebuild cached constraint systems only when something changed.
#[derive(Debug, Clone, Default)]
pub struct DragSet {
    drags: Vec<(DragId, Drag)>,
    next_id: u64,
    revision: u64,
    vertex_count: usize,
    orientation_supported: bool,
}

impl DragSet {
    /// An empty set for a mesh of `vertex_count` vertices.
    pub fn new(vertex_count: usize, orientation_supported: bool) -> Self {
        Self { vertex_count, orientation_supported, ..Self::default() }
    }

    fn check(&self, drag: &Drag) -> Result<(), SolverError> {
        if drag.vertex >= self.vertex_count {
            return Err(SolverError::BadDrag(format!(
                "vertex {} does not exist (mesh has {})",
                drag.vertex, self.vertex_count
            )));
        }
        match drag.kind {
            DragKind::Position(p) | DragKind::Orientation(p) if !p.is_finite() => {
                Err(SolverError::BadDrag("target is not finite".into()))
            }
            DragKind::Orientation(_) if !self.orientation_supported => {
                Err(SolverError::BadDrag("this method has no orientation constraints".into()))
            }
            _ => Ok(()),
        }
    }

    /// Add a constraint; returns its handle.
    pub fn add(&mut self, drag: Drag) -> Result<DragId, SolverError> {
        self.check(&drag)?;
        let id = DragId(self.next_id);
        self.next_id += 1;
        self.drags.push((id, drag));
        self.revision += 1;
        Ok(id)
    }

    /// Add a constraint under a caller-chosen handle (for callers that must name it before it exists,
    /// like a UI talking to another thread). Fails if the handle is taken.
    pub fn insert(&mut self, id: DragId, drag: Drag) -> Result<(), SolverError> {
        self.check(&drag)?;
        if self.index_of(id).is_ok() {
            return Err(SolverError::BadDrag(format!("drag id {} is already in use", id.0)));
        }
        self.next_id = self.next_id.max(id.0 + 1);
        self.drags.push((id, drag));
        self.revision += 1;
        Ok(())
    }

    /// Move an existing constraint's target (its kind must stay the same).
    pub fn retarget(&mut self, id: DragId, kind: DragKind) -> Result<(), SolverError> {
        let idx = self.index_of(id)?;
        let drag = Drag { vertex: self.drags[idx].1.vertex, kind };
        if std::mem::discriminant(&drag.kind) != std::mem::discriminant(&self.drags[idx].1.kind) {
            return Err(SolverError::BadDrag("cannot change a drag's kind; remove it and add another".into()));
        }
        self.check(&drag)?;
        self.drags[idx].1 = drag;
        self.revision += 1;
        Ok(())
    }

    /// Remove a constraint.
    pub fn remove(&mut self, id: DragId) -> Result<Drag, SolverError> {
        let idx = self.index_of(id)?;
        self.revision += 1;
        Ok(self.drags.remove(idx).1)
    }

    /// Remove every constraint.
    pub fn clear(&mut self) {
        self.drags.clear();
        self.revision += 1;
    }

    /// The constraints in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = &(DragId, Drag)> {
        self.drags.iter()
    }

    /// Number of constraints.
    pub fn len(&self) -> usize {
        self.drags.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.drags.is_empty()
    }

    /// Incremented on every change.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    fn index_of(&self, id: DragId) -> Result<usize, SolverError> {
        self.drags
            .iter()
            .position(|(i, _)| *i == id)
            .ok_or_else(|| SolverError::BadDrag(format!("no drag with id {}", id.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn add_move_remove_with_validation() {
        let mut set = DragSet::new(3, false);
        let a = set.add(Drag { vertex: 1, kind: DragKind::Position(DVec3::ONE) }).unwrap();
        assert!(set.add(Drag { vertex: 3, kind: DragKind::Position(DVec3::ONE) }).is_err());
        assert!(set.add(Drag { vertex: 0, kind: DragKind::Position(DVec3::NAN) }).is_err());
        assert!(set.add(Drag { vertex: 0, kind: DragKind::Orientation(DVec3::X) }).is_err());
        let r = set.revision();
        set.retarget(a, DragKind::Position(DVec3::ZERO)).unwrap();
        assert!(set.revision() > r);
        assert!(set.retarget(a, DragKind::Orientation(DVec3::X)).is_err());
        assert_eq!(set.iter().next().unwrap().1.kind, DragKind::Position(DVec3::ZERO));
        set.remove(a).unwrap();
        assert!(set.is_empty());
        set.insert(DragId(10), Drag { vertex: 2, kind: DragKind::Position(DVec3::ONE) }).unwrap();
        assert!(set.insert(DragId(10), Drag { vertex: 2, kind: DragKind::Position(DVec3::ONE) }).is_err());
        assert_eq!(set.add(Drag { vertex: 0, kind: DragKind::Position(DVec3::ONE) }).unwrap(), DragId(11));
        assert!(set.remove(a).is_err());
    }
}
