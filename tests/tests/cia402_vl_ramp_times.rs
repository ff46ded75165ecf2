//! vl ramps given as times (docs/firmware.md "vl ramp times",
//! docs/devices/bmaxx4400.md D69): 0x604F ramp function time (acceleration),
//! 0x6050 slow down time (deceleration) and 0x6051 quick stop time, each in
//! ms from 0 to the reference speed, on the b maXX 4400 (App. C: P1172-P1174,
//! "Hochlaufgeber" times to MotorMaxSpeed; its vl quick stop "über P1174 HLG
//! Haltezeit oder in 6051h"). Its reference is 0x6080 max motor speed
//! (MotorMaxSpeed, P1031) or, while that is 0, the motor's 3000 min⁻¹.
//! Measured on the axis: TPDO3 carries the statusword, 0x6044 (actual) and
//! 0x6043 (demand), in min⁻¹, at a SYNC every millisecond. A SYNC's frame shows
//! the ticks before it: a target written at 200 ms moves from the tick at
//! 201 ms, so the frame at 250 ms shows 49 ticks of the ramp.

mod common;

use common::bmaxx4400::{Bmaxx, ID, controlword, powered};
use common::{ms, ok_write};

const SYNC: u16 = 0x080;
const TPDO3: u16 = 0x382;

const OPERATION_ENABLED: u16 = 0x0237;
const QUICK_STOP_ACTIVE: u16 = 0x0217;
const SWITCH_ON_DISABLED: u16 = 0x0250;

/// Node 2 in vl, Operation enabled with 0x6042 = 0 at 10 ms, `settings`
/// written first; TPDO3 on every SYNC. The clock at 100 ms.
fn enabled(settings: &[(u16, u8, &[u8])]) -> Bmaxx {
    let mut b = powered();
    b.map_pdo(ID, 0x1A02, &[0x6041_0010, 0x6044_0010, 0x6043_0010]);
    assert_eq!(b.sdo_write(ID, 0x1802, 2, &[1]), ok_write(0x1802, 2));
    for &(index, sub, value) in settings {
        assert_eq!(b.sdo_write(ID, index, sub, value), ok_write(index, sub), "{index:#x}");
    }
    assert_eq!(b.sdo_write(ID, 0x6060, 0, &[2]), ok_write(0x6060, 0));
    b.nmt(0x01, ID);
    for cw in [0x06u16, 0x07, 0x0F] {
        controlword(&mut b, cw);
    }
    b.run_until(ms(100));
    b
}

/// An expedited SDO download of sub 0 at the bench's time (answer checked, TPDOs ignored).
fn write(b: &mut Bmaxx, index: u16, value: &[u8]) {
    write_sub(b, index, 0, value);
}

/// [`write`] of sub-index `sub`.
fn write_sub(b: &mut Bmaxx, index: u16, sub: u8, value: &[u8]) {
    let out = b.rx(b.now, 0x600 + u16::from(ID), &common::expedited_download(index, sub, value));
    assert!(out.contains(&(0x580 + u16::from(ID), ok_write(index, sub))), "{index:#x}: {out:x?}");
}

/// 0x6042 at `t` ms.
fn target(b: &mut Bmaxx, t: u64, rpm: i16) {
    b.run_until(ms(t));
    write(b, 0x6042, &rpm.to_le_bytes());
}

/// TPDO3 at a SYNC every millisecond up to `to` ms: (ms, statusword, 0x6044, 0x6043).
fn trace(b: &mut Bmaxx, to: u64) -> Vec<(u64, u16, i16, i16)> {
    let from = b.now.as_micros() / 1000 + 1;
    let mut frames = Vec::new();
    for t in from..=to {
        for (id, d) in b.rx(ms(t), SYNC, &[]) {
            if id == TPDO3 {
                let word = |i: usize| u16::from_le_bytes([d[i], d[i + 1]]);
                frames.push((t, word(0), word(2) as i16, word(4) as i16));
            }
        }
    }
    frames
}

/// The frame at `t` ms.
#[track_caller]
fn at(frames: &[(u64, u16, i16, i16)], t: u64) -> (u64, u16, i16, i16) {
    *frames.iter().find(|f| f.0 == t).expect("a frame")
}

/// The first time the demand (0x6043) is `rpm`.
fn demand_reaches(frames: &[(u64, u16, i16, i16)], rpm: i16) -> u64 {
    frames.iter().find(|f| f.3 == rpm).expect("reached").0
}

#[test]
fn ramp_function_time_0x604f_1000_ms_to_3000_min_accelerates_3_min_per_ms() {
    // 1 s from 0 to MotorMaxSpeed (0x6080 = 0: the motor's 3000 min⁻¹): 600 min⁻¹ in 200 ms.
    let mut b = enabled(&[(0x604F, 0, &1000u32.to_le_bytes())]);
    target(&mut b, 200, 600);
    let frames = trace(&mut b, 500);
    assert_eq!(at(&frames, 250), (250, OPERATION_ENABLED, 147, 147), "49 ms: 147 min⁻¹");
    assert_eq!(at(&frames, 300), (300, OPERATION_ENABLED, 297, 297), "99 ms: about half way");
    assert_eq!(demand_reaches(&frames, 600), 401, "200 ms");
    assert_eq!(at(&frames, 500), (500, OPERATION_ENABLED | 0x0400, 600, 600), "target reached");
}

