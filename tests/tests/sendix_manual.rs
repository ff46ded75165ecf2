//! Every frame example of the Sendix manual (seed 002) as the device review
//! lists them (S1–S21, shared/notes/device-review.md §3.4), misprints
//! corrected as the review says; each test names its manual line.

mod common;

use canopen_core::services::nmt::NmtState;
use common::sendix::{Encoder, encoder, read, read_u32};
use common::{Bench, abort, ms, ok_write};
use firmware::devices::sendix::{self, BenchSensor};
use hal_host::storage::MemStorage;

fn node() -> Encoder {
    encoder(MemStorage::new(4096), 0, 19642)
}

/// The Sendix as node `id` (the §5.7.5 examples use 0x0B and 8).
fn node_at(id: u8) -> Encoder {
    let mut b = Bench::new(sendix::od::Ram::new(id), sendix::App::with_sensor(BenchSensor::new(0)), MemStorage::new(4096), id);
    assert_eq!(b.at(ms(0)), [(0x700 + u16::from(id), vec![0x00])]);
    b
}

fn sdo(b: &mut Encoder, request: [u8; 8]) -> Vec<u8> {
    let out = b.rx(b.now, 0x63F, &request);
    assert_eq!(out.len(), 1, "one answer to {request:02x?}: {out:x?}");
    assert_eq!(out[0].0, 0x5BF);
    out[0].1.clone()
}

#[test]
fn s1_start_node_63_l1056() {
    let mut b = node();
    let out = b.rx(ms(1), 0x000, &[0x01, 0x3F]);
    assert_eq!(b.node.state(), NmtState::Operational);
    assert_eq!(out, [(0x1BF, vec![0xBA, 0x4C, 0x00, 0x00]), (0x3BF, vec![0, 0, 0, 0])], "TPDO1 and TPDO3 once on entering Operational");
}

#[test]
fn s2_s3_code_sequence_written_and_read_back_l1285_l1346() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x2B, 0x00, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00]), [0x60, 0x00, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x40, 0x00, 0x60, 0x00, 0, 0, 0, 0]), [0x4B, 0x00, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00]);
}

#[test]
fn s4_restore_defaults_applies_at_reset_node_l902() {
    let mut b = node();
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x01, 0x00]), ok_write(0x6000, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(sdo(&mut b, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64]), [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
    assert_eq!(read(&mut b, 0x6000, 0), [0x01, 0x00], "still the saved value before the reset");
    assert_eq!(b.rx(ms(1), 0x000, &[0x81, 0x3F]), [(0x73F, vec![0x00])]);
    assert_eq!(read(&mut b, 0x6000, 0), [0x00, 0x00], "the M5868 default 0x0000 (not the A family's 0x0004)");
}

#[test]
fn s5_store_keeps_parameters_over_a_power_cycle_l1913() {
    let mut b = node();
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x01, 0x00]), ok_write(0x6000, 0));
    assert_eq!(sdo(&mut b, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]), [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    let storage = b.node.storage_mut().clone();
    let mut again = encoder(storage, 0, 0);
    assert_eq!(read(&mut again, 0x6000, 0), [0x01, 0x00]);
}

#[test]
fn s6_the_misprinted_signature_is_refused_l962() {
    let mut b = node();
    // `73 67 76 65` is a misprint of "save": a wrong signature stores nothing (D5).
    assert_eq!(sdo(&mut b, [0x23, 0x10, 0x10, 0x01, 0x73, 0x67, 0x76, 0x65]), abort(0x1010, 1, 0x0800_0020));
}

#[test]
fn s7_preset_on_sub_1_is_a_misprint_l933() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x23, 0x03, 0x60, 0x01, 0, 0, 0, 0]), abort(0x6003, 1, 0x0609_0011));
    assert_eq!(read_u32(&mut b, 0x6004, 0), 19642, "no preset applied");
}

#[test]
fn s8_save_bus_parameters_on_sub_1_is_a_misprint_l2268() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x23, 0x05, 0x21, 0x01, 0x73, 0x61, 0x76, 0x65]), abort(0x2105, 1, 0x0609_0011));
}

