//! UNITEK DS servo: its own REGID register protocol, with the register table described as manufacturer objects (seed 001).
//!
//! Defined by `eds/unitek-ds.eds`; decisions where the manual is ambiguous are in
//! `docs/devices/unitek-ds.md`.
//!
//! The drive does not speak CANopen ("Dieses Format entspricht nicht
//! CANopen", L219): this image switches the CANopen services off (no
//! boot-up, NMT, SDO or PDO) and the register protocol owns the bus. It
//! listens on the RX id of register 0x68 and answers on the TX id of 0x69;
//! register `r` is object `0x2000 + r`, so the protocol and the dictionary
//! hold one value. The frames are in [`wire`], the cyclic reads in
//! [`cyclic`], the drive behind the registers in [`servo`].

pub mod cyclic;
pub mod registers;
pub mod servo;
pub mod wire;

/// The object dictionary generated from `eds/unitek-ds.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/unitek_ds.rs"));
}

use canopen_core::axis::{Axis, AxisParams};
use canopen_core::node::{Application, Claims, Ctx, NmtEvent};
use canopen_core::od::Dictionary;
use canopen_core::services::store::{self, Scope};
use canopen_core::time::{Instant, earliest};

use self::cyclic::Cyclic;
use self::registers as reg;
use self::servo::{Limits, Servo};
use self::wire::{Period, Reply, Request};

/// The device's own rules (its hooks in the node): the register protocol
/// and the servo behind it.
#[derive(Debug)]
pub struct App {
    /// The servo and its motor (the axis model).
    pub servo: Servo<Axis>,
    /// The cyclic reads.
    cyclic: Cyclic,
}

impl App {
    /// The state at power-on: `const` and all zero bits ([`canopen_core::node`]).
    pub const NEW: App = App { servo: Servo::new(Axis::NEW), cyclic: Cyclic::NEW };
}

impl Default for App {
    fn default() -> Self {
        App::NEW
    }
}

/// The motor the axis model simulates: 65536 increments per revolution
/// (L887); speed and acceleration come from Nmax 0xC8 and the ramp 0x35;
/// limit switches 200 revolutions either side of zero (U-D4).
pub const AXIS: AxisParams = AxisParams {
    increments_per_rev: servo::INCREMENTS_PER_REV as u32,
    max_acceleration: 0,
    max_velocity: 0,
    position_gain: 50,
    friction_permille: 0,
    ambient_c: 25,
    rise_at_rated_c: 60,
    thermal_tau_s: 300,
    warning_c: 100,
    fault_c: 120,
    dc_link_mv: 325_000,
    following_limit: 0,
    limits: (-200 * servo::INCREMENTS_PER_REV, 200 * servo::INCREMENTS_PER_REV),
    home_switch: None,
};

impl Limits for Axis {
    fn set_limits(&mut self, max_velocity: u32, max_acceleration: u32) {
        // A position loop faster than the ramp can brake overshoots (and Tol
        // flickers): the gain is at most the ramp's acceleration over Nmax.
        let position_gain = (max_acceleration / max_velocity.max(1)).clamp(1, AXIS.position_gain);
        self.configure(AxisParams { max_velocity, max_acceleration, position_gain, ..AXIS });
    }
}

impl Application for App {
    // EEPROM store by the function register 0x84; the EDS has no 0x1010.
    const STORES: bool = true;
    // No RPDO (`rpdo_written` does nothing) and no TPDO trigger.
    const PDO_CALLS: bool = false;

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        // Power-on is the only reset without CANopen.
        if event == NmtEvent::ResetApplication {
            self.cyclic.stop_all();
            self.servo.power_on(ctx);
        }
    }

    fn on_frame(&mut self, ctx: &mut Ctx<'_>, cob_id: u16, rtr: bool, data: &[u8]) -> bool {
        if u32::from(cob_id) != reg::read_u32(ctx, reg::CAN_ID_RX) {
            return false;
        }
        // RTR is not used and ignored (L321, L1030).
        if rtr {
            return true;
        }
        self.servo.heard(ctx.now());
        let handled = match Request::parse(data) {
            Ok(Request::Read { regid, period }) => self.read_request(ctx, regid, period),
            Ok(Request::Write { regid, value }) => self.write(ctx, regid, value),
            Err(wire::Malformed) => false,
        };
        if !handled {
            reject(ctx);
        }
        true
    }

    fn claim_ids(&self, dict: &'static Dictionary, image: &[u8], claims: &mut Claims<'_>) {
        if let Some(id) = dict.read_u32(image, reg::object(reg::CAN_ID_RX), 0) {
            claims.claim(id as u16, false);
        }
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let now = ctx.now();
        let (deadline, event) = self.servo.poll(ctx);
        if let Some(status) = event {
            // Event frames are always the whole 32-bit STATUS (Ex. 10, L762).
            send(ctx, Reply { regid: reg::STATUS, value: status, wide: true });
        }
        if self.cyclic.deadline().is_some_and(|due| due <= now) {
            self.servo.refresh(ctx);
        }
        while let Some(regid) = self.cyclic.next_due(now) {
            match reply(ctx, regid) {
                Some(r) if send(ctx, r) => {}
                // The burst is full: the rest go out in the next call, at once.
                Some(_) => {
                    self.cyclic.retry(regid, now);
                    break;
                }
                None => self.cyclic.stop(regid),
            }
        }
        earliest(deadline, self.cyclic.deadline())
    }

    fn rpdo_written(&mut self, _ctx: &mut Ctx<'_>, _n: u8) {
        // No RPDO: CANopen is off.
    }

    fn canopen(&self) -> bool {
        false
    }
}

