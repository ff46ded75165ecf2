//! Interroll RollerDrive EC5000 BI: CiA 301 slave with the CiA 402 drive profile and LSS (seed 000).
//!
//! Defined by `eds/ec5000.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/ec5000.md`.
//!
//! An unconfigured drive starts as node 127 (the manual's fallback), so a
//! plant of drives that all ship alike is commissioned through LSS.

/// The object dictionary generated from `eds/ec5000.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/ec5000.rs"));
}

use canopen_core::abort::AbortCode;
use canopen_core::axis::AxisParams;
use canopen_core::node::{Application, CanEmcyCodes, Ctx, NmtEvent, ServiceOptions, Source};
use canopen_core::od::EntryRef;
use canopen_core::profiles::cia402::{Cia402, Config};
use canopen_core::services::store::{self, Scope};
use canopen_core::time::{Instant, earliest};
use canopen_core::wire::emcy::EmcyCode;

mod monitor;
mod roller;
mod rpdo;
use monitor::Monitor;
pub use monitor::{COLD_WARNING, DERATING, SPEED_WARNING, TEMPERATURE_WARNING};
pub use roller::{
    BLOCKED, COLD_FAULT_C, LOSS_OF_PARAMETERS, MIN_VELOCITY, OVER_CURRENT_OUTPUT, POSITION_REGULATOR, Roller, SPEED_ERROR, TOO_COLD,
};
use rpdo::FixedRpdos;

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary, and the CiA 402 profile driving the
/// axis model (until a board drives the roller's motor).
#[derive(Debug)]
pub struct App {
    /// The CiA 402 profile and the roller behind it.
    pub drive: Cia402<Roller>,
    /// The EMCY table's warnings, 0x2200 and the traffic lights (D48-D50, D53, D55).
    monitor: Monitor,
    /// The RPDOs' fixed mappings, kept at each RPDO's first frame after reset communication.
    rpdos: FixedRpdos,
}

impl App {
    /// The state at power-on: `const` and all zero bits ([`canopen_core::node`]).
    pub const NEW: App = App { drive: Cia402::new(Roller::NEW), monitor: Monitor::NEW, rpdos: FixedRpdos::NONE };
}

/// The profile's constants for the EC5000 (decisions D41-D44 in docs/devices/ec5000.md).
pub const PROFILE: Config = Config {
    // The roller's motor encoder: 4096 increments per motor revolution (D41).
    increments_per_rev: 4096,
    // D44: NMT leaving Operational is a "CAN failure" for 0x6007.
    leaving_operational_aborts: true,
    // 0x6067 and 0x606D are not in the dictionary: 1 mm and 5 mm/s (D42).
    position_window: 1,
    velocity_window: 5,
    // 0x6099 is a single 0..0 VAR: homing 37 does not move (D43).
    homing_speeds: (0, 0),
    velocity_unit: None,
};

/// The roller as the axis model simulates it: 4096 inc/rev, 3000 min⁻¹ at
/// the motor (about 436 mm/s at the roller with gear 18:1 and feed 157 mm),
/// 0.2 s from standstill to full speed, a 95 °C warning (0x4231) and a fault at 110 °C.
pub const AXIS: AxisParams = AxisParams {
    increments_per_rev: 4096,
    max_acceleration: 1_024_000,
    max_velocity: 204_800,
    position_gain: 40,
    friction_permille: 50,
    ambient_c: 25,
    rise_at_rated_c: 60,
    thermal_tau_s: 120,
    warning_c: 95,
    fault_c: 110,
    dc_link_mv: 24_000,
    following_limit: 200_000,
    limits: (0, 0),
    home_switch: None,
};

impl Application for App {
    /// 0x1010 sub 1 stores "all parameters except node-ID" (L744): only a
    /// write to 0x4650 sub 1 (or LSS) makes a node-ID permanent. At the
    /// factory node-ID 127 a node-ID configured by LSS becomes active on
    /// leaving configuration ("temporär aktiv", L219/L234).
    const OPTIONS: ServiceOptions = ServiceOptions {
        not_saved_by_1010: Some((NODE_ID, NODE_ID)),
        lss_unconfigured_node_id: Some(FACTORY_NODE_ID),
        ..ServiceOptions::CIA301
    };

