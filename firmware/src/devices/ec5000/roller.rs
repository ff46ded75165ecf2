//! The roller behind the CiA 402 profile: the axis model with the EC5000's
//! own drive monitoring (M §9, decisions D52-D54 in docs/devices/ec5000.md):
//! the fault codes of its table in place of the model's generic ones, a
//! blocked shaft, a speed the load holds down, a motor too cold, and the
//! minimum speed below which it holds its position (Zero Motion Hold).

use canopen_core::axis::{Axis, AxisDrive, fault};
use canopen_core::profiles::cia402::drive::{Drive, SetPoint};
use canopen_core::wire::emcy::EmcyCode;

/// 0x4320 "Motor temperature too low" (F).
pub const TOO_COLD: EmcyCode = EmcyCode(0x4320);
/// 0x7121 "Motor shaft is blocked" (F).
pub const BLOCKED: EmcyCode = EmcyCode(0x7121);
/// 0x8600 "Position regulator failure" (F): the model's following error 0x8611.
pub const POSITION_REGULATOR: EmcyCode = EmcyCode(0x8600);
/// 0xFF15 "Over current regulator output" (F): the model's power stage fault 0x2320.
pub const OVER_CURRENT_OUTPUT: EmcyCode = EmcyCode(0xFF15);
/// 0xFF50 "Motor speed error (heavy load)" (F).
pub const SPEED_ERROR: EmcyCode = EmcyCode(0xFF50);
/// 0x6310 "Loss of parameters" (F): the stored set was refused for its layout (D66).
pub const LOSS_OF_PARAMETERS: EmcyCode = EmcyCode(0x6310);

/// The lowest motor speed [inc/s]: 100 min⁻¹ at 4096 inc/rev (D52).
pub const MIN_VELOCITY: u32 = 6_827;
/// A fault at or below this motor temperature [°C] (D53).
pub const COLD_FAULT_C: i16 = -30;
/// A demand the roller does not follow for this long [ms]: it stands (blocked),
/// or turns at less than half the demand (warning 0xFFD4, then 0xFF50) (D53).
const BLOCKED_MS: u16 = 500;
const SPEED_WARNING_MS: u16 = 200;
const SPEED_ERROR_MS: u16 = 2000;

/// The axis model with the EC5000's monitoring.
#[derive(Clone, Debug)]
pub struct Roller {
    /// The simulated motor and load (faults are injected here).
    pub axis: Axis,
    /// The monitoring holds a temperature warning (0xFFA8, 0xFFA9, 0xFFAA):
    /// statusword bit 7, as the EMCY says.
    pub warned: bool,
    /// The temperature limiter halves the speed limit (warning 0xFFAA).
    pub derated: bool,
    /// A fault of the roller's own monitoring, until a fault reset.
    fault: EmcyCode,
    /// The velocity demand of the last set-point [inc/s].
    demand: i32,
    /// Milliseconds the roller stood, and turned at less than half the demand, against its demand.
    standing_ms: u16,
    lagging_ms: u16,
}

impl Roller {
    /// At power-on: all zero bits.
    pub const NEW: Roller =
        Roller { axis: Axis::NEW, warned: false, derated: false, fault: EmcyCode::NO_ERROR, demand: 0, standing_ms: 0, lagging_ms: 0 };

    /// The drive starts in Fault with `code`, a fault of the start-up
    /// rather than of the roller (0x6310, D66), until a fault reset.
    pub fn fault_at_start(&mut self, code: EmcyCode) {
        self.fault = code;
    }

    /// The speed warning 0xFFD4: the roller turns slower than half its demand (heavy load).
    pub fn slowed(&self) -> bool {
        self.lagging_ms >= SPEED_WARNING_MS
    }
}

