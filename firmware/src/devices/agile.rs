//! Bonfiglioli Agile inverter: CiA 402 velocity mode, parameters at 0x2000 + number with the data set as sub-index (seed 004).
//!
//! Defined by `eds/agile.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/agile.md`.
//!
//! The factory setting of parameter 387 (node-id −1) switches CANopen off;
//! the simulated device starts as node 1 instead.

/// The object dictionary generated from `eds/agile.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/agile.rs"));
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
    name: "agile",
    description: "Bonfiglioli Agile inverter: CiA 402 velocity mode, parameters at 0x2000 + number with the data set as sub-index (seed 004).",
    dictionary: &od::DICTIONARY,
    default_node_id: 1,
    startup: None,
};
