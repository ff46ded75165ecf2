//! The device: its dictionary (generated from `device.eds` by `build.rs`)
//! running the CiA 406 encoder profile of canopen-core, on a simulated
//! shaft until your board reads a real sensor.
//!
//! The profile owns the CiA 406 objects: the position 0x6004 from the
//! sensor's count with the scaling of 0x6000–0x6002, the preset 0x6003,
//! speed 0x6030, work areas 0x6400–0x6402, alarms 0x6503 and warnings 0x6505
//! with their EMCY, and the cyclic timer 0x6200 as TPDO1's event timer. A
//! real sensor implements `cia406::PositionSource` (a quadrature counter:
//! `cia406::QuadratureCounter`). Your own rules go around the calls into
//! the profile, as in `sendix.rs` of canopen-firmware.

/// The object dictionary generated from `device.eds`.
#[allow(missing_docs, dead_code, clippy::all)]
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/od.rs"));
}

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx, NmtEvent, Source};
use canopen_core::profiles::cia406::diag::{ErrorEmcy, FaultAlarm};
use canopen_core::profiles::cia406::{self, Config, Encoder, SensorFault, SimulatedShaft};
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::emcy::EmcyCode;

/// Sensor steps per revolution (the EDS's 0x6501).
const RESOLUTION: u32 = 4096;
/// Revolutions the sensor's turn counter distinguishes (the EDS's 0x6502; 0: 2^64 steps in all).
const TURNS: u32 = 0;

/// The shaft: 30 min⁻¹ clockwise, ±2 steps of noise, the sensor's whole range.
pub type Shaft = SimulatedShaft<{ (RESOLUTION / 2) as i32 }, 2, RESOLUTION, TURNS>;

/// The device's state: the profile on its sensor. `const` and all zero
/// bits, so the node lies in `.bss`.
#[derive(Debug, Default)]
pub struct App {
    /// The CiA 406 profile and its sensor.
    pub encoder: Encoder<Shaft>,
}

impl App {
    /// The state at power-on.
    pub const NEW: App = App { encoder: Encoder::new(SimulatedShaft::NEW) };
}

/// 0x6200 Cyclic timer (CiA 406): one value with TPDO1's event timer 0x1800:05.
const CYCLIC_TIMER: u16 = 0x6200;

/// What the encoder fixes that no object holds.
const PROFILE: Config = Config {
    // 0x6000 bits: code sequence (0) and scaling (2).
    operating_mask: 0x0005,
    // Speed in rpm only.
    speed_format_bit: 0,
    update: Duration::from_millis(2),
    overspeed_rpm: 0,
    // CiA 406: a position error is 0x6503 bit 0 with EMCY 0x1000 (generic), a
    // sensor that does not answer 0x6503 bit 15 with EMCY 0xFF00 (device specific).
    faults: &[
        FaultAlarm {
            fault: SensorFault::Position,
            mask: cia406::ALARM_POSITION,
            emcy: ErrorEmcy { code: EmcyCode::GENERIC, register: 0, info: [0; 5] },
        },
        FaultAlarm { fault: SensorFault::Sync, mask: cia406::ALARM_DEVICE, emcy: ErrorEmcy { code: EmcyCode(0xFF00), register: 0, info: [0; 5] } },
    ],
    warnings: &[],
    storage_fault: None,
    operating_time_saved_every: 0,
};

impl Application for App {
    /// Scaling (MUR ≤ TMR) and preset range checks.
    fn check_write(&mut self, ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.encoder.check_write(ctx, &PROFILE, index, sub, data)
    }

    /// A profile object written: the position follows; 0x6200 and 0x1800:05 stay one value.
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        match (index, sub) {
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
            _ => self.encoder.written(ctx, &PROFILE, index, sub),
        }
    }

    /// The position at a SYNC, before the synchronous TPDOs are built.
    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.encoder.sample(ctx, &PROFILE);
    }

    /// The sensor every 2 ms.
    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        self.encoder.poll(ctx, &PROFILE)
    }

    /// Reset application: the position from the absolute count and the stored preset offset.
    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.encoder.reset(ctx, &PROFILE);
        }
    }
}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device, as the image uses it.
pub const DEVICE: canopen_firmware::devices::Device = canopen_firmware::devices::Device {
    name: "canopen-template",
    description: "A CiA 406 encoder on canopen-firmware",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x10,
    startup: None,
};
