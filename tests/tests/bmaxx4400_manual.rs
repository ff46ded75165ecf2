//! The Baumüller b maXX 4400 (seed 003): the frame examples of its manual
//! that the other b maXX tests do not run (device-review B1, B3, B4, B7,
//! B11, B13, and B14/B15 for node 7 with the manual's cross communication
//! between node 2 and node 7), as exact frames, with the misprints the
//! review flags corrected (CiA 301 and docs/devices/bmaxx4400.md). Manual
//! lines as "M-L" in the test names.

mod common;

use common::{Bench, F, abort, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

/// Node `id` after its V4 boot-up (B1, M-L674-679: `700h + ID [1] 00`), at 10 ms.
fn node(id: u8) -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(id), bmaxx4400::App::NEW, MemStorage::new(8192), id);
    assert_eq!(b.at(ms(0)), [(0x700 + u16::from(id), vec![0x00])]);
    b.now = ms(10);
    b
}

/// One request as the manual prints it (8 bytes) and its one answer.
#[track_caller]
fn ex(b: &mut Bmaxx, id: u8, request: [u8; 8], answer: [u8; 8]) {
    let out = b.rx(b.now, 0x600 + u16::from(id), &request);
    assert_eq!(out, [(0x580 + u16::from(id), answer.to_vec())], "request {request:02X?}");
}

#[test]
fn b1_b3_m_l1763_enter_pre_operational_for_node_16() {
    let mut b = node(16);
    b.nmt(0x01, 16);
    assert_eq!(b.rtr(ms(20), 0x710), [(0x710, vec![0x05])]);
    // "00hex 02hex 80hex 10hex": node 16 into Pre-operational; unconfirmed.
    assert_eq!(b.rx(ms(30), 0x000, &[0x80, 0x10]), []);
    assert_eq!(b.rtr(ms(40), 0x710), [(0x710, vec![0xFF])]);
}

#[test]
fn b4_m_l1880_guarding_answers_with_the_toggle_bit_in_every_state() {
    let mut b = node(1);
    // The toggle bit runs on across state changes (M-L1876-1878).
    assert_eq!(b.rtr(ms(20), 0x701), [(0x701, vec![0x7F])]);
    assert_eq!(b.rtr(ms(30), 0x701), [(0x701, vec![0xFF])]);
    b.nmt(0x01, 1);
    assert_eq!(b.rtr(ms(40), 0x701), [(0x701, vec![0x05])]);
    assert_eq!(b.rtr(ms(50), 0x701), [(0x701, vec![0x85])]);
    b.nmt(0x02, 1);
    assert_eq!(b.rtr(ms(60), 0x701), [(0x701, vec![0x04])]);
    assert_eq!(b.rtr(ms(70), 0x701), [(0x701, vec![0x84])]);
    // Only "Initialisierung" resets it: reset communication.
    b.nmt(0x82, 1);
    assert_eq!(b.rtr(ms(80), 0x701), [(0x701, vec![0x7F])]);
}

#[test]
fn b7_m_l2050_the_mapping_entry_belongs_in_0x1a01_not_0x1800() {
    let mut b = node(4);
    // The manual writes 0x60610008 to 0x1800 sub 2, the UNSIGNED8 transmission type:
    // a CiA 301 server refuses the length. The value is TPDO2's second mapping entry.
    ex(&mut b, 4, [0x23, 0x00, 0x18, 0x02, 0x08, 0x00, 0x61, 0x60], abort(0x1800, 2, 0x0607_0012).try_into().unwrap());
    ex(&mut b, 4, [0x23, 0x01, 0x1A, 0x02, 0x08, 0x00, 0x61, 0x60], ok_write(0x1A01, 2).try_into().unwrap());
    ex(&mut b, 4, [0x40, 0x01, 0x1A, 0x02, 0, 0, 0, 0], [0x43, 0x01, 0x1A, 0x02, 0x08, 0x00, 0x61, 0x60]);
}

