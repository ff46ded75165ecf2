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
use canopen_core::axis::AxisParams;
use canopen_core::node::{Application, CommError, Ctx, NmtEvent, Source};
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::profiles::cia402::fsa::{PdsState, Reaction};
use canopen_core::profiles::cia402::{Cia402, Config};
use canopen_core::services::nmt::NmtState;
use canopen_core::services::store;
use canopen_core::time::{Instant, earliest};
use canopen_core::wire::emcy::EmcyCode;

use super::sync_watch::SyncWatch;

mod abort_connection;
mod control;
mod data_sets;
mod faults;
mod ramps;

pub use faults::AgileDrive;

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary, and the CiA 402 profile in velocity
/// mode driving the axis model (until a board drives the inverter's motor).
#[derive(Debug)]
pub struct App {
    /// The CiA 402 profile (vl only) and the drive behind it.
    pub drive: Cia402<AgileDrive>,
    /// In NMT Operational: leaving it is a bus fault.
    operational: bool,
    /// The fault key of the last bus fault (F20.nn, F23.nn).
    bus_fault: u16,
    /// The last bus fault came in NMT Operational: its reset needs Operational again (D58).
    reset_in_operational: bool,
    /// The SYNC monitoring (D55): it starts with the first SYNC in
    /// Operational and stops on leaving it.
    sync: SyncWatch,
}

impl App {
    /// The state at power-on: `const` and all zero bits ([`canopen_core::node`]).
    pub const NEW: App =
        App { drive: Cia402::new(AgileDrive::NEW), operational: false, bus_fault: 0, reset_in_operational: false, sync: SyncWatch::NEW };
}

/// The profile's constants for the Agile (decisions D42-D47 in docs/devices/agile.md).
pub const PROFILE: Config = Config {
    // vl works in min⁻¹ at the motor shaft; the axis model counts 4096 per revolution (D42).
    increments_per_rev: 4096,
    // The device reacts to leaving Operational itself, with the other bus faults (D44).
    leaving_operational_aborts: false,
    // vl has no position or velocity window; pp/pv/hm objects are not in the dictionary.
    position_window: 0,
    velocity_window: 0,
    homing_speeds: (0, 0),
    velocity_unit: None,
};

/// The inverter's motor as the axis model simulates it: a 4-pole machine up
/// to 3000 min⁻¹ (100 Hz), 0.1 s from standstill to full speed at the
/// inverter's current limit (the vl ramps 0x6048/0x6049 are slower), a
/// 400 V mains DC link of 560 V.
pub const AXIS: AxisParams = AxisParams {
    increments_per_rev: 4096,
    max_acceleration: 2_048_000,
    max_velocity: 204_800,
    position_gain: 40,
    friction_permille: 0,
    ambient_c: 25,
    rise_at_rated_c: 50,
    thermal_tau_s: 300,
    warning_c: 80,
    fault_c: 95,
    dc_link_mv: 560_000,
    following_limit: 0,
    limits: (0, 0),
    home_switch: None,
};