#[test]
fn slow_down_time_0x6050_2000_ms_decelerates_1_5_min_per_ms() {
    let mut b = enabled(&[(0x6050, 0, &2000u32.to_le_bytes())]);
    target(&mut b, 200, 600);
    b.run_until(ms(300));
    // Up at the drive's limit (0x6048 is 0, 0x604F 0), down in 2 s per 3000 min⁻¹: 400 ms.
    target(&mut b, 300, 0);
    let frames = trace(&mut b, 800);
    assert_eq!(at(&frames, 400), (400, OPERATION_ENABLED, 451, 451), "99 ms: −148.5 min⁻¹");
    assert_eq!(at(&frames, 501), (501, OPERATION_ENABLED, 300, 300), "200 ms: half");
    assert_eq!(demand_reaches(&frames, 0), 701, "400 ms");
}

#[test]
fn max_motor_speed_0x6080_is_the_reference_of_the_ramp_times() {
    // 0x6080 = 1500 min⁻¹ (MotorMaxSpeed): 1 s per 1500 min⁻¹, 600 min⁻¹ in 400 ms.
    let mut b = enabled(&[(0x604F, 0, &1000u32.to_le_bytes()), (0x6080, 0, &1500u32.to_le_bytes())]);
    target(&mut b, 200, 600);
    let frames = trace(&mut b, 700);
    assert_eq!(at(&frames, 301), (301, OPERATION_ENABLED, 150, 150), "100 ms: 150 min⁻¹");
    assert_eq!(demand_reaches(&frames, 600), 601, "400 ms");
}

#[test]
fn quick_stop_time_0x6051_brakes_a_vl_quick_stop_and_ends_when_0x6044_reads_0() {
    // 0x6051 = 500 ms per 3000 min⁻¹ (App. C: "über P1174 HLG Haltezeit oder in 6051h";
    // 0x605A = 2, its default, the quick stop ramp): from 600 min⁻¹ in 100 ms.
    let mut b = enabled(&[(0x6051, 0, &500u32.to_le_bytes()), (0x605A, 0, &2i16.to_le_bytes())]);
    target(&mut b, 200, 600);
    b.run_until(ms(300));
    write(&mut b, 0x6040, &0x000Bu16.to_le_bytes());
    let frames = trace(&mut b, 500);
    assert_eq!(at(&frames, 302), (302, QUICK_STOP_ACTIVE, 594, 594), "6 min⁻¹ per ms");
    assert_eq!(at(&frames, 351), (351, QUICK_STOP_ACTIVE, 300, 300), "half way after 50 ms");
    // The demand and the axis at 0 after 100 ms: Switch on disabled in that frame.
    let i = frames.iter().position(|f| f.1 == SWITCH_ON_DISABLED).expect("Switch on disabled");
    assert_eq!((frames[i - 1], frames[i]), ((400, QUICK_STOP_ACTIVE, 6, 6), (401, SWITCH_ON_DISABLED, 0, 0)));
}

#[test]
fn without_0x6051_a_vl_quick_stop_brakes_at_the_drives_limit() {
    // No 0x604A in the dictionary and 0x6051 = 0: the motor's 500 revolutions/s², 30 min⁻¹
    // per ms, stops 600 min⁻¹ in 20 ms.
    let mut b = enabled(&[(0x605A, 0, &2i16.to_le_bytes())]);
    target(&mut b, 200, 600);
    b.run_until(ms(300));
    write(&mut b, 0x6040, &0x000Bu16.to_le_bytes());
    let frames = trace(&mut b, 400);
    assert_eq!(at(&frames, 311), (311, QUICK_STOP_ACTIVE, 300, 300));
    let i = frames.iter().position(|f| f.1 == SWITCH_ON_DISABLED).expect("Switch on disabled");
    assert_eq!((frames[i - 1], frames[i]), ((320, QUICK_STOP_ACTIVE, 30, 30), (321, SWITCH_ON_DISABLED, 0, 0)));
}

#[test]
fn the_ramp_written_last_rules_0x6048_after_0x604f_and_0x604f_after_0x6048() {
    // On the card 0x6048 sub 2 and 0x604F both write P1172 (App. C): the last one rules.
    let mut b = enabled(&[(0x604F, 0, &1000u32.to_le_bytes())]);
    // 0x6048: 600 min⁻¹ per 2 s, 0.3 min⁻¹ per ms.
    write_sub(&mut b, 0x6048, 1, &600u32.to_le_bytes());
    write_sub(&mut b, 0x6048, 2, &2u16.to_le_bytes());
    assert_eq!(b.sdo_upload(ID, 0x604F, 0), Ok(vec![0; 4]), "the time gave way to the pair");
    target(&mut b, 200, 600);
    let frames = trace(&mut b, 300);
    assert_eq!(at(&frames, 300).3, 30, "0x6048: 0.3 min⁻¹ per ms, 29.7 after 99 ms");
    // 0x604F again: 3 min⁻¹ per ms from here.
    write(&mut b, 0x604F, &1000u32.to_le_bytes());
    let frames = trace(&mut b, 400);
    assert_eq!(at(&frames, 400).3, 327, "0x604F: 297 min⁻¹ more in the next 99 ms");
}