#[test]
fn b11_m_l2176_device_name_by_segmented_upload() {
    let mut b = node(4);
    // The manual's answer holds 6 bytes ("b maXX") with command 0x14; the text (M-L1256)
    // names the device "b maXX 4400": 11 bytes in two segments, the last with c = 1.
    ex(&mut b, 4, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0], [0x41, 0x08, 0x10, 0x00, 0x0B, 0, 0, 0]);
    ex(&mut b, 4, [0x60, 0, 0, 0, 0, 0, 0, 0], [0x00, b'b', b' ', b'm', b'a', b'X', b'X', b' ']);
    ex(&mut b, 4, [0x70, 0, 0, 0, 0, 0, 0, 0], [0x17, b'4', b'4', b'0', b'0', 0, 0, 0]);
}

#[test]
fn b13_m_l2609_rpdo1_made_invalid() {
    let mut b = node(1);
    // Printed "01 00 00 01", garbled: the text's intent is RPDO1 not valid, 0x80000201.
    ex(&mut b, 1, [0x23, 0x00, 0x14, 0x01, 0x01, 0x02, 0x00, 0x80], ok_write(0x1400, 1).try_into().unwrap());
    b.nmt(0x01, 1);
    b.rx(ms(20), 0x201, &[0x06, 0x00]);
    assert_eq!(b.sdo_upload(1, 0x6040, 0), Ok(vec![0, 0]), "RPDO1 is not received");
}

/// Node 7's settings of §5.5.3 (B14) and §5.5.3's communication parameters
/// (B15), every request as printed, each answered `587 60 …`.
fn node_7() -> Bmaxx {
    let mut b = node(7);
    for req in [
        // TPDO1: 0x6041, 0x6044.
        [0x23, 0x00, 0x1A, 0x01, 0x10, 0x00, 0x41, 0x60],
        [0x23, 0x00, 0x1A, 0x02, 0x10, 0x00, 0x44, 0x60],
        [0x2F, 0x00, 0x1A, 0x00, 0x02, 0x00, 0x00, 0x00],
        // RPDO1: a 2-byte dummy, 0x6042 (the speed set-point from node 2's bytes 2-3).
        [0x23, 0x00, 0x16, 0x01, 0x10, 0x00, 0x06, 0x00],
        [0x23, 0x00, 0x16, 0x02, 0x10, 0x00, 0x42, 0x60],
        [0x2F, 0x00, 0x16, 0x00, 0x02, 0x00, 0x00, 0x00],
        // RPDO2: 0x6040 alone.
        [0x23, 0x01, 0x16, 0x01, 0x10, 0x00, 0x40, 0x60],
        [0x2F, 0x01, 0x16, 0x00, 0x01, 0x00, 0x00, 0x00],
        // RPDO1 event-driven on its default 0x207; TPDO1 on every third SYNC; TPDO2 event-driven.
        [0x2F, 0x00, 0x14, 0x02, 0xFF, 0x00, 0x00, 0x00],
        [0x2F, 0x00, 0x18, 0x02, 0x03, 0x00, 0x00, 0x00],
        [0x2F, 0x01, 0x18, 0x02, 0xFF, 0x00, 0x00, 0x00],
    ] {
        let [_, lo, hi, sub, ..] = req;
        ex(&mut b, 7, req, ok_write(u16::from_le_bytes([lo, hi]), sub).try_into().unwrap());
    }
    b
}

#[test]
fn b14_b15_m_l2797_m_l3114_node_7_mapping_and_transmission_types() {
    let mut b = node_7();
    assert_eq!(b.sdo_upload(7, 0x1400, 1), Ok(vec![0x07, 0x02, 0x00, 0x00]), "RPDO1 on 207h by default");
    assert_eq!(b.sdo_upload(7, 0x1800, 1), Ok(vec![0x87, 0x01, 0x00, 0x00]));
    assert_eq!(b.sdo_upload(7, 0x1801, 1), Ok(vec![0x87, 0x02, 0x00, 0x00]));
    let out = b.nmt(0x01, 7);
    // TPDO2 (its default 0x6041 + 0x6061, type 255) on entering Operational; TPDO1 waits for SYNCs.
    assert_eq!(out, [(0x287, vec![0x50, 0x02, 0x00])]);
    let mut tpdo1 = Vec::new();
    for n in 1..=6u64 {
        for (id, data) in b.rx(ms(20 + n), 0x080, &[]) {
            if id == 0x187 {
                tpdo1.push((n, data));
            }
        }
    }
    assert_eq!(tpdo1, [(3, vec![0x50, 0x02, 0, 0]), (6, vec![0x50, 0x02, 0, 0])]);
}

