//! CiA 406 encoder profile, class C2: the position 0x6004 from a
//! [`PositionSource`], with scaling, preset, speed and acceleration, work
//! areas, alarms and warnings with their EMCY, and operating time.
//!
//! An [`Encoder`] is the profile's state; a device's
//! [`crate::node::Application`] holds one and calls it from its hooks
//! (`on_nmt`, `check_write`, `written`, `sample`, `poll`), adding its own
//! rules around it. It reads and writes the dictionary only through the
//! hook's [`Ctx`], so the SDO server, the TPDOs and the application see
//! the same values. The cyclic timer 0x6200 is the device's: it is one
//! value with TPDO1's event timer (0x1800:05), kept so by the device.
//!
//! Every sample (each [`Config::update`], and at each SYNC before the
//! synchronous TPDOs are built) reads the sensor and moves the position by
//! the steps moved since the last one ([`scaling`]); a reset computes it
//! from the absolute count and the stored preset offset (0x6509).

pub mod diag;
pub mod scaling;
pub mod source;
pub mod speed;

use crate::abort::AbortCode;
use crate::node::Ctx;
use crate::od::le_u32;
use crate::time::{Duration, Instant};
use diag::{BitEmcy, EmcyChange, ErrorEmcy, FaultAlarm};
use scaling::Scaling;
pub use source::{CounterRegister, ManualShaft, PositionSource, QuadratureCounter, SensorFault, SimulatedShaft};
use speed::{Gate, SpeedFormat};

/// The profile's object indices (CiA 406 v4).
pub mod index {
    /// 0x6000 Operating parameters.
    pub const OPERATING_PARAMETERS: u16 = 0x6000;
    /// 0x6001 Measuring units per revolution (MUR).
    pub const MEASURING_UNITS_PER_REVOLUTION: u16 = 0x6001;
    /// 0x6002 Total measuring range in measuring units (TMR).
    pub const TOTAL_MEASURING_RANGE: u16 = 0x6002;
    /// 0x6003 Preset value.
    pub const PRESET_VALUE: u16 = 0x6003;
    /// 0x6004 Position value.
    pub const POSITION_VALUE: u16 = 0x6004;
    /// 0x600B Position raw value (64 bit).
    pub const POSITION_RAW_64: u16 = 0x600B;
    /// 0x600C Position raw value.
    pub const POSITION_RAW: u16 = 0x600C;
    /// 0x6030 Speed value.
    pub const SPEED_VALUE: u16 = 0x6030;
    /// 0x6031 Speed parameters.
    pub const SPEED_PARAMETERS: u16 = 0x6031;
    /// 0x6040 Acceleration value.
    pub const ACCELERATION_VALUE: u16 = 0x6040;
    /// 0x6041 Acceleration parameters.
    pub const ACCELERATION_PARAMETERS: u16 = 0x6041;
    /// 0x6200 Cyclic timer.
    pub const CYCLIC_TIMER: u16 = 0x6200;
    /// 0x6400 Work area state.
    pub const WORK_AREA_STATE: u16 = 0x6400;
    /// 0x6401 Work area low limit.
    pub const WORK_AREA_LOW_LIMIT: u16 = 0x6401;
    /// 0x6402 Work area high limit.
    pub const WORK_AREA_HIGH_LIMIT: u16 = 0x6402;
    /// 0x6500 Operating status.
    pub const OPERATING_STATUS: u16 = 0x6500;
    /// 0x6501 Single-turn resolution (steps per revolution).
    pub const SINGLE_TURN_RESOLUTION: u16 = 0x6501;
    /// 0x6502 Number of distinguishable revolutions.
    pub const NUMBER_OF_REVOLUTIONS: u16 = 0x6502;
    /// 0x6503 Alarms.
    pub const ALARMS: u16 = 0x6503;
    /// 0x6505 Warnings.
    pub const WARNINGS: u16 = 0x6505;
    /// 0x6508 Operating time (0.1 h).
    pub const OPERATING_TIME: u16 = 0x6508;
    /// 0x6509 Offset value.
    pub const OFFSET_VALUE: u16 = 0x6509;
    /// 0x650A Module identification (manufacturer offset, min, max).
    pub const MODULE_IDENTIFICATION: u16 = 0x650A;
}

