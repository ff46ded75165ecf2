//! The EC5000's own monitoring beyond CiA 402: the over-temperature warning
//! EMCY 0xFFA8 with the threshold and hysteresis of 0x4231 (D48).

use canopen_core::node::Ctx;
use canopen_core::profiles::cia402::objects::signed;

/// EMCY 0xFFA8 "Motor temperature close to high" (class W, §5.2).
pub const TEMPERATURE_WARNING: u16 = 0xFFA8;
/// 0x4231 "High Temperature Warning Level": sub 1 threshold, sub 2 hysteresis [°C].
const WARNING_LEVEL: u16 = 0x4231;

/// What the monitoring remembers between polls.
#[derive(Debug)]
pub struct Monitor {
    /// EMCY 0xFFA8 is active.
    warning: bool,
}

impl Monitor {
    /// At power-on: no warning.
    pub const NEW: Monitor = Monitor { warning: false };

    /// Raises or clears the temperature warning for `temperature` [°C];
    /// returns the temperature from which statusword bit 7 shows it, so that
    /// bit 7 and the EMCY agree: the threshold while clear, the lowest
    /// temperature still warned while raised.
    pub fn temperature(&mut self, ctx: &mut Ctx<'_>, temperature: i16) -> i16 {
        // D48: on at T >= threshold, off at T <= threshold - hysteresis (95/93 °C by default).
        let threshold = signed(ctx, WARNING_LEVEL, 1).unwrap_or(95);
        let clear_at = threshold - signed(ctx, WARNING_LEVEL, 2).unwrap_or(2);
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
}
