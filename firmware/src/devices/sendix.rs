//! Kübler Sendix M5868 multi-turn encoder: CiA 406 class C2 with LSS (seed 002).
//!
//! Defined by `eds/sendix.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/sendix.md`.
//!
//! With nothing stored through LSS or 0x2101 the encoder starts as node 0x3F
//! at 250 kbit/s, as the manual's examples assume.

/// The object dictionary generated from `eds/sendix.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/sendix.rs"));
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
    name: "sendix",
    description: "Kübler Sendix M5868 multi-turn encoder: CiA 406 class C2 with LSS (seed 002).",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x3F,
    startup: Some(startup),
};

/// Node-id 0x3F and 250 kbit/s: what the encoder uses when nothing is stored.
const FACTORY: (u8, u8) = (0x3F, 3);

/// The node-id and bit rate (CiA 305 table index) the encoder starts with
/// when LSS stored no configuration (the node applies an LSS store itself):
/// 0x2101 and 0x2100 from the stored parameters, where 0xFF means "not
/// set" and 0x2100 counts down (8 − table index, manual §5.2.3), else the
/// factory 0x3F at 250 kbit/s. Decision D24 in docs/devices/sendix.md.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, u8) {
    use canopen_core::od::ObjectDictionary;
    use canopen_core::services::store::{self, Part};
    let mut ram = od::Ram::new(FACTORY.0);
    store::load(&od::DICTIONARY, ram.image_mut(), FACTORY.0, storage, Part::Application);
    let node_id = match ram.node_address() {
        id @ 1..=127 => id,
        _ => FACTORY.0,
    };
    let bit_rate = match ram.baud_rate() {
        code @ 0..=8 => 8 - code,
        _ => FACTORY.1,
    };
    (node_id, bit_rate)
}
