//! Baumüller b maXX 4400 CANopen slave option module: CiA 402 drive, drive parameters at 0x4000 + number (seed 003).
//!
//! Defined by `eds/bmaxx4400.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/bmaxx4400.md`.
//!
//! The manual leaves node-id setting to the drive's operating instructions;
//! node 1 is used until it is configured.

/// The object dictionary generated from `eds/bmaxx4400.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/bmaxx4400.rs"));
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
    name: "bmaxx4400",
    description: "Baumüller b maXX 4400 CANopen slave option module: CiA 402 drive, drive parameters at 0x4000 + number (seed 003).",
    dictionary: &od::DICTIONARY,
    default_node_id: 1,
    startup: None,
};
