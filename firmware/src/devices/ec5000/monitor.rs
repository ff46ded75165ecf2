//! The EC5000's own monitoring beyond CiA 402: the warnings of its EMCY
//! table (0xFFA8/0xFFA9 with the threshold and hysteresis of 0x4231, D48 and
//! D53; 0xFFD4), the monitoring values 0x2200 (D49) with the counters kept
//! across power-off (D55) and the hourly power average (D67), and the
//! traffic lights 0x2210/0x2211 (D50, the lifetime light D68).

use super::roller::{COLD_FAULT_C, Roller, TOO_COLD};
use canopen_core::axis::fault;
use canopen_core::node::Ctx;
use canopen_core::profiles::cia402::Cia402;
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::profiles::cia402::fsa::PdsState;
use canopen_core::profiles::cia402::objects::signed;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;

/// EMCY 0xFFA8 "Motor temperature close to high" (class W, §9.2).
pub const TEMPERATURE_WARNING: EmcyCode = EmcyCode(0xFFA8);
/// EMCY 0xFFA9 "Motor temperature close to low" (W), 10 °C above the cold fault (D53).
pub const COLD_WARNING: EmcyCode = EmcyCode(0xFFA9);
const COLD_WARNING_C: i16 = COLD_FAULT_C + 10;
/// EMCY 0xFFAA "Power reduced by temperature limiter" (W): half the speed
/// limit from 100 °C, 5 K above the warning and 10 K below the fault (D53).
pub const DERATING: EmcyCode = EmcyCode(0xFFAA);
const DERATING_C: i16 = 100;
/// EMCY 0xFFD4 "Motor speed warning (heavy load)" (W).
pub const SPEED_WARNING: EmcyCode = EmcyCode(0xFFD4);
/// 0x4231 "High Temperature Warning Level": sub 1 threshold, sub 2 hysteresis [°C].
const WARNING_LEVEL: u16 = 0x4231;
/// 0x2200 "Monitoring Values".
const MONITORING: u16 = 0x2200;
/// 0x2210 "Lifetime traffic light".
const LIFETIME: u16 = 0x2210;
/// 0x2211 "Health traffic light": sub 1 temperature, sub 2 power, sub 3 error quantity.
const HEALTH: u16 = 0x2211;
/// 0x4048 "Nominal Power" [W]: the power at the rated speed (D67).
const NOMINAL_POWER: u16 = 0x4048;
/// The roller's nominal life [motor revolutions]: 20,000 h at the rated
/// 3,000 min⁻¹ (D68); the lifetime light is yellow from 90 % of it.
const NOMINAL_LIFE_REVS: u32 = 3_600_000_000;
const LIFETIME_YELLOW_REVS: u32 = NOMINAL_LIFE_REVS / 10 * 9;
/// The power average's window [s of uptime]: an hour (D67, "W/h").
const HOUR_S: u32 = 3600;
/// Traffic light colours (0x2210/0x2211: "0 = grün, 1 = gelb, 2 = rot").
const GREEN: u8 = 0;
const YELLOW: u8 = 1;
const RED: u8 = 2;
/// The monitoring runs every 100 ms (§6.1: the values are updated at
/// intervals), not at each of the profile's 1 ms ticks: it would cost more
/// than the profile's own part of a frame.
const PERIOD_US: u64 = 100_000;
/// (object, sub, length) of each value the monitoring shows, in the order of `Monitor::shown`.
const SHOWN: [(u16, u8, u8); 13] = [
    (MONITORING, 1, 4),
    (MONITORING, 2, 4),
    (MONITORING, 3, 4),
    (MONITORING, 4, 2),
    (MONITORING, 5, 2),
    (MONITORING, 6, 2),
    (MONITORING, 7, 2),
    (MONITORING, 8, 1),
    (MONITORING, 9, 4),
    (LIFETIME, 0, 1),
    (HEALTH, 1, 1),
    (HEALTH, 2, 1),
    (HEALTH, 3, 1),
];
/// Entries 0x1003 holds (sub 1..8): a full history is red (D50).
const HISTORY_DEPTH: u32 = 8;
/// The 0x2200 sub-indices kept across power-off (D55): start/stops, working
/// time, lowest and highest temperature, quick stops, rotations.
const REMANENT: [u8; 6] = [1, 2, 4, 5, 7, 9];
/// Changed counters are stored at most this often [s of uptime] (D55), and
/// when the DC link collapses.
const STORE_PERIOD_S: u32 = 8 * 3600;

/// Whole seconds and the microseconds towards the next one: a 32-bit count
/// (a 64-bit division is a library call on a Cortex-M3).
#[derive(Debug, Clone, Copy)]
struct Seconds {
    s: u32,
    us: u32,
}

