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

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "sendix",
    description: "Kübler Sendix M5868 multi-turn encoder: CiA 406 class C2 with LSS (seed 002).",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x3F,
};
