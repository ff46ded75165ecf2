//! CiA CANopen Conformance Test Tool 3.0.3.10, EMCY cases 5.1–5.6 and
//! SYNC cases 6.1–6.10 (`/work/shared/notes/cia-notes.md`, appendix A), as
//! exact frames at exact times on the interop fixture (node 4).
//! CiA 301 v4.2 §7.2.7 (EMCY; objects 0x1001, 0x1003, 0x1014, 0x1015) and
//! §7.2.5 (SYNC; objects 0x1005, 0x1006, 0x1007, 0x1019).
//!
//! Cases: all of 5.1–5.6 and 6.1–6.10 apply. 5.4 forces an EMCY the way a
//! tester can from outside: an RPDO shorter than its mapping (EMCY 0x8210,
//! CiA 301 §7.2.2.3).

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use common::{Bench, F, ms, ok_write};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

fn u32_le(v: Vec<u8>) -> u32 {
    let mut b = [0u8; 4];
    b[..v.len()].copy_from_slice(&v);
    u32::from_le_bytes(b)
}

const TPDO1: [u8; 7] = [0x11, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44];
/// 0x2004 = −5, 0x2007 = 1.5.
const TPDO2: [u8; 8] = [0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0xC0, 0x3F];

// ---- EMCY -----------------------------------------------------------------------

#[test]
fn cct_5_1_emcy_cob_id() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1014, 0), [0x43, 0x14, 0x10, 0x00, 0x84, 0, 0, 0]);
}

#[test]
fn cct_5_2_error_register_is_clear() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1001, 0), [0x4F, 0x01, 0x10, 0x00, 0x00, 0, 0, 0]);
}

#[test]
fn cct_5_3_error_history_is_empty() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1003, 0), [0x4F, 0x03, 0x10, 0x00, 0x00, 0, 0, 0]);
    // Sub-indices above sub 0's count hold no error: "no data available"
    // (CiA 301 §7.5.2.4; as CANopenNode answers), in the expedited frame.
    assert_eq!(b.sdo_read(ID, 0x1003, 1), [0x80, 0x03, 0x10, 0x01, 0x24, 0x00, 0x00, 0x08]);
}

/// Operational, then RPDO1 (8 mapped bytes) with 2 bytes: EMCY 0x8210, info = RPDO number.
fn force_emcy(b: &mut Interop) -> Vec<F> {
    assert_eq!(b.nmt(0x01, ID), [(0x184, TPDO1.to_vec())]);
    b.rx(ms(10), 0x204, &[0x01, 0x02])
}

#[test]
fn cct_5_4_force_an_emcy() {
    let mut b = interop();
    assert_eq!(force_emcy(&mut b), [(0x084, vec![0x10, 0x82, 0x11, 0x01, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(11), 0x204, &[0x01, 0x02]), [], "the same error is active already");
    // A good RPDO ends it: "error reset" with the register clear.
    assert_eq!(b.rx(ms(12), 0x204, &[1, 0, 2, 0, 3, 0, 4, 0]), [(0x084, vec![0; 8])]);
    // EMCY off (0x1014 bit 31): the error is recorded, not sent.
    assert_eq!(b.sdo_download(ID, 0x1014, 0, &0x8000_0084u32.to_le_bytes()), Ok(()));
    assert_eq!(b.rx(ms(13), 0x204, &[0x01]), []);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x11]));
}

#[test]
fn cct_5_5_error_register_after_the_emcy() {
    let mut b = interop();
    force_emcy(&mut b);
    // Generic (bit 0) and communication (bit 4), as the EMCY said.
    assert_eq!(b.sdo_read(ID, 0x1001, 0), [0x4F, 0x01, 0x10, 0x00, 0x11, 0, 0, 0]);
}

#[test]
fn cct_5_6_error_history_matches_the_emcy() {
    let mut b = interop();
    let emcy = force_emcy(&mut b).remove(0).1;
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![1]));
    let entry = u32_le(b.sdo_upload(ID, 0x1003, 1).unwrap());
    // Error code in bits 0..15, the first two bytes of the EMCY's additional information above.
    assert_eq!(entry & 0xFFFF, u32::from(u16::from_le_bytes([emcy[0], emcy[1]])));
    assert_eq!(entry >> 16, u32::from(u16::from_le_bytes([emcy[3], emcy[4]])));
    // A second error is the newest entry, sub 1.
    assert_eq!(b.rx(ms(20), 0x204, &[1, 0, 2, 0, 3, 0, 4, 0]), [(0x084, vec![0; 8])], "error reset: not in the history");
    // RPDO2 (3 mapped bytes, the values unchanged) one byte too long: 0x8220.
    assert_eq!(b.rx(ms(22), 0x304, &[0x11, 0x22, 0x22, 0]), [(0x084, vec![0x20, 0x82, 0x11, 0x02, 0, 0, 0, 0])]);
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![2]));
    assert_eq!(u32_le(b.sdo_upload(ID, 0x1003, 1).unwrap()), 0x0002_8220);
    assert_eq!(u32_le(b.sdo_upload(ID, 0x1003, 2).unwrap()), 0x0001_8210);
    assert_eq!(b.sdo_upload(ID, 0x1003, 3), Err(0x0800_0024), "above the count: no error there");
}