/// 0x6503 bit 0: position error.
pub const ALARM_POSITION: u16 = 1 << 0;
/// 0x6503 bit 15: device error (the sensor does not answer).
pub const ALARM_DEVICE: u16 = 1 << 15;
/// 0x6505 bit 0: overspeed.
pub const WARNING_OVERSPEED: u16 = 1 << 0;

/// One hour-tenth (the unit of 0x6508), in µs.
const OPERATING_TIME_UNIT: u64 = 360_000_000;

/// What a device fixes of the profile.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// The 0x6000 bits the device supports; writing another aborts 0x06090030.
    pub operating_mask: u16,
    /// The 0x6000 bit that selects units per second for the speed (else rpm); 0: rpm only.
    pub speed_format_bit: u16,
    /// How often the sensor is sampled.
    pub update: Duration,
    /// Speed above which 0x6505 bit 0 (overspeed) is set, in rpm; 0: never.
    pub overspeed_rpm: u32,
    /// The 0x6503 bits and the EMCY each sensor fault raises; a fault not
    /// listed sets bit 0 (position error) and raises none.
    pub faults: &'static [FaultAlarm],
    /// The EMCY each warning bit (0x6505) raises.
    pub warnings: &'static [BitEmcy],
    /// The EMCY the non-volatile memory raises when it fails a store (a
    /// storage fault, abort 0x06060000), besides warning bit 15; it stays
    /// active until a reset communication. `None`: the warning alone.
    pub storage_fault: Option<ErrorEmcy>,
    /// The operating time 0x6508 is stored every this many tenths of an
    /// hour and counts on from the stored value after a power cycle; 0: it
    /// counts from 0 at each power-on.
    pub operating_time_saved_every: u32,
}

/// The profile's state: `const` and all zero bits ([`Encoder::NEW`],
/// [`crate::node`]). The dictionary holds every value a
/// master sees; this holds only what lies between two samples.
#[derive(Clone, Copy, Debug, Default)]
pub struct Encoder<P> {
    /// The sensor.
    pub source: P,
    /// Whether the position has been computed since the last reset.
    tracking: bool,
    /// The count at the last sample.
    last_count: u64,
    /// The position numerator ([`scaling`]).
    num: u64,
    /// The preset offset (0x6509), in measuring units `0..TMR`.
    offset: u32,
    /// The scaling in force, once `scaled` (an `Option` would not be all zero bits).
    scaling: Scaling,
    scaled: bool,
    gate: Gate,
    speed: i32,
    next_sample: Instant,
    /// The sensor fault active (index into [`Config::faults`] + 1; 0: none,
    /// `u8::MAX`: one the table does not list).
    fault: u8,
    /// The operating time stored when the device powered on, in 0.1 h.
    time_base: u32,
    /// Whether `time_base` has been read (once per power-on, not per reset).
    time_loaded: bool,
    /// The operating time the storage holds, in 0.1 h.
    time_saved: u32,
}

impl<P: PositionSource> Encoder<P> {
    /// An encoder on `source`, not yet reset.
    pub const fn new(source: P) -> Self {
        Encoder {
            source,
            tracking: false,
            last_count: 0,
            num: 0,
            offset: 0,
            scaling: Scaling::NONE,
            scaled: false,
            gate: Gate::NEW,
            speed: 0,
            next_sample: Instant::ZERO,
            fault: 0,
            time_base: 0,
            time_loaded: false,
            time_saved: 0,
        }
    }

    /// The position value now (as 0x6004 holds it after the last sample).
    pub fn position(&self) -> u32 {
        self.scaling.position(self.num)
    }

    /// Reset application: the parameters hold their stored values, the
    /// offset comes back from storage, and the position is computed from
    /// the absolute count.
    pub fn reset(&mut self, ctx: &mut Ctx<'_>, config: &Config) {
        let mut buf = [0u8; 4];
        let stored = match ctx.stored(index::OFFSET_VALUE, 0, &mut buf) {
            Some(4) => u32::from_le_bytes(buf),
            _ => 0,
        };
        self.set_offset(ctx, stored);
        // The operating time counts on from what was stored at power-on; a
        // later reset keeps counting (a restore of the defaults does not zero it).
        let saved = match ctx.stored(index::OPERATING_TIME, 0, &mut buf) {
            Some(4) => Some(u32::from_le_bytes(buf)),
            _ => None,
        };
        if !self.time_loaded {
            self.time_base = saved.unwrap_or(0);
            self.time_loaded = true;
        }
        // Nothing stored (a restore of the defaults): stored again at the next interval.
        self.time_saved = saved.unwrap_or(0);
        let _ = ctx.set_value(index::OPERATING_TIME, 0, &self.operating_time(ctx.now()).to_le_bytes());
        self.tracking = false;
        self.speed = 0;
        self.gate = Gate::NEW;
        self.rescale(ctx);
        self.sample(ctx, config);
    }