impl Application for App {
    // Its hooks send no frame outside CANopen.
    const RAW_FRAMES: bool = false;

    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.drive.check_write(index, data)?;
        match (index, sub, data) {
            // D6: the communication cycle period in whole milliseconds only.
            (0x1006, 0, [a, b, c, d]) if u32::from_le_bytes([*a, *b, *c, *d]) % 1000 != 0 => Err(AbortCode::InvalidValue),
            // D53: the inverter produces no SYNC ("wird nicht unterstützt", M-L1405).
            (0x1005, 0, [_, _, _, d]) if d & 0x40 != 0 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn upload_size(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        // D43: the write-only 0x6060 answers the manual's only "not readable" code (§8.3.3).
        if (index, sub) == (MODES_OF_OPERATION, 0) {
            return Some(Err(AbortCode::UnsupportedAccess));
        }
        let target = data_sets::target(ctx, index, sub)?;
        Some(data_sets::read(ctx, index, target).map(<[u8]>::len))
    }

    fn read(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        let target = data_sets::target(ctx, index, sub)?;
        Some(data_sets::read(ctx, index, target).map(|value| {
            let value = value.get(offset..).unwrap_or(&[]);
            buf.iter_mut().zip(value).map(|(d, s)| *d = *s).count()
        }))
    }

    fn download_check(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        // D51: "Parameter nicht schreibbar" is 0x06010000, the manual's one code for
        // both directions (§8.3.3, M-L793), as the read of 0x6060 (D43).
        let Some(target) = data_sets::target(ctx, index, sub) else {
            return read_only(ctx, index, sub).then_some(Err(AbortCode::UnsupportedAccess));
        };
        Some(match size {
            _ if !target.writable => Err(AbortCode::UnsupportedAccess),
            Some(n) if n > target.len => Err(AbortCode::LengthTooHigh),
            Some(n) if n < target.len => Err(AbortCode::LengthTooLow),
            _ => Ok(()),
        })
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        // D61: "save" in 0x1010/3 stores the application objects, 0x3000 among them (M-L2391).
        if (index, sub, data) == (0x1010, 3, b"save".as_slice()) {
            return Some(ctx.save_objects(0x3000, 0x9FFF));
        }
        // D53: TPDO inhibit times in whole milliseconds, 37 → 30, below 10 → 0 (M-L2016-2020).
        if let (0x1800..=0x1802, 3, [lo, hi]) = (index, sub, data) {
            let whole_ms = u16::from_le_bytes([*lo, *hi]) / 10 * 10;
            return Some(ctx.write_object(index, 3, &whole_ms.to_le_bytes()));
        }
        let Some(target) = data_sets::target(ctx, index, sub) else {
            return read_only(ctx, index, sub).then_some(Err(AbortCode::UnsupportedAccess));
        };
        if control::refused(index, data) {
            return Some(Err(AbortCode::InvalidValue));
        }
        let mut result = data_sets::write(ctx, index, target, data);
        if index == CAN_FAULT_BEHAVIOUR && result.is_ok() {
            result = abort_connection::from_p388(ctx, target.stored());
        }
        if matches!(
            index,
            control::LOCAL_REMOTE
                | control::DATA_SET_SELECTION
                | ramps::MAX_CONTROL_DEVIATION
                | ramps::MINIMUM_FREQUENCY
                | ramps::MAXIMUM_FREQUENCY
                | ramps::POLE_PAIRS
        ) {
            self.settings(ctx);
        }
        Some(result)
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        if index == ABORT_CONNECTION {
            abort_connection::to_p388(ctx);
        }
        // D54: the vl limits and ramps into p.418-p.425 (p.418/p.419 set bit 10's hysteresis, D62).
        ramps::written(ctx, index, sub);
        if index == VL_MIN_MAX {
            self.settings(ctx);
        }
        // The CiA 402 objects, from SDO and from each RPDO-mapped object (the
        // default `rpdo_written`); the controlword as the inverter takes it,
        // in steps the profile runs one after the other (one call site: the
        // profile's `written` is inlined here).
        let (steps, n, word) = if index == CONTROLWORD { self.controlword(ctx) } else { ([0; 3], 1, 0) };
        let mut stored = word;
        for &step in steps.iter().take(n) {
            if step != stored {
                let _ = ctx.set_value(CONTROLWORD, 0, &step.to_le_bytes());
                stored = step;
            }
            self.drive.written(ctx, &PROFILE, index);
        }
        if stored != word {
            let _ = ctx.set_value(CONTROLWORD, 0, &word.to_le_bytes());
        }
    }

    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        if self.operational {
            self.sync.seen(ctx.now());
        }
        self.drive.sample(ctx);
        self.actuals(ctx);
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        // D55 (§9.2.4, M-L1440-1448): a SYNC "um mehr als 50 %" later than 0x1006
        // after the one before is F20.24, reacting as 0x6007 says while the drive
        // function is on; the watch then stops until the next SYNC.
        let mut deadline = SyncWatch::period(ctx).and_then(|period| self.sync.deadline(period + period / 2));
        if deadline.is_some_and(|at| ctx.now() >= at) {
            self.sync.stop();
            deadline = None;
            if self.drive.state().drive_function() {
                self.bus_fault(ctx, NmtEvent::CommunicationError(CommError::BusOff), FAULT_SYNC);
            }
        }
        let next = self.drive.poll(ctx, &PROFILE);
        self.actuals(ctx);
        earliest(next, deadline)
    }

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        let bus_fault = match event {
            NmtEvent::ResetApplication => {
                abort_connection::at_power_on(ctx);
                ramps::at_power_on(ctx);
                self.drive.drive.axis.configure(AXIS);
                self.settings(ctx);
                self.operational = false;
                None
            }
            NmtEvent::Entered(state) => {
                // p.1290 "Node-State (NMT)" (§8.7, M-L870): the state as heartbeat reports it.
                let _ = ctx.set_value(NODE_STATE, 0, &u16::from(state.reported().code()).to_le_bytes());
                let left = self.operational && state != NmtState::Operational;
                self.operational = state == NmtState::Operational;
                if !self.operational {
                    self.sync.stop();
                }
                left.then_some(FAULT_NMT)
            }
            NmtEvent::CommunicationError(CommError::BusOff) => Some(FAULT_BUS_OFF),
            NmtEvent::CommunicationError(CommError::LifeGuarding) => Some(FAULT_GUARDING),
            NmtEvent::CommunicationError(CommError::Heartbeat(node)) => Some(FAULT_HEARTBEAT | u16::from(node)),
            NmtEvent::CommunicationError(CommError::RpdoTimeout(n)) => Some(FAULT_RPDO_TIMEOUT + u16::from(n)),
            NmtEvent::CommunicationError(CommError::RpdoLength(n)) => Some(FAULT_RPDO_LENGTH + u16::from(n)),
            _ => None,
        };
        match bus_fault {
            Some(fault) if self.drive.state().drive_function() => self.bus_fault(ctx, event, fault),
            _ => self.drive.on_nmt(ctx, &PROFILE, event),
        }
    }
}