#[test]
fn a_full_error_history_drops_the_oldest_and_writing_0_clears_it() {
    let mut b = interop();
    // Ten application errors, one per millisecond: 0x1003 holds eight (sub 1..8), newest first.
    for k in 0..10u16 {
        b.node.raise_error(EmcyCode(0xFF00 + k), [k as u8, 0x10, 0, 0, 0]);
        assert_eq!(b.at(ms(1 + u64::from(k))).len(), 1, "error {k}: one EMCY");
    }
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![8]));
    for sub in 1..=8u8 {
        let k = 10 - u32::from(sub);
        assert_eq!(u32_le(b.sdo_upload(ID, 0x1003, sub).unwrap()), (0x1000 + k) << 16 | (0xFF00 + k), "sub {sub}");
    }
    // CiA 301 §7.5.2.4: writing 0 to sub 0 empties it, every field too.
    assert_eq!(b.sdo_download(ID, 0x1003, 0, &[0]), Ok(()));
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![0]));
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Err(0x0800_0024));
    assert_eq!(b.sdo_upload(ID, 0x1003, 8), Err(0x0800_0024));
    assert_eq!(b.sdo_upload(ID, 0x1003, 9), Err(0x0609_0011), "no sub 9 at all");
}

// ---- SYNC -----------------------------------------------------------------------

#[test]
fn cct_6_1_default_sync_cob_id() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1005, 0), [0x43, 0x05, 0x10, 0x00, 0x80, 0, 0, 0]);
}

/// Makes the node the SYNC producer with `period_us`, at `t` ms.
fn produce_sync(b: &mut Interop, t: u64, period_us: u32) {
    b.at(ms(t));
    assert_eq!(b.sdo_download(ID, 0x1006, 0, &period_us.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1005, 0, &0x4000_0080u32.to_le_bytes()), Ok(()));
}

fn times(out: &[(Instant, F)], cob: u16) -> Vec<u64> {
    out.iter().filter(|(_, (c, _))| *c == cob).map(|(t, _)| t.as_micros() / 1000).collect()
}

#[test]
fn cct_6_2_count_sync_messages() {
    let mut b = interop();
    produce_sync(&mut b, 100, 10_000);
    let out = b.run_until(ms(200));
    assert_eq!(times(&out, 0x080), (110..=200).step_by(10).collect::<Vec<_>>());
    assert!(out.iter().all(|(_, f)| *f == (0x080, vec![])), "no counter: no data");
}

#[test]
fn cct_6_3_count_transmit_pdos() {
    let mut b = interop();
    // TPDO1 on every 2nd SYNC, TPDO2 (type 1) on every SYNC.
    assert_eq!(b.sdo_download(ID, 0x1800, 1, &0xC000_0184u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1800, 2, &[2]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1800, 1, &0x4000_0184u32.to_le_bytes()), Ok(()));
    produce_sync(&mut b, 100, 10_000);
    assert_eq!(b.nmt(0x01, ID), []);
    let out = b.run_until(ms(200));
    assert_eq!(times(&out, 0x080).len(), 10);
    assert_eq!(times(&out, 0x284), (110..=200).step_by(10).collect::<Vec<_>>());
    assert_eq!(times(&out, 0x184), (120..=200).step_by(20).collect::<Vec<_>>());
    assert_eq!(out[..3], [(ms(110), (0x080, vec![])), (ms(110), (0x284, TPDO2.to_vec())), (ms(120), (0x080, vec![]))]);
}

#[test]
fn cct_6_4_sync_consumer_with_period_0() {
    let mut b = interop();
    produce_sync(&mut b, 100, 10_000);
    assert_eq!(b.run_until(ms(110)), [(ms(110), (0x080, vec![]))]);
    assert_eq!(b.sdo_download(ID, 0x1006, 0, &[0; 4]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1005, 0, &0x80u32.to_le_bytes()), Ok(()));
    assert_eq!(b.run_until(ms(1000)), [], "no SYNC produced");
    // It consumes SYNCs: the synchronous TPDO2 answers one.
    b.nmt(0x01, ID);
    assert_eq!(b.rx(ms(1010), 0x080, &[]), [(0x284, TPDO2.to_vec())]);
}

