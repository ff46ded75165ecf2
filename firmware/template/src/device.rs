//! The device: its dictionary (generated from `device.eds` by `build.rs`)
//! and its own rules, the hooks of the node (`Application`). Each hook has a
//! default; this one shows a validation rule, a reaction and a timer.

/// The object dictionary generated from `device.eds`.
#[allow(missing_docs, dead_code, clippy::all)]
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/od.rs"));
}

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx, Source};
use canopen_core::time::{Duration, Instant};

/// 0x1017 Producer heartbeat time, in ms.
const HEARTBEAT: u16 = 0x1017;
/// The shortest heartbeat time this device accepts (0 switches it off).
const MIN_HEARTBEAT_MS: u16 = 10;
/// How often the timer sends TPDO 1.
const PERIOD: Duration = Duration::from_millis(1000);

/// The device's state: `const`-constructible and all zero bits, so the node lies in `.bss`.
#[derive(Debug, Default)]
pub struct App {
    /// When the timer runs next (µs; 0: at the first poll).
    next_us: u64,
}

impl App {
    /// The state at power-on.
    pub const NEW: App = App { next_us: 0 };
}

impl Application for App {
    /// Validation: a heartbeat faster than 10 ms is refused (abort 0x06090030).
    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, sub, data) {
            (HEARTBEAT, 0, &[lo, hi]) if (1..MIN_HEARTBEAT_MS).contains(&u16::from_le_bytes([lo, hi])) => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    /// Reaction: a new heartbeat time is logged, whoever wrote it.
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        if (index, sub) == (HEARTBEAT, 0) {
            defmt::info!("heartbeat time now {} ms", ctx.read_u32(HEARTBEAT, 0).unwrap_or(0));
        }
    }

    /// Timer: TPDO 1 once a second (nothing happens while it is not Operational or has no mapping).
    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let now = ctx.now();
        if now.as_micros() >= self.next_us {
            let _ = ctx.trigger_tpdo(0);
            self.next_us = (now + PERIOD).as_micros();
        }
        Some(Instant::from_micros(self.next_us))
    }
}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device, as the image uses it.
pub const DEVICE: canopen_firmware::devices::Device = canopen_firmware::devices::Device {
    name: "canopen-template",
    description: "A CANopen device on canopen-firmware",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x10,
    startup: None,
};
