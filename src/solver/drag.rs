//! Drag (manipulation) constraints: position and orientation targets on single vertices, and
//! orientation targets on a group of vertices that turns as one frame (a track's selection).

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

/// An orientation target for a group of vertices that turns as one rigid frame (a track's
/// selection): the mean of their rotations follows the target, three conditions for the whole
/// group instead of three per vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameDrag {
    /// The vertices of the group (not empty, no repeats needed).
    pub vertices: Vec<usize>,
    /// The target rotation vector (axis × angle, radians, relative to rest).
    pub rotation: DVec3,
}

/// The drag constraints of one solver: validated on entry, with a revision counter so a solver can
/// rebuild cached constraint systems only when something changed.
#[derive(Debug, Clone, Default)]
pub struct DragSet {
    drags: Vec<(DragId, Drag)>,
    frames: Vec<(DragId, FrameDrag)>,
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

    /// Whether the method takes orientation targets ([`DragKind::Orientation`] and [`FrameDrag`]).
    pub fn supports_orientation(&self) -> bool {
        self.orientation_supported
    }

    fn check_frame(&self, frame: &FrameDrag) -> Result<(), SolverError> {
        if !self.orientation_supported {
            return Err(SolverError::BadDrag("this method has no orientation constraints".into()));
        }
        if !frame.rotation.is_finite() {
            return Err(SolverError::BadDrag("target is not finite".into()));
        }
        match frame.vertices.iter().find(|&&v| v >= self.vertex_count) {
            _ if frame.vertices.is_empty() => Err(SolverError::BadDrag("a frame drag needs vertices".into())),
            Some(v) => Err(SolverError::BadDrag(format!("vertex {v} does not exist (mesh has {})", self.vertex_count))),
            None => Ok(()),
        }
    }

    /// Add a frame orientation constraint on a group of vertices; returns its handle.
    pub fn add_frame(&mut self, frame: FrameDrag) -> Result<DragId, SolverError> {
        self.check_frame(&frame)?;
        let id = self.fresh_id();
        self.frames.push((id, frame));
        Ok(id)
    }

    /// A new handle, counted as a change.
    fn fresh_id(&mut self) -> DragId {
        self.next_id += 1;
        self.revision += 1;
        DragId(self.next_id - 1)
    }

    /// Move a frame constraint's target rotation.
    pub fn retarget_frame(&mut self, id: DragId, rotation: DVec3) -> Result<(), SolverError> {
        let idx = self.frame_index(id)?;
        if !rotation.is_finite() {
            return Err(SolverError::BadDrag("target is not finite".into()));
        }
        self.frames[idx].1.rotation = rotation;
        self.revision += 1;
        Ok(())
    }

    fn frame_index(&self, id: DragId) -> Result<usize, SolverError> {
        (self.frames.iter().position(|(i, _)| *i == id))
            .ok_or_else(|| SolverError::BadDrag(format!("no frame drag with id {}", id.0)))
    }

    /// The frame constraints in insertion order.
    pub fn frames(&self) -> impl Iterator<Item = &(DragId, FrameDrag)> {
        self.frames.iter()
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
        let id = self.fresh_id();
        self.drags.push((id, drag));
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

    /// Remove a single-vertex constraint.
    pub fn remove(&mut self, id: DragId) -> Result<Drag, SolverError> {
        let idx = self.index_of(id)?;
        self.revision += 1;
        Ok(self.drags.remove(idx).1)
    }

    /// Remove a frame constraint.
    pub fn remove_frame(&mut self, id: DragId) -> Result<FrameDrag, SolverError> {
        let idx = self.frame_index(id)?;
        self.revision += 1;
        Ok(self.frames.remove(idx).1)
    }

    /// Remove every constraint.
    pub fn clear(&mut self) {
        self.drags.clear();
        self.frames.clear();
        self.revision += 1;
    }

    /// The single-vertex constraints in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = &(DragId, Drag)> {
        self.drags.iter()
    }

    /// Number of single-vertex constraints.
    pub fn len(&self) -> usize {
        self.drags.len()
    }

    /// Whether there are none (single-vertex or frame).
    pub fn is_empty(&self) -> bool {
        self.drags.is_empty() && self.frames.is_empty()
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

    #[test]
    fn frames_are_checked_retargeted_and_removed() {
        let mut set = DragSet::new(3, true);
        let frame = |vertices: Vec<usize>| FrameDrag { vertices, rotation: DVec3::X };
        assert!(set.add_frame(frame(vec![])).is_err());
        assert!(set.add_frame(frame(vec![0, 3])).is_err());
        let f = set.add_frame(frame(vec![1, 2])).unwrap();
        assert!(!set.is_empty() && set.iter().next().is_none(), "a frame, no single-vertex drag");
        assert!(set.retarget_frame(f, DVec3::NAN).is_err());
        assert_eq!(set.frames().next().unwrap().1, frame(vec![1, 2]), "a refused target changes nothing");
        set.retarget_frame(f, DVec3::Y).unwrap();
        assert_eq!(set.frames().next().unwrap().1.rotation, DVec3::Y);
        set.remove_frame(f).unwrap();
        assert!(set.is_empty());
        assert!(DragSet::new(3, false).add_frame(frame(vec![0])).is_err(), "no orientation drags");
    }
}
