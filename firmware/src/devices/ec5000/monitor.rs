//! The EC5000's own monitoring beyond CiA 402: the over-temperature warning
//! EMCY 0xFFA8 with the threshold and hysteresis of 0x4231 (D48), the
//! monitoring values 0x2200 (D49) and the traffic lights 0x2210/0x2211 (D50).

use canopen_core::axis::{Axis, fault};
use canopen_core::node::Ctx;
use canopen_core::profiles::cia402::Cia402;
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::profiles::cia402::fsa::PdsState;
use canopen_core::profiles::cia402::objects::signed;
use canopen_core::wire::emcy::EmcyCode;

/// EMCY 0xFFA8 "Motor temperature close to high" (class W, §5.2).
pub const TEMPERATURE_WARNING: EmcyCode = EmcyCode(0xFFA8);
/// 0x4231 "High Temperature Warning Level": sub 1 threshold, sub 2 hysteresis [°C].
const WARNING_LEVEL: u16 = 0x4231;
/// 0x2200 "Monitoring Values".
const MONITORING: u16 = 0x2200;
/// 0x2211 "Health traffic light": sub 1 temperature, sub 2 power, sub 3 error quantity.
const HEALTH: u16 = 0x2211;
/// Traffic light colours (0x2210/0x2211: "0 = grün, 1 = gelb, 2 = rot").
const GREEN: u8 = 0;
const YELLOW: u8 = 1;
const RED: u8 = 2;
/// The monitoring runs every 100 ms (§6.1: the values are updated at
/// intervals), not at each of the profile's 1 ms ticks: it would cost more
/// than the profile's own part of a frame.
const PERIOD_US: u64 = 100_000;
/// Entries 0x1003 holds (sub 1..8): a full history is red (D50).
const HISTORY_DEPTH: u32 = 8;

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
    /// EMCY 0xFFA8 is active.
    warning: bool,
    /// The time of the last poll [µs], `None` before the first one.
    last_us: Option<u64>,
    /// The position then [inc], and increments turned towards the next motor revolution.
    last_position: i64,
    travel: u32,
    last_state: PdsState,
    moving: bool,
    start_stops: u32,
    working: Seconds,
    uptime: Seconds,
    /// Lowest and highest temperature seen [°C].
    extremes: Option<(i16, i16)>,
    quick_stops: u16,
    rotations: u32,
    /// 0x4231 sub 1 and sub 2, read when written and at reset application
    /// (a dictionary look-up in every tick costs more than the rest).
    threshold: i16,
    hysteresis: i16,
    /// What 0x2200 sub 1..9 and 0x2211 sub 1..3 show, so that only a change is
    /// written, once `shown_valid` (all written since the reset).
    shown: [i32; 11],
    shown_valid: bool,
}

impl Monitor {
    /// At power-on: no warning, nothing counted.
    pub const NEW: Monitor = Monitor {
        warning: false,
        last_us: None,
        last_position: 0,
        travel: 0,
        last_state: PdsState::NotReadyToSwitchOn,
        moving: false,
        start_stops: 0,
        working: Seconds::ZERO,
        uptime: Seconds::ZERO,
        extremes: None,
        quick_stops: 0,
        rotations: 0,
        // Zero, as the whole node (canopen_core::node): 0x4231 is read at reset application.
        threshold: 0,
        hysteresis: 0,
        shown: [0; 11],
        shown_valid: false,
    };

    /// Reads 0x4231 again (after a write to it, and at reset application).
    #[inline(never)]
    pub fn levels(&mut self, ctx: &Ctx<'_>) {
        self.threshold = signed(ctx, WARNING_LEVEL, 1).unwrap_or(95) as i16;
        self.hysteresis = signed(ctx, WARNING_LEVEL, 2).unwrap_or(2) as i16;
    }

