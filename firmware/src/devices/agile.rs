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

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx};
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
    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, sub, data) {
            // D6: the communication cycle period in whole milliseconds only.
            (0x1006, 0, [a, b, c, d]) if u32::from_le_bytes([*a, *b, *c, *d]) % 1000 != 0 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn download_check(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        let len = data_sets(ctx, index, sub)?;
        Some(match size {
            Some(n) if n > len => Err(AbortCode::LengthTooHigh),
            Some(n) if n < len => Err(AbortCode::LengthTooLow),
            _ => Ok(()),
        })
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        data_sets(ctx, index, sub)?;
        // D25, §9.3.1: data set 0 writes all four data sets.
        Some((1..=4).try_for_each(|set| ctx.write_object(index, set, data)))
    }

    fn rpdo_written(&mut self, _ctx: &mut Ctx<'_>, _n: u8) {
        // No rule of this device reacts to an object an RPDO writes.
    }
}

/// The value length of a four-data-set parameter (an ARRAY whose sub 0 is
/// 9: data sets 1–4 and their RAM copies) when `sub` is 0, its "data set 0".
fn data_sets(ctx: &Ctx<'_>, index: u16, sub: u8) -> Option<usize> {
    // Sub 9 exists only in such an ARRAY (a VAR parameter has sub 0 alone, whatever its value).
    let is_parameter = (0x2000..0x3000).contains(&index) && sub == 0 && ctx.read_u32(index, 0) == Some(9) && ctx.read(index, 9).is_ok();
    is_parameter.then(|| ctx.read(index, 1).map_or(0, <[u8]>::len))
}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "agile",
    description: "Bonfiglioli Agile inverter: CiA 402 velocity mode, parameters at 0x2000 + number with the data set as sub-index (seed 004).",
    dictionary: &od::DICTIONARY,
    default_node_id: 1,
    startup: Some(startup),
};

/// The node-id the simulated inverter uses while p.387 holds its factory −1.
const DEFAULT_NODE_ID: u8 = 1;

/// The node-id and bit rate from p.387 (0x2183) and p.385 (0x2181) when the
/// stored parameters hold them. The factory p.387 = −1 means "CANopen off"
/// on the real inverter (L654–658); this image starts as node 1 instead, so
/// that it can be reached and configured (D41). p.385's codes 1–8 are 10,
/// 20, 50, 100, 125, 250, 500, 1000 kbit/s; 100 kbit/s has no CiA 305
/// timing and keeps the image's rate.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, Option<u8>) {
    let mut value = [0u8; 2];
    let mut stored = |index| store::stored_value(&od::DICTIONARY, storage, DEFAULT_NODE_ID, index, 0, &mut value).map(|_| value);
    let node_id = stored(NODE_NUMBER)
        .and_then(|v| u8::try_from(i16::from_le_bytes(v)).ok())
        .filter(|id| (1..=127).contains(id))
        .unwrap_or(DEFAULT_NODE_ID);
    let bit_rate = match stored(BAUD_RATE).map(u16::from_le_bytes) {
        Some(1) => Some(8),
        Some(2) => Some(7),
        Some(3) => Some(6),
        Some(5) => Some(4),
        Some(6) => Some(3),
        Some(7) => Some(2),
        Some(8) => Some(0),
        _ => None,
    };
    (node_id, bit_rate)
}

/// p.387 CAN node number (INTEGER16, −1…127).
const NODE_NUMBER: u16 = 0x2183;
/// p.385 CAN baud rate (UNSIGNED16, codes 1…8).
const BAUD_RATE: u16 = 0x2181;
