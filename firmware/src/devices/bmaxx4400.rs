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
use canopen_core::axis::AxisParams;
use canopen_core::node::{Application, Ctx, NmtEvent, ServiceOptions, Source};
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::profiles::cia402::fsa::{PdsState, Reaction};
use canopen_core::profiles::cia402::objects::index::{CONTROLWORD, QUICK_STOP_OPTION, STATUSWORD};
use canopen_core::profiles::cia402::{Cia402, Config, mode, statusword};
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;

mod errors;
mod ip;
mod option_codes;
mod params;
mod positioning;
mod slots;
mod speed;
mod sync;

pub use errors::BmaxxDrive;

/// The device's own rules (its hooks in the node): what its manual asks of
/// the firmware beyond the dictionary, and the CiA 402 profile driving the
/// axis model (until the option module talks to a drive).
#[derive(Debug)]
pub struct App {
    /// The CiA 402 profile and the drive behind it.
    pub drive: Cia402<BmaxxDrive>,
    /// 0x606B and 0x606C as last converted to speed units (D57).
    speeds: [i32; 2],
    /// The interpolation time period in use, as a power of two of ticks (D58).
    ip_period: u8,
    /// A homing completed since power-on (reset application) (D61).
    homed: bool,
    /// The hardware limit switches as last seen: bit 0 negative, bit 1 positive (D65).
    switches: u8,
    /// When the SYNCs came (D66).
    sync: sync::Monitor,
    /// The 0x6060 value last taken (D51): what an unused value an RPDO wrote falls back to.
    mode: i8,
}

impl App {
    /// The state at power-on: `const` and all zero bits ([`canopen_core::node`]).
    pub const NEW: App = App {
        drive: Cia402::new(BmaxxDrive::NEW),
        speeds: [0; 2],
        ip_period: 0,
        homed: false,
        switches: 0,
        sync: sync::Monitor::NEW,
        mode: 0,
    };
}

/// The profile's constants for the b maXX 4400 (decisions D50-D53 in docs/devices/bmaxx4400.md).
pub const PROFILE: Config = Config {
    // §4.4.5: 65536 increments per motor revolution; the default 0x6092 (65536 BE per
    // revolution) makes 1 BE = 1 INC (D50).
    increments_per_rev: 65536,
    // Only guarding/heartbeat loss triggers 0x6007 (App. C 6007h); NMT commands do not.
    leaving_operational_aborts: false,
    // 0x606D is not in the dictionary: 0.1 revolution per second (D50).
    position_window: 0,
    velocity_window: 6554,
    homing_speeds: (0, 0),
    // D68: 0x606F and 0x606C are min⁻¹ (D57).
    velocity_unit: Some(speed::unit),
};

/// The motor as the axis model simulates it: 65536 increments per
/// revolution, up to 3000 min⁻¹ (3,276,800 inc/s), 0.1 s from standstill to
/// full speed, following-error fault at one revolution, a 560 V DC link,
/// hardware limit switches 100 revolutions either side of the power-on
/// position (homing methods 17/18, drive errors 198/199, D65).
pub const AXIS: AxisParams = AxisParams {
    increments_per_rev: 65536,
    max_acceleration: 32_768_000,
    max_velocity: 3_276_800,
    position_gain: 40,
    friction_permille: 0,
    ambient_c: 25,
    rise_at_rated_c: 60,
    thermal_tau_s: 300,
    warning_c: 90,
    fault_c: 105,
    dc_link_mv: 560_000,
    following_limit: 65_536,
    limits: (-LIMIT_SWITCH, LIMIT_SWITCH),
    home_switch: None,
};

/// Where the hardware limit switches are [inc]: 100 revolutions.
const LIMIT_SWITCH: i64 = 100 * 65536;

/// A 0x6060 value the manual accepts (App. C, M-L5241-5410), with the mode
/// the profile runs for it and what 0x6061 shows (D51): −3 (drive speed
/// control) runs pv and shows 3; −4 (drive position control, the drive
/// mode of ip) runs ip and shows −4 (D59); the other manufacturer modes
/// hold the axis (profile mode 0) and show themselves. `None`: refused.
const fn mode_of(requested: i8) -> Option<(i8, i8)> {
    Some(match requested {
        mode::PP | mode::VL | mode::HM | mode::IP => (requested, requested),
        mode::PV | -3 => (mode::PV, mode::PV),
        -4 => (mode::IP, -4),
        -106 | -7..=-1 => (0, requested),
        _ => return None,
    })
}
/// 0x6060 modes of operation.
const MODES_OF_OPERATION: u16 = 0x6060;
/// 0x6061 modes of operation display.
const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;

