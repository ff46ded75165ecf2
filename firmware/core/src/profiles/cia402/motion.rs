//! The trajectory generator's demand values and the ramps every mode
//! shares, one [`TICK_US`] tick at a time, in binary fixed point so that
//! slow motion is exact and no tick divides (a 64-bit division costs a
//! Cortex-M3 a library call and most of a kilobyte of flash):
//! - positions in Q24 increments (increments × 2^24);
//! - velocities in Q24 increments per tick;
//! - accelerations in Q24 increments per tick per tick (500 inc/s² is
//!   8,389 units: ramps are exact to 10^-4).

use super::TICK_US;

// The conversion constants below are for a 1 ms tick.
const _: () = assert!(TICK_US == 1000);

/// Fraction bits of the fixed-point values.
pub const FRACTION: u32 = 24;

/// increments/s → Q24 increments per tick: × 2^24 / 1000, computed as
/// × round(2^40 / 1000) / 2^16.
// |per_s| ≤ 2^32 after the clamp, times about 2^30: below 2^63.
#[allow(clippy::arithmetic_side_effects)]
pub const fn speed_q(per_s: i64) -> i64 {
    // Clamped so that the product fits: a saturating 64-bit multiplication
    // would check for overflow with a division on a Cortex-M3.
    let per_s = if per_s > 1 << 32 {
        1 << 32
    } else if per_s < -(1 << 32) {
        -(1 << 32)
    } else {
        per_s
    };
    (per_s * 1_099_511_628) >> 16
}

/// [`speed_q`] out of line, for the profile's callers off the per-frame
/// path (parameters, mode changes, a stopped axis's demand): inlined at
/// each the 64-bit clamp and multiply cost the drive images some hundred
/// bytes. `speed_q` itself stays inline for the RPDO's 0x60FF, the tick's
/// limits (a drive's constant minimum and maximum fold) and the simulated
/// axes, where a call made the images larger.
#[inline(never)]
pub fn speed_q_call(per_s: i64) -> i64 {
    speed_q(per_s)
}

/// Q24 increments per tick → increments/s, rounded. Out of line: inlined
/// at each of its callers the 64-bit clamp and multiply cost each drive
/// image about 800 B of flash, the call one instruction a frame.
// |q| ≤ i64::MAX / 1001 after the clamp: × 1000 plus 2^23 fits.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
pub const fn speed_per_s(q: i64) -> i64 {
    const LIMIT: i64 = i64::MAX / 1001;
    let q = if q > LIMIT {
        LIMIT
    } else if q < -LIMIT {
        -LIMIT
    } else {
        q
    };
    (q * 1000 + (1 << (FRACTION - 1))) >> FRACTION
}

/// increments/s² → Q24 increments per tick²: × 2^24 / 10^6, computed as
/// × round(2^40 / 10^6) / 2^16; at least 1 so that every ramp ends. Out of
/// line: the 64-bit product at each caller cost about 200 B.
// A u32 times about 2^20 fits a u64.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
pub const fn acceleration_q(per_s2: u32) -> i64 {
    let q = ((per_s2 as u64 * 1_099_512) >> 16) as i64;
    if q < 1 { 1 } else { q }
}

/// Position demand value and velocity demand value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Demand {
    /// Position demand [Q24 inc].
    pub position_q: i64,
    /// Velocity demand [Q24 inc/tick].
    pub velocity_q: i64,
}

impl Demand {
    /// At rest: all zero bits.
    pub const ZERO: Demand = Demand { position_q: 0, velocity_q: 0 };

    /// Starts from where the axis is: `position` [inc], `velocity` [inc/s].
    pub fn at(position: i64, velocity: i32) -> Demand {
        Demand { position_q: position << FRACTION, velocity_q: speed_q_call(i64::from(velocity)) }
    }

    /// Position demand [inc].
    pub fn position(&self) -> i64 {
        self.position_q >> FRACTION
    }