    /// Validates a write to a profile object (after the dictionary's type
    /// and limit checks).
    pub fn check_write(&self, ctx: &Ctx<'_>, config: &Config, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let value = le_u32(data);
        let read = |i| ctx.read_u32(i, 0).unwrap_or(0);
        match (index, sub) {
            (index::OPERATING_PARAMETERS, 0) if value & !u32::from(config.operating_mask) != 0 => Err(AbortCode::InvalidValue),
            (index::MEASURING_UNITS_PER_REVOLUTION, 0) => {
                scaling::check_range(value, read(index::TOTAL_MEASURING_RANGE))?;
                if value > read(index::SINGLE_TURN_RESOLUTION) { Err(AbortCode::ValueTooHigh) } else { Ok(()) }
            }
            (index::TOTAL_MEASURING_RANGE, 0) => scaling::check_range(read(index::MEASURING_UNITS_PER_REVOLUTION), value),
            (index::PRESET_VALUE, 0) => scaling::check_preset(&self.current_scaling(ctx), value),
            _ => Ok(()),
        }
    }

    /// A profile object holds a new value.
    pub fn written(&mut self, ctx: &mut Ctx<'_>, config: &Config, index: u16, sub: u8) {
        match (index, sub) {
            (index::OPERATING_PARAMETERS | index::MEASURING_UNITS_PER_REVOLUTION | index::TOTAL_MEASURING_RANGE, 0) => {
                // A new scaling shows the same shaft position in the new units,
                // and the preset point keeps the preset's value.
                let old = self.current_scaling(ctx);
                if self.offset != 0 {
                    // The position now, in the old units.
                    self.sample(ctx, config);
                }
                self.rescale(ctx);
                if self.offset != 0 {
                    self.keep_preset(ctx, &old);
                }
                self.tracking = false;
                self.sample(ctx, config);
            }
            (index::PRESET_VALUE, 0) => self.preset(ctx, config),
            // New limits apply to the position held, not only from the next sample.
            (index::WORK_AREA_LOW_LIMIT | index::WORK_AREA_HIGH_LIMIT, _) => {
                let position = self.position();
                self.work_areas(ctx, position);
            }
            _ => {}
        }
    }

    /// Samples the sensor (a SYNC: the synchronous TPDOs carry this).
    pub fn sample(&mut self, ctx: &mut Ctx<'_>, config: &Config) {
        let now = ctx.now();
        let scaling = self.current_scaling(ctx);
        let count = match self.source.count(now) {
            Ok(count) => count,
            Err(fault) => {
                self.set_fault(ctx, config, Some(fault));
                // The movement during the fault is unknown: start again from the absolute count.
                self.tracking = false;
                return;
            }
        };
        self.set_fault(ctx, config, None);
        let range = self.source.range();
        let steps = steps_between(self.last_count, count, range);
        if self.tracking && steps.unsigned_abs() <= scaling::MAX_STEP as u64 {
            // The physical counter wrapped: the offset takes up what it dropped, so the
            // position does not jump, now or after the next power-on.
            if range != 0 && steps != 0 && (steps > 0) == (count < self.last_count) {
                self.rebase(ctx, config, &scaling, count);
            }
            self.num = scaling.advance(self.num, steps);
            // |steps| ≤ MAX_STEP: checked above.
            #[allow(clippy::arithmetic_side_effects)]
            let signed = if scaling.ccw { -steps } else { steps };
            let length = Duration::from_millis(u64::from(ctx.read_u32(index::SPEED_PARAMETERS, 2).unwrap_or(100).max(1)));
            if let Some(m) = self.gate.add(now, signed, length) {
                self.measured(ctx, config, &scaling, m);
            }
        } else {
            self.num = scaling.at(count, self.offset);
            self.gate.restart(now);
            self.tracking = true;
        }
        self.last_count = count;
        let position = scaling.position(self.num);
        let _ = ctx.set_value(index::POSITION_VALUE, 0, &position.to_le_bytes());
        let _ = ctx.set_value(index::POSITION_RAW, 0, &(count as u32).to_le_bytes());
        let _ = ctx.set_value(index::POSITION_RAW_64, 0, &count.to_le_bytes());
        self.work_areas(ctx, position);
    }

