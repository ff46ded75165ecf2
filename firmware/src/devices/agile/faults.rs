//! The inverter's faults (§9.5.2, §12.5, M-L2626-2662; D52 in
//! docs/devices/agile.md): the axis model's faults as the Agile's fault
//! keys (group FXX in the high byte, code XX in the low byte) and the DS402
//! error codes 0x603F takes for them. The EMCY carries the key in bytes 6-7
//! (M-L1636-1647), and parameter 260 "Aktueller Fehler" holds it.

use canopen_core::axis::{Axis, AxisDrive, fault};
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::profiles::cia402::statusword;
use canopen_core::wire::emcy::EmcyCode;

/// The axis model as the inverter's power section and motor.
#[derive(Clone, Debug)]
pub struct AgileDrive {
    /// The simulated motor and load.
    pub axis: Axis,
    /// Controlled by contacts (p.412 0 or 2), not by the state machine:
    /// statusword bit 9 "Remote" clear (M-L3187).
    pub local: bool,
    /// The hysteresis of statusword bit 10 [inc/s] (p.549, D62).
    pub window: u32,
}

impl AgileDrive {
    /// The drive at power-on (all zero bits).
    pub const NEW: AgileDrive = AgileDrive { axis: Axis::NEW, local: false, window: 0 };

    /// The fault key of the active axis fault, 0 for none.
    pub fn key(&self) -> u16 {
        fault_of(self.axis.fault()).map_or(0, |(key, _)| key)
    }
}

/// (fault key, 0x603F) for an axis fault, as §9.5.2's table groups them
/// (its code "xx" within a group is the operating manual's; 00 here):
/// F04 motor temperature 4310h, F05 output current above the limit 2340h
/// (the power stage's failure), F07 DC link voltage out of range 3210h
/// (over- and under-voltage alike); anything else F00-F99's generic 1000h.
const fn fault_of(code: EmcyCode) -> Option<(u16, EmcyCode)> {
    Some(match code {
        EmcyCode::NO_ERROR => return None,
        fault::OVER_TEMPERATURE => (0x0400, EmcyCode(0x4310)),
        fault::POWER_STAGE => (0x0500, EmcyCode(0x2340)),
        fault::OVER_VOLTAGE | fault::UNDER_VOLTAGE => (0x0700, EmcyCode(0x3210)),
        _ => (0x0000, EmcyCode::GENERIC),
    })
}

impl AxisDrive for AgileDrive {
    fn axis(&self) -> &Axis {
        &self.axis
    }
    fn axis_mut(&mut self) -> &mut Axis {
        &mut self.axis
    }
    fn fault(&self) -> EmcyCode {
        fault_of(self.axis.fault()).map_or(EmcyCode::NO_ERROR, |(_, code)| code)
    }
    /// Bit 9 "Remote" under the state machine's control; bit 15 "Warnung 2"
    /// while a delayed warning of the motor temperature is on ("kritischer
    /// Betriebszustand, der innerhalb kurzer Zeit zu einer
    /// Störungsabschaltung … führt", M-L3193): the axis model's temperature
    /// warning, which bit 7 shows as well (D59), so bit 7 of `word`.
    fn velocity_window(&self) -> Option<u32> {
        Some(self.window)
    }
    fn status_bits(&self, word: u16) -> u16 {
        let remote = if self.local { 0 } else { statusword::REMOTE };
        let warning_2 = if word & statusword::WARNING != 0 { WARNING_2 } else { 0 };
        word | remote | warning_2
    }
    fn fault_info(&self) -> [u8; 5] {
        let [lo, hi] = self.key().to_le_bytes();
        [0, 0, 0, lo, hi]
    }
}

/// Statusword bit 15 "Warnung 2" (§10.1.1, M-L3101, M-L3193).
const WARNING_2: u16 = 1 << 15;
