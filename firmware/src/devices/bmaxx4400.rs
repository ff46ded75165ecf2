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

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx, ServiceOptions};

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary.
#[derive(Debug, Default)]
pub struct App;

impl App {
    /// The state at power-on: `const` and all zero bits, so the node stays in `.bss`.
    pub const NEW: App = App;
}

impl Application for App {
    /// §5.5.3 (D27): mapping entries and COB-IDs are rewritten while the PDO
    /// is valid, in Pre-operational; §5.5.2 (D26): type 254 is time-triggered.
    const OPTIONS: ServiceOptions = ServiceOptions { pdo_rewrite_while_valid: true, tpdo_254_timer_only: true, ..ServiceOptions::CIA301 };

    fn download_check(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        // D9: masters following the manual write 0x1017 with one byte (2F).
        ((index, sub, size) == (HEARTBEAT_TIME, 0, Some(1))).then_some(Ok(()))
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        match (index, sub, data) {
            (HEARTBEAT_TIME, 0, [ms]) => Some(ctx.write_object(HEARTBEAT_TIME, 0, &[*ms, 0])),
            _ => None,
        }
    }

    fn rpdo_written(&mut self, _ctx: &mut Ctx<'_>, _n: u8) {
        // No rule of this device reacts to an object an RPDO writes.
    }
}

/// 0x1017 Producer heartbeat time.
const HEARTBEAT_TIME: u16 = 0x1017;

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
