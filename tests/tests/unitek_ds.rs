//! The UNITEK DS register protocol with exact frames on virtual time: every
//! frame example U1–U18 of the device review (notes/device-review.md §2.4),
//! misprints corrected as it says, the manual line in the test name
//! (`m_l…`), plus the rules the manual states around them. RX id 0x201,
//! TX id 0x181 unless a test moves them.

mod common;

use common::{Bench, F, ms};
use firmware::devices::unitek_ds::{self, App, od};
use hal_host::storage::MemStorage;

type Drive = Bench<od::Ram, App, MemStorage, { od::RPDO_COUNT }, { od::TPDO_COUNT }, { od::HB_CONSUMER_COUNT }>;

const RX: u16 = 0x201;
const TX: u16 = 0x181;
/// STATUS with P-N and N-I (always set, U-D4).
const LOOPS: u32 = 0x0180;
const ENA: u32 = 0x0001;
const CAL: u32 = 0x1000;
const TOL: u32 = 0x2000;

fn drive_on(storage: MemStorage) -> Drive {
    let mut b = Bench::new(od::Ram::new(1), App::NEW, storage, 1);
    assert_eq!(b.at(ms(0)), [], "no boot-up: CANopen is off");
    b
}

fn drive() -> Drive {
    drive_on(MemStorage::new(8192))
}

/// A frame to the drive at `t` that it does not answer (writes are not acknowledged).
fn w(b: &mut Drive, t: u64, data: &[u8]) {
    assert_eq!(b.rx(ms(t), RX, data), [], "no answer to {data:02X?}");
}

/// READ once at `t` on (`rx`, `tx`): the one reply's data.
fn read_via(b: &mut Drive, t: u64, rx: u16, tx: u16, regid: u8) -> Vec<u8> {
    let out = b.rx(ms(t), rx, &[0x3D, regid, 0x00]);
    assert_eq!(out.len(), 1, "one reply to READ {regid:#04X}: {out:02X?}");
    assert_eq!(out[0].0, tx);
    out[0].1.clone()
}

fn read(b: &mut Drive, t: u64, regid: u8) -> Vec<u8> {
    read_via(b, t, RX, TX, regid)
}

fn status(value: u32) -> Vec<u8> {
    let [a, b, c, d] = value.to_le_bytes();
    vec![0x40, a, b, c, d, 0x00]
}

fn r16(regid: u8, v: u16) -> Vec<u8> {
    let [a, b] = v.to_le_bytes();
    vec![regid, a, b, 0x00]
}

fn r32(regid: u8, v: u32) -> Vec<u8> {
    let [a, b, c, d] = v.to_le_bytes();
    vec![regid, a, b, c, d, 0x00]
}

/// Frames sent up to `t`, with their times in ms.
fn run(b: &mut Drive, t: u64) -> Vec<(u64, F)> {
    b.run_until(ms(t)).into_iter().map(|(at, f)| (at.as_micros() / 1000, f)).collect()
}

/// The speed the drive reports (0x30).
fn speed(b: &mut Drive, t: u64) -> i16 {
    let r = read(b, t, 0x30);
    i16::from_le_bytes([r[1], r[2]])
}

fn position(b: &mut Drive, t: u64) -> i32 {
    let r = read(b, t, 0x6D);
    i32::from_le_bytes([r[1], r[2], r[3], r[4]])
}

// ---- CANopen is off ------------------------------------------------------

