//! Speed 0x6030 and acceleration 0x6040 (CiA 406 §6.3, manual §5.5.34–37):
//! the movement over a gate of the integration time (0x6031:02), scaled by
//! C1/C2 (0x6031:03/04); acceleration the change of speed over the gate
//! that follows, scaled by 0x6041's C1/C2.

use crate::time::{Duration, Instant};

/// Speed units (0x6000 speed-format bit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeedFormat {
    /// Revolutions per minute.
    Rpm,
    /// Measuring units (0x6004) per second.
    UnitsPerSecond,
}

/// One gate of the speed measurement: steps counted since `start`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Gate {
    start: Instant,
    steps: i64,
    running: bool,
}

/// What a closed gate measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Measured {
    /// Steps moved (signed, in the counting direction).
    pub steps: i64,
    /// The gate's length, in ms (at least 1).
    pub ms: u64,
}

impl Gate {
    /// Closed, counting nothing: all zero bits.
    pub const NEW: Gate = Gate { start: Instant::ZERO, steps: 0, running: false };

    /// Opens a new gate at `now` (after a reset or a sensor fault).
    pub fn restart(&mut self, now: Instant) {
        *self = Gate { start: now, steps: 0, running: true };
    }

    /// Counts `steps` moved; closes the gate once `length` has passed,
    /// returning what it measured, and opens the next.
    pub fn add(&mut self, now: Instant, steps: i64, length: Duration) -> Option<Measured> {
        if !self.running {
            self.restart(now);
        }
        self.steps = self.steps.saturating_add(steps);
        let elapsed = now.saturating_duration_since(self.start);
        if elapsed < length {
            return None;
        }
        let measured = Measured { steps: self.steps, ms: elapsed.as_millis().max(1) };
        self.restart(now);
        Some(measured)
    }
}

/// The largest movement a gate counts, in steps (far beyond any shaft:
/// the products below stay within 64 bits).
const MAX_GATE_STEPS: i64 = 1 << 40;

/// Steps per second over `m`.
// |steps| ≤ 2^40, × 1000 below 2^50; the divisor is at least 1.
#[allow(clippy::arithmetic_side_effects)]
fn steps_per_s(m: Measured) -> i64 {
    // A gate lasts at least 1 ms (`Gate::add`), and far less than 2^63.
    m.steps.clamp(-MAX_GATE_STEPS, MAX_GATE_STEPS) * 1000 / m.ms as i64
}

/// Revolutions per minute of `m` with `resolution` steps per revolution.
// `steps_per_s` is below 2^50: × 60 fits; the divisor is at least 1.
#[allow(clippy::arithmetic_side_effects)]
pub fn rpm(m: Measured, resolution: u32) -> i64 {
    steps_per_s(m) * 60 / i64::from(resolution.max(1))
}

/// The speed value: `m` in `format`, × C1 / C2 (a C2 of 0 counts as 1).
// The divisor is at least 1. Where the product saturates (|speed| beyond
// 2^47 steps/s), `scale` answers the same limit the exact value would.
#[allow(clippy::arithmetic_side_effects)]
pub fn value(m: Measured, format: SpeedFormat, resolution: u32, mur: u32, c1: i16, c2: i16) -> i32 {
    let per = match format {
        SpeedFormat::Rpm => 60,
        SpeedFormat::UnitsPerSecond => i64::from(mur.min(1 << 16)),
    };
    scale(steps_per_s(m).saturating_mul(per) / i64::from(resolution.max(1)), c1, c2)
}

/// The acceleration from speed `from` to `to` over `ms`: speed units per
/// second, × C1 / C2 of 0x6041.
// The difference of two i32s, × 1000, fits an i64; the divisor is at least 1.
#[allow(clippy::arithmetic_side_effects)]
pub fn acceleration(from: i32, to: i32, ms: u64, c1: i16, c2: i16) -> i32 {
    scale((i64::from(to) - i64::from(from)) * 1000 / ms.max(1) as i64, c1, c2)
}

/// `v` × C1 / C2 within i32. `v` is cut to ±2^47 first: the product then
/// fits, and a larger `v` is beyond i32 for any C1/C2 but 0 (|C1/C2| ≥
/// 2^-15), so the answer is the same limit.
// After the cut, |v × C1| < 2^62, and C2 is not 0.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
fn scale(v: i64, c1: i16, c2: i16) -> i32 {
    let c2 = if c2 == 0 { 1 } else { i64::from(c2) };
    let v = v.clamp(-(1 << 47), 1 << 47);
    (v * i64::from(c1) / c2).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> Instant {
        Instant::from_micros(t * 1000)
    }

    #[test]
    fn units_per_second_over_a_100_ms_gate() {
        // Seed notes §11.29: +1000 steps per 100 ms, scaling off → 10000 units/s.
        let mut g = Gate::NEW;
        assert_eq!(g.add(ms(0), 0, Duration::from_millis(100)), None);
        assert_eq!(g.add(ms(50), 500, Duration::from_millis(100)), None);
        let m = g.add(ms(100), 500, Duration::from_millis(100)).expect("gate closes");
        assert_eq!(value(m, SpeedFormat::UnitsPerSecond, 8192, 8192, 1, 1), 10_000);
    }

    #[test]
    fn rpm_with_its_sign() {
        let m = Measured { steps: 8192, ms: 1000 };
        assert_eq!(value(m, SpeedFormat::Rpm, 8192, 8192, 1, 1), 60);
        assert_eq!(value(Measured { steps: -8192, ms: 1000 }, SpeedFormat::Rpm, 8192, 8192, 1, 1), -60);
        assert_eq!(value(m, SpeedFormat::Rpm, 8192, 8192, 3, 2), 90, "C1/C2 act as a gear");
        assert_eq!(value(m, SpeedFormat::Rpm, 8192, 8192, 1, 0), 60, "C2 = 0 counts as 1");
    }

    #[test]
    fn acceleration_is_the_change_of_speed_per_second() {
        assert_eq!(acceleration(0, 60, 100, 1, 1), 600);
        assert_eq!(acceleration(60, 0, 100, 1, 1), -600);
    }

    #[test]
    fn a_speed_past_64_bits_saturates_at_the_i32_limits() {
        // 2^40 steps in 1 ms at 2^16 units per step: 2^66 units/s before the division.
        let m = Measured { steps: 1 << 40, ms: 1 };
        assert_eq!(value(m, SpeedFormat::UnitsPerSecond, 1, 1 << 16, 1, 1), i32::MAX);
        assert_eq!(value(Measured { steps: -(1 << 40), ms: 1 }, SpeedFormat::UnitsPerSecond, 1, 1 << 16, 1, 1), i32::MIN);
        // The largest C1 against the smallest C2, and the other way round.
        assert_eq!(value(m, SpeedFormat::UnitsPerSecond, 1, 1 << 16, i16::MAX, -1), i32::MIN);
        assert_eq!(value(m, SpeedFormat::UnitsPerSecond, 1, 1 << 16, 1, i16::MAX), i32::MAX);
    }
}
