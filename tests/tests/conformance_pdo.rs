//! CiA CANopen Conformance Test Tool 3.0.3.10, PDO cases 3.1–3.33
//! (`/work/shared/notes/cia-notes.md`, appendix A), as exact frames on the
//! interop fixture (node 4, as in the CCT log). CiA 301 v4.2 §7.2.2 (PDO),
//! §7.5.2.35–38 (PDO parameters and the mapping procedure).
//!
//! The fixture's defaults: RPDO1 0x204 maps 0x2100 sub 1..4 (4 × u16),
//! RPDO2 0x304 maps 0x2000 (u8) and 0x2001 (u16), RPDO3/4 are not valid;
//! TPDO1 0x184 (no RTR, type 255) maps 0x2000, 0x2001, 0x2003 (u32), TPDO2
//! 0x284 (no RTR, type 1) maps 0x2004 (i32) and 0x2007 (real32), TPDO3/4
//! are not valid and map nothing.
//!
//! Cases:
//! - 3.1–3.9, 3.15, 3.21–3.26, 3.28–3.30, 3.32, 3.33: interop node.
//! - 3.4–3.8 configure TPDO1, 3.10–3.14 all four TPDOs (the plural in the
//!   CCT names), in Pre-operational, and check them in Operational.
//! - 3.16–3.20 repeat the configurations of 3.4–3.8 and check that a
//!   Pre-operational node sends no PDO (in the CCT log of CANopenNode the
//!   DUT stays Pre-operational while SYNCs are sent, and no TPDO is expected).
//! - 3.27 and 3.31 need mappable objects with access rww or wo, which the
//!   interop fixture lacks: they run on the Agile drive (0x6040 rww,
//!   0x6060 wo, both PDOMapping=1).

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use common::{Bench, F, ms};
use firmware::devices::agile;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

const TPDO1: [u8; 7] = [0x11, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44];
/// 0x2004 = −5, 0x2007 = 1.5.
const TPDO2: [u8; 8] = [0xFB, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0xC0, 0x3F];

fn w(b: &mut Interop, index: u16, sub: u8, v: u32, len: usize) -> Result<(), u32> {
    b.sdo_download(ID, index, sub, &v.to_le_bytes()[..len])
}

fn w32(b: &mut Interop, index: u16, sub: u8, v: u32) -> Result<(), u32> {
    w(b, index, sub, v, 4)
}

fn r32(b: &mut Interop, index: u16, sub: u8) -> u32 {
    let v = b.sdo_upload(ID, index, sub).expect("readable");
    let mut x = [0u8; 4];
    x[..v.len()].copy_from_slice(&v);
    u32::from_le_bytes(x)
}

/// The TPDO configuration CCT cases write, TPDO `n` (0-based) on its
/// default CAN-ID: COB-ID invalid, transmission type, event timer (ms),
/// SYNC start value, then COB-ID valid again (with `rtr`: RTR allowed).
fn configure_tpdo(b: &mut Interop, n: u16, transmission_type: u8, timer_ms: u16, start: u8, rtr: bool) {
    let comm = 0x1800 + n;
    let cob = 0x180 + 0x100 * u32::from(n) + u32::from(ID) + if rtr { 0 } else { 0x4000_0000 };
    assert_eq!(w32(b, comm, 1, cob | 0x8000_0000), Ok(()));
    assert_eq!(w(b, comm, 2, transmission_type.into(), 1), Ok(()));
    assert_eq!(w(b, comm, 5, timer_ms.into(), 2), Ok(()));
    assert_eq!(w(b, comm, 6, start.into(), 1), Ok(()));
    if r32(b, 0x1A00 + n, 0) == 0 {
        // TPDO3/4 map nothing by default: map 0x2000 (u8) with the procedure.
        assert_eq!(w32(b, 0x1A00 + n, 1, 0x2000_0008), Ok(()));
        assert_eq!(w(b, 0x1A00 + n, 0, 1, 1), Ok(()));
    }
    assert_eq!(w32(b, comm, 1, cob), Ok(()));
}

fn start(b: &mut Interop) -> Vec<F> {
    b.nmt(0x01, ID)
}