impl Application for App {
    /// §5.5.3 (D27): mapping entries and COB-IDs are rewritten while the PDO
    /// is valid, in Pre-operational; §5.5.2 (D26): type 254 is time-triggered;
    /// P0830 bit 0 (§4.3.1): boot-up as DS 301 V3; bit 4 (§4.3.5): a life
    /// guarding event enters Pre-operational only when set (D62).
    const OPTIONS: ServiceOptions = ServiceOptions {
        pdo_rewrite_while_valid: true,
        tpdo_254_timer_only: true,
        boot_up_v3: Some((speed::CONFIGURATION, 1 << 0)),
        communication_error_pre_operational: Some((speed::CONFIGURATION, 1 << 4)),
        // D10: 0x100E and 0x1014 are "nicht abspeicherbar" (M-L1303, M-L1357); between
        // them only 0x100F (read-only) and the store commands themselves.
        not_saved_by_1010: Some((0x100E, 0x1014)),
        ..ServiceOptions::CIA301
    };
    // Its hooks send no frame outside CANopen.
    const RAW_FRAMES: bool = false;

    fn download_check(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        if index == PDOS_SUPPORTED {
            return Some(Err(pdos_supported(sub).err().unwrap_or(AbortCode::ReadOnly)));
        }
        // D9: masters following the manual write 0x1017 with one byte (2F).
        ((index, sub, size) == (HEARTBEAT_TIME, 0, Some(1))).then_some(Ok(()))
    }