impl Seconds {
    const ZERO: Seconds = Seconds { s: 0, us: 0 };

    fn add(&mut self, us: u32) {
        let total = self.us.saturating_add(us);
        self.s = self.s.saturating_add(total / 1_000_000);
        self.us = total % 1_000_000;
    }
}

/// What the monitoring remembers between polls.
#[derive(Debug)]
pub struct Monitor {
    /// EMCY 0xFFA8, 0xFFA9 and 0xFFD4 are active.
    warning: bool,
    cold: bool,
    slowed: bool,
    derated: bool,
    /// The counters were read from the stored set (at power-on).
    restored: bool,
    /// A remanent value changed since it was stored; the uptime of that store [s].
    dirty: bool,
    /// The counters are to be stored again once the node's store in stages
    /// (an SDO 0x1011 restore) is done (D55).
    keep_pending: bool,
    stored_s: u32,
    /// The time of the last run [µs], once `ran`. Not `Option`s, here and in
    /// `extremes`: measured (`cargo xtask size`), the two made the ec5000
    /// image 524 B larger, in the poll's deadline and in the node's code,
    /// whose fields behind the device's moved by the 8 bytes they take.
    last_us: u64,
    ran: bool,
    /// The position then [inc], and increments turned towards the next motor revolution.
    last_position: i64,
    travel: u32,
    last_state: PdsState,
    moving: bool,
    start_stops: u32,
    working: Seconds,
    uptime: Seconds,
    /// Lowest and highest temperature seen [°C]; from power-on
    /// (`i16::MAX`, `i16::MIN`) until a reading or the stored ones.
    extremes: (i16, i16),
    quick_stops: u16,
    rotations: u32,
    /// The mechanical energy of the hour of uptime running [mJ].
    energy_mj: u32,
    /// 0x2200 sub 8: the mean mechanical power of the last full hour [W] (D67).
    power_average: u8,
    /// 0x4231 sub 1 and sub 2, read when written and at reset application
    /// (a dictionary look-up in every tick costs more than the rest).
    threshold: i16,
    /// The temperature the warnings were last checked at [°C] (`i16::MIN`: check again).
    checked_c: i16,
    hysteresis: i16,
    /// What 0x2200 sub 1..9, 0x2210 and 0x2211 sub 1..3 show, so that only a
    /// change is written, once `shown_valid` (all written since the reset).
    shown: [i32; 13],
    shown_valid: bool,
}

impl Monitor {
    /// At power-on: no warning, nothing counted.
    pub const NEW: Monitor = Monitor {
        warning: false,
        cold: false,
        slowed: false,
        derated: false,
        restored: false,
        dirty: false,
        keep_pending: false,
        stored_s: 0,
        last_us: 0,
        ran: false,
        last_position: 0,
        travel: 0,
        last_state: PdsState::NotReadyToSwitchOn,
        moving: false,
        start_stops: 0,
        working: Seconds::ZERO,
        uptime: Seconds::ZERO,
        extremes: (0, 0),
        quick_stops: 0,
        rotations: 0,
        energy_mj: 0,
        power_average: 0,
        // Zero, as the whole node (canopen_core::node): 0x4231 is read at reset application.
        threshold: 0,
        checked_c: 0,
        hysteresis: 0,
        shown: [0; 13],
        shown_valid: false,
    };

    /// Reads 0x4231 again (after a write to it, and at reset application).
    #[inline(never)]
    pub fn levels(&mut self, ctx: &Ctx<'_>) {
        self.threshold = signed(ctx, WARNING_LEVEL, 1).unwrap_or(95) as i16;
        self.hysteresis = signed(ctx, WARNING_LEVEL, 2).unwrap_or(2) as i16;
        self.checked_c = i16::MIN;
    }