/// Writes 0x2000 through an SDO at `t`: returns what the node sends besides the confirmation.
fn change_0x2000(b: &mut Interop, t: u64, v: u8) -> Vec<F> {
    let mut out = b.rx(ms(t), 0x604, &[0x2F, 0x00, 0x20, 0x00, v, 0, 0, 0]);
    let confirmation = out.iter().position(|(cob, _)| *cob == 0x584).expect("SDO confirmation");
    assert_eq!(out.remove(confirmation).1, [0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]);
    out
}

fn sync(b: &mut Interop, t: u64, counter: Option<u8>) -> Vec<F> {
    b.rx(ms(t), 0x080, counter.as_slice())
}

fn tpdo1(first: u8) -> F {
    let mut d = TPDO1.to_vec();
    d[0] = first;
    (0x184, d)
}

// ---- Scans ---------------------------------------------------------------------

#[test]
fn cct_3_1_scan_rpdos() {
    let mut b = interop();
    let cob_ids: Vec<u32> = (0x1400..0x1404).map(|i| r32(&mut b, i, 1)).collect();
    assert_eq!(cob_ids, [0x204, 0x304, 0x8000_0404, 0x8000_0504]);
    assert_eq!(b.sdo_upload(ID, 0x1404, 1), Err(0x0602_0000));
}

#[test]
fn cct_3_2_scan_tpdos() {
    let mut b = interop();
    let cob_ids: Vec<u32> = (0x1800..0x1804).map(|i| r32(&mut b, i, 1)).collect();
    assert_eq!(cob_ids, [0x4000_0184, 0x4000_0284, 0xC000_0384, 0xC000_0484]);
    assert_eq!(b.sdo_upload(ID, 0x1804, 1), Err(0x0602_0000));
}

/// A PDO parameter the PDO's rules refuse is not stored (the abort code, and
/// the old value read back); one they take is stored and used; writing back
/// a locked mapping's current value is taken and changes nothing.
#[test]
fn a_refused_pdo_download_leaves_the_image_and_a_taken_one_is_stored_and_used() {
    let mut b = interop();
    // TPDO1 valid: its inhibit time and its mapping are locked.
    assert_eq!(w(&mut b, 0x1800, 3, 100, 2), Err(0x0609_0030));
    assert_eq!(r32(&mut b, 0x1800, 3), 0);
    assert_eq!(w(&mut b, 0x1A00, 0, 1, 1), Err(0x0601_0000));
    assert_eq!(r32(&mut b, 0x1A00, 0), 3);
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x2001_0010), Err(0x0601_0000));
    assert_eq!(r32(&mut b, 0x1A00, 1), 0x2000_0008);
    assert_eq!(w(&mut b, 0x1A00, 0, 3, 1), Ok(()), "the current value written back");
    assert_eq!(r32(&mut b, 0x1A00, 0), 3);
    // A restricted CAN-ID (0x701) in a valid COB-ID.
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0701), Err(0x0609_0030));
    assert_eq!(r32(&mut b, 0x1800, 1), 0x4000_0184);
    // Invalid, then a new mapping (0x2000 alone) and a new CAN-ID: stored and used.
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(r32(&mut b, 0x1800, 1), 0xC000_0184);
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 9, 1), Err(0x0604_0042), "more than 8 entries");
    assert_eq!(r32(&mut b, 0x1A00, 0), 0);
    assert_eq!(w(&mut b, 0x1A00, 0, 1, 1), Ok(()));
    assert_eq!(r32(&mut b, 0x1A00, 0), 1);
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0190), Ok(()));
    assert_eq!(r32(&mut b, 0x1800, 1), 0x4000_0190);
    assert_eq!(start(&mut b), [(0x190, vec![0x11])]);
}

// ---- One TPDO configured, Operational --------------------------------------------

#[test]
fn cct_3_3_rtr_in_operational() {
    let mut b = interop();
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.rtr(ms(1), 0x184), [], "bit 30 set: no RTR allowed");
    b.nmt(0x80, ID);
    configure_tpdo(&mut b, 0, 255, 0, 0, true);
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.rtr(ms(2), 0x184), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.rtr(ms(3), 0x184), [(0x184, TPDO1.to_vec())]);
}

