//! Position scaling (CiA 406 §6.2: 0x6000 bits 0 and 2, 0x6001, 0x6002,
//! 0x6501): pure arithmetic, no state.
//!
//! The position is kept as a numerator `num = position × R + fraction` in
//! `0..TMR × R` (R = 0x6501, steps per revolution), and a movement of `d`
//! steps adds `d × MUR` to it. The output therefore wraps exactly at TMR
//! whatever TMR is (36000 with MUR 3600: ten turns), and a physical counter
//! that wraps at a range TMR does not divide cannot make it jump: only
//! the movement counts, never the counter's absolute value.

use crate::abort::AbortCode;

/// 0x6000 bit 0: code sequence, counting down when the shaft turns clockwise.
pub const CODE_SEQUENCE: u16 = 1 << 0;
/// 0x6000 bit 2: scaling function on (0x6001/0x6002 apply).
pub const SCALING: u16 = 1 << 2;
/// TMR = 0 in 0x6002 means 2^32 measuring units (CiA 406, manual L2506).
pub const FULL_RANGE: u64 = 1 << 32;

/// The scaling in force: measuring units per revolution, total measuring
/// range and direction, from 0x6000/0x6001/0x6002 and the sensor's 0x6501.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scaling {
    /// Measuring units per revolution (0x6001, or R with scaling off).
    pub mur: u32,
    /// Total measuring range in measuring units, 1..=2^32.
    pub tmr: u64,
    /// Steps per revolution of the sensor (0x6501), at least 1.
    pub resolution: u32,
    /// Counting direction inverted (0x6000 bit 0).
    pub ccw: bool,
}

impl Scaling {
    /// No scaling yet (all zero bits; every method still answers without dividing by 0).
    pub const NONE: Scaling = Scaling { mur: 0, tmr: 0, resolution: 0, ccw: false };

    /// The scaling the parameters give. With scaling off (or a MUR of 0)
    /// the position is the step count itself over the full 32 bits.
    /// Sensors of up to 2^16 steps per revolution (0x6501): the arithmetic
    /// stays within 64 bits (TMR × R < 2^48, a count below it × MUR < 2^64).
    pub fn new(operating: u16, mur: u32, tmr: u32, resolution: u32) -> Scaling {
        let resolution = resolution.clamp(1, MAX_RESOLUTION);
        let ccw = operating & CODE_SEQUENCE != 0;
        if operating & SCALING != 0 && mur != 0 {
            Scaling { mur: mur.min(resolution), tmr: if tmr == 0 { FULL_RANGE } else { u64::from(tmr) }, resolution, ccw }
        } else {
            Scaling { mur: resolution, tmr: FULL_RANGE, resolution, ccw }
        }
    }

    /// The numerator's modulus, TMR × R (below 2^48).
    // TMR ≤ 2^32 and R ≤ 2^16 (`new`): the product is below 2^49.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn modulus(&self) -> u64 {
        (self.tmr * u64::from(self.resolution)).max(1)
    }

    /// The numerator after a movement of `steps` sensor steps (positive:
    /// clockwise, as the sensor counts), in the configured direction;
    /// `|steps|` at most [`MAX_STEP`] (the caller re-synchronises on larger jumps).
    // See the bounds below; the modulus is at least 1.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn advance(&self, num: u64, steps: i64) -> u64 {
        let m = self.modulus();
        let steps = if self.ccw { -steps } else { steps };
        // |steps| ≤ 2^31 and MUR ≤ 2^16: the product fits, and so does num (< 2^48) plus it.
        let moved = steps * i64::from(self.mur);
        (num as i64 + moved).rem_euclid(m as i64) as u64
    }

    /// The numerator of the position at step count `count` with `offset`
    /// measuring units added (the preset's offset, 0x6509, below TMR).
    // Below the modulus (< 2^49) each product with MUR or R (≤ 2^16) fits; m ≥ 1.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn at(&self, count: u64, offset: u32) -> u64 {
        let m = self.modulus();
        let count = count % m;
        let count = if self.ccw { (m - count) % m } else { count };
        // count < 2^48 and MUR ≤ 2^16: no overflow.
        let scaled = (count * u64::from(self.mur)) % m;
        (scaled + u64::from(offset) * u64::from(self.resolution)) % m
    }

    /// The position value (0x6004) of a numerator, `0..TMR`.
    // The divisor is at least 1.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn position(&self, num: u64) -> u32 {
        (num / u64::from(self.resolution.max(1))) as u32
    }

    /// The numerator that makes the position `value` while keeping the
    /// fraction `num` holds (so a preset does not move the next step).
    // A u32 times R (≤ 2^16) plus a remainder below R fits a u64; r ≥ 1.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn with_position(&self, num: u64, value: u32) -> u64 {
        let r = u64::from(self.resolution.max(1));
        u64::from(value) * r + num % r
    }

    /// Measuring units `v` wrapped into `0..TMR`.
    pub fn wrap(&self, v: i64) -> u32 {
        v.rem_euclid(self.tmr.max(1) as i64) as u32
    }

    /// What `turns` whole revolutions move the position by, in measuring units within `0..TMR`.
    // Below TMR (≤ 2^32) times MUR (≤ 2^16): no overflow; tmr ≥ 1.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn turns(&self, turns: u64) -> u32 {
        let tmr = self.tmr.max(1);
        ((turns % tmr) * u64::from(self.mur) % tmr) as u32
    }
}