    /// The manual's CAN warnings (M §9.2 L1737-1743, D63) in place of CiA 301's
    /// 0x8140, 0x8110 and 0x8120; 0xFFD3 for a broken NMT or heartbeat frame;
    /// its one PDO length code 0x8210 for an RPDO too long as well (D64).
    const CAN_EMCY: CanEmcyCodes = CanEmcyCodes {
        bus_off_recovered: EmcyCode(0xFFD0),
        overrun: EmcyCode(0xFFD1),
        error_passive: EmcyCode(0xFFD2),
        protocol: Some(EmcyCode(0xFFD3)),
        rpdo_too_long: EmcyCode::PDO_LENGTH,
    };

    /// The roller's timers depend on time, its hooks and injected faults
    /// alone: the node polls it at its deadline, not at every process (D65).
    const POLL_WHEN_DUE: bool = true;
    // Its hooks send no frame outside CANopen.
    const RAW_FRAMES: bool = false;

    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.drive.check_write(index, data)?;
        match (index, sub, data) {
            // D34: profile position, profile velocity, homing (as int8 bytes 1, 3, 6) and no mode change (D71).
            (MODES_OF_OPERATION, 0, [mode]) if !matches!(mode, 0 | 1 | 3 | 6) => Err(AbortCode::InvalidValue),
            // D35: polarity bits 7 and 6 only.
            (0x607E, 0, [p]) if p & 0x3F != 0 => Err(AbortCode::InvalidValue),
            // D69: the two bit rates of the manual's DeviceInfo [kbit/s].
            (BAUD_RATE, 1, [lo, hi]) if !matches!(u16::from_le_bytes([*lo, *hi]), 125 | 250) => Err(AbortCode::InvalidValue),
            // D51: program control 1 "restart" is the only value the manual describes.
            (PROGRAM_CONTROL, 1, [v]) if *v != 1 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn download_check(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        (matches!(index, 0x1010 | 0x1011) && sub == SSW).then_some(match size {
            Some(n) if n != 4 => Err(if n > 4 { AbortCode::LengthTooHigh } else { AbortCode::LengthTooLow }),
            _ => Ok(()),
        })
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        if (index, sub) == (NODE_ID, 1) {
            // D31: the static node-ID is the one the drive starts with: stored at
            // once, and a failed store fails the write.
            return Some(ctx.write_object(NODE_ID, 1, data).and_then(|()| ctx.save_objects(NODE_ID, NODE_ID)));
        }
        // F8: 0x1010/0x1011 sub 5 "manufacturer parameters SSW" work as sub 4
        // (the manual does not say which manufacturer objects are SSW, so both
        // sub-indices cover 0x2000–0x5FFF). Decision D40.
        if sub != SSW || !matches!(index, 0x1010 | 0x1011) {
            return None;
        }
        let (signature, save) = if index == 0x1010 { (store::SAVE, true) } else { (store::LOAD, false) };
        Some(match data {
            [a, b, c, d] if u32::from_le_bytes([*a, *b, *c, *d]) == signature => {
                if save {
                    ctx.save(Scope::Manufacturer)
                } else {
                    ctx.restore_defaults(Scope::Manufacturer).map(|()| self.monitor.keep(ctx))
                }
            }
            _ => Err(AbortCode::CannotStore),
        })
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        // D51: the node restarts once the SDO answer is queued.
        if (index, sub) == (PROGRAM_CONTROL, 1) {
            ctx.reset_node();
        }
        // The monitoring checks the warnings again at the next process (D65).
        if index == WARNING_LEVEL {
            self.monitor.levels(ctx);
            ctx.wake();
        }
        // D55: restored parameters leave the roller's life counters as they are.
        if index == 0x1011 {
            self.monitor.keep(ctx);
            ctx.wake();
        }

        // D71: 0 is CiA 402's "no mode change": RPDO1 carries 0x6060 with the
        // controlword, and a master that only switches states sends 0 there.
        if index == MODES_OF_OPERATION && ctx.read_u32(MODES_OF_OPERATION, 0) == Some(0) {
            let running = ctx.read_u32(MODES_OF_OPERATION_DISPLAY, 0).unwrap_or(0);
            let _ = ctx.set_value(MODES_OF_OPERATION, 0, &[running as u8]);
        }

        // The CiA 402 objects, from SDO and from the RPDO-mapped objects
        // `rpdo_written` does not take itself.
        self.drive.written(ctx, &PROFILE, index);
    }

    /// The objects of an RPDO whose mapping is fixed (all four of the
    /// manual's) as kept at its first frame, without asking the node for
    /// its mapping: the controlword straight to the profile, the others
    /// each to [`App::rpdo_value`].
    fn rpdo_written(&mut self, ctx: &mut Ctx<'_>, n: u8) {
        rpdo::written(self, ctx, n);
    }

    /// The controlword and the target velocity straight from the RPDO's
    /// values; any other object as [`App::written`] takes it.
    fn rpdo_value(&mut self, ctx: &mut Ctx<'_>, at: EntryRef, value: u32, len: u8) -> bool {
        self.drive.rpdo_object(ctx, at, value, len)
    }

    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.drive.sample(ctx);
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        // Before the profile's poll, so that statusword bit 7 changes with the EMCY.
        self.monitor.update(ctx, &mut self.drive, AXIS.increments_per_rev);
        let drive = self.drive.poll(ctx, &PROFILE);
        // D65: what the profile's ticks changed, the monitoring sees at the
        // next process, as when it ran at every one; its own period is a deadline.
        if self.monitor.pending(&self.drive) {
            ctx.wake();
        }
        earliest(drive, self.monitor.next())
    }

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.drive.drive.axis.configure(AXIS);
            self.monitor.reset(ctx);
        }
        self.drive.on_nmt(ctx, &PROFILE, event);
        // D66: parameters saved under another dictionary layout are lost (an
        // update): the drive runs on its defaults, in Fault with 0x6310 until
        // a fault reset acknowledges it, at every reset until a save or restore.
        if event == NmtEvent::ResetApplication && ctx.stored_set_refused() {
            self.drive.drive.fault_at_start(LOSS_OF_PARAMETERS);
        }
        if event == NmtEvent::ResetCommunication {
            // The RPDOs are configured again: their objects are found at their next frame.
            self.rpdos = FixedRpdos::NONE;
            // D31: 0x4650 sub 2 is the node-ID in use, after every boot and LSS change.
            if (1..=127).contains(&ctx.node_id()) {
                let _ = ctx.set_value(NODE_ID, 2, &[ctx.node_id()]);
            }
        }
    }
}

