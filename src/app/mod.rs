//! The interactive viewer: simulation thread and hand-off (UI-independent), window, panel, picking.

pub mod sim_thread;
