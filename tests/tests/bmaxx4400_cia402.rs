//! The Baumüller b maXX 4400 (seed 003) as its manual describes its CiA 402
//! part: the SDO examples of §5.3 (device-review B5, B6, B8-B10, B12) as
//! exact frames, the modes of operation with the manufacturer-specific ones
//! and their read-back (App. C), the drive parameters App. C ties to CiA
//! objects (P0300, P0301, P0304, P0462 with the 2^31 offset, P1000), pp and
//! pv moves through the default PDOs in virtual time, and 0x6007 on life
//! guarding loss. Manual lines as "M-L" in the test names.

mod common;

use common::{Bench, abort, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

/// The manual's examples address node 4.
const ID: u8 = 4;
const RPDO1: u16 = 0x204;
const RPDO2: u16 = 0x304;
const RPDO3: u16 = 0x404;
const RPDO4: u16 = 0x504;

const SWITCH_ON_DISABLED: u16 = 0x0250;
const OPERATION_ENABLED: u16 = 0x0237;

fn operational() -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b.now = ms(10);
    b.nmt(0x01, ID);
    b
}

/// One SDO request to node 4 and its answer.
fn req(b: &mut Bmaxx, frame: [u8; 8]) -> Vec<u8> {
    let out: Vec<_> = b.rx(b.now, 0x604, &frame).into_iter().filter(|(id, _)| *id == 0x584).collect();
    assert_eq!(out.len(), 1, "one answer: {out:x?}");
    out[0].1.clone()
}

fn statusword(b: &mut Bmaxx) -> u16 {
    let v = b.sdo_upload(ID, 0x6041, 0).expect("0x6041");
    u16::from_le_bytes([v[0], v[1]])
}

fn i32_at(b: &mut Bmaxx, index: u16) -> i32 {
    let v = b.sdo_upload(ID, index, 0).expect("readable");
    i32::from_le_bytes([v[0], v[1], v[2], v[3]])
}

/// Operation enabled in `mode` (RPDO2: 0x6040 + 0x6060) at 100-300 ms; pp
/// after a homing on the current position (method 35) in hm at 300-320 ms,
/// which the CANopen positioning mode P0601 = 9 requires (§4.4.8, D61).
fn enabled(mode: i8) -> Bmaxx {
    let mut b = operational();
    let first = if mode == 1 { 6 } else { mode };
    assert_eq!(b.sdo_write(ID, 0x6098, 0, &[35]), ok_write(0x6098, 0));
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, first as u8]);
    }
    if mode == 1 {
        b.rx(ms(310), RPDO2, &[0x1F, 0, 6]);
        b.rx(ms(320), RPDO2, &[0x0F, 0, 1]);
    }
    b.run_until(ms(350));
    assert_eq!(statusword(&mut b) & 0x6F, OPERATION_ENABLED & 0x6F);
    b
}