/// 0x4650 "Bus Address": sub 1 static (stored) node-ID, sub 2 the active one.
const NODE_ID: u16 = 0x4650;
/// 0x4651 "Baud Rate": sub 1 the CAN bit rate [kbit/s] from the next start (D69).
const BAUD_RATE: u16 = 0x4651;
/// 0x4231 "High Temperature Warning Level" (D48).
const WARNING_LEVEL: u16 = 0x4231;
/// 0x6060 "Modes of operation" (D34, D71).
const MODES_OF_OPERATION: u16 = 0x6060;
/// 0x6061 "Modes of operation display": the mode the profile runs.
const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// 0x1F51 "Switch Bootloader Mode" (program control): sub 1 = 1 restarts the drive.
const PROGRAM_CONTROL: u16 = 0x1F51;
/// 0x1010/0x1011 sub 5: manufacturer parameters "SSW" (Man2).
const SSW: u8 = 5;

/// The node-ID and bit rate (CiA 305 table index) the drive starts with
/// when LSS stored none: 0x4650 sub 1 (D31) and 0x4651 sub 1 (D69) from the
/// stored parameters, else 127 and the image's bit rate.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, Option<u8>) {
    let mut id = [0];
    let node_id = match store::stored_value(&od::DICTIONARY, storage, FACTORY_NODE_ID, NODE_ID, 1, &mut id) {
        Some(1) if (1..=127).contains(&id[0]) => id[0],
        _ => FACTORY_NODE_ID,
    };
    let mut kbps = [0; 2];
    let bit_rate =
        match store::stored_value(&od::DICTIONARY, storage, FACTORY_NODE_ID, BAUD_RATE, 1, &mut kbps).map(|_| u16::from_le_bytes(kbps)) {
            Some(250) => Some(3),
            Some(125) => Some(4),
            _ => None,
        };
    (node_id, bit_rate)
}

/// EMCY 0x6010 "Restart (powerfail, watchdog)" (M §9.1): the board reports
/// a restart the firmware did not ask for with it (D53).
pub const RESTART: EmcyCode = EmcyCode(0x6010);

/// The manual's fallback node-ID.
const FACTORY_NODE_ID: u8 = 127;

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "ec5000",
    description: "Interroll RollerDrive EC5000 BI: CiA 301 slave with the CiA 402 drive profile and LSS (seed 000).",
    dictionary: &od::DICTIONARY,
    default_node_id: 127,
    startup: Some(startup),
};
