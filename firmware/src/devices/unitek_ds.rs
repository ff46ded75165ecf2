//! UNITEK DS servo: its own REGID register protocol, with the register table described as manufacturer objects (seed 001).
//!
//! Defined by `eds/unitek-ds.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/unitek-ds.md`.
//!
//! The register protocol uses fixed CAN identifiers and has no node-id; the
//! default node-id only matters to the CiA 301 services this image also offers.

/// The object dictionary generated from `eds/unitek-ds.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/unitek_ds.rs"));
}

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary.
#[derive(Debug, Default)]
pub struct App;

impl App {
    /// The state at power-on: `const` and all zero bits, so the node stays in `.bss`.
    pub const NEW: App = App;
}

impl canopen_core::node::Application for App {
    fn rpdo_written(&mut self, _ctx: &mut canopen_core::node::Ctx<'_>, _n: u8) {
        // No rule of this device reacts to an object an RPDO writes.
    }
}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "unitek-ds",
    description: "UNITEK DS servo: its own REGID register protocol, with the register table described as manufacturer objects (seed 001).",
    dictionary: &od::DICTIONARY,
    default_node_id: 1,
    startup: None,
};