#[test]
fn b5_b8_m_l2010_m_l2098_mode_minus_3_speed_control_reads_back_3() {
    let mut b = operational();
    assert_eq!(req(&mut b, [0x2F, 0x60, 0x60, 0x00, 0xFD, 0, 0, 0]), [0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(req(&mut b, [0x40, 0x61, 0x60, 0x00, 0, 0, 0, 0]), [0x4F, 0x61, 0x60, 0x00, 0x03, 0, 0, 0]);
    // P1000 (0x43E8) is the drive's mode −3, P0304 (0x4130) its actual mode −3.
    assert_eq!(req(&mut b, [0x40, 0xE8, 0x43, 0x00, 0, 0, 0, 0]), [0x4B, 0xE8, 0x43, 0x00, 0xFD, 0xFF, 0, 0]);
    assert_eq!(req(&mut b, [0x40, 0x30, 0x41, 0x00, 0, 0, 0, 0]), [0x4B, 0x30, 0x41, 0x00, 0xFD, 0xFF, 0, 0]);
}

#[test]
fn b6_m_l2014_drive_parameter_p1001_at_0x43e9() {
    let mut b = operational();
    assert_eq!(req(&mut b, [0x2B, 0xE9, 0x43, 0x00, 0x0C, 0x00, 0, 0]), [0x60, 0xE9, 0x43, 0x00, 0, 0, 0, 0]);
    assert_eq!(req(&mut b, [0x40, 0xE9, 0x43, 0x00, 0, 0, 0, 0]), [0x4B, 0xE9, 0x43, 0x00, 0x0C, 0x00, 0, 0]);
}

#[test]
fn b9_m_l2129_statusword_and_p0301_follow_the_state_machine() {
    let mut b = operational();
    let [lo, hi] = SWITCH_ON_DISABLED.to_le_bytes();
    assert_eq!(req(&mut b, [0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]), [0x4B, 0x41, 0x60, 0x00, lo, hi, 0, 0]);
    b.rx(ms(100), RPDO1, &[0x06, 0x00]);
    assert_eq!(req(&mut b, [0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]), [0x4B, 0x41, 0x60, 0x00, 0x31, 0x02, 0, 0]);
    // P0301 (0x412D) is the statusword, P0300 (0x412C) the controlword.
    assert_eq!(req(&mut b, [0x40, 0x2D, 0x41, 0x00, 0, 0, 0, 0]), [0x4B, 0x2D, 0x41, 0x00, 0x31, 0x02, 0, 0]);
    assert_eq!(req(&mut b, [0x40, 0x2C, 0x41, 0x00, 0, 0, 0, 0]), [0x4B, 0x2C, 0x41, 0x00, 0x06, 0x00, 0, 0]);
}

#[test]
fn b10_m_l2145_rpdo1_cob_id_of_node_4() {
    let mut b = operational();
    assert_eq!(req(&mut b, [0x40, 0x00, 0x14, 0x01, 0, 0, 0, 0]), [0x43, 0x00, 0x14, 0x01, 0x04, 0x02, 0, 0]);
}

#[test]
fn b12_m_l2270_sub_index_does_not_exist() {
    let mut b = operational();
    assert_eq!(req(&mut b, [0x40, 0x08, 0x10, 0x01, 0, 0, 0, 0]), [0x80, 0x08, 0x10, 0x01, 0x11, 0x00, 0x09, 0x06]);
}

#[test]
fn m_l5241_modes_of_operation_and_their_display() {
    let mut b = operational();
    for (mode, display, drive) in [
        (1i8, 1i8, 1i16),
        (2, 2, 2),
        (3, 3, -3),
        (-3, 3, -3),
        (6, 6, 6),
        (7, 7, -4),
        (-4, -4, -4),
        (-6, -6, 5),
        (-106, -106, -6),
        (-7, -7, -7),
        (-5, -5, -5),
        (-2, -2, -2),
        (-1, -1, -1),
    ] {
        assert_eq!(req(&mut b, [0x2F, 0x60, 0x60, 0x00, mode as u8, 0, 0, 0]), ok_write(0x6060, 0), "{mode}");
        assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![display as u8]), "{mode}");
        assert_eq!(b.sdo_upload(ID, 0x43E8, 0), Ok(drive.to_le_bytes().to_vec()), "P1000 for {mode}");
    }
    // 0, 4 (torque: not supported), 5 and 8..127 are unused: refused, the mode stays.
    for mode in [0u8, 4, 5, 8, 127, 0x80] {
        assert_eq!(req(&mut b, [0x2F, 0x60, 0x60, 0x00, mode, 0, 0, 0]), abort(0x6060, 0, 0x0609_0030), "{mode}");
    }
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![0xFF]));
}

