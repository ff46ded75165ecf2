//! The EC5000's EMCY table beyond CiA 402 (D48): the over-temperature
//! warning 0xFFA8 from 0x4231 sub 1 (95 °C) with the hysteresis of sub 2
//! (2 K), raised and cleared with the exact frames, and statusword bit 7
//! following it.

mod common;

use common::ec5000::*;

fn ambient(b: &mut Ec5000, celsius: i16) {
    roller(b).axis.set_ambient(celsius);
}

/// TPDO1 (0x6041, 0x6061, 0x1001, 0x2200 sub 6 actual temperature, 0x6077).
fn tpdo1(statusword: u16, error_register: u8, celsius: u8) -> Vec<u8> {
    let [lo, hi] = statusword.to_le_bytes();
    vec![lo, hi, 3, error_register, celsius, 0, 0, 0]
}

/// TPDO2 (0x6041, 0x6064).
fn tpdo2(statusword: u16) -> Vec<u8> {
    let [lo, hi] = statusword.to_le_bytes();
    vec![lo, hi, 0, 0, 0, 0]
}

/// Operation enabled in pv at rest, and with bit 7 warning.
const AT_REST: u16 = 0x1637;
const WARNED: u16 = 0x16B7;

#[test]
fn temperature_warning_0xffa8_at_95_and_cleared_at_93() {
    let mut b = enabled();
    // 94 °C: below the threshold; TPDO1 carries the temperature (0x2200 sub 6,
    // updated every 100 ms) only.
    ambient(&mut b, 94);
    assert_eq!(frames(&mut b, 700, 200), [(100, TPDO1, tpdo1(AT_REST, 0, 94))]);
    // 95 °C: EMCY 0xFFA8 at once, error register 0x81 (generic +
    // manufacturer), the temperature in bytes 3-4; the drive keeps running (a
    // warning, no fault reaction). Bit 7 and 0x1001 show at the next tick
    // (TPDO1, TPDO2), 0x2200 sub 6 at the next 100 ms.
    ambient(&mut b, 95);
    assert_eq!(
        frames(&mut b, 900, 200),
        [
            (0, EMCY, vec![0xA8, 0xFF, 0x81, 95, 0, 0, 0, 0]),
            (1, TPDO1, tpdo1(WARNED, 0x81, 94)),
            (1, TPDO2, tpdo2(WARNED)),
            (101, TPDO1, tpdo1(WARNED, 0x81, 95)),
        ]
    );
    // Within the hysteresis: no second EMCY, bit 7 stays.
    ambient(&mut b, 94);
    assert_eq!(frames(&mut b, 1100, 200), [(100, TPDO1, tpdo1(WARNED, 0x81, 94))]);
    ambient(&mut b, 96);
    assert_eq!(frames(&mut b, 1300, 200), [(100, TPDO1, tpdo1(WARNED, 0x81, 96))]);
    // 93 °C = threshold - hysteresis: "error reset", bit 7 off.
    ambient(&mut b, 93);
    assert_eq!(
        frames(&mut b, 1500, 200),
        [(0, EMCY, vec![0; 8]), (1, TPDO1, tpdo1(AT_REST, 0, 96)), (1, TPDO2, tpdo2(AT_REST)), (101, TPDO1, tpdo1(AT_REST, 0, 93))]
    );
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![1]), "the warning stays in the history");
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0xA8, 0xFF, 95, 0]), "code and the first two bytes of its information");
}

#[test]
fn threshold_and_hysteresis_follow_0x4231() {
    let mut b = enabled();
    b.sdo_download(ID, 0x4231, 1, &90i16.to_le_bytes()).expect("threshold 90 °C");
    b.sdo_download(ID, 0x4231, 2, &10i16.to_le_bytes()).expect("hysteresis 10 K");
    let emcy = |out: Vec<(u64, u16, Vec<u8>)>| out.into_iter().filter(|(_, id, _)| *id == EMCY).collect::<Vec<_>>();
    ambient(&mut b, 89);
    assert_eq!(emcy(frames(&mut b, 700, 200)), []);
    ambient(&mut b, 90);
    assert_eq!(emcy(frames(&mut b, 900, 200)), [(0, EMCY, vec![0xA8, 0xFF, 0x81, 90, 0, 0, 0, 0])]);
    ambient(&mut b, 81);
    assert_eq!(emcy(frames(&mut b, 1100, 200)), [], "above 90 - 10");
    ambient(&mut b, 80);
    assert_eq!(emcy(frames(&mut b, 1300, 200)), [(0, EMCY, vec![0; 8])]);
    // Limits as the manual prints them: 50..110 °C and 2..50 K.
    assert_eq!(b.sdo_download(ID, 0x4231, 1, &111i16.to_le_bytes()), Err(0x0609_0031));
    assert_eq!(b.sdo_download(ID, 0x4231, 2, &1i16.to_le_bytes()), Err(0x0609_0032));
}