#[test]
fn no_boot_up_no_nmt_no_sdo() {
    let mut b = drive();
    assert_eq!(b.rx(ms(1), 0x000, &[0x01, 0x00]), [], "NMT start all");
    assert_eq!(b.rx(ms(2), 0x601, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [], "SDO upload of 0x1000");
    assert_eq!(b.rx(ms(3), 0x000, &[0x81, 0x00]), [], "NMT reset node: no boot-up");
    assert_eq!(run(&mut b, 2000), [], "no heartbeat, no PDO");
    assert!(b.node.acceptance().accepts(RX, false), "the board's filter passes the RX id");
    assert!(!b.node.acceptance().accepts(0x601, false) && !b.node.acceptance().accepts(0x000, false));
}

// ---- receive rules (§4.1, §4.5, English item 1) ----------------------------

#[test]
fn u1_position_set_point_32_bit_m_l355() {
    let mut b = drive();
    w(&mut b, 1, &[0x6E, 0x10, 0xCA, 0xE1, 0x11]);
    assert_eq!(read(&mut b, 2, 0x6E), r32(0x6E, 300_010_000));
}

#[test]
fn dlc_6_to_8_are_read_as_5_and_dlc_4_as_3_m_l231() {
    let mut b = drive();
    w(&mut b, 1, &[0x6E, 0x10, 0xCA, 0xE1, 0x11, 0xAA, 0xBB, 0xCC]);
    assert_eq!(read(&mut b, 2, 0x6E), r32(0x6E, 0x11E1_CA10));
    w(&mut b, 3, &[0x79, 0x20, 0x00, 0x55]);
    assert_eq!(read(&mut b, 4, 0x79), r16(0x79, 0x20));
}

#[test]
fn a_16_bit_write_is_sign_extended_and_a_32_bit_one_truncated_m_l1033() {
    let mut b = drive();
    // POS_DEST is INTEGER32: 0x8000 becomes −32768.
    w(&mut b, 1, &[0x6E, 0x00, 0x80]);
    assert_eq!(read(&mut b, 2, 0x6E), [0x6E, 0x00, 0x80, 0xFF, 0xFF, 0x00]);
    // The ramp 0x35 is UNSIGNED32: zero-extended.
    w(&mut b, 3, &[0x35, 0x00, 0x80]);
    assert_eq!(read(&mut b, 4, 0x35), r32(0x35, 0x8000));
    // A 32-bit write to 16-bit SPEED_CMD keeps the low word (M-L1037).
    w(&mut b, 5, &[0x31, 0xCD, 0x0C, 0x34, 0x12]);
    assert_eq!(read(&mut b, 6, 0x31), r16(0x31, 0x0CCD));
}

#[test]
fn rtr_short_frames_and_refused_writes_get_no_answer_and_are_counted_m_l321() {
    let mut b = drive();
    assert_eq!(b.rtr(ms(1), RX), [], "RTR ignored (M-L321, L1030)");
    for data in [&[][..], &[0x31], &[0x31, 0x01]] {
        w(&mut b, 2, data);
    }
    w(&mut b, 3, &[0x30, 0x01, 0x00]); // 0x30 SPEED_ACTUAL is read-only
    w(&mut b, 3, &[0x3A, 0x01, 0x00]); // 0x3A is no register (D3)
    w(&mut b, 3, &[0x31, 0x00, 0x80]); // −32768 is outside ±32767 (D11)
    assert_eq!(b.rx(ms(4), RX, &[0x3D, 0x3A, 0x00]), [], "READ of no register");
    assert_eq!(b.rx(ms(4), RX, &[0x3D, 0x84, 0x00]), [], "READ of a function register");
    assert_eq!(read(&mut b, 5, 0x97), r16(0x97, 8), "CAN_COUNTREJ");
    assert_eq!(read(&mut b, 6, 0x31), r16(0x31, 0), "the refused set-point changed nothing");
}

// ---- identifiers (Ex. 1, Ex. 9) ------------------------------------------

#[test]
fn u2_rx_id_changes_at_once_m_l453() {
    let mut b = drive();
    w(&mut b, 1, &[0x68, 0x10, 0x02]);
    assert!(b.node.acceptance().accepts(0x210, false));
    assert_eq!(b.rx(ms(2), RX, &[0x3D, 0x68, 0x00]), [], "0x201 is no longer heard");
    assert_eq!(read_via(&mut b, 3, 0x210, TX, 0x68), r16(0x68, 0x210));
    // Outside 0x201..0x27F (L204): refused.
    assert_eq!(b.rx(ms(4), 0x210, &[0x68, 0x00, 0x03]), []);
    assert_eq!(read_via(&mut b, 5, 0x210, TX, 0x68), r16(0x68, 0x210));
}

#[test]
fn u10_cyclic_read_every_100_ms_on_ids_0x210_0x190_m_l633() {
    let mut b = drive();
    // Ex. 9 uses RX 0x210 (Ex. 1) and TX 0x190, which no example sets: set here.
    w(&mut b, 0, &[0x68, 0x10, 0x02]);
    assert_eq!(b.rx(ms(0), 0x210, &[0x69, 0x90, 0x01]), []);
    assert_eq!(b.rx(ms(0), 0x210, &[0x51, 0x00, 0x00]), []);
    assert_eq!(b.rx(ms(0), 0x210, &[0x31, 0xFF, 0x7F]), []);
    run(&mut b, 200); // the default ramp: 100 ms to Nmax
    assert_eq!(b.rx(ms(200), 0x210, &[0x3D, 0x30, 0x64]), [(0x190, r16(0x30, 0x7FFF))]);
    let sent = run(&mut b, 650);
    let expected: Vec<(u64, F)> = [300, 400, 500, 600].iter().map(|&t| (t, (0x190, r16(0x30, 0x7FFF)))).collect();
    assert_eq!(sent, expected, "every 100 ms, 100 % speed");
    assert_eq!(b.rx(ms(650), 0x210, &[0x3D, 0x30, 0xFF]), []);
    assert_eq!(run(&mut b, 1000), [], "stopped");
}

// ---- MODE, set-points and scaling (Ex. 2-5, English item 5) ----------------

#[test]
fn u3_mode_bit_2_disables_m_l496() {
    let mut b = drive();
    assert_eq!(read(&mut b, 0, 0x51), r16(0x51, 0x0004), "disabled at power-on (U-D2)");
    w(&mut b, 1, &[0x51, 0x00, 0x00]);
    assert_eq!(read(&mut b, 1, 0x40), status(LOOPS | TOL | ENA));
    w(&mut b, 2, &[0x51, 0x04, 0x00]);
    assert_eq!(read(&mut b, 2, 0x40), status(LOOPS | TOL));
}

#[test]
fn u4_speed_10_percent_moves_the_axis_m_l512() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x31, 0xCD, 0x0C]);
    run(&mut b, 1000);
    assert_eq!(speed(&mut b, 1000), 3277, "10 % of Nmax");
    // 10 % of 3600 rpm = 6 rev/s ≈ 393250 inc/s, reached after 10 ms of the
    // 100 ms ramp: about 0.995 s at speed.
    let p = position(&mut b, 1000);
    assert!((391_000..=392_000).contains(&p), "position {p}");
}