    /// Counts, checks and shows what the drive did since the last poll, and
    /// tells the roller its warnings for statusword bit 7 (D48, D53); the
    /// profile then writes the statusword again.
    #[inline(never)]
    pub fn update(&mut self, ctx: &mut Ctx<'_>, drive: &mut Cia402<Roller>, increments_per_rev: u32) {
        if self.keep_pending {
            self.keep(ctx);
        }
        // Quick stops at every poll: one at rest lasts a single tick.
        let state = drive.state();
        if state == PdsState::QuickStopActive && self.last_state != PdsState::QuickStopActive {
            self.quick_stops = self.quick_stops.saturating_add(1);
        }
        self.last_state = state;
        // The warnings at every poll too, so that the EMCY and bit 7 change
        // together; checked again only when what they depend on changed (the
        // poll runs with every frame).
        let roller = &mut drive.drive;
        let t = roller.temperature();
        let slowed = roller.slowed();
        if t != self.checked_c || slowed != self.slowed {
            self.checked_c = t;
            let [lo, hi] = t.to_le_bytes();
            let info = [lo, hi, 0, 0, 0];
            let (threshold, hysteresis) = (self.threshold, self.hysteresis);
            // D48: on at T >= threshold, off at T <= threshold - hysteresis (95/93 °C by default).
            warn(ctx, &mut self.warning, t >= threshold, t <= threshold.saturating_sub(hysteresis), TEMPERATURE_WARNING, info);
            warn(ctx, &mut self.cold, t <= COLD_WARNING_C, t >= COLD_WARNING_C + hysteresis, COLD_WARNING, info);
            warn(ctx, &mut self.derated, t >= DERATING_C, t <= DERATING_C - hysteresis, DERATING, info);
            warn(ctx, &mut self.slowed, slowed, !slowed, SPEED_WARNING, [0; 5]);
            (roller.warned, roller.derated) = (self.warning || self.cold || self.derated, self.derated);
            drive.refresh();
        }
        let axis = &drive.drive;
        let now = ctx.now().as_micros();
        let since = now.saturating_sub(self.last_us);
        if self.ran && since < PERIOD_US {
            return;
        }
        let elapsed = if self.ran { since.min(u64::from(u32::MAX)) as u32 } else { 0 };
        (self.last_us, self.ran) = (now, true);
        let hour = self.uptime.s / HOUR_S;
        self.uptime.add(elapsed);
        // D49: a start is the roller leaving standstill; a position change at
        // standstill is a new reference (homing), not a turn.
        let moving = axis.velocity() != 0;
        let position = axis.position();
        // Also the last stretch of a roller that stopped since the last run.
        if moving || self.moving {
            self.working.add(elapsed);
            let turned = position.abs_diff(self.last_position).min(u64::from(u32::MAX)) as u32;
            let travel = self.travel.saturating_add(turned);
            self.rotations = self.rotations.saturating_add(travel / increments_per_rev.max(1));
            self.travel = travel % increments_per_rev.max(1);
            if moving && !self.moving {
                self.start_stops = self.start_stops.saturating_add(1);
            }
        }
        self.moving = moving;
        self.last_position = position;
        self.average_power(ctx, axis, elapsed, hour);
        let (low, high) = (self.extremes.0.min(t), self.extremes.1.max(t));
        self.extremes = (low, high);

        // D50: the health traffic lights.
        let temperature = if matches!(axis.fault(), fault::OVER_TEMPERATURE | TOO_COLD) {
            RED
        } else if self.warning || self.cold {
            YELLOW
        } else {
            GREEN
        };
        let power = if axis.dc_link_mv() == 0 {
            RED
        } else if self.derated {
            YELLOW
        } else {
            GREEN
        };
        let errors = match ctx.read_u32(0x1003, 0).unwrap_or(0) {
            0 => GREEN,
            n if n < HISTORY_DEPTH => YELLOW,
            _ => RED,
        };
        // D68: the lifetime light, from the motor revolutions.
        let lifetime = if self.rotations >= LIFETIME_YELLOW_REVS { YELLOW } else { GREEN };
        // In the order of `SHOWN` and `shown`.
        let values = [
            self.start_stops as i32,
            self.working.s as i32,
            self.uptime.s as i32,
            i32::from(low),
            i32::from(high),
            i32::from(t),
            i32::from(self.quick_stops),
            i32::from(self.power_average),
            self.rotations as i32,
            i32::from(lifetime),
            i32::from(temperature),
            i32::from(power),
            i32::from(errors),
        ];
        for (i, (&(index, sub, len), value)) in SHOWN.iter().zip(values).enumerate() {
            self.show(ctx, i, (index, sub), usize::from(len), value);
        }
        self.shown_valid = true;
        // D55: changed counters at most every 8 h, and at once when the power fails.
        if self.dirty && (power == RED || self.uptime.s.wrapping_sub(self.stored_s) >= STORE_PERIOD_S) {
            self.stored_s = self.uptime.s;
            self.dirty = ctx.save_objects(MONITORING, MONITORING).is_err();
        }
    }

