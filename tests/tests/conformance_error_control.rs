//! CiA CANopen Conformance Test Tool 3.0.3.10, error control cases:
//! guarding 7.1–7.6, heartbeat 7.101–7.107, heartbeat versus guarding
//! 7.201–7.207 (`/work/shared/notes/cia-notes.md`, appendix A), as exact
//! frames at exact times. CiA 301 v4.2 §7.2.8.3 (error control),
//! objects 0x100C, 0x100D, 0x1016, 0x1017, 0x1029.
//!
//! Guarding needs 0x100C/0x100D, which the interop fixture lacks: 7.1–7.6
//! and 7.201–7.207 run on the b maXX 4400 (node 4), the heartbeat cases on
//! the interop fixture (node 4, consuming the heartbeat of node 5).
//!
//! Decision (CiA 301 §7.2.8.3.2: "if the heartbeat producer time is not 0,
//! the heartbeat protocol is used"): while 0x1017 ≠ 0 the node answers no
//! guarding RTR and life guarding is off, whatever 0x100C/0x100D say.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::services::nmt::NmtState;
use common::{Bench, F, ms};
use firmware::devices::bmaxx4400;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const EC: u16 = 0x704;

type Bmaxx = Bench<bmaxx4400::od::Ram, NoApplication, MemStorage, 4, 4, 0>;
type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn bmaxx() -> Bmaxx {
    let mut b: Bmaxx = Bench::new(bmaxx4400::od::Ram::new(ID), NoApplication, MemStorage::new(8192), ID);
    assert_eq!(b.at(ms(0)), [(EC, vec![0x00])]);
    b
}

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(EC, vec![0x00])]);
    b
}

/// EMCY 0x8130 (life guard or heartbeat error) for `node` (0: life guarding).
fn hb_emcy(node: u8) -> F {
    (0x084, vec![0x30, 0x81, 0x11, node, 0, 0, 0, 0])
}

/// EMCY "error reset / no error".
fn no_error() -> F {
    (0x084, vec![0; 8])
}

fn guard(b: &mut Bmaxx, guard_ms: u16, factor: u8) {
    assert_eq!(b.sdo_download(ID, 0x100C, 0, &guard_ms.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x100D, 0, &[factor]), Ok(()));
}

// ---- Guarding -------------------------------------------------------------------

#[test]
fn cct_7_1_read_guard_time_and_life_time_factor() {
    let mut b = bmaxx();
    assert_eq!(b.sdo_read(ID, 0x100C, 0), [0x4B, 0x0C, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(b.sdo_read(ID, 0x100D, 0), [0x4F, 0x0D, 0x10, 0x00, 0, 0, 0, 0]);
}

#[test]
fn cct_7_2_rtr_is_answered_with_the_state() {
    let mut b = bmaxx();
    // Guarding answers even with guard time 0 (only life guarding needs it).
    assert_eq!(b.rtr(ms(10), EC), [(EC, vec![0x7F])]);
}

#[test]
fn cct_7_3_toggle_bit_alternates() {
    let mut b = bmaxx();
    let bytes: Vec<u8> = (0..5).map(|k| b.rtr(ms(10 + k), EC)[0].1[0]).collect();
    assert_eq!(bytes, [0x7F, 0xFF, 0x7F, 0xFF, 0x7F]);
    b.nmt(0x01, ID);
    assert_eq!(b.rtr(ms(20), EC), [(EC, vec![0x85])], "Operational, toggle 1");
    b.nmt(0x02, ID);
    assert_eq!(b.rtr(ms(21), EC), [(EC, vec![0x04])], "Stopped, toggle 0");
    // Reset communication starts the toggle bit at 0 again.
    assert_eq!(b.nmt(0x82, ID), [(EC, vec![0x00])]);
    assert_eq!(b.rtr(ms(22), EC), [(EC, vec![0x7F])]);
}

#[test]
fn cct_7_4_only_the_own_guarding_id_is_answered() {
    let mut b = bmaxx();
    for cob in (0x700..=0x7FF).filter(|&c| c != EC) {
        assert_eq!(b.rtr(ms(10), cob), [], "{cob:03X}");
    }
    assert_eq!(b.rtr(ms(11), EC), [(EC, vec![0x7F])], "the first answer still has toggle 0");
}

#[test]
fn cct_7_5_write_guard_time_and_life_time_factor() {
    let mut b = bmaxx();
    guard(&mut b, 250, 4);
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![250, 0]));
    assert_eq!(b.sdo_upload(ID, 0x100D, 0), Ok(vec![4]));
    assert_eq!(b.sdo_download(ID, 0x100D, 0, &[1, 0]), Err(0x0607_0012));
}