#[test]
fn u5_position_set_point_3000000_is_reached_m_l528() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x6E, 0xC0, 0xC6, 0x2D, 0x00]);
    assert_eq!(read(&mut b, 1, 0xF4), r16(0xF4, 0), "not in tolerance yet");
    // The position loop runs at most 10 rev/s (its gain is capped by the ramp, U-D3): about 5 s.
    run(&mut b, 7000);
    let p = position(&mut b, 7000);
    assert!((3_000_000 - p).abs() <= 100, "within POS_WINDOW: {p}");
    assert_eq!(read(&mut b, 7000, 0xF4), r16(0xF4, 1));
}

#[test]
fn u6_torque_16380_is_75_percent_not_50_m_l541() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x90, 0xFC, 0x3F]);
    run(&mut b, 20);
    // 16380 / 32767 × 150 % = 75 %: the axis accelerates at 0.75 of its limit
    // (Nmax in 100 ms), so 20 ms give 15 % of Nmax = 4915 Num (50 % would give 3277).
    let s = speed(&mut b, 20);
    assert!((4900..=4930).contains(&s), "speed {s}");
    let r = read(&mut b, 20, 0xA0);
    assert_eq!(r, r16(0xA0, 16384), "TORQUE_OUT: 750 ‰ back in Num");
}

#[test]
fn u7_acceleration_ramp_1000_ms_corrected_frame_m_l557() {
    let mut b = drive();
    // Printed `35 CD 0C`; the text's 1000 ms = 0x03E8.
    w(&mut b, 0, &[0x35, 0xE8, 0x03]);
    assert_eq!(read(&mut b, 0, 0x35), r32(0x35, 1000), "zero-extended into the 32-bit register");
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x31, 0xFF, 0x7F]);
    run(&mut b, 500);
    assert_eq!(speed(&mut b, 500), 16384, "half of Nmax after half the ramp");
}

#[test]
fn u15_speed_and_torque_command_tables_m_l1084() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    let mut t = 0;
    for (data, num) in [([0xFF, 0x7F], 32767), ([0x00, 0x40], 16384), ([0x00, 0x00], 0), ([0x00, 0xC0], -16384), ([0x01, 0x80], -32767)] {
        w(&mut b, t, &[0x31, data[0], data[1]]);
        t += 300;
        run(&mut b, t);
        assert_eq!(speed(&mut b, t), num, "SPEED_COMMAND {data:02X?}");
    }
    // Torque: 0x5555 = +100 % and 0xAAAB = −100 % (printed 0xAAAA, M-L1159).
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    for (t, data, out) in [(0, [0x55, 0x55], 21845u16), (20, [0xAB, 0xAA], (-21845i16) as u16)] {
        w(&mut b, t, &[0x90, data[0], data[1]]);
        run(&mut b, t + 5);
        assert_eq!(read(&mut b, t + 5, 0xA0), r16(0xA0, out), "TORQUE_COMMAND {data:02X?}");
    }
}