/// The axis model with the roller's monitoring; the rest is the axis's.
impl AxisDrive for Roller {
    fn axis(&self) -> &Axis {
        &self.axis
    }
    fn axis_mut(&mut self) -> &mut Axis {
        &mut self.axis
    }
    fn reset(&mut self) {
        self.axis.reset();
        (self.fault, self.demand, self.standing_ms, self.lagging_ms) = (EmcyCode::NO_ERROR, 0, 0, 0);
    }
    fn enable(&mut self, on: bool) {
        // Switched off, the roller has no demand to follow.
        if !on {
            (self.demand, self.standing_ms, self.lagging_ms) = (0, 0, 0);
        }
        self.axis.enable(on);
    }
    fn command(&mut self, set_point: SetPoint) {
        self.demand = match set_point {
            SetPoint::Position { velocity, .. } | SetPoint::Velocity(velocity) => velocity,
            _ => 0,
        };
        self.axis.command(set_point);
    }
    fn tick(&mut self) {
        self.axis.tick();
        let (demand, actual) = (self.demand, self.axis.velocity());
        // The speed in the demanded direction: a roller pushed back lags too.
        let along = if demand < 0 { actual.saturating_neg() } else { actual };
        let count = |ms: u16, on: bool| if on { ms.saturating_add(1) } else { 0 };
        let moving = demand.unsigned_abs() >= MIN_VELOCITY && self.axis.fault() == EmcyCode::NO_ERROR;
        self.standing_ms = count(self.standing_ms, moving && actual.unsigned_abs() < MIN_VELOCITY);
        self.lagging_ms = count(self.lagging_ms, moving && along < (demand / 2).saturating_abs());
        if self.fault == EmcyCode::NO_ERROR {
            if self.standing_ms >= BLOCKED_MS {
                self.fault = BLOCKED;
            } else if self.lagging_ms >= SPEED_ERROR_MS {
                self.fault = SPEED_ERROR;
            }
        }
    }
    fn fault(&self) -> EmcyCode {
        match self.axis.fault() {
            _ if self.fault != EmcyCode::NO_ERROR => self.fault,
            EmcyCode::NO_ERROR if self.axis.temperature() <= COLD_FAULT_C => TOO_COLD,
            fault::POWER_STAGE => OVER_CURRENT_OUTPUT,
            fault::FOLLOWING_ERROR => POSITION_REGULATOR,
            code => code,
        }
    }
    /// Bytes 3-4: the temperature [°C] of a temperature fault, the DC link
    /// voltage [mV] of a voltage fault (D54).
    fn fault_info(&self) -> [u8; 5] {
        let value = match AxisDrive::fault(self).value() >> 8 {
            0x32 => self.axis.dc_link_mv().min(0xFFFF) as u16,
            0x43 => self.axis.temperature() as u16,
            _ => 0,
        };
        let [lo, hi] = value.to_le_bytes();
        [lo, hi, 0, 0, 0]
    }
    fn warning(&self) -> bool {
        self.warned || self.slowed()
    }
    fn reset_fault(&mut self) -> bool {
        let cleared = self.axis.reset_fault() && self.axis.temperature() > COLD_FAULT_C;
        if cleared {
            (self.fault, self.standing_ms, self.lagging_ms) = (EmcyCode::NO_ERROR, 0, 0);
        }
        cleared
    }
    fn max_velocity(&self) -> u32 {
        self.axis.max_velocity() >> u32::from(self.derated)
    }
    fn min_velocity(&self) -> u32 {
        MIN_VELOCITY
    }
}

#[cfg(test)]
mod tests {
    // `Drive` alone, as the profile sees the roller (not `AxisDrive`).
    use super::{OVER_CURRENT_OUTPUT, POSITION_REGULATOR, Roller};
    use crate::devices::ec5000::AXIS;
    use canopen_core::axis::{Injected, fault};
    use canopen_core::profiles::cia402::drive::{Drive, SetPoint};

    fn roller() -> Roller {
        let mut r = Roller::NEW;
        r.axis.configure(AXIS);
        r.enable(true);
        r
    }

    #[test]
    fn the_models_generic_faults_take_the_manuals_codes() {
        // A following error beyond the drive's 200,000 inc: 0x8600, not 0x8611.
        let mut r = roller();
        r.command(SetPoint::Position { position: 300_000, velocity: 0 });
        r.tick();
        assert_eq!(r.fault(), POSITION_REGULATOR);
        // The power stage: 0xFF15, not 0x2320.
        let mut r = roller();
        r.axis.inject(Injected::PowerStage);
        assert_eq!(r.fault(), OVER_CURRENT_OUTPUT);
        // Codes the table shares with CiA 402 stay.
        r.axis.remove(Injected::PowerStage);
        assert!(r.reset_fault());
        r.axis.inject(Injected::UnderVoltage);
        assert_eq!((r.fault(), r.fault_info()), (fault::UNDER_VOLTAGE, [0; 5]));
    }
}