#[test]
fn pp_absolute_move_through_rpdo3_with_p0462_offset_by_2_31() {
    let mut b = enabled(1);
    assert_eq!(b.sdo_write(ID, 0x6067, 0, &16u32.to_le_bytes()), ok_write(0x6067, 0), "position window");
    assert_eq!(b.sdo_write(ID, 0x6081, 0, &655_360u32.to_le_bytes()), ok_write(0x6081, 0));
    assert_eq!(b.sdo_write(ID, 0x6083, 0, &6_553_600u32.to_le_bytes()), ok_write(0x6083, 0));
    assert_eq!(b.sdo_write(ID, 0x6084, 0, &6_553_600u32.to_le_bytes()), ok_write(0x6084, 0));
    // Two revolutions (1 BE = 1 INC, 65536 per revolution), new set-point.
    let target = 131_072i32.to_le_bytes();
    b.rx(ms(400), RPDO3, &[0x1F, 0x00, target[0], target[1], target[2], target[3]]);
    b.run_until(ms(450));
    assert_eq!(statusword(&mut b) & 0x1000, 0x1000, "set-point acknowledge");
    b.rx(ms(450), RPDO3, &[0x0F, 0x00, target[0], target[1], target[2], target[3]]);
    b.run_until(ms(600));
    let halfway = i32_at(&mut b, 0x6064);
    assert!(0 < halfway && halfway < 131_072, "moving: {halfway}");
    b.run_until(ms(1000));
    // The profile's fixed point at 65536 inc/rev ends within one increment (D50).
    assert!((131_071..=131_073).contains(&i32_at(&mut b, 0x6064)));
    assert_eq!(statusword(&mut b) & 0x0400, 0x0400, "target reached");
    // P0462 (0x41CE) is the drive's unsigned position: 0x6064 + 2^31 (M-L983-997).
    let p = i32_at(&mut b, 0x6064);
    assert_eq!(b.sdo_upload(ID, 0x41CE, 0), Ok((p as u32 ^ 0x8000_0000).to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x4258, 0), Ok(0x8002_0000u32.to_le_bytes().to_vec()), "P0600: 0x607A + 2^31");
    // P0830 (0x433E) bit 5: no offset (M-L652-783).
    assert_eq!(b.sdo_write(ID, 0x433E, 0, &0x0020u16.to_le_bytes()), ok_write(0x433E, 0));
    assert_eq!(b.sdo_upload(ID, 0x4258, 0), Ok(0x0002_0000u32.to_le_bytes().to_vec()));
}

#[test]
fn pv_move_in_manufacturer_speed_control_minus_3_through_rpdo4() {
    let mut b = enabled(-3);
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![3]));
    // 60 min⁻¹: one revolution per second (App. C: speeds in min⁻¹, D57).
    let v = 60i32.to_le_bytes();
    b.rx(ms(400), RPDO4, &[0x0F, 0x00, v[0], v[1], v[2], v[3]]);
    b.run_until(ms(700));
    assert_eq!(i32_at(&mut b, 0x606C), 60);
    assert_eq!(i32_at(&mut b, 0x606B), 60);
    assert_eq!(i32_at(&mut b, 0x60FF), 60, "the target stays in min⁻¹");
    assert_eq!(statusword(&mut b) & 0x0400, 0x0400, "target reached");
    let p = i32_at(&mut b, 0x6064);
    b.run_until(ms(1700));
    let moved = i32_at(&mut b, 0x6064) - p;
    assert!((65_000..=66_100).contains(&moved), "one revolution in a second: {moved}");
}

#[test]
fn manufacturer_modes_hold_the_axis() {
    let mut b = enabled(-5);
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![0xFB]));
    let p = i32_at(&mut b, 0x6064);
    b.rx(ms(400), RPDO4, &[0x0F, 0x00, 0x00, 0x00, 0x01, 0x00]);
    b.run_until(ms(900));
    assert_eq!(i32_at(&mut b, 0x6064), p, "no motion in electronic gearing (D51)");
}

#[test]
fn m_l696_p0830_bit_2_speeds_in_tenths_of_min_1() {
    let mut b = operational();
    assert_eq!(b.sdo_write(ID, 0x433E, 0, &0x0004u16.to_le_bytes()), ok_write(0x433E, 0));
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, 3]);
    }
    // 200.0 min⁻¹ is 2000 (§4.3.3, V31).
    let v = 2000i32.to_le_bytes();
    b.rx(ms(400), RPDO4, &[0x0F, 0x00, v[0], v[1], v[2], v[3]]);
    b.run_until(ms(800));
    assert_eq!(i32_at(&mut b, 0x606C), 2000);
    let p = i32_at(&mut b, 0x6064);
    b.run_until(ms(1100));
    let moved = i32_at(&mut b, 0x6064) - p;
    // 200 min⁻¹ = 3⅓ rev/s: 65536 BE in 0.3 s.
    assert!((65_400..=65_700).contains(&moved), "{moved}");
}