#[test]
fn cct_7_6_life_guarding() {
    let mut b = bmaxx();
    guard(&mut b, 100, 3);
    b.nmt(0x01, ID);
    for k in 0..5u64 {
        assert_eq!(b.run_until(ms(10 + 100 * k)), []);
        assert_eq!(b.rtr(ms(10 + 100 * k), EC).len(), 1);
    }
    // The master stops: after the life time (300 ms) EMCY 0x8130 and 0x1029 (Pre-operational).
    assert_eq!(b.run_until(ms(709)), []);
    assert_eq!(b.run_until(ms(710)), [(ms(710), hb_emcy(0))]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    // Guarding resumes: the error is over.
    assert_eq!(b.rtr(ms(800), EC), [no_error(), (EC, vec![0xFF])]);
    assert_eq!(b.run_until(ms(1099)), []);
    assert_eq!(b.run_until(ms(1100)), [(ms(1100), hb_emcy(0))], "and is reported again");
}

// ---- Heartbeat ------------------------------------------------------------------

#[test]
fn cct_7_101_write_producer_heartbeat_time() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[0x64, 0x00]), Ok(()));
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0x64, 0x00]));
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[0x64]), Err(0x0607_0013));
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[0x64, 0, 0, 0]), Err(0x0607_0012));
}

#[test]
fn cct_7_102_count_heartbeats() {
    let mut b = interop();
    b.at(ms(50));
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    let beats = b.run_until(ms(1050));
    assert_eq!(beats.len(), 10);
    assert!(beats.iter().enumerate().all(|(k, (t, f))| *t == ms(150 + 100 * k as u64) && *f == (EC, vec![0x7F])));
}

#[test]
fn cct_7_103_disable_heartbeat() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(b.run_until(ms(200)).len(), 2);
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[0, 0]), Ok(()));
    assert_eq!(b.run_until(ms(2000)), []);
}

#[test]
fn cct_7_104_write_the_same_consumer_entry_twice() {
    let mut b = interop();
    let entry = 0x0005_0064u32.to_le_bytes();
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &entry), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &entry), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 2, &entry), Err(0x0604_0043), "node 5 is monitored by sub 1");
    assert_eq!(b.sdo_download(ID, 0x1016, 2, &0x0005_0000u32.to_le_bytes()), Ok(()), "time 0: entry unused");
    assert_eq!(b.sdo_upload(ID, 0x1016, 1), Ok(entry.to_vec()));
}

/// Node 5's heartbeat (Operational) every `period` ms from `from` to `to`; what the node sends, with times.
fn heartbeats_from_5(b: &mut Interop, from: u64, to: u64, period: u64) -> Vec<(u64, F)> {
    let mut out = Vec::new();
    let mut t = from;
    while t <= to {
        out.extend(b.run_until(ms(t)).into_iter().map(|(at, f)| (at.as_micros() / 1000, f)));
        out.extend(b.rx(ms(t), 0x705, &[0x05]).into_iter().map(|f| (t, f)));
        t += period;
    }
    out
}

#[test]
fn cct_7_105_consumer_time_longer_than_the_producer_time() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0005_0096u32.to_le_bytes()), Ok(()), "node 5, 150 ms");
    b.nmt(0x01, ID);
    b.at(ms(1));
    assert_eq!(heartbeats_from_5(&mut b, 10, 2000, 100), []);
    assert_eq!(b.node.state(), NmtState::Operational);
}

#[test]
fn cct_7_106_consumer_time_shorter_than_the_producer_time() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0005_0064u32.to_le_bytes()), Ok(()), "node 5, 100 ms");
    b.nmt(0x01, ID);
    b.at(ms(1));
    // Heartbeats every 150 ms: each gap is a heartbeat event (EMCY 0x8130,
    // then 0x1029: Pre-operational); each heartbeat after it ends the error.
    let out = heartbeats_from_5(&mut b, 10, 310, 150);
    assert_eq!(out, [(110, hb_emcy(5)), (160, no_error()), (260, hb_emcy(5)), (310, no_error())]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![2]));
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0x30, 0x81, 0x05, 0x00]));
}