#[test]
fn s9_operating_parameters_0x5005_l2471() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x2B, 0x00, 0x60, 0x00, 0x05, 0x50, 0x00, 0x00]), [0x60, 0x00, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(read(&mut b, 0x6500, 0), [0x05, 0x50], "0x6500 mirrors 0x6000");
    // §5.7.3's 0x2004 (legacy speed format bit 13) is not an M5868 bit (D15).
    assert_eq!(sdo(&mut b, [0x2B, 0x00, 0x60, 0x00, 0x04, 0x20, 0x00, 0x00]), abort(0x6000, 0, 0x0609_0030));
    // Bit 14: after save and reset the encoder starts in Operational by itself (§5.5.15).
    assert_eq!(b.sdo_write(0x3F, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.rx(ms(1), 0x000, &[0x81, 0x3F]), [(0x73F, vec![0x00])], "the boot-up first, alone");
    let out = b.at(ms(1));
    assert_eq!(b.node.state(), NmtState::Operational, "no NMT start needed");
    assert!(out.iter().any(|f| f.0 == 0x1BF), "TPDO1 flows: {out:x?}");
}

#[test]
fn s10_transmission_type_255_response_echoes_sub_2_l2856() {
    let mut b = node();
    // The manual prints the response with sub 05: the response echoes sub 02.
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x18, 0x02, 0xFF, 0x00, 0x00, 0x00]), [0x60, 0x02, 0x18, 0x02, 0, 0, 0, 0]);
    // L1214: 252/253 are not supported on the M58 (whatever COB-ID bit 30 says).
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x18, 0x01, 0xBF, 0x03, 0x00, 0x80]), ok_write(0x1802, 1));
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x18, 0x02, 0xFC, 0x00, 0x00, 0x00]), abort(0x1802, 2, 0x0609_0030));
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x18, 0x02, 0xFD, 0x00, 0x00, 0x00]), abort(0x1802, 2, 0x0609_0030));
}

#[test]
fn s11_tpdo3_event_timer_500_ms_l2862() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x2B, 0x02, 0x18, 0x05, 0xF4, 0x01, 0x00, 0x00]), [0x60, 0x02, 0x18, 0x05, 0, 0, 0, 0]);
    b.rx(ms(1), 0x000, &[0x01, 0x3F]);
    let times: Vec<u64> = b.run_until(ms(1100)).iter().filter(|(_, f)| f.0 == 0x3BF).map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(times, [501, 1001]);
}

#[test]
fn s12_bus_parameters_and_their_save_l2870_trace_l3581() {
    let mut b = node();
    assert_eq!(sdo(&mut b, [0x2F, 0x00, 0x21, 0x00, 0x05, 0, 0, 0]), [0x60, 0x00, 0x21, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x2F, 0x01, 0x21, 0x00, 0x3F, 0, 0, 0]), [0x60, 0x01, 0x21, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x21, 0x00, 0x00, 0, 0, 0]), [0x60, 0x02, 0x21, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x23, 0x05, 0x21, 0x00, 0x73, 0x61, 0x76, 0x65]), [0x60, 0x05, 0x21, 0x00, 0, 0, 0, 0]);
    // 0x2100 = 5 is 250 kbit/s, CiA 305 table index 3 (8 − 5).
    assert_eq!(sendix::startup(b.node.storage_mut()), (0x3F, Some(3)));
    let storage = b.node.storage_mut().clone();
    let mut again = encoder(storage, 0, 0);
    assert_eq!(read(&mut again, 0x2102, 0), [0x00], "termination off after the power cycle");
}

#[test]
fn s13_the_commissioning_example_l2909() {
    let mut b = node();
    for (req, index) in [
        ([0x2B, 0x00, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00], 0x6000),
        ([0x23, 0x02, 0x60, 0x00, 0x00, 0x00, 0x01, 0x00], 0x6002),
        ([0x23, 0x01, 0x60, 0x00, 0x00, 0x10, 0x00, 0x00], 0x6001),
        ([0x23, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00], 0x6003),
        ([0x2B, 0x00, 0x62, 0x00, 0x0A, 0x00, 0x00, 0x00], 0x6200),
    ] {
        assert_eq!(sdo(&mut b, req), ok_write(index, 0), "{req:02x?}");
    }
    assert_eq!(read_u32(&mut b, 0x6004, 0), 0, "preset 0");
    b.rx(ms(1), 0x000, &[0x01, 0x3F]);
    let out: Vec<u64> = b.run_until(ms(31)).iter().filter(|(_, f)| f.0 == 0x1BF).map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(out, [11, 21, 31], "TPDO1 every 10 ms");
}

