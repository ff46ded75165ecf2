//! The b maXX 4400's drive errors as EMCY (§5.6.2 "Umsetzung der
//! Fehlermeldungen nach DSP 402", M-L3262-4133, and P0830 bit 9, §4.3.9
//! M-L764-773; D54 and D64 in docs/devices/bmaxx4400.md): the manual's
//! example B16 (node 5, encoder 1 wire break) and B18 (drive error 167,
//! "Bremse öffnet nicht", FFA7h or FF00h) as exact frames in virtual time,
//! the table's collective FF00h, and the error reset B17.

mod common;

use common::{Bench, F, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

/// The manual's EMCY example addresses node 5.
const ID: u8 = 5;
const RPDO1: u16 = 0x205;
const TPDO1: u16 = 0x185;
const TPDO2: u16 = 0x285;
const EMCY: u16 = 0x085;
const P0830: u16 = 0x433E;

/// Node 5 with P0830 = `word`, Operational, Operation enabled through RPDO1
/// (0x6040) at 100-300 ms: statusword 0x0237 in TPDO1 (type 255).
fn enabled(word: u16) -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    b.now = ms(10);
    assert_eq!(b.sdo_write(ID, P0830, 0, &word.to_le_bytes()), ok_write(P0830, 0));
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO1, &[cw, 0]);
    }
    b.run_until(ms(350));
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x02]));
    b
}

/// The drive reports `number` at 400 ms: the frames up to 450 ms, with their time.
fn reported(b: &mut Bmaxx, number: u8) -> Vec<(u64, F)> {
    b.run_until(ms(400));
    b.node.app_mut().drive.drive.report(number);
    b.run_until(ms(450)).into_iter().map(|(t, f)| (t.as_micros() / 1000, f)).collect()
}

/// The EMCY at `t`, then Fault: statusword 0x0218 (bit 3, voltage enabled,
/// remote) in TPDO1 and TPDO2 (with 0x6061, no mode); TPDO3/4 are timer-only (type 254).
fn fault_at(t: u64, emcy: Vec<u8>) -> Vec<(u64, F)> {
    vec![(t, (EMCY, emcy)), (t, (TPDO1, vec![0x18, 0x02])), (t, (TPDO2, vec![0x18, 0x02, 0x00]))]
}

#[test]
fn b16_b17_m_l3232_encoder_1_wire_break_0073h_is_emcy_7300h_with_the_drive_error_number() {
    let mut b = enabled(0);
    // "Slave 5 hat einen Geberfehler an Geber 1 erkannt (Leitungsbruch Geber 1)":
    // 0073h → 7300h, the number in bytes 3-4: `85 [8] 00 73 81 00 73 00 00 00`. The error
    // register is the core's, 21h (generic + the 7xxx class), not the example's 81h (D54).
    assert_eq!(reported(&mut b, 0x73), fault_at(401, vec![0x00, 0x73, 0x21, 0x00, 0x73, 0, 0, 0]));
    // Fault reset: "Sind alle Fehler quittiert, … Error Reset / No Error" (B17), Switch on disabled.
    assert_eq!(b.rx(ms(500), RPDO1, &[0x80, 0x00]), [(EMCY, vec![0; 8]), (TPDO1, vec![0x50, 0x02]), (TPDO2, vec![0x50, 0x02, 0x00])]);
}

#[test]
fn b18_m_l764_p0830_bit_9_clear_a_drive_error_without_dsp_402_code_is_ff00h_plus_its_number() {
    let mut b = enabled(0x0000);
    // "Reglerfehler Nummer 167 (Bremse öffnet nicht), wird dann mit FF00hex + 00A7hex
    // (Nr. 167) = FFA7hex ausgegeben" (bit 9 = 0, "Standard"). Register 81h: manufacturer-specific.
    assert_eq!(reported(&mut b, 0xA7), fault_at(401, vec![0xA7, 0xFF, 0x81, 0x00, 0xA7, 0, 0, 0]));
}

#[test]
fn b18_m_l772_p0830_bit_9_set_a_drive_error_without_dsp_402_code_is_ff00h() {
    let mut b = enabled(0x0200);
    // "Bit 9 ⇒ 1: altes Verhalten z.B.: FF00hex"; the number stays in bytes 3-4.
    assert_eq!(reported(&mut b, 0xA7), fault_at(401, vec![0x00, 0xFF, 0x81, 0x00, 0xA7, 0, 0, 0]));
    // The homing error 00CDh, the last of the table's rows without a code, the same way.
    let mut b = enabled(0x0200);
    assert_eq!(reported(&mut b, 0xCD), fault_at(401, vec![0x00, 0xFF, 0x81, 0x00, 0xCD, 0, 0, 0]));
}

#[test]
fn m_l4060_module_errors_are_the_collective_ff00h_whatever_bit_9() {
    // "Die herstellerspezifischen Error Codes 0030hex bis 003Bhex, 0050hex, 0070hex und
    // 0080hex werden zusammenfassend über ein EMY-Telegramm mit dem CANopen Error Code
    // FF00hex ausgegeben": 0030h (SmallModule_A), not FF30h.
    let mut b = enabled(0x0000);
    assert_eq!(reported(&mut b, 0x30), fault_at(401, vec![0x00, 0xFF, 0x81, 0x00, 0x30, 0, 0, 0]));
}

#[test]
fn m_l3262_the_table_gives_each_drive_error_its_dsp_402_code() {
    // (drive error, EMCY code, error register) from §5.6.2, one row of each kind.
    for (number, code, register) in [
        (0x01u8, 0x7400u16, 0x21u8), // watchdog
        (0x11, 0x5530, 0x01),        // software error
        (0x20, 0x8100, 0x11),        // ProProg timeout
        (0x41, 0x3130, 0x05),        // phase failure
        (0x54, 0x2240, 0x03),        // earth current
        (0x55, 0x4110, 0x09),        // inner air temperature
        (0x60, 0x4320, 0x09),        // motor temperature sensor short-circuited
        (0x63, 0x7120, 0x21),        // I²t motor
        (0x91, 0x7320, 0x21),        // encoder 2 absolute position unknown
        (0xA2, 0x8110, 0x11),        // cyclic communication time-out
        (0xB7, 0x5530, 0x01),        // PSI erased
        (0xC0, 0x8611, 0x11),        // dynamic following error
        (0xC9, 0x8600, 0x11),        // set-point too late
        (0xD0, 0x7121, 0x21),        // drive blocked
        (0xE1, 0xFFE1, 0x81),        // run-time error: no code
    ] {
        let mut b = enabled(0);
        let [lo, hi] = code.to_le_bytes();
        let emcy = vec![lo, hi, register, 0x00, number, 0, 0, 0];
        assert_eq!(reported(&mut b, number), fault_at(401, emcy), "drive error {number:02X}h");
    }
}