    /// Timers: samples every [`Config::update`] and counts the operating
    /// time; returns when to run again.
    pub fn poll(&mut self, ctx: &mut Ctx<'_>, config: &Config) -> Option<Instant> {
        let now = ctx.now();
        if now >= self.next_sample {
            self.sample(ctx, config);
            self.next_sample = now + config.update;
            let tenths = self.operating_time(now);
            if ctx.read_u32(index::OPERATING_TIME, 0) != Some(tenths) {
                let _ = ctx.set_value(index::OPERATING_TIME, 0, &tenths.to_le_bytes());
                let every = config.operating_time_saved_every;
                if every != 0 && tenths >= self.time_saved.saturating_add(every) {
                    // Stored whatever the outcome: a failed store is tried again one interval later.
                    self.time_saved = tenths;
                    if let Err(e) = ctx.save_objects(index::OPERATING_TIME, index::OPERATING_TIME) {
                        self.store_failed(ctx, config, e);
                    }
                }
            }
        }
        Some(self.next_sample)
    }

    /// The operating time at `now` (since power-on), in 0.1 h.
    fn operating_time(&self, now: Instant) -> u32 {
        self.time_base.saturating_add((now.as_micros() / OPERATING_TIME_UNIT) as u32)
    }

    /// A store the profile triggers failed: warning bit 15 (0x6505) and,
    /// for a storage fault, the device's memory EMCY.
    fn store_failed(&mut self, ctx: &mut Ctx<'_>, config: &Config, e: AbortCode) {
        if let (AbortCode::Hardware, Some(emcy)) = (e, config.storage_fault) {
            ctx.raise_error_with(emcy.code, emcy.register, emcy.info);
        }
        self.set_bits(ctx, index::WARNINGS, config.warnings, WARNING_MEMORY, WARNING_MEMORY, None);
    }

    /// The sensor reports `fault` (or none): 0x6503 and the EMCY follow
    /// the [`Config::faults`] entry; a new fault's EMCY goes out before the
    /// old one's is cleared, so no "error reset" comes between them.
    fn set_fault(&mut self, ctx: &mut Ctx<'_>, config: &Config, fault: Option<SensorFault>) {
        let slot = match fault {
            None => 0,
            Some(f) => config.faults.iter().position(|a| a.fault == f).map_or(u8::MAX, |i| (i as u8).saturating_add(1)),
        };
        if slot == self.fault {
            return;
        }
        let entry = |slot: u8| config.faults.get(usize::from(slot.checked_sub(1)?));
        let (old, new) = (entry(self.fault), entry(slot));
        if let Some(a) = new {
            ctx.raise_error_with(a.emcy.code, a.emcy.register, a.emcy.info);
        }
        if let Some(a) = old.filter(|o| new.is_none_or(|n| n.emcy.code != o.emcy.code)) {
            ctx.clear_error(a.emcy.code);
        }
        self.fault = slot;
        let bits = match (slot, new) {
            (0, _) => 0,
            (_, Some(a)) => a.mask,
            (_, None) => ALARM_POSITION,
        };
        let _ = ctx.set_value(index::ALARMS, 0, &bits.to_le_bytes());
    }

    /// Sets `bits` of the alarm or warning object `object` to `value`
    /// (within `mask`), raising or clearing the EMCY `table` gives them;
    /// `info` replaces the table's manufacturer bytes of a code raised now.
    pub fn set_bits(&mut self, ctx: &mut Ctx<'_>, object: u16, table: &[BitEmcy], mask: u16, value: u16, info: Option<[u8; 5]>) {
        let old = ctx.read_u32(object, 0).unwrap_or(0) as u16;
        let new = (old & !mask) | (value & mask);
        if new == old {
            return;
        }
        let _ = ctx.set_value(object, 0, &new.to_le_bytes());
        for change in diag::emcy_changes(table, old, new) {
            match change {
                EmcyChange::Raise(e) => {
                    ctx.raise_error_with(e.code, e.register, info.unwrap_or(e.info));
                }
                EmcyChange::Clear(code) => ctx.clear_error(code),
            }
        }
    }

    /// The scaling the dictionary holds now.
    fn current_scaling(&self, ctx: &Ctx<'_>) -> Scaling {
        if self.scaled { self.scaling } else { scaling_of(ctx) }
    }