#[test]
fn cct_3_4_event_driven_tpdo() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 254, 0, 0, false);
    assert_eq!(w(&mut b, 0x1800, 3, 100, 2), Err(0x0609_0030), "the inhibit time changes only while not valid");
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1800, 3, 100, 2), Ok(()), "10 ms");
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0184), Ok(()));
    b.at(ms(10));
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    // A change within the inhibit time waits for its end.
    assert_eq!(change_0x2000(&mut b, 15, 0x12), []);
    assert_eq!(b.run_until(ms(20)), [(ms(20), tpdo1(0x12))]);
    assert_eq!(change_0x2000(&mut b, 40, 0x13), [tpdo1(0x13)]);
    assert_eq!(change_0x2000(&mut b, 45, 0x13), [], "the same value is no change");
    assert_eq!(b.run_until(ms(1000)), []);
}

/// An expedited download while the transmit queue has no room for the
/// answer (4 slots are kept for heartbeat and EMCY): the value is written
/// once, so the event-driven TPDO mapping it sees the change, and the
/// answer follows once the queue drains (written twice, the value would
/// have changed nothing for the TPDO).
#[test]
fn an_expedited_download_into_a_full_queue_reaches_its_tpdo_and_answers_later() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 254, 0, 0, false);
    b.at(ms(10));
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    // 28 SYNCs queue 28 TPDO2s (type 1): 4 slots left, none for an SDO answer.
    let sync = CanFrame::standard(0x080, &[]).unwrap();
    for _ in 0..28 {
        b.node.on_frame(ms(20), &sync);
    }
    b.node.on_frame(ms(20), &CanFrame::standard(0x604, &[0x2F, 0x00, 0x20, 0x00, 0x12, 0, 0, 0]).unwrap());
    let mut expected = vec![tpdo1(0x12)];
    expected.extend(vec![(0x284, TPDO2.to_vec()); 28]);
    assert_eq!(b.at(ms(20)), expected);
    assert_eq!(b.at(ms(21)), [(0x584, vec![0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0])]);
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x12]));
    assert_eq!(b.node.tx_overflows(), 0);
}

#[test]
fn cct_3_5_event_timer() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 254, 100, 0, false);
    b.at(ms(10));
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    let sent = b.run_until(ms(350));
    assert_eq!(sent, [(ms(110), tpdo1(0x11)), (ms(210), tpdo1(0x11)), (ms(310), tpdo1(0x11))]);
    // A change restarts the timer.
    assert_eq!(change_0x2000(&mut b, 360, 0x12), [tpdo1(0x12)]);
    assert_eq!(b.run_until(ms(460)), [(ms(460), tpdo1(0x12))]);
}

#[test]
fn cct_3_6_sync_cyclic() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 2, 0, 0, false);
    assert_eq!(start(&mut b), []);
    assert_eq!(sync(&mut b, 20, None), [(0x284, TPDO2.to_vec())], "TPDO2 is type 1");
    assert_eq!(sync(&mut b, 30, None), [(0x184, TPDO1.to_vec()), (0x284, TPDO2.to_vec())]);
    assert_eq!(sync(&mut b, 40, None), [(0x284, TPDO2.to_vec())]);
    assert_eq!(sync(&mut b, 50, None), [(0x184, TPDO1.to_vec()), (0x284, TPDO2.to_vec())]);
}

#[test]
fn cct_3_7_sync_acyclic() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 0, 0, 0, false);
    configure_tpdo(&mut b, 1, 0, 0, 0, false);
    assert_eq!(start(&mut b), []);
    assert_eq!(sync(&mut b, 20, None), [(0x184, TPDO1.to_vec()), (0x284, TPDO2.to_vec())], "the first SYNC: nothing sent yet");
    assert_eq!(sync(&mut b, 30, None), []);
    assert_eq!(change_0x2000(&mut b, 35, 0x12), [], "sent at the next SYNC, not now");
    assert_eq!(sync(&mut b, 40, None), [tpdo1(0x12)]);
    assert_eq!(sync(&mut b, 50, None), []);
}

