//! The b maXX 4400's drive errors (§5.6.2 "Umsetzung der Fehlermeldungen
//! nach DSP 402", M-L3262-4133) for the faults the axis model produces
//! (D54): the EMCY code the table gives and the drive error number in EMCY
//! bytes 3-4, most significant byte first as the manual's example prints it
//! (M-L3232-3257: `085 [8] 00 73 81 00 73 00 00 00`).

use canopen_core::axis::{Axis, fault};
use canopen_core::profiles::cia402::drive::{Drive, SetPoint, Switches};

/// The axis model as a b maXX drive: the same motor, its faults in the drive's terms.
#[derive(Clone, Debug)]
pub struct BmaxxDrive {
    /// The simulated motor and load.
    pub axis: Axis,
}

impl BmaxxDrive {
    /// The drive at power-on (all zero bits).
    pub const NEW: BmaxxDrive = BmaxxDrive { axis: Axis::NEW };
}

/// (drive error number, EMCY code) for an axis fault: 00C1h static
/// following error → 8611h, 0062h motor over-temperature → 4310h, 005Eh
/// DC-link under-voltage → 3100h, 0053h power-unit over-current → 2310h.
const fn drive_error(code: u16) -> Option<(u16, u16)> {
    Some(match code {
        fault::FOLLOWING_ERROR => (0x00C1, 0x8611),
        fault::OVER_TEMPERATURE => (0x0062, 0x4310),
        fault::UNDER_VOLTAGE => (0x005E, 0x3100),
        fault::POWER_STAGE => (0x0053, 0x2310),
        _ => return None,
    })
}

impl Drive for BmaxxDrive {
    fn reset(&mut self) {
        self.axis.reset();
    }
    fn enable(&mut self, on: bool) {
        self.axis.enable(on);
    }
    fn command(&mut self, set_point: SetPoint) {
        self.axis.command(set_point);
    }
    fn tick(&mut self) {
        self.axis.tick();
    }
    fn position(&self) -> i64 {
        self.axis.position()
    }
    fn set_position(&mut self, position: i64) {
        self.axis.set_position(position);
    }
    fn velocity(&self) -> i32 {
        self.axis.velocity()
    }
    fn torque(&self) -> i16 {
        self.axis.torque()
    }
    fn temperature(&self) -> i16 {
        self.axis.temperature()
    }
    fn dc_link_mv(&self) -> u32 {
        self.axis.dc_link_mv()
    }
    fn fault(&self) -> u16 {
        let code = self.axis.fault();
        drive_error(code).map_or(code, |(_, emcy)| emcy)
    }
    fn fault_info(&self) -> [u8; 5] {
        let [hi, lo] = drive_error(self.axis.fault()).map_or(0, |(number, _)| number).to_be_bytes();
        [hi, lo, 0, 0, 0]
    }
    fn warning(&self) -> bool {
        self.axis.warning()
    }
    fn reset_fault(&mut self) -> bool {
        self.axis.reset_fault()
    }
    fn switches(&self) -> Switches {
        self.axis.switches()
    }
    fn max_acceleration(&self) -> u32 {
        self.axis.max_acceleration()
    }
    fn max_velocity(&self) -> u32 {
        self.axis.max_velocity()
    }
}