// ---- reads (Ex. 8, §5.2, English items 7 and 8) ----------------------------

#[test]
fn u9_status_read_once_is_32_bit_m_l591() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x31, 0xCD, 0x0C]);
    run(&mut b, 100);
    // Ena, P-N, N-I = 0x0181 as in Ex. 8, with DLC 6: STATUS is 32 bits (U-D1).
    assert_eq!(read(&mut b, 100, 0x40), status(0x0181));
    assert_eq!(run(&mut b, 1000), [], "once means once");
}

#[test]
fn cyclic_read_every_10_ms_by_time_stamps_and_stop_m_l635() {
    let mut b = drive();
    assert_eq!(b.rx(ms(5), RX, &[0x3D, 0x1B, 0x0A]), [(TX, r16(0x1B, 472))], "the first at once");
    let sent = run(&mut b, 48);
    let times: Vec<u64> = sent.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, [15, 25, 35, 45]);
    assert!(sent.iter().all(|(_, f)| *f == (TX, r16(0x1B, 472))));
    assert_eq!(b.rx(ms(48), RX, &[0x3D, 0x1B, 0xFF]), []);
    assert_eq!(run(&mut b, 200), []);
}

/// With CANopen off the node keeps no time of its own (its epoch is each
/// call's time): the device's clock is the board's, just before 2^31 µs
/// (where a CANopen node moves its epoch), across 2^32 µs and past 2^33 µs.
#[test]
fn cyclic_reads_keep_their_times_late_in_the_clock() {
    for start in [2_147_483 - 12, 4_294_967 - 25, 8_589_934 + 3] {
        let mut b = drive();
        assert_eq!(b.rx(ms(start), RX, &[0x3D, 0x1B, 0x0A]), [(TX, r16(0x1B, 472))], "the first at once ({start} ms)");
        let sent = run(&mut b, start + 48);
        let times: Vec<u64> = sent.iter().map(|(t, _)| *t - start).collect();
        assert_eq!(times, [10, 20, 30, 40], "from {start} ms");
        assert!(sent.iter().all(|(_, f)| *f == (TX, r16(0x1B, 472))));
    }
}

#[test]
fn eight_cyclic_slots_a_ninth_refused_a_stopped_one_reused_m_l1596() {
    let mut b = drive();
    let regs = [0x1B, 0x30, 0x40, 0x6D, 0x8F, 0xCE, 0xD9, 0xE2];
    for r in regs {
        assert_eq!(b.rx(ms(0), RX, &[0x3D, r, 0x0A]).len(), 1);
    }
    assert_eq!(b.rx(ms(0), RX, &[0x3D, 0xE8, 0x0A]), [], "a ninth register");
    assert_eq!(read(&mut b, 0, 0x97), r16(0x97, 1), "counted as refused");
    let sent = run(&mut b, 10);
    assert_eq!(sent.len(), 8, "eight streams: {sent:02X?}");
    assert_eq!(b.rx(ms(10), RX, &[0x3D, 0x30, 0xFF]), []);
    assert_eq!(b.rx(ms(10), RX, &[0x3D, 0xE8, 0x0A]), [(TX, r16(0xE8, 1))]);
    let sent = run(&mut b, 20);
    let mut ids: Vec<u8> = sent.iter().map(|(_, f)| f.1[0]).collect();
    ids.sort_unstable();
    assert_eq!(ids, [0x1B, 0x40, 0x6D, 0x8F, 0xCE, 0xD9, 0xE2, 0xE8]);
}