#[test]
fn cct_3_8_sync_cyclic_with_start_value() {
    let mut b = interop();
    assert_eq!(w(&mut b, 0x1019, 0, 10, 1), Ok(()));
    configure_tpdo(&mut b, 0, 2, 0, 3, false);
    assert_eq!(w(&mut b, 0x1800, 6, 4, 1), Err(0x0609_0030), "the start value changes only while not valid");
    assert_eq!(w(&mut b, 0x1801, 6, 241, 1), Err(0x0609_0030), "start value 0..=240");
    assert_eq!(start(&mut b), []);
    let mut sent = Vec::new();
    for (k, counter) in (1..=10).chain(1..=2).enumerate() {
        let out = sync(&mut b, 20 + k as u64, Some(counter));
        sent.extend(out.into_iter().filter(|(cob, _)| *cob == 0x184).map(|_| counter));
    }
    // The SYNC with counter 3 counts as the first; then every second one.
    assert_eq!(sent, [4, 6, 8, 10, 2]);
}

#[test]
fn cct_3_9_rtr_in_stopped() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 255, 0, 0, true);
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.nmt(0x02, ID), []);
    assert_eq!(b.rtr(ms(1), 0x184), []);
    assert_eq!(sync(&mut b, 2, None), []);
    assert_eq!(b.nmt(0x01, ID), [(0x184, TPDO1.to_vec())], "Operational again: sent once more");
    assert_eq!(b.rtr(ms(3), 0x184), [(0x184, TPDO1.to_vec())]);
}

// ---- All TPDOs -----------------------------------------------------------------

/// TPDOn with the default data: TPDO3/4 map 0x2000 only (see `configure_tpdo`).
fn all(first: u8) -> Vec<F> {
    vec![tpdo1(first), (0x284, TPDO2.to_vec()), (0x384, vec![first]), (0x484, vec![first])]
}

#[test]
fn cct_3_10_all_tpdos_event_driven() {
    let mut b = interop();
    (0..4).for_each(|n| configure_tpdo(&mut b, n, 254, 0, 0, false));
    assert_eq!(start(&mut b), all(0x11));
    let expected: Vec<F> = all(0x12).into_iter().filter(|(cob, _)| *cob != 0x284).collect();
    assert_eq!(change_0x2000(&mut b, 10, 0x12), expected);
}

#[test]
fn cct_3_11_all_tpdos_event_timer() {
    let mut b = interop();
    for n in 0..4 {
        configure_tpdo(&mut b, n, 255, 100 * (n + 1), 0, false);
    }
    assert_eq!(start(&mut b), all(0x11));
    let sent: Vec<(u64, u16)> = b.run_until(ms(400)).into_iter().map(|(t, (cob, _))| (t.as_micros() / 1000, cob)).collect();
    assert_eq!(sent, [(100, 0x184), (200, 0x184), (200, 0x284), (300, 0x184), (300, 0x384), (400, 0x184), (400, 0x284), (400, 0x484)]);
}

#[test]
fn cct_3_12_all_tpdos_sync_cyclic() {
    let mut b = interop();
    for n in 0..4 {
        configure_tpdo(&mut b, n, (n + 1) as u8, 0, 0, false);
    }
    assert_eq!(start(&mut b), []);
    let mut count = [0; 4];
    for k in 0..12 {
        for (cob, _) in sync(&mut b, 10 + k, None) {
            count[usize::from((cob - 0x184) / 0x100)] += 1;
        }
    }
    assert_eq!(count, [12, 6, 4, 3]);
}

#[test]
fn cct_3_13_all_tpdos_sync_acyclic() {
    let mut b = interop();
    (0..4).for_each(|n| configure_tpdo(&mut b, n, 0, 0, 0, false));
    assert_eq!(start(&mut b), []);
    assert_eq!(sync(&mut b, 10, None), all(0x11));
    assert_eq!(sync(&mut b, 20, None), []);
    assert_eq!(change_0x2000(&mut b, 25, 0x12), []);
    let expected: Vec<F> = all(0x12).into_iter().filter(|(cob, _)| *cob != 0x284).collect();
    assert_eq!(sync(&mut b, 30, None), expected);
}