/// Frames of `from` that `to` receives (its PDOs' COB-IDs and SYNC), delivered at `t`.
fn forward(out: &[F], to: &mut Bmaxx, t: u64) -> Vec<F> {
    out.iter().filter(|(id, _)| *id == 0x207).flat_map(|(id, data)| to.rx(ms(t), *id, data)).collect()
}

#[test]
fn b14_b15_m_l3101_cross_communication_node_2_speed_actual_value_is_node_7_speed_set_point() {
    // Node 2 (B14 first part, B15): TPDO1 = 0x6086 + 0x6044 on 207h, event-driven.
    let mut n2 = node(2);
    for req in [
        [0x23, 0x00, 0x1A, 0x01, 0x10, 0x00, 0x86, 0x60],
        [0x23, 0x00, 0x1A, 0x02, 0x10, 0x00, 0x44, 0x60],
        [0x2F, 0x00, 0x1A, 0x00, 0x02, 0x00, 0x00, 0x00],
        [0x23, 0x00, 0x18, 0x01, 0x07, 0x02, 0x00, 0x00],
        [0x2F, 0x00, 0x18, 0x02, 0xFF, 0x00, 0x00, 0x00],
    ] {
        let [_, lo, hi, sub, ..] = req;
        ex(&mut n2, 2, req, ok_write(u16::from_le_bytes([lo, hi]), sub).try_into().unwrap());
    }
    let mut n7 = node_7();
    // Both in vl (0x6060 = 2) and Operational; node 7 enabled through its RPDO2 (0x6040).
    for (b, id) in [(&mut n2, 2u8), (&mut n7, 7)] {
        assert_eq!(b.sdo_write(id, 0x6060, 0, &[2]), ok_write(0x6060, 0));
    }
    n7.nmt(0x01, 7);
    let from_2 = n2.nmt(0x01, 2);
    assert!(from_2.contains(&(0x207, vec![0, 0, 0, 0])), "0x6086 = 0, 0x6044 = 0: {from_2:x?}");
    assert_eq!(forward(&from_2, &mut n7, 10), []);
    for (t, cw) in [(40u64, 0x06u8), (50, 0x07), (60, 0x0F)] {
        n7.rx(ms(t), 0x307, &[cw, 0x00]);
    }
    assert_eq!(n7.sdo_upload(7, 0x6041, 0), Ok(vec![0x37, 0x02]), "node 7 Operation enabled");
    // Node 2 runs at 300 min⁻¹ (vl, enabled by SDO, ramp 3000 min⁻¹/s); each change of its
    // 0x6044 goes in TPDO1 to node 7, whose 0x6042 follows it.
    assert_eq!(n2.sdo_write(2, 0x6048, 1, &3000u32.to_le_bytes()), ok_write(0x6048, 1));
    assert_eq!(n2.sdo_write(2, 0x6042, 0, &300i16.to_le_bytes()), ok_write(0x6042, 0));
    for cw in [0x06u8, 0x07, 0x0F] {
        let out = n2.rx(n2.now, 0x602, &[0x2B, 0x40, 0x60, 0x00, cw, 0x00, 0x00, 0x00]);
        assert!(out.contains(&(0x582, ok_write(0x6040, 0))), "{out:x?}");
    }
    let mut t = 60;
    while t < 400 {
        t += 1;
        let out: Vec<F> = n2.run_until(ms(t)).into_iter().map(|(_, f)| f).collect();
        forward(&out, &mut n7, t);
        n7.run_until(ms(t));
    }
    let speed = |b: &mut Bmaxx, id: u8, index: u16| {
        let v = b.sdo_upload(id, index, 0).expect("readable");
        i16::from_le_bytes([v[0], v[1]])
    };
    assert_eq!(speed(&mut n2, 2, 0x6044), 300);
    assert_eq!(speed(&mut n7, 7, 0x6042), 300, "node 2's speed actual value");
    // Node 7 turns at it: its vl ramps are 0 (placeholders), so the drive's own limit.
    assert_eq!(speed(&mut n7, 7, 0x6044), 300, "node 7's speed actual value");
}