#[test]
fn m_l1863_life_guarding_loss_with_0x6007_3_quick_stops() {
    let mut b = enabled(3);
    let v = 60i32.to_le_bytes();
    b.rx(ms(400), RPDO4, &[0x0F, 0x00, v[0], v[1], v[2], v[3]]);
    b.run_until(ms(700));
    assert_eq!(b.sdo_write(ID, 0x6007, 0, &3i16.to_le_bytes()), ok_write(0x6007, 0));
    assert_eq!(b.sdo_write(ID, 0x100C, 0, &100u16.to_le_bytes()), ok_write(0x100C, 0));
    assert_eq!(b.sdo_write(ID, 0x100D, 0, &[2]), ok_write(0x100D, 0));
    // Guarding starts with the first RTR (M-L1889); then none for more than 200 ms.
    assert_eq!(b.rtr(ms(700), 0x704), [(0x704, vec![0x05])]);
    b.run_until(ms(1200));
    assert_eq!(i32_at(&mut b, 0x606C), 0, "stopped on the quick stop ramp");
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED, "0x605A default: Switch on disabled");
}

#[test]
fn b16_b17_m_l3232_drive_errors_as_emcy_with_the_drive_error_number_and_the_error_reset() {
    let mut b = enabled(1);
    // The load blocks during a move of 4 revolutions: drive error 00C1h static following
    // error → EMCY 8611h, the number in bytes 3-4 (the error register as the core derives it).
    b.node.app_mut().drive.drive.axis.inject(canopen_core::axis::Injected::Blocked);
    let target = 262_144i32.to_le_bytes();
    b.rx(ms(400), RPDO3, &[0x1F, 0x00, target[0], target[1], target[2], target[3]]);
    let emcy: Vec<_> = b.run_until(ms(1000)).into_iter().filter(|(_, (id, _))| *id == 0x084).map(|(_, (_, d))| d).collect();
    assert_eq!(emcy, [vec![0x11, 0x86, 0x11, 0x00, 0xC1, 0x00, 0x00, 0x00]]);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "Fault");
    b.node.app_mut().drive.drive.axis.remove(canopen_core::axis::Injected::Blocked);
    // Fault reset (RPDO1): "no error" 0x84 [8] 00 … 00 (B17, M-L3235).
    let out = b.rx(ms(1000), RPDO1, &[0x80, 0x00]);
    assert!(out.contains(&(0x084, vec![0; 8])), "{out:x?}");
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED);
}

#[test]
fn m_l3262_dc_link_under_voltage_is_drive_error_005e_emcy_3100() {
    let mut b = enabled(3);
    b.node.app_mut().drive.drive.axis.inject(canopen_core::axis::Injected::UnderVoltage);
    let emcy: Vec<_> = b.run_until(ms(600)).into_iter().filter(|(_, (id, _))| *id == 0x084).map(|(_, (_, d))| d).collect();
    assert_eq!(emcy, [vec![0x00, 0x31, 0x05, 0x00, 0x5E, 0x00, 0x00, 0x00]]);
}

#[test]
fn m_l3455_dc_link_over_voltage_is_drive_error_0052_emcy_3210() {
    let mut b = enabled(3);
    b.node.app_mut().drive.drive.axis.inject(canopen_core::axis::Injected::OverVoltage);
    let emcy: Vec<_> = b.run_until(ms(600)).into_iter().filter(|(_, (id, _))| *id == 0x084).map(|(_, (_, d))| d).collect();
    assert_eq!(emcy, [vec![0x10, 0x32, 0x05, 0x00, 0x52, 0x00, 0x00, 0x00]]);
}

/// Maps `entries` into PDO mapping `index` in Pre-operational (invalid first); the answer to sub 0.
fn map(b: &mut Bmaxx, index: u16, entries: &[u32]) -> Vec<u8> {
    assert_eq!(b.sdo_write(ID, index, 0, &[0]), ok_write(index, 0));
    for (i, e) in entries.iter().enumerate() {
        let sub = i as u8 + 1;
        assert_eq!(b.sdo_write(ID, index, sub, &e.to_le_bytes()), ok_write(index, sub));
    }
    b.sdo_write(ID, index, 0, &[entries.len() as u8])
}