#[test]
fn cct_3_14_all_tpdos_sync_start_values() {
    let mut b = interop();
    assert_eq!(w(&mut b, 0x1019, 0, 4, 1), Ok(()));
    for n in 0..4 {
        configure_tpdo(&mut b, n, 1, 0, (n + 1) as u8, false);
    }
    assert_eq!(start(&mut b), []);
    let cobs = |out: Vec<F>| out.into_iter().map(|(cob, _)| cob).collect::<Vec<_>>();
    assert_eq!(cobs(sync(&mut b, 10, Some(1))), [0x184]);
    assert_eq!(cobs(sync(&mut b, 11, Some(2))), [0x184, 0x284]);
    assert_eq!(cobs(sync(&mut b, 12, Some(3))), [0x184, 0x284, 0x384]);
    assert_eq!(cobs(sync(&mut b, 13, Some(4))), [0x184, 0x284, 0x384, 0x484]);
    assert_eq!(cobs(sync(&mut b, 14, Some(1))), [0x184, 0x284, 0x384, 0x484]);
}

#[test]
fn cct_3_15_request_tpdo_with_rtr() {
    let mut b = interop();
    configure_tpdo(&mut b, 0, 253, 0, 0, true);
    configure_tpdo(&mut b, 1, 252, 0, 0, true);
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0184), Err(0x0609_0030), "type 253 cannot be made 'no RTR'");
    assert_eq!(start(&mut b), [], "RTR-only PDOs do not send on their own");
    assert_eq!(b.rtr(ms(10), 0x184), [(0x184, TPDO1.to_vec())]);
    // Type 252: sampled at the SYNC, sent on RTR.
    assert_eq!(sync(&mut b, 20, None), []);
    assert_eq!(b.sdo_download(ID, 0x2004, 0, &7i32.to_le_bytes()), Ok(()));
    assert_eq!(b.rtr(ms(30), 0x284), [(0x284, TPDO2.to_vec())], "the sample of the last SYNC");
    assert_eq!(sync(&mut b, 40, None), []);
    assert_eq!(b.rtr(ms(50), 0x284), [(0x284, vec![7, 0, 0, 0, 0x00, 0x00, 0xC0, 0x3F])]);
}

// ---- Pre-operational: no PDO ------------------------------------------------------

/// Configures TPDO1 as `configure`, stays Pre-operational, drives changes,
/// SYNCs (with counters 1..=10) and RTRs for a second: nothing is sent.
fn silent_in_pre_operational(transmission_type: u8, timer_ms: u16, start_value: u8) {
    let mut b = interop();
    if start_value != 0 {
        assert_eq!(w(&mut b, 0x1019, 0, 10, 1), Ok(()));
    }
    configure_tpdo(&mut b, 0, transmission_type, timer_ms, start_value, true);
    assert_eq!(change_0x2000(&mut b, 10, 0x12), []);
    for k in 0..10u8 {
        let counter = (start_value != 0).then_some(k + 1);
        assert_eq!(sync(&mut b, 20 + u64::from(k), counter), []);
        assert_eq!(b.rtr(ms(30 + u64::from(k)), 0x184), []);
    }
    assert_eq!(b.run_until(ms(1000)), []);
    // The same configuration sends once Operational.
    assert_ne!(start(&mut b).len() + sync(&mut b, 1001, (start_value != 0).then_some(start_value)).len(), 0);
}

#[test]
fn cct_3_16_event_driven_tpdo_not_sent_in_pre_operational() {
    silent_in_pre_operational(254, 0, 0);
}

#[test]
fn cct_3_17_event_timer_not_run_in_pre_operational() {
    silent_in_pre_operational(254, 100, 0);
}

#[test]
fn cct_3_18_sync_cyclic_tpdo_not_sent_in_pre_operational() {
    silent_in_pre_operational(1, 0, 0);
}

#[test]
fn cct_3_19_sync_acyclic_tpdo_not_sent_in_pre_operational() {
    silent_in_pre_operational(0, 0, 0);
}

#[test]
fn cct_3_20_sync_start_value_tpdo_not_sent_in_pre_operational() {
    silent_in_pre_operational(1, 0, 3);
}