    fn upload_size(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == PDOS_SUPPORTED).then(|| pdos_supported(sub).map(|v| v.len()))
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        match (index, sub, data) {
            (PDOS_SUPPORTED, ..) => Some(Err(pdos_supported(sub).err().unwrap_or(AbortCode::ReadOnly))),
            (HEARTBEAT_TIME, 0, [ms]) => Some(ctx.write_object(HEARTBEAT_TIME, 0, &[*ms, 0])),
            // D10: store and restore of sub 2 only (sub 1 "wird nicht unterstützt"), in
            // Pre-operational only (M-L1311-1355).
            (STORE | RESTORE, 1, _) => Some(Err(AbortCode::CannotStore)),
            (STORE | RESTORE, 2, _) if ctx.state() != NmtState::PreOperational => Some(Err(AbortCode::DeviceState)),
            _ => None,
        }
    }

    fn check_write(&mut self, ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            // D51: the manual's modes, manufacturer-specific ones included; 0, 4, 5, 8..127 are unused.
            (MODES_OF_OPERATION, [m]) => mode_of(*m as i8).map(|_| ()).ok_or(AbortCode::InvalidValue),
            // D60: a gear factor with denominator 0 would divide by zero.
            (speed::GEAR_FACTOR, [0, 0, 0, 0]) if sub == 2 => Err(AbortCode::InvalidValue),
            // D58: 2000, 4000 or 8000 µs, taken when sub 2 is written.
            (ip::TIME_PERIOD, [i]) if sub == 2 => ip::period(ctx, Some(*i as i8)).map(|_| ()).ok_or(AbortCode::InvalidValue),
            // D55: the BACI's 8 set-point and 8 actual-value slots.
            (0x1600..=0x1603 | 0x1A00..=0x1A03, [n]) if sub == 0 && slots::exceeded(ctx, index, *n) => Err(AbortCode::PdoTooLong),
            // D13: guarding answers on 700h + node-ID (CiA 301 v4); 0x100E shows it and takes no other.
            (GUARDING_COB_ID, [a, b, c, d]) if u32::from_le_bytes([*a, *b, *c, *d]) != 0x700 + u32::from(ctx.node_id()) => {
                Err(AbortCode::InvalidValue)
            }
            // D15: the SYNC interval 1000, 2000, 4000 or 8000 µs (0: not set), M-L1250-1252.
            (COMMUNICATION_CYCLE, [a, b, c, d]) if !matches!(u32::from_le_bytes([*a, *b, *c, *d]), 0 | 1000 | 2000 | 4000 | 8000) => {
                Err(AbortCode::InvalidValue)
            }
            // D63: the option codes' value tables.
            (0x6007 | 0x605A..=0x605E, [lo, hi]) if !option_codes::valid(index, i16::from_le_bytes([*lo, *hi])) => {
                Err(AbortCode::InvalidValue)
            }
            _ => self.drive.check_write(index, data),
        }
    }

    fn read(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        let value = match (index, sub) {
            (PDOS_SUPPORTED, _) => pdos_supported(sub),
            // D22: the low byte of the drive's status word P0301 (0x6041), bits 25/24 the
            // card type "b maXX 4400" (1 0), M-L1140-1154.
            (STATUS_REGISTER, 0) => Ok((0x0200_0000 | (ctx.read_u32(STATUSWORD, 0).unwrap_or(0) & 0xFF)).to_le_bytes()),
            _ => return params::read(ctx, index, sub, offset, buf),
        };
        Some(value.map(|v| buf.iter_mut().zip(v.iter().skip(offset)).map(|(d, s)| *d = *s).count()))
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        if index == speed::CONFIGURATION {
            // D64: P0830 bit 9 applies to the next drive error, like bits 2 and 5 at once (D56).
            self.drive.drive.ff00_only = speed::configured(ctx, EMCY_FF00_ONLY);
        }
        if index == MODES_OF_OPERATION {
            self.set_mode(ctx);
        } else if (index, sub) == (ip::TIME_PERIOD, 2) {
            self.ip_period = ip::period(ctx, None).unwrap_or(self.ip_period);
        } else {
            // The CiA 402 objects, from SDO and from each RPDO-mapped object (the
            // default `rpdo_written`); a new gear factor (the profile's vl
            // dimension factor) converts 0x60FF and 0x6042 anew (D60).
            self.profile_written(ctx, index);
        }
    }

    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        // D66: a SYNC off its interval; the PLL in step again lets a fault reset acknowledge it.
        if self.sync.on_sync(ctx) {
            self.not_synchronous(ctx);
        }
        if self.sync.in_step(ctx) {
            self.drive.drive.out_of_step = false;
        }
        self.drive.sample(ctx);
        // D58: every SYNC takes the interpolation data record.
        self.drive.interpolate(ip::set_point(ctx), self.ip_period);
        speed::actuals(ctx, &mut self.speeds);
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let next = self.drive.poll(ctx, &PROFILE);
        self.limit_switches(ctx);
        if self.sync.missing(ctx) {
            self.not_synchronous(ctx);
        }
        speed::actuals(ctx, &mut self.speeds);
        next
    }

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.drive.drive.axis.configure(AXIS);
        }
        self.drive.on_nmt(ctx, &PROFILE, event);
        if event == NmtEvent::ResetCommunication {
            // The card starts again: no SYNC seen, the synchronisation anew (D66);
            // P0601 "Absolut/Relativ CANopen" unless P1190 bit 9 keeps it (D67).
            (self.sync, self.drive.drive.out_of_step) = (sync::Monitor::NEW, false);
            positioning::init_mode(ctx);
            if speed::configured(ctx, ZEROED_MAPPING) {
                zero_default_mapping(ctx);
            }
        }
        if event == NmtEvent::ResetApplication {
            // The axis model starts again at 0: the homing is lost. P0830 is back at its default.
            (self.homed, self.switches, self.mode) = (false, 0, 0);
            self.drive.drive.ff00_only = speed::configured(ctx, EMCY_FF00_ONLY);
            self.set_mode(ctx);
            self.ip_period = ip::period(ctx, None).unwrap_or(1);
        }
    }
}