#[test]
fn u17_immediate_reads_m_l1294() {
    let mut b = drive();
    assert_eq!(read(&mut b, 1, 0xCE), r16(0xCE, 3600), "SPEED_RPMMAX_INT");
    assert_eq!(read(&mut b, 1, 0xD9), r16(0xD9, 841), "CURRENT_200PC");
    assert_eq!(read(&mut b, 1, 0x30), r16(0x30, 0));
    assert_eq!(read(&mut b, 1, 0x20), r16(0x20, 0));
    assert_eq!(read(&mut b, 1, 0x40), status(LOOPS | TOL), "DLC 6");
    assert_eq!(read(&mut b, 1, 0x8F), r32(0x8F, 0), "DLC 6");
    // POS_ACTUAL is 0x6D, not the printed 0x6E (D17).
    assert_eq!(read(&mut b, 1, 0x6D), r32(0x6D, 0), "DLC 6");
    let c6 = read(&mut b, 1, 0xC6);
    assert_eq!((c6.len(), c6[0]), (4, 0xC6), "CURRENT_DEVICE, 16 bits");
    let d8 = read(&mut b, 1, 0xD8);
    assert_eq!((d8.len(), d8[0]), (4, 0xD8), "LOGICMAP_IO, 16 bits");
}

#[test]
fn u18_0xdc_upper_byte_01_makes_every_reply_dlc_6_m_l1051() {
    let mut b = drive();
    assert_eq!(read(&mut b, 0, 0xDC), r16(0xDC, 0x0030));
    w(&mut b, 1, &[0x31, 0x00, 0xC0]);
    w(&mut b, 1, &[0xDC, 0x30, 0x01]);
    // 16-bit registers now answer in 32 bits, sign-extended by their type.
    assert_eq!(read(&mut b, 2, 0x31), [0x31, 0x00, 0xC0, 0xFF, 0xFF, 0x00]);
    assert_eq!(read(&mut b, 2, 0xCE), r32(0xCE, 3600));
}

// ---- events (Ex. 10, 10-1) -------------------------------------------------

#[test]
fn u11_status_event_on_tol_with_the_default_mask_m_l681() {
    let mut b = drive();
    w(&mut b, 0, &[0x78, 0x01, 0x00]); // homed: Cal
    // Ex. 10: only the activation; the default mask 0x3000 selects Cal and Tol (D9).
    w(&mut b, 0, &[0x51, 0x10, 0x00]);
    assert_eq!(b.rx(ms(1), RX, &[0x6E, 0xC0, 0xC6, 0x2D, 0x00]), [(TX, status(LOOPS | ENA | CAL))], "Tol falls");
    let sent = run(&mut b, 7000);
    assert_eq!(sent.len(), 1, "{sent:02X?}");
    assert_eq!(sent[0].1, (TX, status(0x3181)), "Tol rises: 0x3181 as printed in the frame");
}

#[test]
fn u12_status_event_on_a_limit_switch_mask_corrected_m_l735() {
    let mut b = drive();
    w(&mut b, 0, &[0x78, 0x01, 0x00]);
    // Printed mask 0x12; the limit switches are STATUS bits 2 and 3 (M-L795): 0x000C.
    w(&mut b, 0, &[0x52, 0x0C, 0x00]);
    w(&mut b, 0, &[0x51, 0x10, 0x00]);
    // Towards the positive limit switch at +200 revolutions (U-D4), stopping 50 past it.
    w(&mut b, 0, &[0x6E, 0x32, 0x00, 0xC8, 0x00]);
    let sent = run(&mut b, 25_000);
    assert_eq!(sent.len(), 1, "only the masked bits: {sent:02X?}");
    assert_eq!(sent[0].1, (TX, status(0x3185)), "Ena, Lim, P-N, N-I, Cal, Tol");
    assert_eq!(read(&mut b, 25_000, 0xE4), r16(0xE4, 1), "limit switch input");
}

// ---- routines (Ex. 11, Ex. 12) ---------------------------------------------

#[test]
fn u13_speed_routine_corrected_values_m_l799() {
    let mut b = drive();
    assert_eq!(read(&mut b, 0, 0xE2), [0xE2, 0x01, 0x00, 0x00], "BTB");
    w(&mut b, 0, &[0x51, 0x04, 0x00]);
    assert_eq!(read(&mut b, 0, 0xE8), [0xE8, 0x01, 0x00, 0x00], "RUN");
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x35, 0xF4, 0x01]); // 500 ms (printed "0x01FE4")
    w(&mut b, 0, &[0xED, 0xE8, 0x03]);
    w(&mut b, 0, &[0x31, 0xD4, 0x03]); // 980 Num ≈ 3 % (printed "30 %")
    assert_eq!(b.rx(ms(0), RX, &[0x3D, 0x30, 0x64]), [(TX, r16(0x30, 0))]);
    let sent = run(&mut b, 1000);
    assert_eq!(sent.iter().map(|(t, _)| *t).collect::<Vec<_>>(), (1..=10).map(|i| i * 100).collect::<Vec<_>>());
    assert_eq!(sent.last().unwrap().1, (TX, r16(0x30, 980)), "at speed after 15 ms of the ramp");
    w(&mut b, 1000, &[0x31, 0xFF, 0x7F]); // 100 % (printed "0x7FA4")
    let sent = run(&mut b, 1600);
    assert_eq!(sent.last().unwrap().1, (TX, r16(0x30, 0x7FFF)));
    w(&mut b, 1600, &[0x31, 0x00, 0x00]);
    w(&mut b, 1600, &[0x51, 0x04, 0x00]);
    assert_eq!(read(&mut b, 1600, 0x40)[1] & 0x01, 0, "disabled");
}