impl App {
    /// READ 0x3D: once at once, cyclically from now, or stop. False if it is
    /// refused (not a readable register, or all eight slots busy).
    fn read_request(&mut self, ctx: &mut Ctx<'_>, regid: u8, period: Period) -> bool {
        self.servo.refresh(ctx);
        match period {
            Period::Stop => {
                self.cyclic.stop(regid);
                true
            }
            _ if reply(ctx, regid).is_none() => false,
            Period::Once => reply(ctx, regid).is_some_and(|r| send(ctx, r)),
            // The first cyclic frame goes out in the `process` that follows.
            Period::EveryMs(ms) => self.cyclic.start(regid, ms, ctx.now()),
        }
    }

    /// A register write: the dictionary's checks (access, limits), then what
    /// the register does. No acknowledge either way (L230-239).
    fn write(&mut self, ctx: &mut Ctx<'_>, regid: u8, value: wire::Value) -> bool {
        let Some((bytes, len)) = reg::encode(ctx, regid, value) else { return false };
        let data = bytes.get(..len).unwrap_or(&bytes);
        // Only the five codes of the bit-rate table (L207-212) are bit rates.
        if regid == reg::CAN_BTR && !matches!(data, [lo, hi] if BIT_RATE_CODES.contains(&u16::from_le_bytes([*lo, *hi]))) {
            return false;
        }
        if ctx.write_object(reg::object(regid), 0, data).is_err() {
            return false;
        }
        match regid {
            // U-D9: a new RX id is active at once; the TX id is read for every reply.
            reg::CAN_ID_RX => ctx.refresh_acceptance(),
            // "Write 0" (L573-586, L1068): every parameter, through the power-cut-safe store.
            reg::FUN_PARAWRITE => return ctx.save(Scope::All).is_ok(),
            _ => self.servo.written(ctx, regid),
        }
        true
    }
}

/// Register `regid`'s value as a reply frame: DLC 6 for a 32-bit register
/// or when the upper byte of 0xDC is 0x01 (L1051-1062); `None` if it is no
/// readable register.
fn reply(ctx: &Ctx<'_>, regid: u8) -> Option<Reply> {
    let (value, wide) = reg::read(ctx, regid)?;
    let all_wide = reg::read_u32(ctx, reg::REPLY_FORMAT) >> 8 & 0xFF == 0x01;
    Some(Reply { regid, value, wide: wide || all_wide })
}

/// Sends a reply on the TX id (0x69); false if the transmit burst is full.
fn send(ctx: &mut Ctx<'_>, r: Reply) -> bool {
    let tx = reg::read_u32(ctx, reg::CAN_ID_TX) as u16;
    let mut buf = [0; 6];
    ctx.send_raw(tx, r.emit(&mut buf))
}

/// Counts a refused frame in CAN_COUNTREJ 0x97 (there is no error reply).
fn reject(ctx: &mut Ctx<'_>) {
    let count = reg::read_u32(ctx, reg::CAN_COUNT_REJECT);
    reg::set(ctx, reg::CAN_COUNT_REJECT, count.wrapping_add(1));
}

/// The CiA 305 bit-timing index of a 0x73 bit-rate code (L207-212);
/// `None` for 625 and 100 kbit/s, which CiA 305 has no index for, and
/// for any other value.
pub fn bit_rate_index(code: u16) -> Option<u8> {
    match code {
        0x4002 => Some(0),
        0x4025 => Some(2),
        0x405C => Some(3),
        _ => None,
    }
}

/// The bit-rate codes of 0x73: 1000, 500, 625, 250 and 100 kbit/s (L207-212).
const BIT_RATE_CODES: [u16; 5] = [0x4002, 0x4025, 0x4014, 0x405C, 0x4425];

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device entry for [`super::ALL`].
pub const DEVICE: super::Device = super::Device {
    name: "unitek-ds",
    description: "UNITEK DS servo: its own REGID register protocol, with the register table described as manufacturer objects (seed 001).",
    dictionary: &od::DICTIONARY,
    default_node_id: 1,
    startup: Some(startup),
};

/// The bit rate (CiA 305 table index) of the stored 0x73 code; the
/// node-id only numbers the stored set, as CANopen is off.
pub fn startup(storage: &mut dyn canopen_core::storage::Storage) -> (u8, Option<u8>) {
    let mut code = [0; 2];
    let stored = store::stored_value(&od::DICTIONARY, storage, 1, reg::object(reg::CAN_BTR), 0, &mut code);
    (1, stored.and_then(|_| bit_rate_index(u16::from_le_bytes(code))))
}