    fn rescale(&mut self, ctx: &mut Ctx<'_>) {
        let s = scaling_of(ctx);
        self.scaling = s;
        self.scaled = true;
        let operating = ctx.read_u32(index::OPERATING_PARAMETERS, 0).unwrap_or(0) as u16;
        let _ = ctx.set_value(index::OPERATING_STATUS, 0, &operating.to_le_bytes());
        // The offset stays within the new range; it is stored with the scaling (0x1010) or the next preset.
        self.set_offset(ctx, self.offset);
    }

    /// The scaling changed from `old` after a preset: the offset is derived
    /// again so that the preset point still shows the preset (0x6003) and
    /// the position is the preset plus the movement since, in the new units
    /// (D40). An offset kept as a number would mean nothing in the new
    /// units (the old range's wrap of a negative offset made the position
    /// jump). The movement is the old position's distance from the preset,
    /// the shorter way round the old range.
    // Distances below 2^32 units times R or MUR (≤ 2^16) over MUR or R (≥ 1):
    // below 2^48; the old position and the preset are below TMR ≤ 2^32. In
    // u64 but for the last sum.
    #[allow(clippy::arithmetic_side_effects)]
    fn keep_preset(&mut self, ctx: &mut Ctx<'_>, old: &Scaling) {
        // Set by `rescale` just before.
        let new = self.scaling;
        let preset = u64::from(ctx.read_u32(index::PRESET_VALUE, 0).unwrap_or(0));
        let tmr = old.tmr.max(1);
        let ahead = (u64::from(old.position(self.num)) + tmr - preset % tmr) % tmr;
        let back = ahead > tmr / 2;
        let units = if back { tmr - ahead } else { ahead };
        let steps = units * u64::from(old.resolution) / u64::from(old.mur.max(1));
        let units = (steps * u64::from(new.mur) / u64::from(new.resolution.max(1))) as i64;
        let moved = if back == (old.ccw == new.ccw) { -units } else { units };
        let bare = i64::from(new.position(new.at(self.last_count, 0)));
        self.set_offset(ctx, new.wrap(preset as i64 + moved - bare));
    }

    /// Sets the preset offset (0x6509), wrapped into `0..TMR`.
    fn set_offset(&mut self, ctx: &mut Ctx<'_>, offset: u32) {
        self.offset = self.current_scaling(ctx).wrap(i64::from(offset));
        let _ = ctx.set_value(index::OFFSET_VALUE, 0, &self.offset.to_le_bytes());
    }

    /// The preset 0x6003 becomes the position at once; the offset it
    /// takes (0x6509) is stored, so the position keeps it over a power cycle.
    fn preset(&mut self, ctx: &mut Ctx<'_>, config: &Config) {
        self.sample(ctx, config);
        let s = self.current_scaling(ctx);
        let preset = ctx.read_u32(index::PRESET_VALUE, 0).unwrap_or(0);
        let bare = s.position(s.at(self.last_count, 0));
        // Two u32s: the difference fits an i64.
        #[allow(clippy::arithmetic_side_effects)]
        let offset = i64::from(preset) - i64::from(bare);
        self.set_offset(ctx, s.wrap(offset));
        self.num = s.with_position(s.at(self.last_count, 0), preset);
        let _ = ctx.set_value(index::POSITION_VALUE, 0, &preset.to_le_bytes());
        self.work_areas(ctx, preset);
        if let Err(e) = ctx.save_objects(index::OFFSET_VALUE, index::OFFSET_VALUE) {
            self.store_failed(ctx, config, e);
        }
    }

    /// The physical counter wrapped at `count`: the offset grows by what
    /// the wrap dropped, so that count and offset give the position held.
    // Turns of a u32 range, an offset below 2^32: the sum fits an i64; the divisor is at least 1.
    #[allow(clippy::arithmetic_side_effects)]
    fn rebase(&mut self, ctx: &mut Ctx<'_>, config: &Config, s: &Scaling, count: u64) {
        // The range is whole revolutions of the sensor (PositionSource::range).
        let dropped = i64::from(s.turns(self.source.range() / u64::from(s.resolution.max(1))));
        let forward = (count < self.last_count) != s.ccw;
        let dropped = if forward { dropped } else { -dropped };
        self.set_offset(ctx, s.wrap(i64::from(self.offset) + dropped));
        if let Err(e) = ctx.save_objects(index::OFFSET_VALUE, index::OFFSET_VALUE) {
            self.store_failed(ctx, config, e);
        }
    }

