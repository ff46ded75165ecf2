//! The Bonfiglioli Agile (seed 004) as its manual describes its CiA 402
//! part: the frame examples of §9.5 and §11 (device-review A11, A16,
//! A29-A35, A37) as exact frames, velocity mode with its ramps in virtual
//! time, 0x6007 on heartbeat loss and on leaving Operational, RPDO
//! transmission types 1-240 (every SYNC), and the all-zero EMCY after the
//! fault reset. Manual lines as "M-L" in the test names.

mod common;

use common::{Bench, abort, ms, ok_write};
use firmware::devices::agile;
use hal_host::storage::MemStorage;

type Agile = Bench<agile::od::Ram, agile::App, MemStorage, 4, 4, 1>;

const RPDO1: u16 = 0x201;
const TPDO1: u16 = 0x181;
const EMCY: u16 = 0x081;

/// Statusword values: bit 9 remote, bit 4 voltage enabled (D46).
const SWITCH_ON_DISABLED: u16 = 0x0250;
const READY_TO_SWITCH_ON: u16 = 0x0231;
const OPERATION_ENABLED: u16 = 0x0237;
const FAULT_REACTION_ACTIVE: u16 = 0x021F;
const FAULT: u16 = 0x0218;

/// Node 1, Operational at t = 10 ms.
fn operational() -> Agile {
    let mut b = Bench::new(agile::od::Ram::new(1), agile::App::NEW, MemStorage::new(8192), 1);
    assert_eq!(b.at(ms(0)), [(0x701, vec![0x00])]);
    b.now = ms(10);
    b.nmt(0x01, 1);
    b
}

/// A padded expedited request (the manual prints them short; the core needs DLC 8).
fn req(b: &mut Agile, bytes: &[u8]) -> Vec<u8> {
    let mut frame = [0u8; 8];
    frame[..bytes.len()].copy_from_slice(bytes);
    let out: Vec<_> = b.rx(b.now, 0x601, &frame).into_iter().filter(|(id, _)| *id == 0x581).collect();
    assert_eq!(out.len(), 1, "one answer: {out:x?}");
    out[0].1.clone()
}

fn statusword(b: &mut Agile) -> u16 {
    let v = b.sdo_upload(1, 0x6041, 0).expect("0x6041");
    u16::from_le_bytes([v[0], v[1]])
}

fn i16_at(b: &mut Agile, index: u16) -> i16 {
    let v = b.sdo_upload(1, index, 0).expect("readable");
    i16::from_le_bytes([v[0], v[1]])
}

/// RPDO1 (0x6040, 0x6042) at `t`.
fn rpdo1(b: &mut Agile, t: u64, controlword: u16, target: i16) -> Vec<(u16, Vec<u8>)> {
    let [c0, c1] = controlword.to_le_bytes();
    let [t0, t1] = target.to_le_bytes();
    b.rx(ms(t), RPDO1, &[c0, c1, t0, t1])
}

/// Operation enabled by the manual's short sequence 0x0000 → 0x000F at 100 ms.
fn enabled() -> Agile {
    let mut b = operational();
    rpdo1(&mut b, 100, 0x0000, 0);
    rpdo1(&mut b, 150, 0x000F, 0);
    b.run_until(ms(200));
    assert_eq!(statusword(&mut b) & !0x0400, OPERATION_ENABLED);
    b
}

#[test]
fn a29_m_l2613_abort_connection_option_code_reads_1_and_takes_minus_2() {
    let mut b = operational();
    assert_eq!(req(&mut b, &[0x40, 0x07, 0x60, 0x00]), [0x4B, 0x07, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00]);
    assert_eq!(req(&mut b, &[0x2B, 0x07, 0x60, 0x00, 0xFE, 0xFF]), ok_write(0x6007, 0));
    assert_eq!(req(&mut b, &[0x40, 0x07, 0x60, 0x00]), [0x4B, 0x07, 0x60, 0x00, 0xFE, 0xFF, 0x00, 0x00]);
    assert_eq!(req(&mut b, &[0x2B, 0x07, 0x60, 0x00, 0xFD, 0xFF]), abort(0x6007, 0, 0x0609_0032), "−3 is below −2");
}

#[test]
fn a30_m_l2664_error_code_reads_0() {
    let mut b = operational();
    assert_eq!(req(&mut b, &[0x40, 0x3F, 0x60, 0x00]), [0x4B, 0x3F, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]);
}

