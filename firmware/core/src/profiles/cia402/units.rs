//! The factor group (CiA 402-2 §6.5): user units (0x607A, 0x6064, 0x60FF,
//! 0x606C, 0x6083 …) to the drive's increments and back, from the
//! encoder's increments per motor revolution, the gear ratio 0x6091 and the
//! feed constant 0x6092, and the polarity 0x607E.
//!
//! position [inc] = position [user] × inc/rev × gear (motor revs / shaft revs)
//! ÷ feed (user units / shaft revs). Velocities and accelerations use the
//! same factor per second and per second squared. The factors are Q32
//! fixed-point, computed when the objects change, so the per-frame
//! conversions are one multiplication each (no division on a Cortex-M3).

/// One direction of a conversion: `value × factor / 2^32`, rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Factor(i64);

impl Factor {
    /// Zero: everything converts to 0 (before reset application).
    pub const ZERO: Factor = Factor(0);

    /// `numerator / denominator` (1:1 if either is 0 or the ratio does not fit).
    pub fn ratio(mut numerator: u64, mut denominator: u64) -> Factor {
        if numerator == 0 || denominator == 0 {
            return Factor(1 << 32);
        }
        while numerator >= 1 << 31 || denominator >= 1 << 31 {
            numerator >>= 1;
            denominator = (denominator >> 1).max(1);
        }
        Factor(q32_ratio(numerator as u32, denominator as u32).min(i64::MAX as u64) as i64)
    }

    /// `value` converted, rounded to the nearest (one copy of the 64 × 64-bit
    /// multiplication for every call site).
    // Two i64s multiply within an i128 (below 2^126), and 2^31 more fits.
    #[allow(clippy::arithmetic_side_effects)]
    #[inline(never)]
    pub fn apply(self, value: i64) -> i64 {
        self.apply_in_line(value)
    }

    /// [`Factor::apply`] in line (the RPDO's target velocity).
    // Two i64s multiply within an i128 (below 2^126), and 2^31 more fits.
    #[allow(clippy::arithmetic_side_effects)]
    #[inline(always)]
    pub fn apply_in_line(self, value: i64) -> i64 {
        ((i128::from(value) * i128::from(self.0) + (1 << 31)) >> 32) as i64
    }
}

/// `(numerator << 32) / denominator` by shift and subtract: it runs when
/// a factor changes, and spares the image the 64-bit division routine
/// (most of a kilobyte on a Cortex-M3).
// `remainder` < `divisor` < 2^32 before each shift; it only subtracts what it holds.
#[allow(clippy::arithmetic_side_effects)]
fn q32_ratio(numerator: u32, denominator: u32) -> u64 {
    let dividend = u64::from(numerator) << 32;
    let divisor = u64::from(denominator.max(1));
    let (mut quotient, mut remainder) = (0u64, 0u64);
    for bit in (0..64).rev() {
        remainder = (remainder << 1) | ((dividend >> bit) & 1);
        if remainder >= divisor {
            remainder -= divisor;
            quotient |= 1 << bit;
        }
    }
    quotient
}

/// The conversions of one device at one moment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Units {
    /// User position (and velocity, acceleration) units to increments.
    pub to_inc: Factor,
    /// Increments to user units.
    pub to_user: Factor,
    /// vl velocity (0x6042, min⁻¹ of the motor) to increments per second.
    pub vl_to_inc: Factor,
    /// Increments per second to vl velocity.
    pub vl_to_user: Factor,
    /// 0x607E bit 7: positions are negated.
    pub position_negative: bool,
    /// 0x607E bit 6: velocities are negated.
    pub velocity_negative: bool,
}

impl Units {
    /// Before reset application: all zero bits.
    pub const ZERO: Units = Units {
        to_inc: Factor::ZERO,
        to_user: Factor::ZERO,
        vl_to_inc: Factor::ZERO,
        vl_to_user: Factor::ZERO,
        position_negative: false,
        velocity_negative: false,
    };

