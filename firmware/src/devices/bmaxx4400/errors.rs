//! The b maXX 4400's drive errors (§5.6.2 "Umsetzung der Fehlermeldungen
//! nach DSP 402", M-L3262-4133) for the faults the axis model produces
//! (D54): the EMCY code the table gives and the drive error number in EMCY
//! bytes 3-4, most significant byte first as the manual's example prints it
//! (M-L3232-3257: `085 [8] 00 73 81 00 73 00 00 00`).

use canopen_core::axis::{Axis, AxisDrive, fault};
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::wire::emcy::EmcyCode;

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
/// DC-link under-voltage → 3100h, 0052h DC-link over-voltage → 3210h,
/// 0053h power-unit over-current → 2310h.
const fn drive_error(code: EmcyCode) -> Option<(u16, EmcyCode)> {
    Some(match code {
        fault::FOLLOWING_ERROR => (0x00C1, EmcyCode(0x8611)),
        fault::OVER_TEMPERATURE => (0x0062, EmcyCode(0x4310)),
        fault::UNDER_VOLTAGE => (0x005E, EmcyCode(0x3100)),
        fault::OVER_VOLTAGE => (0x0052, EmcyCode(0x3210)),
        fault::POWER_STAGE => (0x0053, EmcyCode(0x2310)),
        _ => return None,
    })
}

/// The axis model's drive with the b maXX's fault codes and error numbers.
impl AxisDrive for BmaxxDrive {
    fn axis(&self) -> &Axis {
        &self.axis
    }
    fn axis_mut(&mut self) -> &mut Axis {
        &mut self.axis
    }
    fn fault(&self) -> EmcyCode {
        let code = self.axis.fault();
        drive_error(code).map_or(code, |(_, emcy)| emcy)
    }
    fn fault_info(&self) -> [u8; 5] {
        let [hi, lo] = drive_error(self.axis.fault()).map_or(0, |(number, _)| number).to_be_bytes();
        [hi, lo, 0, 0, 0]
    }
    fn at_rest(&self) -> bool {
        // `Drive`'s default, standing still, as the b maXX has always had
        // it; the axis's own test (a load turning a coasting motor) is the EC5000's.
        self.axis.velocity() == 0
    }
}