// ---- Mapping -------------------------------------------------------------------------

#[test]
fn cct_3_21_default_mappings_name_existing_objects() {
    let mut b = interop();
    let mut mapped = Vec::new();
    for record in (0x1600..0x1604).chain(0x1A00..0x1A04) {
        let count = r32(&mut b, record, 0);
        for sub in 1..=count as u8 {
            let entry = r32(&mut b, record, sub);
            let (index, sub, bits) = ((entry >> 16) as u16, (entry >> 8) as u8, entry & 0xFF);
            let value = b.sdo_upload(ID, index, sub).expect("a mapped object is readable");
            assert_eq!(value.len() * 8, bits as usize, "{index:04X}:{sub}");
            mapped.push(entry);
        }
    }
    assert_eq!(
        mapped,
        [
            0x2100_0110,
            0x2100_0210,
            0x2100_0310,
            0x2100_0410,
            0x2000_0008,
            0x2001_0010,
            0x2000_0008,
            0x2001_0010,
            0x2003_0020,
            0x2004_0020,
            0x2007_0020
        ]
    );
}

#[test]
fn cct_3_22_new_mapping_with_the_mapping_procedure() {
    let mut b = interop();
    // RPDO1: not valid, sub 0 = 0, entries, sub 0 = n, valid.
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2001_0010), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 2, 0x2000_0008), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 2, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1400, 1, 0x204), Ok(()));
    // TPDO1 likewise: 0x2003 alone.
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x2003_0020), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 1, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0184), Ok(()));
    assert_eq!(start(&mut b), [(0x184, vec![0x44, 0x44, 0x44, 0x44])]);
    // The RPDO writes 0x2001 then 0x2000; TPDO1 does not map them, so nothing is sent.
    assert_eq!(b.rx(ms(10), 0x204, &[0x34, 0x12, 0x56]), []);
    assert_eq!(b.sdo_upload(ID, 0x2001, 0), Ok(vec![0x34, 0x12]));
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x56]));
}

#[test]
fn cct_3_23_new_mapping_without_the_procedure_is_refused() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2001_0010), Err(0x0601_0000), "sub 0 is not 0");
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x2001_0010), Err(0x0601_0000));
    assert_eq!(r32(&mut b, 0x1A00, 1), 0x2000_0008, "unchanged");
}

#[test]
fn cct_3_24_new_mapping_on_a_valid_pdo_is_refused() {
    let mut b = interop();
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Err(0x0601_0000));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2001_0010), Err(0x0601_0000));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Err(0x0601_0000));
    assert_eq!(w(&mut b, 0x1A00, 0, 3, 1), Ok(()), "writing back the current value is no change");
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())], "the old mapping still works");
}

#[test]
fn cct_3_25_too_many_mapped_objects() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Ok(()));
    for sub in 1..=8 {
        assert_eq!(w32(&mut b, 0x1600, sub, 0x2000_0008), Ok(()));
    }
    assert_eq!(w(&mut b, 0x1600, 0, 9, 1), Err(0x0604_0042));
    assert_eq!(w(&mut b, 0x1600, 0, 8, 1), Ok(()), "eight single bytes fit");
}

#[test]
fn cct_3_26_mapped_objects_too_long() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    for sub in 1..=3 {
        assert_eq!(w32(&mut b, 0x1A00, sub, 0x2003_0020), Ok(()));
    }
    assert_eq!(w(&mut b, 0x1A00, 0, 3, 1), Err(0x0604_0042), "96 bits");
    assert_eq!(w(&mut b, 0x1A00, 0, 2, 1), Ok(()), "64 bits");
    assert_eq!(r32(&mut b, 0x1A00, 0), 2);
}

type Agile = Bench<
    agile::od::Ram,
    NoApplication,
    MemStorage,
    { agile::od::RPDO_COUNT },
    { agile::od::TPDO_COUNT },
    { agile::od::HB_CONSUMER_COUNT },
>;