#[test]
fn s14_the_printed_mapping_example_fails_on_the_m5868_and_its_32_bit_form_works_l3410() {
    let mut b = node();
    // Printed first step: sub 0 = 3 on a valid, mapped PDO (CiA 301 order: invalid first).
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x1A, 0x00, 0x03, 0, 0, 0]), abort(0x1A02, 0, 0x0601_0000));
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x18, 0x01, 0xBF, 0x03, 0x00, 0xC0]), ok_write(0x1802, 1));
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x1A, 0x00, 0x00, 0, 0, 0]), ok_write(0x1A02, 0));
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x1A, 0x01, 0x20, 0x00, 0x04, 0x60]), ok_write(0x1A02, 1));
    // 16-bit speed: 0x6030:01 is INTEGER32 on this variant (D13).
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60]), abort(0x1A02, 2, 0x0604_0043));
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x1A, 0x02, 0x20, 0x01, 0x30, 0x60]), ok_write(0x1A02, 2));
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x1A, 0x00, 0x02, 0, 0, 0]), ok_write(0x1A02, 0));
    assert_eq!(sdo(&mut b, [0x23, 0x02, 0x18, 0x01, 0xBF, 0x03, 0x00, 0x40]), ok_write(0x1802, 1));
    let out = b.rx(ms(1), 0x000, &[0x01, 0x3F]);
    assert!(out.contains(&(0x3BF, vec![0xBA, 0x4C, 0, 0, 0, 0, 0, 0])), "position + speed: {out:x?}");
    // In Operational the mapping is locked (§5.3.4.1 L1028).
    assert_eq!(sdo(&mut b, [0x2F, 0x02, 0x1A, 0x00, 0x00, 0, 0, 0]), abort(0x1A02, 0, 0x0800_0022));
}

#[test]
fn s15_cob_id_change_at_node_11_l3448() {
    let mut b = node_at(0x0B);
    let w = |b: &mut Encoder, req: [u8; 8]| {
        let out = b.rx(b.now, 0x60B, &req);
        assert_eq!(out.len(), 1);
        out[0].1.clone()
    };
    assert_eq!(w(&mut b, [0x23, 0x00, 0x18, 0x01, 0x8B, 0x01, 0x00, 0x80]), ok_write(0x1800, 1));
    assert_eq!(w(&mut b, [0x23, 0x00, 0x18, 0x01, 0x0B, 0x04, 0x00, 0x80]), ok_write(0x1800, 1));
    // The printed last frame clears bit 30: the M-series keeps "no RTR" (§5.5.13, D9).
    assert_eq!(w(&mut b, [0x23, 0x00, 0x18, 0x01, 0x0B, 0x04, 0x00, 0x00]), abort(0x1800, 1, 0x0609_0030));
    assert_eq!(w(&mut b, [0x23, 0x00, 0x18, 0x01, 0x0B, 0x04, 0x00, 0x40]), ok_write(0x1800, 1));
    let out = b.rx(ms(1), 0x000, &[0x01, 0x0B]);
    assert!(out.iter().any(|f| f.0 == 0x40B) && !out.iter().any(|f| f.0 == 0x18B), "{out:x?}");
}

#[test]
fn s16_tpdo2_moves_from_0x288_to_0x388_at_node_8_l3474() {
    let mut b = node_at(8);
    let w = |b: &mut Encoder, req: [u8; 8]| {
        let out = b.rx(b.now, 0x608, &req);
        assert_eq!(out.len(), 1);
        out[0].1.clone()
    };
    // The printed bytes are swapped against the text: invalidate 0x288 first, then the new 0x388.
    assert_eq!(w(&mut b, [0x23, 0x01, 0x18, 0x01, 0x88, 0x02, 0x00, 0x80]), ok_write(0x1801, 1));
    assert_eq!(w(&mut b, [0x23, 0x01, 0x18, 0x01, 0x88, 0x03, 0x00, 0x80]), ok_write(0x1801, 1));
    // TPDO3 leaves 0x388 free for it.
    assert_eq!(w(&mut b, [0x23, 0x02, 0x18, 0x01, 0x88, 0x03, 0x00, 0x80]), ok_write(0x1802, 1));
    assert_eq!(w(&mut b, [0x23, 0x01, 0x18, 0x01, 0x88, 0x03, 0x00, 0x40]), ok_write(0x1801, 1));
    b.rx(ms(1), 0x000, &[0x01, 0x08]);
    let out = b.rx(ms(2), 0x080, &[]);
    assert!(out.iter().any(|f| f.0 == 0x388) && !out.iter().any(|f| f.0 == 0x288), "TPDO2 on 0x388 at the SYNC: {out:x?}");
}