    /// Velocity demand [inc/s] (out of line: -88 B in each drive image).
    #[inline(never)]
    pub fn velocity(&self) -> i32 {
        speed_per_s(self.velocity_q).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// One tick towards velocity `target`: `acceleration` while the speed
    /// grows, `deceleration` while it falls (Q24 per tick²).
    #[inline(never)]
    pub fn ramp(&mut self, target: i64, acceleration: i64, deceleration: i64) {
        let v = self.velocity_q;
        let speeding_up = (target > 0 && target > v && v >= 0) || (target < 0 && target < v && v <= 0);
        let step = if speeding_up { acceleration } else { deceleration };
        // Velocities come from `speed_q` (|v| < 2^47) and accelerations from
        // `acceleration_q` (< 2^37): a step cannot overflow.
        #[allow(clippy::arithmetic_side_effects)]
        let velocity = if target > v { (v + step).min(target) } else { (v - step).max(target) };
        self.velocity_q = velocity;
        // Positions wrap like an encoder count: 2^63 in Q24 is a multiple of
        // 2^32 increments, so the 32-bit position objects wrap as before.
        self.position_q = self.position_q.wrapping_add(velocity);
    }

    /// One tick of a point-to-point move to `target` [Q24 inc], `beyond`
    /// further in the same direction without a stop (a blended set-point):
    /// at most `speed`, braking so as to stop there. True when the target is
    /// reached (the demand is then exactly on it).
    #[inline(never)]
    pub fn move_to(&mut self, target: i64, beyond: u64, speed: i64, acceleration: i64, deceleration: i64) -> bool {
        let distance = target.wrapping_sub(self.position_q);
        // v² = 2·a·d, every term in Q24 per-tick units.
        let room = distance.unsigned_abs().saturating_add(beyond);
        // Saturated (and so conservative) far from the target, where the speed limit rules.
        let braking = isqrt(deceleration.unsigned_abs().saturating_mul(2).saturating_mul(room));
        // The square root is below 2^32, the sign ±1 or 0.
        #[allow(clippy::arithmetic_side_effects)]
        let wanted = (braking.min(speed.unsigned_abs()) as i64) * distance.signum();
        let before = self.position_q;
        self.ramp(wanted, acceleration, deceleration);
        let moved = self.position_q.wrapping_sub(before);
        if distance == 0 || (moved.signum() == distance.signum() && moved.abs() >= distance.abs()) {
            self.position_q = target;
            if beyond == 0 {
                self.velocity_q = 0;
            }
            return true;
        }
        false
    }
}

/// ⌊√n⌋ digit by digit: `u64::isqrt` divides, and a 64-bit division is a
/// library call of most of a kilobyte on a Cortex-M3.
// `root` < 2^32 and `bit` ≤ 2^62: their sum fits, and `rest` loses it only when it holds it.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
fn isqrt(n: u64) -> u64 {
    let (mut rest, mut root, mut bit) = (n, 0u64, 1u64 << 62);
    while bit > rest {
        bit >>= 2;
    }
    while bit != 0 {
        if rest >= root + bit {
            rest -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_root_digit_by_digit() {
        for n in [0u64, 1, 2, 3, 4, 15, 16, 17, 1 << 40, (1 << 40) - 1, 999_999_999_999, u64::MAX] {
            assert_eq!(isqrt(n), n.isqrt(), "{n}");
        }
    }

    #[test]
    fn conversions() {
        assert_eq!(speed_per_s(speed_q(5000)), 5000);
        assert_eq!(speed_per_s(speed_q(-123_456)), -123_456);
        // 2000 inc/s² for 100 ticks: 200 inc/s.
        assert_eq!(speed_per_s(acceleration_q(2000) * 100), 200);
    }

    #[test]
    fn ramp_speeds_up_and_slows_down_at_their_own_rates() {
        let mut d = Demand::ZERO;
        let (up, down) = (acceleration_q(2000), acceleration_q(500));
        for _ in 0..100 {
            d.ramp(speed_q(1_000_000), up, down);
        }
        assert_eq!(d.velocity(), 200, "100 ms at 2000 inc/s²");
        for _ in 0..100 {
            d.ramp(0, up, down);
        }
        assert_eq!(d.velocity(), 150, "100 ms at 500 inc/s²");
    }

    #[test]
    fn point_to_point_stops_exactly_on_the_target() {
        let mut d = Demand::ZERO;
        let a = acceleration_q(20_000);
        let mut ticks = 0;
        while !d.move_to(10_000 << FRACTION, 0, speed_q(5000), a, a) {
            ticks += 1;
            assert!(d.velocity() <= 5000);
            assert!(ticks < 10_000);
        }
        assert_eq!((d.position(), d.velocity()), (10_000, 0));
        // Trapezoid: 0.25 s up, 1.75 s at 5000 inc/s, 0.25 s down: about 2.25 s.
        assert!((2200..2300).contains(&ticks), "{ticks} ticks");
    }
}
