//! Profile velocity (pv, 0x6060 = 3; CiA 402-2 §11: 0x60FF with the
//! profile ramps, velocity window 0x606D/0x606E, threshold 0x606F/0x6070)
//! and velocity mode (vl, 0x6060 = 2; CiA 402-2 §7: 0x6042 in min⁻¹ of
//! the motor, limited by 0x6046 min/max amount, ramps 0x6048/0x6049, quick
//! stop ramp 0x604A): the target and its limits. The ramps are
//! [`super::motion::Demand::ramp`].

/// A vl target with its min/max amount (CiA 402-2 §7 "velocity limit
/// function"): above max → max; between 0 and min → min; 0 stays 0. The
/// flag tells whether a limit applied (statusword bit 11).
// `limited` is at most i32::MAX: its negation fits.
#[allow(clippy::arithmetic_side_effects)]
pub const fn vl_limit(target: i32, min: u32, max: u32) -> (i32, bool) {
    let magnitude = target.unsigned_abs();
    let limited = if magnitude > max && max != 0 {
        max
    } else if magnitude != 0 && magnitude < min {
        min
    } else {
        return (target, false);
    };
    let limited = if limited > i32::MAX as u32 { i32::MAX } else { limited as i32 };
    (if target < 0 { -limited } else { limited }, true)
}

/// A vl ramp (delta speed [min⁻¹] per delta time [s]) as min⁻¹ per second;
/// a zero time counts as one second.
// The divisor is at least 1.
#[allow(clippy::arithmetic_side_effects)]
pub const fn vl_ramp(delta_speed: u32, delta_time: u32) -> u32 {
    delta_speed / if delta_time == 0 { 1 } else { delta_time }
}

/// A vl ramp given as a time (0x604F-0x6051): `reference` [inc/s] reached
/// from 0 in `ms` milliseconds, as increments per second squared; 0 for a
/// time of 0 (no ramp: the drive's limit). 32-bit divisions only (one
/// instruction on a Cortex-M3); times beyond 4,000 s count as 4,000 s.
// `ms` ≥ 1 and ≤ 4·10^6: `rest` < `ms`, so `rest · 1000` fits a u32.
#[allow(clippy::arithmetic_side_effects)]
pub const fn vl_ramp_time(reference: u32, ms: u32) -> u32 {
    if ms == 0 {
        return 0;
    }
    let ms = if ms > 4_000_000 { 4_000_000 } else { ms };
    let (whole, rest) = (reference / ms, reference % ms);
    whole.saturating_mul(1000).saturating_add(rest * 1000 / ms)
}

/// A monitoring window: how many ticks a condition has held.
#[derive(Clone, Copy, Debug, Default)]
pub struct Window(u32);

impl Window {
    /// Nothing has held yet.
    pub const NEW: Window = Window(0);

    /// One tick with `condition`; true once it has held for `ticks` ticks (at least one).
    pub fn tick(&mut self, condition: bool, ticks: u32) -> bool {
        self.0 = if condition { self.0.saturating_add(1) } else { 0 };
        self.0 >= ticks.max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_limit_function() {
        assert_eq!(vl_limit(3000, 100, 1500), (1500, true));
        assert_eq!(vl_limit(-50, 100, 1500), (-100, true));
        assert_eq!(vl_limit(0, 100, 1500), (0, false));
        assert_eq!(vl_limit(-700, 100, 1500), (-700, false));
        assert_eq!(vl_ramp(150, 1), 150);
        assert_eq!(vl_ramp(1500, 10), 150);
        // 3000 min⁻¹ at 65,536 inc/rev (3,276,800 inc/s) in 500 ms: 6,553,600 inc/s².
        assert_eq!(vl_ramp_time(3_276_800, 500), 6_553_600);
        assert_eq!(vl_ramp_time(1000, 3), 333_333);
        assert_eq!(vl_ramp_time(u32::MAX, 1), u32::MAX);
        assert_eq!(vl_ramp_time(4_000_000, u32::MAX), 1000);
        assert_eq!(vl_ramp_time(3_276_800, 0), 0);
    }
}