    /// The factors of `increments_per_rev` with gear `motor_revs : shaft_revs`
    /// and feed `feed` user units per `feed_revs` shaft revolutions; polarity
    /// byte `polarity`.
    pub fn new(increments_per_rev: u32, (motor_revs, shaft_revs): (u32, u32), (feed, feed_revs): (u32, u32), polarity: u8) -> Units {
        // A u32 × u32 fits a u64; the third factor may not (0x6091 and
        // 0x6092 take any u32). A gear term past 32 bits loses its low bits
        // first, and the denominator with it, as `Factor::ratio` drops them
        // anyway; the product then fits.
        #[allow(clippy::arithmetic_side_effects)]
        let (mut gear, mut denominator) = (u64::from(increments_per_rev) * u64::from(motor_revs), u64::from(shaft_revs) * u64::from(feed));
        while gear >> 32 != 0 {
            (gear, denominator) = (gear >> 1, (denominator >> 1).max(1));
        }
        // Two factors below 2^32.
        #[allow(clippy::arithmetic_side_effects)]
        let numerator = gear * u64::from(feed_revs);
        Units {
            to_inc: Factor::ratio(numerator, denominator),
            to_user: Factor::ratio(denominator, numerator),
            vl_to_inc: Factor::ZERO,
            vl_to_user: Factor::ZERO,
            position_negative: polarity & 0x80 != 0,
            velocity_negative: polarity & 0x40 != 0,
        }
        .with_vl_dimension(increments_per_rev, 1, 1)
    }

    /// The vl factors of `increments_per_rev` with the vl dimension factor
    /// 0x604C (CiA 402-2: min⁻¹ of the motor = vl value × `numerator` /
    /// `denominator`; a negative factor turns the other way; 0 counts as 1).
    // Out of line: inlined into its two callers it cost 164 B of flash.
    // A u32 times a magnitude of at most 2^31, and 60 times one, fit a u64;
    // `Factor::ratio` is at most i64::MAX, so its negation fits.
    #[allow(clippy::arithmetic_side_effects)]
    #[inline(never)]
    pub fn with_vl_dimension(self, increments_per_rev: u32, numerator: i32, denominator: i32) -> Units {
        let magnitude = |v: i32| u64::from(v.unsigned_abs().max(1));
        let (motor, vl) = (u64::from(increments_per_rev) * magnitude(numerator), 60 * magnitude(denominator));
        let sign = |f: Factor| if (numerator < 0) != (denominator < 0) { Factor(-f.0) } else { f };
        Units { vl_to_inc: sign(Factor::ratio(motor, vl)), vl_to_user: sign(Factor::ratio(vl, motor)), ..self }
    }

    /// A target or actual position: user units to increments (polarity
    /// applied; [`Units::inc_of`] is out of line already).
    pub fn position_to_inc(&self, user: i32) -> i64 {
        self.inc_of(user, self.position_negative)
    }

    /// Increments to a user position (polarity applied), saturated to 32 bits.
    pub fn position_to_user(&self, inc: i64) -> i32 {
        self.user_of(inc, self.position_negative)
    }

    /// A velocity: user units per second to increments per second (polarity applied).
    pub fn velocity_to_inc(&self, user: i32) -> i64 {
        // Not through `inc_of`: one call, not two.
        negate(self.to_inc.apply(i64::from(user)), self.velocity_negative)
    }

    /// [`Units::velocity_to_inc`] without a call, for the RPDO's target velocity.
    #[inline(always)]
    pub(super) fn velocity_to_inc_in_line(&self, user: i32) -> i64 {
        negate(self.to_inc.apply_in_line(i64::from(user)), self.velocity_negative)
    }

    /// Increments per second to user velocity units (polarity applied).
    pub fn velocity_to_user(&self, inc: i64) -> i32 {
        self.user_of(inc, self.velocity_negative)
    }

    // Out of line, as the next: the profile converts in some twenty places.
    #[inline(never)]
    fn inc_of(&self, user: i32, negative: bool) -> i64 {
        negate(self.to_inc.apply(i64::from(user)), negative)
    }

    #[inline(never)]
    fn user_of(&self, inc: i64, negative: bool) -> i32 {
        saturate(negate(self.to_user.apply(inc), negative))
    }