impl App {
    /// The controlword as the inverter takes it (§10.2, M-L3109-3160), as
    /// the controlwords the profile runs (`n` of them) and the one written:
    /// none unless the state machine controls (p.412, D56); after a bus
    /// fault in NMT Operational, bit 7 not seen outside it, nor while a
    /// guarding or heartbeat loss lasts (M-L2605-2609, D58), so that its
    /// next rising edge once both are over resets; "enable operation" in Switch
    /// on disabled with Shutdown first (0x0000 → 0x000F, M-L3279-3282, D45);
    /// "disable operation" with p.392 = 0 as disable voltage, shutdown and
    /// switch on (D57: Switched on at once, the motor coasting).
    fn controlword(&mut self, ctx: &mut Ctx<'_>) -> ([u16; 3], usize, u16) {
        let word = ctx.read_u32(CONTROLWORD, 0).unwrap_or(0) as u16;
        let state = self.drive.state();
        let bus_fault = state == PdsState::Fault && Drive::fault(&self.drive.drive) == EmcyCode::NO_ERROR;
        // The cause gone too: a guarding or heartbeat loss (0x8130) ends when it is back.
        let left = self.reset_in_operational && ctx.state() != NmtState::Operational;
        let blocked = left || ctx.error_active(EmcyCode::LIFE_GUARD_OR_HEARTBEAT);
        let seen = if bus_fault && blocked { word & !0x0080 } else { word };
        let (steps, n) = match state {
            _ if self.drive.drive.local => ([word; 3], 0),
            PdsState::SwitchOnDisabled if seen & 0x8F == 0x0F => ([seen & !0x0001, seen, 0], 2),
            PdsState::OperationEnabled if seen & 0x8F == 0x07 && control::transition_5_coasts(ctx) => ([0x0000, 0x0006, seen], 3),
            _ => ([seen; 3], 1),
        };
        (steps, n, word)
    }

    /// p.412, p.414, p.549, p.418/p.419 (0x6046) or p.373 changed, or
    /// power-on: the control source (statusword bit 9, D56) and the
    /// hysteresis of bit 10 (D62) in the active data set.
    fn settings(&mut self, ctx: &mut Ctx<'_>) {
        let set = control::active_set(ctx);
        self.drive.drive.local = control::local(ctx, set);
        self.drive.drive.window = ramps::target_window(ctx, set);
        self.drive.refresh();
    }

    /// §9.5.16/§9.5.17 (M-L2985-3015), D48: the current actual value 0x6078
    /// (‰ of the rated current: the axis model's torque estimate, which has
    /// no magnetising current) and the DC link voltage 0x6079 [mV]; the
    /// profile keeps 0x6077.
    /// p.260 holds the active fault's key (D52), p.270 bit 7 the motor
    /// temperature warning (§12.3).
    fn actuals(&self, ctx: &mut Ctx<'_>) {
        let drive = &self.drive.drive;
        let _ = ctx.set_value(CURRENT_ACTUAL, 0, &drive.torque().to_le_bytes());
        let _ = ctx.set_value(DC_LINK_VOLTAGE, 0, &drive.dc_link_mv().to_le_bytes());
        let key = match self.drive.state() {
            PdsState::Fault | PdsState::FaultReactionActive if drive.key() != 0 => drive.key(),
            PdsState::Fault | PdsState::FaultReactionActive => self.bus_fault,
            _ => 0,
        };
        let _ = ctx.set_value(CURRENT_FAULT, 0, &key.to_le_bytes());
        let _ = ctx.set_value(WARNINGS, 0, &(u16::from(drive.warning()) << 7).to_le_bytes());
    }