#[test]
fn a31_m_l2683_controlword_6_gives_ready_to_switch_on() {
    let mut b = operational();
    assert_eq!(req(&mut b, &[0x2B, 0x40, 0x60, 0x00, 0x06, 0x00]), ok_write(0x6040, 0));
    assert_eq!(req(&mut b, &[0x40, 0x40, 0x60, 0x00]), [0x4B, 0x40, 0x60, 0x00, 0x06, 0x00, 0x00, 0x00]);
    // The manual prints 0x0031; bit 9 remote is set as the state machine controls the inverter (D46).
    let [lo, hi] = READY_TO_SWITCH_ON.to_le_bytes();
    assert_eq!(req(&mut b, &[0x40, 0x41, 0x60, 0x00]), [0x4B, 0x41, 0x60, 0x00, lo, hi, 0x00, 0x00]);
}

#[test]
fn a32_m_l2733_target_velocity_1500_and_the_ramp_towards_it() {
    let mut b = enabled();
    assert_eq!(req(&mut b, &[0x40, 0x42, 0x60, 0x00]), [0x4B, 0x42, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(req(&mut b, &[0x2B, 0x42, 0x60, 0x00, 0xDC, 0x05]), ok_write(0x6042, 0));
    assert_eq!(req(&mut b, &[0x40, 0x42, 0x60, 0x00]), [0x4B, 0x42, 0x60, 0x00, 0xDC, 0x05, 0x00, 0x00]);
    // The manual's 0x01AB/0x01DE are snapshots; with the default ramp 150 min⁻¹/s the
    // demand after 2.85 s is 427 min⁻¹ (0x01AB).
    b.run_until(ms(200 + 2847));
    assert_eq!(req(&mut b, &[0x40, 0x43, 0x60, 0x00]), [0x4B, 0x43, 0x60, 0x00, 0xAB, 0x01, 0x00, 0x00]);
}

#[test]
fn a33_m_l2796_velocity_min_amount() {
    let mut b = operational();
    assert_eq!(req(&mut b, &[0x40, 0x46, 0x60, 0x01]), [0x43, 0x46, 0x60, 0x01, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(req(&mut b, &[0x23, 0x46, 0x60, 0x01, 0xDC, 0x05, 0x00, 0x00]), ok_write(0x6046, 1));
}

#[test]
fn a34_m_l2827_ramps_read_150_and_take_20560() {
    let mut b = operational();
    for index in [0x6048u16, 0x6049, 0x604A] {
        let [lo, hi] = index.to_le_bytes();
        assert_eq!(req(&mut b, &[0x40, lo, hi, 0x01]), [0x43, lo, hi, 0x01, 0x96, 0x00, 0x00, 0x00], "{index:#x}");
    }
    assert_eq!(req(&mut b, &[0x23, 0x48, 0x60, 0x01, 0x50, 0x50, 0x00, 0x00]), ok_write(0x6048, 1));
    assert_eq!(req(&mut b, &[0x23, 0x49, 0x60, 0x01, 0x40, 0x50, 0x00, 0x00]), ok_write(0x6049, 1));
    assert_eq!(req(&mut b, &[0x23, 0x4A, 0x60, 0x01, 0x20, 0x50, 0x00, 0x00]), ok_write(0x604A, 1));
}

#[test]
fn a35_m_l2914_modes_of_operation_2_only_display_2() {
    let mut b = operational();
    assert_eq!(req(&mut b, &[0x2F, 0x60, 0x60, 0x00, 0x02]), ok_write(0x6060, 0));
    assert_eq!(req(&mut b, &[0x40, 0x61, 0x60, 0x00]), [0x4F, 0x61, 0x60, 0x00, 0x02, 0x00, 0x00, 0x00]);
    // M-L2905 "only 2": any other mode is refused (D43), the display stays 2.
    assert_eq!(req(&mut b, &[0x2F, 0x60, 0x60, 0x00, 0x03]), abort(0x6060, 0, 0x0609_0031));
    assert_eq!(req(&mut b, &[0x2F, 0x60, 0x60, 0x00, 0x01]), abort(0x6060, 0, 0x0609_0032));
    assert_eq!(req(&mut b, &[0x40, 0x61, 0x60, 0x00]), [0x4F, 0x61, 0x60, 0x00, 0x02, 0x00, 0x00, 0x00]);
    // Write-only: a read answers the manual's "not readable" 0x06010000 (§8.3.3, D43).
    assert_eq!(req(&mut b, &[0x40, 0x60, 0x60, 0x00]), abort(0x6060, 0, 0x0601_0000));
}

#[test]
fn m_l1818_m_l2034_pdo_abort_codes() {
    let mut b = operational();
    b.nmt(0x80, 1);
    assert_eq!(req(&mut b, &[0x23, 0x00, 0x14, 0x01, 0x01, 0x02, 0x00, 0x80]), ok_write(0x1400, 1));
    // RPDO transmission types 241-253 are not allowed (M-L1818-1824).
    for tt in [241u8, 251, 252, 253] {
        assert_eq!(req(&mut b, &[0x2F, 0x00, 0x14, 0x02, tt]), abort(0x1400, 2, 0x0609_0030), "{tt}");
    }
    // Sub 4 exists for compatibility only: any access aborts (M-L2034-2038).
    assert_eq!(req(&mut b, &[0x40, 0x00, 0x18, 0x04]), abort(0x1800, 4, 0x0609_0011));
    assert_eq!(req(&mut b, &[0x40, 0x00, 0x14, 0x04]), abort(0x1400, 4, 0x0609_0011));
}

#[test]
fn a37_m_l3270_both_switch_on_sequences_reach_operation_enabled_with_the_tpdo() {
    // 0x0000 → 0x0006 → 0x0007 → 0x000F.
    let mut b = operational();
    let sw = |out: Vec<(u16, Vec<u8>)>| {
        out.into_iter().filter(|(id, _)| *id == TPDO1).map(|(_, d)| u16::from_le_bytes([d[0], d[1]])).collect::<Vec<_>>()
    };
    assert_eq!(sw(rpdo1(&mut b, 100, 0x0000, 0)), []);
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED);
    assert_eq!(sw(rpdo1(&mut b, 200, 0x0006, 0)), [READY_TO_SWITCH_ON]);
    assert_eq!(sw(rpdo1(&mut b, 300, 0x0007, 0)), [0x0233]);
    assert_eq!(sw(rpdo1(&mut b, 400, 0x000F, 0)), [OPERATION_ENABLED]);
    // 0x0000 → 0x000F (M-L3279-3282).
    assert_eq!(sw(rpdo1(&mut b, 500, 0x0000, 0)), [SWITCH_ON_DISABLED]);
    assert_eq!(sw(rpdo1(&mut b, 600, 0x000F, 0)), [OPERATION_ENABLED]);
}

#[test]
fn vl_ramps_up_with_0x6048_and_down_with_0x6049_m_l2827() {
    let mut b = enabled();
    // 0x6048: 3000 min⁻¹ per 2 s; 0x6049: 1500 min⁻¹ per 1 s... both 1500 min⁻¹/s, then 0x6049 doubled.
    assert_eq!(b.sdo_write(1, 0x6048, 1, &3000u32.to_le_bytes()), ok_write(0x6048, 1));
    assert_eq!(b.sdo_write(1, 0x6048, 2, &2u16.to_le_bytes()), ok_write(0x6048, 2));
    assert_eq!(b.sdo_write(1, 0x6049, 1, &3000u32.to_le_bytes()), ok_write(0x6049, 1));
    rpdo1(&mut b, 200, 0x000F, 1500);
    b.run_until(ms(700));
    assert_eq!(i16_at(&mut b, 0x6043), 750, "1500 min⁻¹/s for 0.5 s");
    b.run_until(ms(1300));
    assert_eq!(i16_at(&mut b, 0x6043), 1500);
    assert_eq!(i16_at(&mut b, 0x6044), 1500, "the axis follows");
    rpdo1(&mut b, 1300, 0x000F, -1500);
    b.run_until(ms(1550));
    assert_eq!(i16_at(&mut b, 0x6043), 750, "3000 min⁻¹/s down");
    b.run_until(ms(1800));
    assert_eq!(i16_at(&mut b, 0x6043), 0);
    b.run_until(ms(2300));
    assert_eq!(i16_at(&mut b, 0x6043), -750, "up again at 1500 min⁻¹/s in reverse");
}

#[test]
fn m_l2574_heartbeat_loss_with_0x6007_minus_2_quick_stops_then_faults() {
    let mut b = enabled();
    // A11 (M-L1677): consume node 3's heartbeat, 32 ms; A29: 0x6007 = −2; 0x604A 3000 min⁻¹/s.
    assert_eq!(req(&mut b, &[0x23, 0x16, 0x10, 0x01, 0x20, 0x00, 0x03, 0x00]), ok_write(0x1016, 1));
    assert_eq!(req(&mut b, &[0x2B, 0x07, 0x60, 0x00, 0xFE, 0xFF]), ok_write(0x6007, 0));
    assert_eq!(b.sdo_write(1, 0x604A, 1, &3000u32.to_le_bytes()), ok_write(0x604A, 1));
    assert_eq!(b.sdo_write(1, 0x6048, 1, &30000u32.to_le_bytes()), ok_write(0x6048, 1));
    rpdo1(&mut b, 200, 0x000F, 1500);
    b.run_until(ms(400));
    assert_eq!(i16_at(&mut b, 0x6044), 1500);
    b.rx(ms(400), 0x703, &[0x05]);
    let out = b.run_until(ms(440));
    assert!(out.iter().any(|(_, (id, d))| *id == EMCY && d[..2] == [0x30, 0x81]), "heartbeat EMCY 0x8130: {out:x?}");
    // 0x1000 with the fault key F23.03 (heartbeat of node 3) in bytes 6-7.
    assert!(out.iter().any(|(_, (id, d))| *id == EMCY && d[..2] == [0x00, 0x10] && d[6..] == [0x03, 0x23]), "{out:x?}");
    assert_eq!(statusword(&mut b), FAULT_REACTION_ACTIVE, "braking on the quick stop ramp");
    b.run_until(ms(690));
    assert!(i16_at(&mut b, 0x6043) > 0, "still braking after 0.25 s at 3000 min⁻¹/s");
    b.run_until(ms(1000));
    assert_eq!(i16_at(&mut b, 0x6044), 0);
    assert_eq!(statusword(&mut b), FAULT);
    assert_eq!(b.sdo_upload(1, 0x603F, 0), Ok(vec![0x00, 0x10]), "§12.5: bus faults are 0x1000");
}

#[test]
fn m_l2574_leaving_operational_with_0x6007_1_faults_and_the_reset_sends_the_zero_emcy_m_l838() {
    let mut b = enabled();
    rpdo1(&mut b, 200, 0x000F, 300);
    b.run_until(ms(300));
    let out = b.nmt(0x80, 1);
    // 0x603F 0x1000, error register bit 0, the fault key F20.25 in bytes 6-7 (M-L1636-1647).
    assert_eq!(out, [(EMCY, vec![0x00, 0x10, 0x01, 0, 0, 0, 0x25, 0x20])]);
    assert_eq!(statusword(&mut b), FAULT, "0x6007 = 1: Fault at once (M-L136)");
    assert_eq!(b.sdo_upload(1, 0x603F, 0), Ok(vec![0x00, 0x10]));
    let out = b.nmt(0x01, 1);
    assert!(!out.iter().any(|(id, _)| *id == EMCY));
    let out = rpdo1(&mut b, 400, 0x0080, 0);
    assert!(out.contains(&(EMCY, vec![0; 8])), "all-zero EMCY after the fault reset: {out:x?}");
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED);
}

#[test]
fn m_l1818_a16_rpdo_transmission_type_5_applies_at_every_sync() {
    let mut b = operational();
    b.nmt(0x80, 1);
    // A16 (M-L1842-1853): invalidate, type 5, valid again.
    assert_eq!(req(&mut b, &[0x23, 0x00, 0x14, 0x01, 0x01, 0x02, 0x00, 0x80]), ok_write(0x1400, 1));
    assert_eq!(req(&mut b, &[0x2F, 0x00, 0x14, 0x02, 0x05]), ok_write(0x1400, 2));
    assert_eq!(req(&mut b, &[0x23, 0x00, 0x14, 0x01, 0x01, 0x02, 0x00, 0x00]), ok_write(0x1400, 1));
    b.nmt(0x01, 1);
    rpdo1(&mut b, 100, 0x0006, 0);
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED, "held until the SYNC");
    b.rx(ms(110), 0x080, &[]);
    assert_eq!(statusword(&mut b), READY_TO_SWITCH_ON, "the first SYNC applies it, not the fifth");
    rpdo1(&mut b, 120, 0x0007, 0);
    b.rx(ms(130), 0x080, &[]);
    assert_eq!(statusword(&mut b), 0x0233);
}