#[test]
fn u14_homing_and_positioning_routine_corrected_m_l852() {
    let mut b = drive();
    assert_eq!(read(&mut b, 0, 0xE2), [0xE2, 0x01, 0x00, 0x00]);
    w(&mut b, 0, &[0x51, 0x04, 0x00]);
    w(&mut b, 0, &[0x31, 0x00, 0x00]);
    assert_eq!(read(&mut b, 0, 0xE8), [0xE8, 0x01, 0x00, 0x00]);
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x78, 0x01, 0x00]);
    w(&mut b, 0, &[0x52, 0x00, 0x30]); // Cal and Tol: bits 12 and 13 (printed 0x0030, D9)
    w(&mut b, 0, &[0x51, 0x10, 0x00]);
    assert_eq!(b.rx(ms(10), RX, &[0x6E, 0xC0, 0xC6, 0x2D, 0x00]), [(TX, status(0x1181))]);
    assert_eq!(read(&mut b, 20, 0xF4), r16(0xF4, 0));
    let sent = run(&mut b, 7000);
    assert_eq!(sent.iter().map(|(_, f)| f.clone()).collect::<Vec<_>>(), [(TX, status(0x3181))]);
    assert_eq!(read(&mut b, 7000, 0xF4), [0xF4, 0x01, 0x00, 0x00]);
    assert_eq!(b.rx(ms(7000), RX, &[0x6E, 0x00, 0x00, 0x00, 0x00]), [(TX, status(0x1181))]);
    let sent = run(&mut b, 14_000);
    assert_eq!(sent.iter().map(|(_, f)| f.clone()).collect::<Vec<_>>(), [(TX, status(0x3181))], "back at zero");
    // The printed `181 [3] F4 01 00 00` is a DLC-4 reply to a second read.
    assert_eq!(read(&mut b, 14_000, 0xF4), [0xF4, 0x01, 0x00, 0x00]);
    w(&mut b, 14_000, &[0x51, 0x04, 0x00]);
}

#[test]
fn u16_32_bit_command_table_m_l1173() {
    let mut b = drive();
    for v in [0x7FFF_FFFFu32, 0x4000_0000, 0x0010_0000, 0x0001_0000, 0xFFFF_0000, 0xC000_0000, 0x8000_0001] {
        let [a, c, d, e] = v.to_le_bytes();
        w(&mut b, 1, &[0x6E, a, c, d, e]);
        assert_eq!(read(&mut b, 1, 0x6E), r32(0x6E, v), "POS_DEST {v:#010X}");
    }
    // POS_PRESET is 0x7A, not the printed 0x7E (D16); VAR1..VAR4 0xD1..0xD4.
    for r in [0x7A, 0x7E, 0xD1, 0xD2, 0xD3, 0xD4] {
        w(&mut b, 2, &[r, 0x78, 0x56, 0x34, 0x12]);
        assert_eq!(read(&mut b, 2, r), r32(r, 0x1234_5678), "{r:#04X}");
    }
}

// ---- functions (Ex. 7, 0x78, 0x8E, 0xD0, 0x73) -----------------------------

#[test]
fn u8_eeprom_write_keeps_the_parameters_over_a_power_cycle_m_l573() {
    let mut b = drive();
    w(&mut b, 1, &[0x35, 0xF4, 0x01]);
    w(&mut b, 1, &[0x68, 0x05, 0x02]);
    let unsaved = b.node.storage_mut().clone();
    assert_eq!(b.rx(ms(2), 0x205, &[0x84, 0x00, 0x00]), []);
    let mut b = drive_on(b.node.storage_mut().clone());
    assert_eq!(read_via(&mut b, 1, 0x205, TX, 0x35), r32(0x35, 500));
    assert_eq!(read_via(&mut b, 1, 0x205, TX, 0x51), r16(0x51, 0x0004), "starts disabled");
    let mut b = drive_on(unsaved);
    assert_eq!(read(&mut b, 1, 0x35), r32(0x35, 0x0001_0064), "without 0x84: the default");
}