fn agile() -> Agile {
    let mut b: Agile = Bench::new(agile::od::Ram::new(ID), NoApplication, MemStorage::new(8192), ID);
    b.at(ms(0));
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x8000_0204u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1600, 0, &[0]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1800, 1, &0x8000_0184u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1A00, 0, &[0]), Ok(()));
    b
}

#[test]
fn cct_3_27_rww_and_wo_objects_map_to_an_rpdo() {
    let mut b = agile();
    assert_eq!(b.sdo_download(ID, 0x1600, 1, &0x6040_0010u32.to_le_bytes()), Ok(()), "0x6040 rww");
    assert_eq!(b.sdo_download(ID, 0x1600, 2, &0x6060_0008u32.to_le_bytes()), Ok(()), "0x6060 wo");
    assert_eq!(b.sdo_download(ID, 0x1600, 0, &[2]), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x204u32.to_le_bytes()), Ok(()));
}

#[test]
fn cct_3_28_rwr_and_ro_objects_do_not_map_to_an_rpdo() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x1001_0008), Err(0x0604_0041), "0x1001 ro, PDOMapping=1");
    assert_eq!(w32(&mut b, 0x1600, 1, 0x1000_0020), Err(0x0604_0041), "0x1000 const");
}

#[test]
fn cct_3_29_unmappable_objects_do_not_map_to_an_rpdo() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x1017_0010), Err(0x0604_0041), "PDOMapping=0");
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2008_0040), Err(0x0604_0041), "PDOMapping=0");
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2009_0008), Err(0x0602_0000), "no such object");
    assert_eq!(w32(&mut b, 0x1600, 1, 0x2000_0010), Err(0x0604_0043), "wrong length");
}

#[test]
fn cct_3_30_rwr_and_ro_objects_map_to_a_tpdo() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x1001_0008), Ok(()), "0x1001 ro, PDOMapping=1");
    assert_eq!(w32(&mut b, 0x1A00, 2, 0x2000_0008), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 2, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0184), Ok(()));
    assert_eq!(start(&mut b), [(0x184, vec![0x00, 0x11])]);
}

#[test]
fn cct_3_31_rww_and_wo_objects_do_not_map_to_a_tpdo() {
    let mut b = agile();
    assert_eq!(b.sdo_download(ID, 0x1A00, 1, &0x6040_0010u32.to_le_bytes()), Err(0x0604_0041), "0x6040 rww");
    assert_eq!(b.sdo_download(ID, 0x1A00, 1, &0x6060_0008u32.to_le_bytes()), Err(0x0604_0041), "0x6060 wo");
    assert_eq!(b.sdo_download(ID, 0x1A00, 1, &0x6041_0010u32.to_le_bytes()), Ok(()), "0x6041 ro");
}

#[test]
fn cct_3_32_unmappable_objects_do_not_map_to_a_tpdo() {
    let mut b = interop();
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x1017_0010), Err(0x0604_0041));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x2005_0008), Err(0x0604_0041), "a string, PDOMapping=0");
}

#[test]
fn cct_3_33_dummy_mapping() {
    let mut b = interop();
    // RPDO1: skip one byte (dummy UNSIGNED8), then 0x2001.
    assert_eq!(w32(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1600, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 1, 0x0005_0008), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 2, 0x2001_0010), Ok(()));
    assert_eq!(w32(&mut b, 0x1600, 3, 0x0006_0008), Err(0x0604_0043), "a dummy UNSIGNED16 is 16 bits");
    assert_eq!(w(&mut b, 0x1600, 0, 2, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1400, 1, 0x204), Ok(()));
    // A TPDO cannot send a dummy.
    assert_eq!(w32(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1A00, 0, 0, 1), Ok(()));
    assert_eq!(w32(&mut b, 0x1A00, 1, 0x0005_0008), Err(0x0604_0041));
    assert_eq!(w(&mut b, 0x1A00, 0, 3, 1), Ok(()), "the old entries again");
    assert_eq!(w32(&mut b, 0x1800, 1, 0x4000_0184), Ok(()));
    assert_eq!(start(&mut b), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.rx(ms(10), 0x204, &[0xAA, 0x34, 0x12]), [(0x184, vec![0x11, 0x34, 0x12, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x11]), "the dummy byte went nowhere");
}