#[test]
fn m_l983_the_2_31_offset_of_6062_6064_607a_607c_607d_in_the_drive_parameters() {
    let mut b = node(4);
    let u32_at = |b: &mut Bmaxx, index: u16| {
        let v = b.sdo_upload(4, index, 0).expect("readable");
        u32::from_le_bytes([v[0], v[1], v[2], v[3]])
    };
    // §4.4.7: "(6062, 6064, 607A, 607C, 607D Sub 1/2) − 2^31" towards CANopen.
    assert_eq!(b.sdo_write(4, 0x607C, 0, &1000i32.to_le_bytes()), ok_write(0x607C, 0));
    assert_eq!(b.sdo_write(4, 0x607D, 1, &(-5000i32).to_le_bytes()), ok_write(0x607D, 1));
    assert_eq!(b.sdo_write(4, 0x607D, 2, &5000i32.to_le_bytes()), ok_write(0x607D, 2));
    assert_eq!(b.sdo_write(4, 0x607A, 0, &(-7i32).to_le_bytes()), ok_write(0x607A, 0));
    for (p, index, value) in [
        ("P0463", 0x41CF, 0u32),
        ("P0462", 0x41CE, 0),
        ("P0600", 0x4258, (-7i32) as u32),
        ("P1200", 0x44B0, 1000),
        ("P1196", 0x44AC, (-5000i32) as u32),
        ("P1197", 0x44AD, 5000),
    ] {
        assert_eq!(u32_at(&mut b, index), value.wrapping_add(1 << 31), "{p}");
    }
    // P0830 bit 5: no offset (§4.4.7, "Bit 5 -> 1: Es wird kein Offset benutzt").
    assert_eq!(b.sdo_write(4, 0x433E, 0, &0x0020u16.to_le_bytes()), ok_write(0x433E, 0));
    assert_eq!(u32_at(&mut b, 0x44AC), (-5000i32) as u32);
    // P0607, the CANopen positioning mode's target (INT32), never has it.
    assert_eq!(u32_at(&mut b, 0x425F), (-7i32) as u32);
}