#[test]
fn eeprom_write_survives_a_power_cut_at_any_step() {
    let mut steps = 0;
    loop {
        let mut b = drive();
        w(&mut b, 1, &[0x35, 0xF4, 0x01]);
        b.node.storage_mut().cut_after(steps);
        b.rx(ms(2), RX, &[0x84, 0x00, 0x00]);
        let done = b.node.storage_mut().is_powered();
        let mut storage = b.node.storage_mut().clone();
        storage.power_on();
        let mut b = drive_on(storage);
        let ramp = read(&mut b, 1, 0x35);
        assert!(ramp == r32(0x35, 500) || ramp == r32(0x35, 0x0001_0064), "cut after {steps}: {ramp:02X?}");
        if done {
            assert_eq!(ramp, r32(0x35, 500));
            break;
        }
        steps += 1;
    }
    assert!(steps > 2, "the store took several steps");
}

#[test]
fn can_timeout_disables_the_drive_until_errors_are_cleared() {
    let mut b = drive();
    w(&mut b, 0, &[0xD0, 0x32, 0x00]); // 50 ms
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x31, 0x00, 0x10]);
    for t in [40, 80, 120] {
        run(&mut b, t);
        assert_eq!(read(&mut b, t, 0x40)[1] & 0x01, 0x01, "a frame every 40 ms keeps it enabled");
    }
    run(&mut b, 169);
    assert_eq!(read(&mut b, 169, 0x40)[1] & 0x01, 0x01);
    run(&mut b, 219);
    assert_eq!(read(&mut b, 219, 0x40)[1] & 0x01, 0x00, "50 ms without a frame");
    assert_eq!(read(&mut b, 219, 0x8F), r32(0x8F, 1 << 3), "CAN timeout error bit");
    assert_eq!(read(&mut b, 219, 0x51), r16(0x51, 0x0004), "MODE says disabled");
    assert_eq!(read(&mut b, 219, 0xE2), r16(0xE2, 0), "not ready");
    w(&mut b, 220, &[0x51, 0x00, 0x00]);
    assert_eq!(read(&mut b, 220, 0x40)[1] & 0x01, 0x00, "no enable before the error is cleared");
    w(&mut b, 221, &[0x8E, 0x01, 0x00]);
    assert_eq!(read(&mut b, 221, 0x8F), r32(0x8F, 0));
    w(&mut b, 222, &[0x51, 0x00, 0x00]);
    assert_eq!(read(&mut b, 222, 0x40)[1] & 0x01, 0x01, "enabled again");
}

#[test]
fn homing_sets_the_reference_offset_and_cal() {
    let mut b = drive();
    w(&mut b, 0, &[0x51, 0x00, 0x00]);
    w(&mut b, 0, &[0x31, 0xCD, 0x0C]);
    run(&mut b, 500);
    w(&mut b, 500, &[0x31, 0x00, 0x00]);
    run(&mut b, 600);
    w(&mut b, 600, &[0x72, 0x00, 0x00, 0x01, 0x00]);
    w(&mut b, 600, &[0x78, 0x01, 0x00]);
    assert_eq!(position(&mut b, 600), 0x10000, "the reference offset, one revolution");
    assert_eq!(read(&mut b, 600, 0x40)[2] & 0x10, 0x10, "Cal");
}

#[test]
fn bit_rate_codes_of_0x73_m_l207() {
    let mut b = drive();
    w(&mut b, 0, &[0x73, 0x00, 0x41]);
    assert_eq!(read(&mut b, 0, 0x73), r16(0x73, 0x4025), "not one of the five codes");
    for (code, index) in [(0x4002u16, Some(0)), (0x405C, Some(3)), (0x4014, None), (0x4425, None), (0x4025, Some(2))] {
        let [lo, hi] = code.to_le_bytes();
        w(&mut b, 1, &[0x73, lo, hi]);
        w(&mut b, 1, &[0x84, 0x00, 0x00]);
        assert_eq!(unitek_ds::startup(b.node.storage_mut()), (1, index), "{code:#06X}");
    }
}
