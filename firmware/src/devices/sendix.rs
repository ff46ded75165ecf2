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

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx, ServiceOptions, Source};
use canopen_core::services::store;

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary.
#[derive(Debug, Default)]
pub struct App;

impl App {
    /// The state at power-on: `const` and all zero bits, so the node stays in `.bss`.
    pub const NEW: App = App;
}

impl Application for App {
    /// §5.2.3, D5: 0x2100–0x2102 become permanent only through 0x2105.
    const OPTIONS: ServiceOptions = ServiceOptions { not_saved_by_1010: Some((BAUD_RATE, TERMINATION)), ..ServiceOptions::CIA301 };

    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, sub, data) {
            // 100 kbit/s (code 3) has no CiA 305 bit timing: refused (D24).
            (BAUD_RATE, 0, [code]) if bit_rate_index(*code).is_none() && *code != NOT_SET => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        match (index, sub) {
            // D11: 0x6200 cyclic timer and TPDO1's event timer are one value, both ways.
            (CYCLIC_TIMER, 0) => {
                if let Ok(&[a, b]) = ctx.read(CYCLIC_TIMER, 0) {
                    let _ = ctx.write_object(0x1800, 5, &[a, b]);
                }
            }
            (0x1800, 5) => {
                if let Ok(&[a, b]) = ctx.read(0x1800, 5) {
                    let _ = ctx.write_object(CYCLIC_TIMER, 0, &[a, b]);
                }
            }
            _ => {}
        }
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        // Stores the device triggers; a failed store fails the write.
        match (index, sub) {
            // D17: the preset is stored when written.
            (PRESET, 0) => Some(ctx.write_object(PRESET, 0, data).and_then(|()| ctx.save_objects(PRESET, PRESET))),
            // §5.2.3: "save" to 0x2105 stores the bus parameters; anything else is refused.
            (SAVE_BUS, 0) if data != store::SAVE.to_le_bytes() => Some(Err(AbortCode::CannotStore)),
            (SAVE_BUS, 0) => Some(ctx.write_object(SAVE_BUS, 0, data).and_then(|()| ctx.save_objects(BAUD_RATE, TERMINATION))),
            _ => None,
        }
    }

    fn rpdo_written(&mut self, _ctx: &mut Ctx<'_>, _n: u8) {
        // No rule of this device reacts to an object an RPDO writes.
    }
}

/// 0x6200 Cyclic timer (CiA 406), in ms.
const CYCLIC_TIMER: u16 = 0x6200;
/// 0x6003 Preset value.
const PRESET: u16 = 0x6003;
/// 0x2100 Baud rate, 0x2101 node address, 0x2102 bus termination.
const BAUD_RATE: u16 = 0x2100;
const NODE_ADDRESS: u16 = 0x2101;
const TERMINATION: u16 = 0x2102;
/// 0x2105 Save all bus parameters.
const SAVE_BUS: u16 = 0x2105;
/// 0x2100/0x2101 "not set".
const NOT_SET: u8 = 0xFF;

/// The CiA 305 bit-timing index of a 0x2100 code (§5.2.3 counts down from
/// 8 = 1 Mbit/s; 3 = 100 kbit/s has no CiA 305 entry).
fn bit_rate_index(code: u8) -> Option<u8> {
    match code {
        0..=2 | 4..=8 => Some(8 - code),
        _ => None,
    }
}

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
/// factory 0x3F at 250 kbit/s; no stored value gives a rate the boards
/// have no timing for. Decision D24 in docs/devices/sendix.md.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, Option<u8>) {
    let mut byte = [NOT_SET];
    let mut stored = |index| match store::stored_value(&od::DICTIONARY, storage, FACTORY.0, index, 0, &mut byte) {
        Some(1) => byte[0],
        _ => NOT_SET,
    };
    let node_id = match stored(NODE_ADDRESS) {
        id @ 1..=127 => id,
        _ => FACTORY.0,
    };
    // A code without CiA 305 timing (3, or any stored by an older image) starts at the factory rate.
    let bit_rate = bit_rate_index(stored(BAUD_RATE)).unwrap_or(FACTORY.1);
    (node_id, Some(bit_rate))
}