    /// D67: adds the mechanical power the roller delivers now over the
    /// `elapsed` µs since the last run to the hour's energy, and when the
    /// uptime leaves hour `hour` makes its mean the power average. The power
    /// is 0x4048 at the rated torque and speed (3,000 min⁻¹, D45): 0x4048 ×
    /// |torque| [‰] × |speed| [‰ of rated] / 10⁶, in either direction.
    fn average_power(&mut self, ctx: &Ctx<'_>, axis: &Roller, elapsed: u32, hour: u32) {
        // Each factor bounded, so that no product overflows (and no
        // saturating step costs code): speed ≤ 2000 ‰, torque ≤ 3000 ‰ (the
        // axis's limit), 0x4048 ≤ 255 W, a sample ≤ 1 s.
        let max = super::AXIS.max_velocity;
        let speed = axis.velocity().unsigned_abs().min(2 * max) * 1000 / max;
        let torque = u32::from(axis.torque().unsigned_abs()).min(3000);
        let nominal_w = ctx.read_u32(NOMINAL_POWER, 0).unwrap_or(0).min(255);
        let mw = nominal_w * torque * speed / 1000;
        // A sample's part below a millijoule is dropped: less than 0.01 Wh an hour.
        self.energy_mj = self.energy_mj.saturating_add(mw * (elapsed / 1000).min(1000) / 1000);
        if self.uptime.s / HOUR_S != hour {
            // The energy of an hour [Wh] is its mean power [W], rounded.
            let wh = self.energy_mj.saturating_add(HOUR_S * 500) / (HOUR_S * 1000);
            self.power_average = wh.min(u32::from(u8::MAX)) as u8;
            self.energy_mj = 0;
        }
    }

    /// Whether the next [`Monitor::update`] has work before its period ends:
    /// the temperature, the speed warning or the PDS state changed since it
    /// last looked (a tick did it), or a store waits.
    pub fn pending(&self, drive: &Cia402<Roller>) -> bool {
        let roller = &drive.drive;
        self.keep_pending || drive.state() != self.last_state || roller.temperature() != self.checked_c || roller.slowed() != self.slowed
    }

    /// When the monitoring runs next: one period after its last run.
    pub fn next(&self) -> Option<Instant> {
        Some(Instant::from_micros(if self.ran { self.last_us.saturating_add(PERIOD_US) } else { 0 }))
    }

    /// Writes `value` to (index, sub) with `len` bytes if it differs from what slot `i` shows.
    #[inline(never)]
    fn show(&mut self, ctx: &mut Ctx<'_>, i: usize, (index, sub): (u16, u8), len: usize, value: i32) {
        let valid = self.shown_valid;
        if let Some(shown) = self.shown.get_mut(i).filter(|s| !valid || **s != value) {
            *shown = value;
            self.dirty |= valid && index == MONITORING && REMANENT.contains(&sub);
            if let Some(bytes) = value.to_le_bytes().get(..len) {
                let _ = ctx.set_value(index, sub, bytes);
            }
        }
    }

    /// Stores the counters again after 0x1011 marked the manufacturer
    /// parameters for their defaults (D55).
    /// While the node's store in stages runs (the restore itself, by SDO),
    /// at the first poll after it.
    pub fn keep(&mut self, ctx: &mut Ctx<'_>) {
        self.keep_pending = ctx.storing();
        if !self.keep_pending {
            self.dirty = ctx.save_objects(MONITORING, MONITORING).is_err();
        }
    }

    /// At reset application: the warnings are gone with the EMCY state; the
    /// counters go on (they count the roller's life, not the application's),
    /// and at power-on they start from the stored ones (D55).
    pub fn reset(&mut self, ctx: &mut Ctx<'_>) {
        (self.warning, self.cold, self.slowed, self.derated, self.shown_valid) = (false, false, false, false, false);
        self.levels(ctx);
        if core::mem::replace(&mut self.restored, true) {
            return;
        }
        self.extremes = (i16::MAX, i16::MIN);
        for sub in REMANENT {
            let mut v = [0; 4];
            if ctx.stored(MONITORING, sub, &mut v).is_none() {
                return;
            }
            let [w, n] = [u32::from_le_bytes(v), u32::from(u16::from_le_bytes([v[0], v[1]]))];
            match sub {
                1 => self.start_stops = w,
                2 => self.working.s = w,
                4 => self.extremes.0 = n as i16,
                5 => self.extremes.1 = n as i16,
                7 => self.quick_stops = n as u16,
                _ => self.rotations = w,
            }
        }
    }
}

/// Raises EMCY `code` with `info` when `on`, clears it when `off` (a warning: no fault reaction).
fn warn(ctx: &mut Ctx<'_>, active: &mut bool, on: bool, off: bool, code: EmcyCode, info: [u8; 5]) {
    if !*active && on {
        *active = true;
        ctx.raise_error(code, info);
    } else if *active && off {
        *active = false;
        ctx.clear_error(code);
    }
}
