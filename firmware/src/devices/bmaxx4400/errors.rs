//! The b maXX 4400's drive errors as EMCY (§5.6.2 "Umsetzung der
//! Fehlermeldungen nach DSP 402", M-L3262-4133; D54, D64): each drive error
//! number the table's EMCY code, the number in EMCY bytes 3-4, most
//! significant byte first as the manual's example prints it (M-L3232-3257:
//! `085 [8] 00 73 81 00 73 00 00 00`). A number with no DSP 402 code is
//! FF00h + number, or FF00h alone with P0830 bit 9 (§4.3.9, M-L764-773).
//! The axis model's faults are the drive errors the table has for them; the
//! drive's other errors come from the drive ([`BmaxxDrive::report`]).

use canopen_core::axis::{Axis, AxisDrive, fault};
use canopen_core::profiles::cia402::drive::Drive;
use canopen_core::wire::emcy::EmcyCode;

/// The axis model as a b maXX drive: the same motor, its faults in the drive's terms.
#[derive(Clone, Debug)]
pub struct BmaxxDrive {
    /// The simulated motor and load.
    pub axis: Axis,
    /// A drive error the drive reported and no fault reset acknowledged yet (0: none).
    reported: u8,
    /// P0830 bit 9: drive errors without a DSP 402 code are FF00h alone.
    pub(super) ff00_only: bool,
    /// The drive is not synchronous to the SYNC yet: a fault reset leaves the reported error (D66).
    pub(super) out_of_step: bool,
}

impl BmaxxDrive {
    /// The drive at power-on (all zero bits).
    pub const NEW: BmaxxDrive = BmaxxDrive { axis: Axis::NEW, reported: 0, ff00_only: false, out_of_step: false };

    /// The drive reports drive error `number` (§5.6.2, e.g. 0073h "Leitungsbruch
    /// Geber 1" or 00A7h "Bremse öffnet nicht"): the drive faults, and a fault
    /// reset acknowledges it. For the errors of a drive the axis model does not
    /// simulate (encoders, brake, mains, firmware); a board with a drive
    /// behind the module reports them from there.
    pub fn report(&mut self, number: u8) {
        self.reported = number;
    }

    /// The drive error number active: the reported one, else the axis model's.
    fn number(&self) -> Option<u8> {
        if self.reported != 0 {
            return Some(self.reported);
        }
        let fault = self.axis.fault();
        AXIS_FAULTS.iter().find(|(code, _)| *code == fault.0).map(|(_, number)| *number)
    }
}

/// The axis model's faults as drive errors: 00C1h static following error,
/// 0062h motor over-temperature, 005Eh DC-link under-voltage, 0052h DC-link
/// over-voltage, 0053h power-unit over-current.
const AXIS_FAULTS: [(u16, u8); 5] = [
    (fault::FOLLOWING_ERROR.0, 0xC1),
    (fault::OVER_TEMPERATURE.0, 0x62),
    (fault::UNDER_VOLTAGE.0, 0x5E),
    (fault::OVER_VOLTAGE.0, 0x52),
    (fault::POWER_STAGE.0, 0x53),
];