#[test]
fn m_l528_at_most_8_set_points_over_all_rpdos_with_0x607a_counting_double() {
    let mut b = operational();
    b.nmt(0x80, ID);
    // Default: 6040, 6060, 607A (2), 60FF = 5 slots. Then 6042, 6072 (7), 6099.1 (8).
    assert_eq!(map(&mut b, 0x1600, &[0x6040_0010, 0x6042_0010, 0x6072_0010]), ok_write(0x1600, 0));
    assert_eq!(map(&mut b, 0x1603, &[0x60FF_0020, 0x6099_0120]), ok_write(0x1603, 0));
    // A ninth: 6099.2 in RPDO2 (instead of 6040, still mapped in RPDO1).
    assert_eq!(map(&mut b, 0x1601, &[0x6099_0220, 0x6060_0008]), abort(0x1601, 0, 0x0604_0042));
    // An object already mapped (6042 in RPDO1) takes no further slot.
    assert_eq!(map(&mut b, 0x1601, &[0x6042_0010, 0x6060_0008]), ok_write(0x1601, 0));
}

#[test]
fn m_l792_0x6041_always_takes_actual_value_slot_1() {
    let mut b = operational();
    b.nmt(0x80, ID);
    // Default TPDOs: 6041, 6061, 6064, 606C = 4. Without 6041 in any TPDO it still counts.
    assert_eq!(map(&mut b, 0x1A00, &[0x6064_0020, 0x606C_0020]), ok_write(0x1A00, 0));
    assert_eq!(map(&mut b, 0x1A01, &[0x6061_0008, 0x6077_0010, 0x6062_0020]), ok_write(0x1A01, 0));
    assert_eq!(map(&mut b, 0x1A02, &[0x606B_0020, 0x6044_0010]), ok_write(0x1A02, 0));
    // 6041, 6064, 606C, 6061, 6077, 6062, 606B, 6044 = 8: one more is refused.
    assert_eq!(map(&mut b, 0x1A03, &[0x6043_0010]), abort(0x1A03, 0, 0x0604_0042));
}

#[test]
fn m_l885_user_units_feed_36000_per_revolution_make_36000_be_65536_increments() {
    let mut b = enabled(1);
    // §4.4.5's example: 360.00° at 1/100° per revolution.
    assert_eq!(b.sdo_write(ID, 0x6092, 1, &36_000u32.to_le_bytes()), ok_write(0x6092, 1));
    assert_eq!(b.sdo_write(ID, 0x6092, 2, &1u32.to_le_bytes()), ok_write(0x6092, 2));
    assert_eq!(b.sdo_write(ID, 0x6067, 0, &2u32.to_le_bytes()), ok_write(0x6067, 0));
    assert_eq!(b.sdo_write(ID, 0x6081, 0, &360_000u32.to_le_bytes()), ok_write(0x6081, 0));
    assert_eq!(b.sdo_write(ID, 0x6083, 0, &3_600_000u32.to_le_bytes()), ok_write(0x6083, 0));
    assert_eq!(b.sdo_write(ID, 0x6084, 0, &3_600_000u32.to_le_bytes()), ok_write(0x6084, 0));
    let target = 36_000i32.to_le_bytes();
    b.rx(ms(400), RPDO3, &[0x1F, 0x00, target[0], target[1], target[2], target[3]]);
    b.rx(ms(450), RPDO3, &[0x0F, 0x00, target[0], target[1], target[2], target[3]]);
    b.run_until(ms(1200));
    assert!((35_999..=36_001).contains(&i32_at(&mut b, 0x6064)));
    let inc = canopen_core::profiles::cia402::drive::Drive::position(&b.node.app().drive.drive);
    assert!((65_535..=65_537).contains(&inc), "one revolution: {inc}");
    // More than 255 revolutions and feeds from 2^24 are refused (§4.4.5).
    assert_eq!(b.sdo_write(ID, 0x6092, 2, &256u32.to_le_bytes()), abort(0x6092, 2, 0x0609_0031));
    assert_eq!(b.sdo_write(ID, 0x6092, 1, &(1u32 << 24).to_le_bytes()), abort(0x6092, 1, 0x0609_0031));
}
