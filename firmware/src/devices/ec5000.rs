//! Interroll RollerDrive EC5000 BI: CiA 301 slave with the CiA 402 drive profile and LSS (seed 000).
//!
//! Defined by `eds/ec5000.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/ec5000.md`.
//!
//! An unconfigured drive starts as node 127 (the manual's fallback), so a
//! plant of drives that all ship alike is commissioned through LSS.

/// The object dictionary generated from `eds/ec5000.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/ec5000.rs"));
}

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary.
#[derive(Debug, Default)]
pub struct App;

impl App {
    /// The state at power-on: `const` and all zero bits, so the node stays in `.bss`.
    pub const NEW: App = App;
}

impl canopen_core::node::Application for App {}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "ec5000",
    description: "Interroll RollerDrive EC5000 BI: CiA 301 slave with the CiA 402 drive profile and LSS (seed 000).",
    dictionary: &od::DICTIONARY,
    default_node_id: 127,
    startup: None,
};
