//! The interactive viewer: simulation thread and hand-off (UI-independent), window, panel, picking.

pub mod gestures;
pub mod ghost;
pub mod gizmo;
pub mod loader;
pub mod orbit;
pub mod panel;
pub mod readout;
pub mod scene_view;
pub mod sim_thread;
pub mod soak;
pub mod surface;
pub mod viewer;