/// The finest sensor the scaling takes: 2^16 steps per revolution.
pub const MAX_RESOLUTION: u32 = 1 << 16;
/// The largest movement between two samples the scaling follows, in steps;
/// a larger one re-synchronises on the absolute count.
pub const MAX_STEP: i64 = 1 << 31;

/// Checks MUR (0x6001) and TMR (0x6002) together: TMR 1..3 is refused with
/// 0x06090030 (below the smallest MUR, manual L2506), and a pair with
/// MUR > TMR (TMR = 0 is 2^32) with 0x06040043: the manual keeps the old
/// value and names no code (docs/devices/sendix.md D16).
pub fn check_range(mur: u32, tmr: u32) -> Result<(), AbortCode> {
    match tmr {
        1..=3 => Err(AbortCode::InvalidValue),
        0 => Ok(()),
        _ if mur > tmr => Err(AbortCode::ParameterIncompatible),
        _ => Ok(()),
    }
}

/// Whether `preset` is a position the scaling can show (below TMR).
pub fn check_preset(scaling: &Scaling, preset: u32) -> Result<(), AbortCode> {
    if u64::from(preset) < scaling.tmr { Ok(()) } else { Err(AbortCode::InvalidValue) }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: u32 = 0x4000;

    #[test]
    fn scaling_off_gives_the_step_count_over_32_bits() {
        let s = Scaling::new(0, 3600, 36000, R);
        assert_eq!((s.mur, s.tmr), (R, FULL_RANGE));
        assert_eq!(s.position(s.at(19642, 0)), 19642);
        assert_eq!(s.position(s.at(FULL_RANGE + 5, 0)), 5, "wraps at 2^32");
        assert_eq!(s.position(s.at(u64::MAX, 0)), u32::MAX, "a 64-bit count");
        assert_eq!(s.position(s.at(0, 7)), 7, "plus the offset");
    }

    #[test]
    fn tmr_zero_means_2_to_the_32() {
        let s = Scaling::new(SCALING, 0x1000, 0, R);
        assert_eq!(s.tmr, FULL_RANGE);
        assert_eq!(s.position(s.at(4 * u64::from(R), 0)), 0x4000);
    }

    #[test]
    fn a_non_binary_range_wraps_at_tmr_in_both_directions() {
        let s = Scaling::new(SCALING, 3600, 36000, R);
        let mut num = s.at(0, 0);
        // Ten turns forward in quarter turns: back to 0.
        for _ in 0..40 {
            num = s.advance(num, i64::from(R / 4));
        }
        assert_eq!(s.position(num), 0);
        num = s.advance(num, -1);
        assert_eq!(s.position(num), 35999, "one step back from 0 is the top of the range");
        let ccw = Scaling::new(SCALING | CODE_SEQUENCE, 3600, 36000, R);
        assert_eq!(ccw.position(ccw.advance(0, i64::from(R))), 36000 - 3600, "counter-clockwise counts down");
        assert_eq!(ccw.position(ccw.at(u64::from(R), 0)), 36000 - 3600);
        assert_eq!(s.turns(17), 17 * 3600 - 36000, "17 turns are 1.7 ranges");
    }

    #[test]
    fn fractions_of_a_unit_add_up_exactly() {
        // 3600 units per 16384 steps: 1 step is 0.2197 units.
        let s = Scaling::new(SCALING, 3600, 36000, R);
        let mut num = 0;
        for _ in 0..R {
            num = s.advance(num, 1);
        }
        assert_eq!(s.position(num), 3600);
        assert_eq!(num % u64::from(R), 0, "no rounding error after a whole turn");
    }

    #[test]
    fn mur_above_tmr_and_tiny_ranges_are_refused() {
        assert_eq!(check_range(0x1000, 0x800), Err(AbortCode::ParameterIncompatible));
        assert_eq!(check_range(4, 3), Err(AbortCode::InvalidValue));
        assert_eq!(check_range(0x4000, 0), Ok(()));
        assert_eq!(check_range(3600, 36000), Ok(()));
        assert_eq!(check_range(3600, 3600), Ok(()));
    }

    #[test]
    fn a_preset_must_lie_below_tmr() {
        let s = Scaling::new(SCALING, 3600, 36000, R);
        assert_eq!(check_preset(&s, 35999), Ok(()));
        assert_eq!(check_preset(&s, 36000), Err(AbortCode::InvalidValue));
        assert_eq!(check_preset(&Scaling::new(0, 0, 0, R), u32::MAX), Ok(()));
    }
}