    /// §1.9/§9.5.1 (M-L670-700, L2574-2597), D44: the reaction 0x6007 (p.388)
    /// asks for on a bus fault while the drive function is on. 1, −1 and −2
    /// end in Fault with 0x603F 0x1000 and the inverter's fault key (F20.nn,
    /// F23.nn) in EMCY bytes 6-7; 2 and 3 are the profile's disable voltage
    /// and quick stop.
    fn bus_fault(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent, fault: u16) {
        self.bus_fault = fault;
        self.reset_in_operational = self.operational || matches!(event, NmtEvent::Entered(_));
        let [lo, hi] = fault.to_le_bytes();
        let info = [0, 0, 0, lo, hi];
        let reaction = match ctx.read(ABORT_CONNECTION, 0) {
            // Under contacts (p.412 not 1) any setting but 0 is an immediate Fault (M-L2602-2603).
            Ok(v) if self.drive.drive.local && v != [0, 0] => Reaction::Coast,
            Ok([1, 0]) => Reaction::Coast,
            Ok([0xFF, 0xFF]) => Reaction::SlowDownRamp,
            Ok([0xFE, 0xFF]) => Reaction::QuickStopRamp,
            // 0, 2 and 3: the profile's reaction (a departure from Operational
            // counts as a communication error only here, so it is passed as one).
            _ => {
                let event = match event {
                    NmtEvent::Entered(_) => NmtEvent::CommunicationError(CommError::BusOff),
                    other => other,
                };
                self.drive.on_nmt(ctx, &PROFILE, event);
                return;
            }
        };
        self.drive.raise_fault(ctx, EmcyCode::GENERIC, info, reaction);
        if let NmtEvent::Entered(_) = event {
            self.drive.on_nmt(ctx, &PROFILE, event);
        }
    }
}

/// D51: (index, sub) exists and is read-only (0x06010000 on a write, §8.3.3).
fn read_only(ctx: &Ctx<'_>, index: u16, sub: u8) -> bool {
    ctx.dictionary().find(index, sub).is_ok_and(|e| !e.writable())
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

use abort_connection::{ABORT_CONNECTION, CAN_FAULT_BEHAVIOUR};
/// 0x603F for the faults §12.5 does not map (M-L2636-2656): the bus faults.
/// Fault keys (§7.3, M-L688-700): group F20 high byte, code low byte.
const FAULT_BUS_OFF: u16 = 0x2021;
/// F20.22 guarding failure.
const FAULT_GUARDING: u16 = 0x2022;
/// F20.24 SYNC error (SYNC timing).
const FAULT_SYNC: u16 = 0x2024;
/// F20.25 NMT state change (Operational → other).
const FAULT_NMT: u16 = 0x2025;
/// F20.26-28 RPDO1-3 length error ("Anzahl der empfangenen Bytes … abweichend vom Mapping", M-L697-699).
const FAULT_RPDO_LENGTH: u16 = 0x2026;
/// F20.2A-2C RPDO1-3 event-time timeout (§9.2.19).
const FAULT_RPDO_TIMEOUT: u16 = 0x202A;
/// F23.nn heartbeat of node nn.
const FAULT_HEARTBEAT: u16 = 0x2300;
/// p.1290 node state (0x250A, UNSIGNED16).
const NODE_STATE: u16 = 0x250A;
/// p.260 current error (0x2104, UNSIGNED16): the fault key.
const CURRENT_FAULT: u16 = 0x2104;
/// p.270 warnings (0x210E, UNSIGNED16).
const WARNINGS: u16 = 0x210E;
/// 0x6078 current actual value (INTEGER16, ‰ of the rated current).
const CURRENT_ACTUAL: u16 = 0x6078;
/// 0x6079 DC link circuit voltage (UNSIGNED32, mV).
const DC_LINK_VOLTAGE: u16 = 0x6079;
/// 0x6046 vl velocity min max amount.
const VL_MIN_MAX: u16 = 0x6046;
/// 0x6060 modes of operation (write-only).
const MODES_OF_OPERATION: u16 = 0x6060;
/// 0x6040 controlword.
const CONTROLWORD: u16 = 0x6040;
/// p.387 CAN node number (INTEGER16, −1…127).
const NODE_NUMBER: u16 = 0x2183;
/// p.385 CAN baud rate (UNSIGNED16, codes 1…8).
const BAUD_RATE: u16 = 0x2181;