#[test]
fn s17_lss_configuration_and_the_reset_that_ends_it_l3498() {
    let mut b = node();
    // An unsaved profile change shows that the node resets, not only its communication.
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x01, 0x00]), ok_write(0x6000, 0));
    let lss = |b: &mut Encoder, t: u64, req: [u8; 8]| b.rx(ms(t), 0x7E5, &req);
    assert_eq!(lss(&mut b, 1, [0x04, 0x01, 0, 0, 0, 0, 0, 0]), [], "switch global: no answer");
    // The manual prints 5E 00: CiA 305 answers the current node-ID (D37).
    assert_eq!(lss(&mut b, 2, [0x5E, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x5E, 0x3F, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(lss(&mut b, 3, [0x11, 0x2A, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(lss(&mut b, 4, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x13, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(lss(&mut b, 5, [0x13, 0x00, 0x05, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x13, 0x01, 0, 0, 0, 0, 0, 0])], "index 5 reserved (D27)");
    assert_eq!(lss(&mut b, 6, [0x11, 0x80, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0x01, 0, 0, 0, 0, 0, 0])], "invalid node-ID");
    assert_eq!(lss(&mut b, 7, [0x17, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x17, 0, 0, 0, 0, 0, 0, 0])]);
    // L3567: the encoder resets itself and boots as node 0x2A.
    assert_eq!(lss(&mut b, 8, [0x04, 0x00, 0x04, 0, 0, 0, 0, 0]), [(0x72A, vec![0x00])]);
    let out = b.rx(ms(9), 0x62A, &[0x40, 0x00, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(out, [(0x5AA, vec![0x4B, 0x00, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00])], "reset node: the unsaved 0x6000 is gone");
    let stored = canopen_core::services::store::newest(&sendix::od::DICTIONARY, b.node.storage_mut()).and_then(|s| s.lss());
    assert_eq!(stored, Some((0x2A, 4)), "node 0x2A at 125 kbit/s for the next power-on");
}

#[test]
fn s18_the_trace_l3575() {
    // Counting CCW (0x6000 = 1), the shaft stands where the trace reads 0x4CBA.
    let mut b = encoder(MemStorage::new(4096), 0, (1u64 << 32) - 19642);
    assert_eq!(sdo(&mut b, [0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64]), [0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(1), 0x000, &[0x81, 0x3F]), [(0x73F, vec![0x00])]);
    assert_eq!(sdo(&mut b, [0x2B, 0x00, 0x62, 0x00, 0x0A, 0x00, 0x00, 0x00]), [0x60, 0x00, 0x62, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x2B, 0x00, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00]), [0x60, 0x00, 0x60, 0x00, 0, 0, 0, 0]);
    assert_eq!(sdo(&mut b, [0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65]), [0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]);
    b.rx(ms(2), 0x000, &[0x01, 0x3F]);
    let out: Vec<_> = b.run_until(ms(42)).into_iter().filter(|(_, f)| f.0 == 0x1BF).map(|(_, f)| f.1).collect();
    // The trace prints DLC 4 with six bytes: the frame is 4 bytes.
    assert_eq!(out, vec![vec![0xBA, 0x4C, 0x00, 0x00]; 4]);
    assert_eq!(b.rx(ms(43), 0x000, &[0x80, 0x3F]), []);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.run_until(ms(100)).iter().filter(|(_, f)| f.0 == 0x1BF).count(), 0, "no PDO in Pre-operational");
}

#[test]
fn s19_no_heartbeat_consumer_on_the_m5868_and_bus_off_follows_0x1029_1_l1970() {
    let mut b = node();
    // The heartbeat consumer of §5.5.9 is "no" in the M5868 column (D7).
    assert_eq!(sdo(&mut b, [0x23, 0x16, 0x10, 0x01, 0x64, 0x00, 0x01, 0x00]), abort(0x1016, 1, 0x0602_0000));
    // Bus-off is this variant's communication error: 0x1029:01 = 0 → Pre-operational.
    b.rx(ms(1), 0x000, &[0x01, 0x3F]);
    b.node.bus_off(ms(2));
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.sdo_write(0x3F, 0x1029, 1, &[2]), ok_write(0x1029, 1));
    b.rx(ms(3), 0x000, &[0x01, 0x3F]);
    b.node.bus_off(ms(4));
    assert_eq!(b.node.state(), NmtState::Stopped);
}

#[test]
fn s21_a_write_to_an_object_the_m5868_lacks_l3765() {
    let mut b = node();
    // The manual's 0x5000 answers 0x06010002 there; here 0x5000 does not exist.
    assert_eq!(sdo(&mut b, [0x23, 0x00, 0x50, 0x00, 0x01, 0x00, 0x00, 0x00]), [0x80, 0x00, 0x50, 0x00, 0x00, 0x00, 0x02, 0x06]);
}