#[test]
fn cct_6_5_invalid_sync_counter_overflow_values() {
    let mut b = interop();
    for v in [1u8, 241, 242, 255] {
        assert_eq!(b.sdo_download(ID, 0x1019, 0, &[v]), Err(0x0609_0030), "{v}");
    }
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![0]));
    for v in [2u8, 240] {
        assert_eq!(b.sdo_download(ID, 0x1019, 0, &[v]), Ok(()), "{v}");
    }
}

#[test]
fn cct_6_6_sync_counter_overflow_0_sends_no_counter() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[3]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[0]), Ok(()));
    produce_sync(&mut b, 100, 10_000);
    assert_eq!(b.run_until(ms(120)), [(ms(110), (0x080, vec![])), (ms(120), (0x080, vec![]))]);
}

#[test]
fn cct_6_7_sync_counter_is_sent() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[5]), Ok(()));
    produce_sync(&mut b, 100, 10_000);
    let out = b.run_until(ms(170));
    let counters: Vec<Vec<u8>> = out.into_iter().map(|(_, (cob, d))| (cob == 0x080).then_some(d).unwrap()).collect();
    assert_eq!(counters, [[1], [2], [3], [4], [5], [1], [2]]);
    // As a consumer with a counter, a SYNC without one is not a SYNC: EMCY 0x8240.
    assert_eq!(b.sdo_download(ID, 0x1006, 0, &[0; 4]), Ok(()));
    assert_eq!(b.rx(ms(180), 0x080, &[]), [(0x084, vec![0x40, 0x82, 0x11, 0, 0, 0, 0, 0])]);
}

#[test]
fn cct_6_8_sync_counter_saved_over_reset_node() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[3]), Ok(()));
    produce_sync(&mut b, 100, 10_000);
    assert_eq!(b.sdo_write(ID, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    b.run_until(ms(125));
    assert_eq!(b.nmt(0x81, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![3]));
    // The producer starts over, and so does the counter.
    let out = b.run_until(ms(165));
    assert_eq!(out, [(ms(135), (0x080, vec![1])), (ms(145), (0x080, vec![2])), (ms(155), (0x080, vec![3])), (ms(165), (0x080, vec![1]))]);
}

#[test]
fn cct_6_9_sync_counter_is_locked_while_a_period_is_set() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1006, 0, &10_000u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[5]), Err(0x0800_0022));
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![0]));
    assert_eq!(b.sdo_download(ID, 0x1006, 0, &[0; 4]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[5]), Ok(()));
}

#[test]
fn cct_6_10_sync_values_saved_to_nvm() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[4]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1007, 0, &2_000u32.to_le_bytes()), Ok(()));
    produce_sync(&mut b, 100, 20_000);
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1005, 0), Ok(0x4000_0080u32.to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x1006, 0), Ok(20_000u32.to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x1007, 0), Ok(2_000u32.to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![4]));
    assert_eq!(b.run_until(ms(140)), [(ms(120), (0x080, vec![1])), (ms(140), (0x080, vec![2]))]);
    // Restore the defaults: after the next reset no SYNC is produced.
    assert_eq!(b.sdo_write(ID, 0x1011, 2, b"load"), ok_write(0x1011, 2));
    assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1005, 0), Ok(vec![0x80, 0, 0, 0]));
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![0]));
    assert_eq!(b.run_until(ms(1000)), []);
}

#[test]
fn a_sync_into_a_full_queue_is_counted_and_its_tpdo_retried_once_the_queue_drains() {
    let mut b = interop();
    b.nmt(0x01, ID);
    let sync = CanFrame::standard(0x080, &[]).unwrap();
    // 32 SYNCs fill the transmit queue with TPDO2 (type 1); nothing leaves meanwhile.
    for _ in 0..32 {
        b.node.on_frame(ms(10), &sync);
    }
    assert_eq!(b.node.tx_overflows(), 0);
    // The 33rd finds it full: TPDO2 keeps this SYNC's data and retries at
    // the next process (refused again: the queue has not drained yet).
    b.node.on_frame(ms(10), &sync);
    assert_eq!(b.node.tx_overflows(), 1);
    assert_eq!(b.at(ms(10)), vec![(0x284, TPDO2.to_vec()); 32]);
    assert_eq!(b.node.tx_overflows(), 2);
    // Drained: one EMCY 0x8110 (2 frames refused) and its reset, then the retry.
    assert_eq!(b.at(ms(11)), [(0x84, vec![0x10, 0x81, 0x11, 2, 0, 0, 0, 1]), (0x84, vec![0; 8])]);
    assert_eq!(b.at(ms(12)), [(0x284, TPDO2.to_vec())]);
    assert_eq!(b.at(ms(13)), []);
    assert_eq!(b.rx(ms(14), 0x080, &[]), [(0x284, TPDO2.to_vec())]);
    assert_eq!(b.node.tx_overflows(), 2);
}