    /// A magnitude (window, ramp, speed): user units to increments, no polarity.
    // Out of line: some ten callers.
    #[inline(never)]
    pub fn magnitude_to_inc(&self, user: u32) -> i64 {
        self.to_inc.apply(i64::from(user))
    }
}

/// `value`, negated if `negative` (a polarity bit).
pub(super) fn negate(value: i64, negative: bool) -> i64 {
    // `apply` keeps 64 bits of its product: the negation wraps as they do.
    if negative { value.wrapping_neg() } else { value }
}

/// Out of line: the 64-bit clamp at each of its callers cost 112 B.
#[inline(never)]
fn saturate(value: i64) -> i32 {
    value.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ec5000_mm_with_gear_18_to_1_and_feed_157_mm() {
        // 4096 inc/rev × 18 / 157 mm = 469.6 inc/mm.
        let u = Units::new(4096, (18, 1), (157, 1), 0);
        assert_eq!(u.position_to_inc(1000), 469_605);
        assert_eq!(u.position_to_user(469_605), 1000, "round trip");
        assert_eq!(u.position_to_user(469_605 + 200), 1000, "within half a millimetre");
        assert_eq!(u.position_to_inc(-157), -73_728, "one output revolution = 18 motor revolutions");
        assert_eq!(u.velocity_to_user(u.velocity_to_inc(-250)), -250);
    }

    #[test]
    fn polarity_bits_7_and_6() {
        let u = Units::new(1000, (1, 1), (1000, 1), 0xC0);
        assert_eq!(u.position_to_inc(5), -5);
        assert_eq!(u.position_to_user(-5), 5);
        assert_eq!(u.velocity_to_inc(7), -7);
        assert_eq!(Units::new(1000, (1, 1), (1000, 1), 0x80).velocity_to_inc(7), 7);
    }

    #[test]
    fn shift_and_subtract_division() {
        for (n, d) in [(1u32, 1u32), (73_728, 157), (157, 73_728), (u32::MAX >> 1, 3), (60, 4096)] {
            assert_eq!(q32_ratio(n, d), (u64::from(n) << 32) / u64::from(d), "{n}/{d}");
        }
    }

    #[test]
    fn a_product_past_64_bits_keeps_its_ratio() {
        // 2^24 inc/rev × 2^20 motor revs × 2^24 feed revs = 2^68 against
        // 2^20 shaft revs × 2^28 user units = 2^48: 2^20 inc per user unit.
        let u = Units::new(1 << 24, (1 << 20, 1 << 20), (1 << 28, 1 << 24), 0);
        assert_eq!(u.position_to_inc(3), 3 << 20);
        assert_eq!(u.position_to_user(3 << 20), 3);
    }

    #[test]
    fn degenerate_factors_are_one_to_one() {
        let u = Units::new(4096, (0, 0), (0, 1), 0);
        assert_eq!(u.position_to_inc(123), 123);
        assert_eq!(Units::new(4096, (1, 1), (4096, 1), 0).vl_to_inc.apply(60), 4096, "60 min⁻¹ = one revolution per second");
    }

    #[test]
    fn vl_dimension_factor_scales_vl_velocities_to_motor_speed() {
        // b maXX 4400 §4.4.6: 100 × 10 / 5 = 200 min⁻¹ of a 65536-increment motor.
        let u = Units::new(65536, (1, 1), (65536, 1), 0).with_vl_dimension(65536, 10, 5);
        assert_eq!(u.vl_to_inc.apply(100), 218_453, "200 min⁻¹ = 218,453.3 inc/s");
        assert_eq!(u.vl_to_user.apply(200 * 65536 / 60), 100);
        let reversed = Units::new(65536, (1, 1), (65536, 1), 0).with_vl_dimension(65536, -10, 5);
        assert_eq!(reversed.vl_to_inc.apply(100), -218_453);
        assert_eq!(reversed.vl_to_user.apply(-(200 * 65536 / 60)), 100);
        let zero = Units::new(60, (1, 1), (60, 1), 0).with_vl_dimension(60, 0, 0);
        assert_eq!(zero.vl_to_inc.apply(7), 7, "0 counts as 1");
    }
}