#[test]
fn cct_7_107_consumer_after_reset_node() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0005_0064u32.to_le_bytes()), Ok(()));
    assert_eq!(heartbeats_from_5(&mut b, 10, 210, 50), []);
    // Reset node restores 0x1016 (default 0): node 5 falls silent unnoticed.
    assert_eq!(b.nmt(0x81, ID), [(EC, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1016, 1), Ok(vec![0; 4]));
    assert_eq!(b.run_until(ms(2000)), []);
    // Saved, the entry survives the reset; monitoring starts with the first heartbeat again.
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0005_0064u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1010, 2, b"save"), Ok(()));
    assert_eq!(heartbeats_from_5(&mut b, 2010, 2210, 50), []);
    assert_eq!(b.nmt(0x81, ID), [(EC, vec![0x00])]);
    assert_eq!(b.run_until(ms(3000)), [], "not armed before the first heartbeat");
    assert_eq!(heartbeats_from_5(&mut b, 3000, 3100, 50), []);
    assert_eq!(b.run_until(ms(3200)), [(ms(3200), hb_emcy(5))]);
    // The monitored node resets: its boot-up restarts monitoring, which
    // waits for its first heartbeat again.
    assert_eq!(b.rx(ms(3300), 0x705, &[0x00]), [no_error()]);
    assert_eq!(b.run_until(ms(5000)), []);
}

// ---- Heartbeat versus guarding --------------------------------------------------------

#[test]
fn cct_7_201_heartbeat_and_guarding_objects() {
    let mut b = bmaxx();
    for index in [0x100C, 0x1017] {
        assert_eq!(b.sdo_upload(ID, index, 0), Ok(vec![0, 0]));
    }
    assert_eq!(b.sdo_upload(ID, 0x100D, 0), Ok(vec![0]));
}

#[test]
fn cct_7_202_switch_off_heartbeat() {
    let mut b = bmaxx();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(b.run_until(ms(100)), [(ms(100), (EC, vec![0x7F]))]);
    assert_eq!(b.rtr(ms(110), EC), [], "heartbeat on: no guarding");
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[0, 0]), Ok(()));
    assert_eq!(b.run_until(ms(1000)), []);
    assert_eq!(b.rtr(ms(1010), EC), [(EC, vec![0x7F])], "guarding answers again");
}

#[test]
fn cct_7_203_node_guarding() {
    let mut b = bmaxx();
    guard(&mut b, 100, 3);
    assert_eq!(b.rtr(ms(10), EC), [(EC, vec![0x7F])]);
    assert_eq!(b.rtr(ms(110), EC), [(EC, vec![0xFF])]);
    assert_eq!(b.run_until(ms(409)), []);
    assert_eq!(b.run_until(ms(410)), [(ms(410), hb_emcy(0))]);
}

#[test]
fn cct_7_204_guarding_off_heartbeat_on() {
    let mut b = bmaxx();
    guard(&mut b, 0, 0);
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    let out = b.run_until(ms(1000));
    assert_eq!(out.len(), 10);
    assert!(out.iter().all(|(_, f)| *f == (EC, vec![0x7F])));
}

#[test]
fn cct_7_205_heartbeat_on_guarding_off_rtrs_unanswered() {
    let mut b = bmaxx();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    let mut beats = 0;
    for k in 0..10 {
        beats += b.run_until(ms(10 + 100 * k)).len();
        assert_eq!(b.rtr(ms(10 + 100 * k), EC), []);
    }
    assert_eq!(beats, 9, "only heartbeats, at 100..=900 ms");
}

#[test]
fn cct_7_206_heartbeat_and_guarding_on_heartbeats_only() {
    let mut b = bmaxx();
    guard(&mut b, 100, 3);
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    let out = b.run_until(ms(2000));
    assert_eq!(out.len(), 20);
    assert!(out.iter().all(|(_, f)| *f == (EC, vec![0x7F])), "no life guarding EMCY: {out:x?}");
}

#[test]
fn cct_7_207_heartbeat_and_guarding_on_rtrs_unanswered() {
    let mut b = bmaxx();
    guard(&mut b, 100, 3);
    // Guarding runs first: life guarding is armed...
    assert_eq!(b.rtr(ms(10), EC), [(EC, vec![0x7F])]);
    // ...until the heartbeat takes over, which also ends life guarding.
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    let mut out = Vec::new();
    for k in 0..10 {
        out.extend(b.run_until(ms(20 + 100 * k)));
        assert_eq!(b.rtr(ms(20 + 100 * k), EC), []);
    }
    out.extend(b.run_until(ms(2000)));
    assert_eq!(out.len(), 19, "at 110..=1910 ms");
    assert!(out.iter().all(|(_, f)| *f == (EC, vec![0x7F])), "heartbeats only: {out:x?}");
}