    /// A speed gate closed: speed, acceleration, overspeed.
    fn measured(&mut self, ctx: &mut Ctx<'_>, config: &Config, s: &Scaling, m: speed::Measured) {
        let operating = ctx.read_u32(index::OPERATING_PARAMETERS, 0).unwrap_or(0) as u16;
        let format = if config.speed_format_bit != 0 && operating & config.speed_format_bit != 0 {
            SpeedFormat::UnitsPerSecond
        } else {
            SpeedFormat::Rpm
        };
        let c = |i, sub| ctx.read_u32(i, sub).unwrap_or(1) as u16 as i16;
        let v = speed::value(m, format, s.resolution, s.mur, c(index::SPEED_PARAMETERS, 3), c(index::SPEED_PARAMETERS, 4));
        let a = speed::acceleration(self.speed, v, m.ms, c(index::ACCELERATION_PARAMETERS, 3), c(index::ACCELERATION_PARAMETERS, 4));
        self.speed = v;
        let _ = ctx.set_value(index::SPEED_VALUE, 1, &v.to_le_bytes());
        let _ = ctx.set_value(index::ACCELERATION_VALUE, 1, &a.to_le_bytes());
        if config.overspeed_rpm != 0 {
            let over = speed::rpm(m, s.resolution).unsigned_abs() > u64::from(config.overspeed_rpm);
            let bits = if over { WARNING_OVERSPEED } else { 0 };
            self.set_bits(ctx, index::WARNINGS, config.warnings, WARNING_OVERSPEED, bits, None);
        }
    }

    /// 0x6400 for each channel.
    fn work_areas(&mut self, ctx: &mut Ctx<'_>, position: u32) {
        let channels = ctx.read_u32(index::WORK_AREA_STATE, 0).unwrap_or(0).min(254) as u8;
        let min = ctx.read_u32(index::MODULE_IDENTIFICATION, 2).unwrap_or(0) as i32;
        let max = ctx.read_u32(index::MODULE_IDENTIFICATION, 3).map_or(i32::MAX, |v| v as i32);
        for c in 1..=channels {
            let low = ctx.read_u32(index::WORK_AREA_LOW_LIMIT, c).unwrap_or(0);
            let high = ctx.read_u32(index::WORK_AREA_HIGH_LIMIT, c).unwrap_or(u32::MAX);
            let state = diag::work_area_state(position, low, high, min, max);
            if ctx.read_u32(index::WORK_AREA_STATE, c) != Some(u32::from(state)) {
                let _ = ctx.set_value(index::WORK_AREA_STATE, c, &[state]);
            }
        }
    }
}

/// 0x6505 bit 15: internal memory error (a value could not be stored).
pub const WARNING_MEMORY: u16 = 1 << 15;

/// The scaling 0x6000, 0x6001, 0x6002 and 0x6501 give.
fn scaling_of(ctx: &Ctx<'_>) -> Scaling {
    let read = |i| ctx.read_u32(i, 0).unwrap_or(0);
    Scaling::new(
        read(index::OPERATING_PARAMETERS) as u16,
        read(index::MEASURING_UNITS_PER_REVOLUTION),
        read(index::TOTAL_MEASURING_RANGE),
        read(index::SINGLE_TURN_RESOLUTION),
    )
}

/// The signed movement from count `a` to `b` on a counter wrapping at
/// `range` (0: 2^64): the shorter way round.
// Each subtraction follows the comparison that orders it; `range` is not 0
// where it divides, and `d` < `range`.
#[allow(clippy::arithmetic_side_effects)]
fn steps_between(a: u64, b: u64, range: u64) -> i64 {
    if range == 0 {
        return b.wrapping_sub(a) as i64;
    }
    // Below 2^64, so the difference modulo the range is exact in u64.
    let d = if b >= a { (b - a) % range } else { range - (a - b) % range };
    let d = d % range;
    if d > range / 2 { -((range - d) as i64) } else { d as i64 }
}

#[cfg(test)]
mod tests {
    use super::steps_between;

    #[test]
    fn movement_takes_the_short_way_round_a_wrap() {
        assert_eq!(steps_between(99, 1, 100), 2);
        assert_eq!(steps_between(1, 99, 100), -2);
        assert_eq!(steps_between(10, 30, 100), 20);
        assert_eq!(steps_between(u64::MAX, 1, 0), 2);
    }
}