    /// Counts, checks and shows what the drive did since the last poll;
    /// returns the temperature from which statusword bit 7 is on (D48).
    #[inline(never)]
    pub fn update(&mut self, ctx: &mut Ctx<'_>, drive: &Cia402<Axis>, increments_per_rev: u32) -> i16 {
        let axis = &drive.drive;
        // Quick stops at every poll: one at rest lasts a single tick.
        let state = drive.state();
        if state == PdsState::QuickStopActive && self.last_state != PdsState::QuickStopActive {
            self.quick_stops = self.quick_stops.saturating_add(1);
        }
        self.last_state = state;
        // The warning at every poll too, so that the EMCY and bit 7 change together.
        let t = drive.drive.temperature();
        let level = self.temperature_warning(ctx, t);
        let now = ctx.now().as_micros();
        if self.last_us.is_some_and(|last| now.saturating_sub(last) < PERIOD_US) {
            return level;
        }
        let elapsed = self.last_us.map_or(0, |last| now.saturating_sub(last).min(u64::from(u32::MAX)) as u32);
        self.last_us = Some(now);
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
        let (low, high) = self.extremes.map_or((t, t), |(low, high)| (low.min(t), high.max(t)));
        self.extremes = Some((low, high));

        // D50: the health traffic lights.
        let temperature = if axis.fault() == fault::OVER_TEMPERATURE {
            RED
        } else if self.warning {
            YELLOW
        } else {
            GREEN
        };
        let power = if axis.dc_link_mv() == 0 { RED } else { GREEN };
        let errors = match ctx.read_u32(0x1003, 0).unwrap_or(0) {
            0 => GREEN,
            n if n < HISTORY_DEPTH => YELLOW,
            _ => RED,
        };
        // (object, sub, length, value) of each value shown, in the order of `shown`.
        let values = [
            (MONITORING, 1, 4, self.start_stops as i32),
            (MONITORING, 2, 4, self.working.s as i32),
            (MONITORING, 3, 4, self.uptime.s as i32),
            (MONITORING, 4, 2, i32::from(low)),
            (MONITORING, 5, 2, i32::from(high)),
            (MONITORING, 6, 2, i32::from(t)),
            (MONITORING, 7, 2, i32::from(self.quick_stops)),
            (MONITORING, 9, 4, self.rotations as i32),
            (HEALTH, 1, 1, i32::from(temperature)),
            (HEALTH, 2, 1, i32::from(power)),
            (HEALTH, 3, 1, i32::from(errors)),
        ];
        for (i, (index, sub, len, value)) in values.into_iter().enumerate() {
            self.show(ctx, i, (index, sub), len, value);
        }
        self.shown_valid = true;
        level
    }

    /// Writes `value` to (index, sub) with `len` bytes if it differs from what slot `i` shows.
    #[inline(never)]
    fn show(&mut self, ctx: &mut Ctx<'_>, i: usize, (index, sub): (u16, u8), len: usize, value: i32) {
        let valid = self.shown_valid;
        if let Some(shown) = self.shown.get_mut(i).filter(|s| !valid || **s != value) {
            *shown = value;
            if let Some(bytes) = value.to_le_bytes().get(..len) {
                let _ = ctx.set_value(index, sub, bytes);
            }
        }
    }

    /// Raises or clears the temperature warning for `temperature` [°C];
    /// returns the temperature from which statusword bit 7 shows it, so that
    /// bit 7 and the EMCY agree: the threshold while clear, the lowest
    /// temperature still warned while raised.
    fn temperature_warning(&mut self, ctx: &mut Ctx<'_>, temperature: i16) -> i16 {
        // D48: on at T >= threshold, off at T <= threshold - hysteresis (95/93 °C by default).
        let threshold = i32::from(self.threshold);
        let clear_at = threshold - i32::from(self.hysteresis);
        let t = i32::from(temperature);
        if !self.warning && t >= threshold {
            self.warning = true;
            let [lo, hi] = temperature.to_le_bytes();
            ctx.raise_error(TEMPERATURE_WARNING, [lo, hi, 0, 0, 0]);
        } else if self.warning && t <= clear_at {
            self.warning = false;
            ctx.clear_error(TEMPERATURE_WARNING);
        }
        (if self.warning { clear_at + 1 } else { threshold }) as i16
    }

    /// At reset application: the warning is gone with the EMCY state; the
    /// counters go on (they count the roller's life, not the application's).
    pub fn reset(&mut self, ctx: &Ctx<'_>) {
        self.warning = false;
        self.shown_valid = false;
        self.levels(ctx);
    }
}