impl App {
    /// The profile hears of `index`; it reads 0x60FF in user units per
    /// second while the object holds min⁻¹ (D57).
    /// Before a homing (D61) the profile sees no new set-point in pp.
    fn profile_written(&mut self, ctx: &mut Ctx<'_>, index: u16) {
        let Ok(&[a, b, c, d]) = ctx.read(speed::TARGET_VELOCITY, 0) else { return };
        if let Some(user) = speed::target_for_profile(ctx) {
            let _ = ctx.set_value(speed::TARGET_VELOCITY, 0, &user.to_le_bytes());
        }
        let cw = ctx.read_u32(CONTROLWORD, 0).unwrap_or(0);
        // A homing shows as attained (statusword bits 12 and 10 in hm) until the next write.
        let (running, status) = running(ctx);
        if running == mode::HM && status & HOMING_ATTAINED == HOMING_ATTAINED {
            self.homed = true;
        }
        // The controlword as the drive takes it in pp: no new set-point before a
        // homing (D61), every target relative with P0601 = 4 (D67).
        let mut seen = cw;
        if index == CONTROLWORD && running == mode::PP {
            if !self.homed && positioning::homing_required(ctx) {
                seen &= !0x10;
            }
            if positioning::always_relative(ctx) {
                seen |= 0x40;
            }
        }
        if seen != cw {
            let _ = ctx.set_value(CONTROLWORD, 0, &(seen as u16).to_le_bytes());
        }
        // D63: the manufacturer's shutdown and disable operation codes −1, −2.
        option_codes::as_cia(ctx, |ctx| self.drive.written(ctx, &PROFILE, index));
        let _ = ctx.set_value(CONTROLWORD, 0, &(cw as u16).to_le_bytes());
        let _ = ctx.set_value(speed::TARGET_VELOCITY, 0, &[a, b, c, d]);
        self.positioning(ctx, seen);
    }

    /// The positioning errors after the profile ran (D61): pp enabled
    /// without homing; a new target the software limits cut; a fault reset
    /// once homed acknowledges the first.
    fn positioning(&mut self, ctx: &mut Ctx<'_>, cw: u32) {
        if cw & 0x80 != 0 && self.homed {
            ctx.clear_error(positioning::CODE);
        }
        let (running, status) = running(ctx);
        if running != mode::PP || self.drive.state() != PdsState::OperationEnabled {
            return;
        }
        if !self.homed && positioning::homing_required(ctx) {
            // Raised once: an active error is not raised again.
            ctx.raise_error(positioning::CODE, positioning::not_homed());
        } else if cw & 0x10 != 0 && status & statusword::INTERNAL_LIMIT != 0 {
            // A new set-point (bit 4) the software limits cut: the fault follows at
            // once, so no later write finds bit 11 still set while enabled.
            self.limit_fault(ctx, positioning::limit(ctx, cw));
        }
    }

    /// §4.4.4 (D65): the axis running onto a hardware limit switch, outside
    /// homing (where methods 17/18 look for it) and with the drive function
    /// on, is drive error 198 (negative) or 199 (positive).
    fn limit_switches(&mut self, ctx: &mut Ctx<'_>) {
        let on = self.drive.drive.axis.switches();
        let on = u8::from(on.negative_limit) | u8::from(on.positive_limit) << 1;
        let reached = on & !core::mem::replace(&mut self.switches, on);
        if reached != 0 && self.drive.state() == PdsState::OperationEnabled && running(ctx).0 != mode::HM {
            self.limit_fault(ctx, positioning::hardware_limit(reached & 1 == 0));
        }
    }

    /// D66: the SYNC off its interval or missing while the drive follows it
    /// (Operation enabled in −4 or ip): drive error 00A5h, which a fault
    /// reset acknowledges once the PLL runs in step again.
    fn not_synchronous(&mut self, ctx: &mut Ctx<'_>) {
        if self.drive.state() == PdsState::OperationEnabled && matches!(running(ctx).0, mode::IP | -4) {
            self.drive.drive.report(sync::NOT_SYNCHRONOUS);
            self.drive.drive.out_of_step = true;
        }
    }

    /// A limit's positioning error: EMCY 8600h with drive error `info`, the
    /// drive reacting as 0x605A says (§4.4.3: "Verhalten des Antriebs über 605Ahex einstellbar").
    fn limit_fault(&mut self, ctx: &mut Ctx<'_>, info: [u8; 5]) {
        let reaction = Reaction::of(ctx.read_u32(QUICK_STOP_OPTION, 0).map_or(-1, |v| v as i16 as i32), Reaction::QuickStopRamp);
        self.drive.raise_fault(ctx, positioning::CODE, info, reaction);
    }