#[test]
fn m_l1308_store_and_restore_only_sub_2_and_only_in_pre_operational() {
    let mut b = node(4);
    // Sub 1 "all" is not supported (reads 0: "does not save on command"); sub 2 reads 1.
    assert_eq!(b.sdo_upload(4, 0x1010, 1), Ok(vec![0, 0, 0, 0]));
    assert_eq!(b.sdo_upload(4, 0x1010, 2), Ok(vec![1, 0, 0, 0]));
    assert_eq!(b.sdo_write(4, 0x1010, 1, b"save"), abort(0x1010, 1, 0x0800_0020));
    assert_eq!(b.sdo_write(4, 0x1011, 1, b"load"), abort(0x1011, 1, 0x0800_0020));
    // "save"/"load" in Pre-operational only (M-L1314, M-L1353).
    b.nmt(0x01, 4);
    assert_eq!(b.sdo_write(4, 0x1010, 2, b"save"), abort(0x1010, 2, 0x0800_0022));
    assert_eq!(b.sdo_write(4, 0x1011, 2, b"load"), abort(0x1011, 2, 0x0800_0022));
    b.nmt(0x80, 4);
    // Sub 2 stores the communication parameters but 0x100E and 0x1014, "nicht abspeicherbar"
    // (M-L1303, M-L1357): after a reset communication 0x1014 is back at its default (0x100E
    // takes only its default, M-L1264).
    assert_eq!(b.sdo_write(4, 0x1017, 0, &100u16.to_le_bytes()), ok_write(0x1017, 0));
    assert_eq!(b.sdo_write(4, 0x1014, 0, &0x8000_0084u32.to_le_bytes()), ok_write(0x1014, 0));
    assert_eq!(b.sdo_write(4, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    b.nmt(0x82, 4);
    assert_eq!(b.sdo_upload(4, 0x1017, 0), Ok(vec![100, 0]), "stored");
    assert_eq!(b.sdo_upload(4, 0x1014, 0), Ok(vec![0x84, 0, 0, 0]), "not stored");
    assert_eq!(b.sdo_write(4, 0x1011, 2, b"load"), ok_write(0x1011, 2));
    b.nmt(0x82, 4);
    assert_eq!(b.sdo_upload(4, 0x1017, 0), Ok(vec![0, 0]), "restored to its default");
}

#[test]
fn m_l1915_either_node_guarding_or_heartbeat() {
    let mut b = node(1);
    assert_eq!(b.rtr(ms(20), 0x701), [(0x701, vec![0x7F])], "guarding while 0x1017 = 0");
    // "entweder das Node Guarding oder das Heartbeat": a heartbeat time switches guarding off.
    assert_eq!(b.sdo_write(1, 0x1017, 0, &100u16.to_le_bytes()), ok_write(0x1017, 0));
    assert_eq!(b.rtr(ms(30), 0x701), []);
    assert_eq!(b.run_until(ms(130)), [(ms(120), (0x701, vec![0x7F]))], "100 ms after the write at 20 ms");
}

#[test]
fn m_l1214_number_of_pdos_supported_0x1004() {
    let mut b = node(4);
    for sub in 0..=2 {
        ex(&mut b, 4, [0x40, 0x04, 0x10, sub, 0, 0, 0, 0], [0x43, 0x04, 0x10, sub, 0x04, 0x00, 0x04, 0x00]);
    }
    ex(&mut b, 4, [0x40, 0x04, 0x10, 0x03, 0, 0, 0, 0], abort(0x1004, 3, 0x0609_0011).try_into().unwrap());
    ex(&mut b, 4, [0x23, 0x04, 0x10, 0x00, 0, 0, 0, 0], abort(0x1004, 0, 0x0601_0002).try_into().unwrap());
}

#[test]
fn m_l1140_manufacturer_status_register_0x1002_is_the_status_word_low_byte_and_the_card_type() {
    let mut b = node(4);
    // Switch on disabled (0x0250): low byte 0x50; bits 25/24 = 1 0, "b maXX 4400".
    ex(&mut b, 4, [0x40, 0x02, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x02, 0x10, 0x00, 0x50, 0x00, 0x00, 0x02]);
    assert_eq!(b.sdo_write(4, 0x6040, 0, &6u16.to_le_bytes()), ok_write(0x6040, 0));
    ex(&mut b, 4, [0x40, 0x02, 0x10, 0x00, 0, 0, 0, 0], [0x43, 0x02, 0x10, 0x00, 0x31, 0x00, 0x00, 0x02]);
}

#[test]
fn m_l1250_sync_interval_1000_2000_4000_or_8000_us() {
    let mut b = node(1);
    for period in [0u32, 1000, 2000, 4000, 8000] {
        assert_eq!(b.sdo_write(1, 0x1006, 0, &period.to_le_bytes()), ok_write(0x1006, 0), "{period} µs");
    }
    for period in [500u32, 3000, 7999] {
        assert_eq!(b.sdo_write(1, 0x1006, 0, &period.to_le_bytes()), abort(0x1006, 0, 0x0609_0030), "{period} µs");
    }
    // Above the EDS's 8000: "value too high".
    assert_eq!(b.sdo_write(1, 0x1006, 0, &16000u32.to_le_bytes()), abort(0x1006, 0, 0x0609_0031));
    assert_eq!(b.sdo_upload(1, 0x1006, 0), Ok(8000u32.to_le_bytes().to_vec()));
}

#[test]
fn m_l1264_guarding_cob_id_0x100e_is_700h_plus_the_node_id() {
    let mut b = node(1);
    assert_eq!(b.sdo_upload(1, 0x100E, 0), Ok(vec![0x01, 0x07, 0, 0]));
    assert_eq!(b.sdo_write(1, 0x100E, 0, &0x715u32.to_le_bytes()), abort(0x100E, 0, 0x0609_0030));
    assert_eq!(b.sdo_write(1, 0x100E, 0, &0x701u32.to_le_bytes()), ok_write(0x100E, 0));
    assert_eq!(b.rtr(ms(20), 0x701), [(0x701, vec![0x7F])]);
}