/// §5.6.2 in runs: the first drive error number of each run and the EMCY
/// code of its numbers up to the next run. 0: no DSP 402 code (empty in the
/// table, or not in it); FF00h: the module errors the table gives FF00h
/// (0030h-003Ah, 0050h, 0070h, 0080h: "zusammenfassend … FF00hex", the
/// number is in P0233-P0250).
const TABLE: [(u8, u16); 62] = [
    (0x01, 0x7400), // watchdog, interrupts
    (0x04, 0),
    (0x10, 0x5530), // boot, software
    (0x12, 0x7400), // operating system, FPGA
    (0x18, 0),      // 0018h-001Ah have no code
    (0x20, 0x8100), // ProProg timeout
    (0x21, 0x7400), // protocol, parameter access
    (0x2E, 0),
    (0x30, 0xFF00), // small and big modules
    (0x3B, 0x7400), // start-up timeout, SPI CRC
    (0x3E, 0),
    (0x40, 0x3100), // mains failure
    (0x41, 0x3130),
    (0x42, 0x3120),
    (0x43, 0x3110),
    (0x44, 0x3100), // 24 V under-voltage
    (0x45, 0),
    (0x50, 0xFF00), // Hiperface (P0233)
    (0x51, 0x4210), // heat sink
    (0x52, 0x3210), // DC-link over-voltage
    (0x53, 0x2310), // power-unit over-current
    (0x54, 0x2240), // earth current
    (0x55, 0x4110), // inner air
    (0x56, 0),
    (0x57, 0x5441), // safety relay
    (0x58, 0x5442),
    (0x59, 0x5400),
    (0x5A, 0x3130), // 005Ah-005Dh as 0041h-0043h
    (0x5B, 0x3100),
    (0x5C, 0x3120),
    (0x5D, 0x3110),
    (0x5E, 0x3100), // DC-link under-voltage
    (0x5F, 0),
    (0x60, 0x4320), // motor temperature sensor, motor temperature
    (0x61, 0x4310),
    (0x63, 0x7120), // I²t
    (0x64, 0),
    (0x70, 0xFF00), // encoder 1 Hiperface (P0234)
    (0x71, 0x7300), // encoder 1
    (0x77, 0x7120), // motor data
    (0x7B, 0x7300),
    (0x7D, 0),
    (0x80, 0xFF00), // encoder 2 Hiperface (P0235)
    (0x81, 0x7300), // encoder 2
    (0x87, 0x7120),
    (0x8B, 0x7300),
    (0x8D, 0),
    (0x90, 0x7320), // absolute position unknown
    (0x92, 0x7300), // encoder modules
    (0xA0, 0x8100), // time-outs
    (0xA2, 0x8110), // cyclic communication
    (0xA3, 0x8100), // on-demand data, field bus, synchronisation, brake control
    (0xA7, 0),      // brake (00A7h-00ACh) have no code
    (0xB0, 0x5530), // EEPROM, data sets
    (0xBB, 0),
    (0xC0, 0x8611), // following errors
    (0xC2, 0x7300),
    (0xC4, 0x8600), // positioning (limit switches, homing required, spindle)
    (0xCD, 0),      // homing error
    (0xD0, 0x7121), // drive blocked
    (0xD1, 0x7300),
    (0xD4, 0), // 00E0h-00EFh have no code
];

/// [`TABLE`]'s first numbers and its codes, apart: 186 bytes of flash, not 248 with the tuples' padding.
const FIRSTS: [u8; TABLE.len()] = columns().0;
const CODES: [u16; TABLE.len()] = columns().1;

const fn columns() -> ([u8; TABLE.len()], [u16; TABLE.len()]) {
    let (mut firsts, mut codes, mut i) = ([0; TABLE.len()], [0; TABLE.len()], 0);
    while i < TABLE.len() {
        (firsts[i], codes[i]) = TABLE[i];
        i += 1;
    }
    (firsts, codes)
}

/// The EMCY code of drive error `number` (§5.6.2, §4.3.9).
pub(super) fn code_of(number: u8, ff00_only: bool) -> EmcyCode {
    let code = FIRSTS.iter().rposition(|first| *first <= number).and_then(|run| CODES.get(run)).map_or(0, |code| *code);
    EmcyCode(match code {
        0 if ff00_only => 0xFF00,
        0 => 0xFF00 | u16::from(number),
        code => code,
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
        self.number().map_or_else(|| self.axis.fault(), |n| code_of(n, self.ff00_only))
    }
    fn fault_info(&self) -> [u8; 5] {
        [0, self.number().unwrap_or(0), 0, 0, 0]
    }
    fn reset_fault(&mut self) -> bool {
        // "Quittieren": a reported error is acknowledged by the reset once its cause is gone.
        if !self.out_of_step {
            self.reported = 0;
        }
        self.axis.reset_fault() && self.reported == 0
    }
    fn at_rest(&self) -> bool {
        // `Drive`'s default, standing still, as the b maXX has always had
        // it; the axis's own test (a load turning a coasting motor) is the EC5000's.
        self.axis.velocity() == 0
    }
}