    /// 0x6060 changed: the profile runs the mode [`mode_of`] gives, and
    /// 0x6061 shows the manual's read-back value.
    fn set_mode(&mut self, ctx: &mut Ctx<'_>) {
        let written = ctx.read(MODES_OF_OPERATION, 0).ok().and_then(|v| v.first().copied()).unwrap_or(0);
        // An SDO write of an unused value is refused (0x06090030) before it lands; an RPDO's
        // is not checked, so it keeps the mode as the refusal does (D51).
        let requested = if mode_of(written as i8).is_some() { written } else { self.mode as u8 };
        self.mode = requested as i8;
        let (runs, shows) = mode_of(requested as i8).unwrap_or((0, 0));
        // The profile reads its mode from 0x6060: it sees the mode it runs for the call.
        let _ = ctx.set_value(MODES_OF_OPERATION, 0, &[runs as u8]);
        self.profile_written(ctx, MODES_OF_OPERATION);
        let _ = ctx.set_value(MODES_OF_OPERATION, 0, &[requested]);
        let _ = ctx.set_value(MODES_OF_OPERATION_DISPLAY, 0, &[shows as u8]);
    }
}

/// P0830 bit 9 (§4.3.9): drive errors without a DSP 402 code are EMCY FF00h, not FF00h + number.
const EMCY_FF00_ONLY: u32 = 1 << 9;

/// P0830 bit 3 (§4.3.4): the default mapping has every entry 0, and 0x6007 is 3.
const ZEROED_MAPPING: u32 = 1 << 3;

/// P0830 bit 3 at reset communication (D62): 0x6007 (the guarding
/// reaction) is 3, quick stop; unless a mapping is stored (0x1010 sub 2),
/// the eight PDO mappings are empty (sub 0 through the PDO service, so the
/// PDOs follow; the entries 0) and their transmission types stay.
#[inline(never)]
fn zero_default_mapping(ctx: &mut Ctx<'_>) {
    let _ = ctx.set_value(ABORT_CONNECTION_OPTION, 0, &3i16.to_le_bytes());
    if ctx.stored(0x1600, 0, &mut [0]).is_some() {
        return;
    }
    for pdo in 0..8u16 {
        // RPDO mappings 0x1600-0x1603, then TPDO mappings 0x1A00-0x1A03.
        let index = 0x1600 + (pdo & 4) * 0x100 + (pdo & 3);
        let _ = ctx.write_object(index, 0, &[0]);
        for sub in 1..=8 {
            let _ = ctx.set_value(index, sub, &[0; 4]);
        }
    }
}

/// 0x6007 abort connection option code.
const ABORT_CONNECTION_OPTION: u16 = 0x6007;

/// The mode the profile runs (0x6061 as it wrote it: pp and hm show
/// themselves) and the statusword.
fn running(ctx: &Ctx<'_>) -> (i8, u16) {
    let shown = ctx.read(MODES_OF_OPERATION_DISPLAY, 0).ok().and_then(|v| v.first().copied()).unwrap_or(0);
    (shown as i8, ctx.read_u32(STATUSWORD, 0).unwrap_or(0) as u16)
}

/// Statusword bits 12 and 10 in hm: homing attained.
const HOMING_ATTAINED: u16 = statusword::BIT12 | statusword::TARGET_REACHED;

/// 0x100E COB-ID node guarding (DS 301 V3).
const GUARDING_COB_ID: u16 = 0x100E;

/// 0x1006 communication cycle period [µs].
const COMMUNICATION_CYCLE: u16 = 0x1006;

/// 0x1002 manufacturer status register.
const STATUS_REGISTER: u16 = 0x1002;

/// 0x1004 number of PDOs supported (DS 301 V3, §5.1 M-L1214-1244, D12).
const PDOS_SUPPORTED: u16 = 0x1004;

/// D12: 0x1004 sub 0 (all), 1 (synchronous) and 2 (asynchronous) read
/// 00040004h: four RPDOs (high word) and four TPDOs (low word), each
/// synchronous or not; read-only.
fn pdos_supported(sub: u8) -> Result<[u8; 4], AbortCode> {
    if sub <= 2 { Ok(0x0004_0004u32.to_le_bytes()) } else { Err(AbortCode::NoSubIndex) }
}

/// 0x1010 store parameters.
const STORE: u16 = 0x1010;
/// 0x1011 restore default parameters.
const RESTORE: u16 = 0x1011;

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
