//! 0x1010/0x1011 in stages (docs/firmware.md, "Store and restore in
//! stages"): the store runs a stage per `process` call and the SDO answer
//! goes out after the last; a power cut after any stage, or at any erase or
//! program within one, leaves the old set or the new one; what other frames
//! meanwhile get. On the interop fixture (node 4), on hal-host's model of
//! STM32F1 flash.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use canopen_core::services::nmt::NmtState;
use common::{Bench, F, ms, ok_write};
use embedded_can::Frame;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const RX: u16 = 0x604;
const TX: u16 = 0x584;
const SAVE: [u8; 8] = [0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e'];
const LOAD: [u8; 8] = [0x23, 0x11, 0x10, 0x01, b'l', b'o', b'a', b'd'];

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

/// A node booted from `storage` at t = 0, its boot-up taken.
fn boot(storage: MemStorage) -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, storage, ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

/// The node's storage after a power cycle now: what the cut left.
fn cycled(b: &mut Interop) -> MemStorage {
    let mut s = b.node.storage_mut().clone();
    s.cut_after(0);
    s.power_on();
    s
}

/// 0x1017 (heartbeat time) and 0x2000 (an application u8) as the node holds them.
fn parameters(b: &mut Interop) -> (Vec<u8>, Vec<u8>) {
    (b.sdo_upload(ID, 0x1017, 0).unwrap(), b.sdo_upload(ID, 0x2000, 0).unwrap())
}

fn set(b: &mut Interop, heartbeat: u16, value: u8) {
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &heartbeat.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x2000, 0, &[value]), Ok(()));
}

fn p(heartbeat: u16, value: u8) -> (Vec<u8>, Vec<u8>) {
    (heartbeat.to_le_bytes().to_vec(), vec![value])
}

/// A node with the set (300 ms, 0x33) stored and (700 ms, 0x77) in RAM.
fn old_stored_new_in_ram() -> Interop {
    let mut b = boot(MemStorage::new(4096));
    set(&mut b, 300, 0x33);
    assert_eq!(b.sdo_download(ID, 0x1010, 1, b"save"), Ok(()));
    set(&mut b, 700, 0x77);
    b
}

/// One received frame, no `process`.
fn deliver(b: &mut Interop, cob_id: u16, data: &[u8]) {
    b.node.on_frame(b.now, &CanFrame::standard(cob_id, data).expect("valid frame"));
}

/// One `process` call and what it queued.
fn stage(b: &mut Interop) -> (Option<canopen_core::time::Instant>, Vec<F>) {
    let deadline = b.node.process(b.now);
    (deadline, std::iter::from_fn(|| b.node.transmit()).map(|f| (f.cob_id().unwrap(), f.data().to_vec())).collect())
}

/// Runs the store to its end; the stages it took and what the last one sent.
fn finish(b: &mut Interop) -> (usize, Vec<F>) {
    let mut stages = 0;
    loop {
        let (deadline, sent) = stage(b);
        stages += 1;
        if !b.node.storing() {
            return (stages, sent);
        }
        assert_eq!(deadline, Some(b.now), "stage {stages} asks to be called again at once");
        assert_eq!(sent, [], "nothing before the store is done (stage {stages})");
    }
}

#[test]
fn a_save_takes_a_stage_per_process_and_is_answered_after_the_last() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    assert!(b.node.storing());
    let (stages, sent) = finish(&mut b);
    // Find the old set (the image in pieces of 256 bytes), erase, write (the same pieces and the header).
    let pieces = (interop::STORED_SIZE).div_ceil(256);
    assert!(stages > 2 * pieces, "{stages} stages for {} bytes", interop::STORED_SIZE);
    assert_eq!(sent, [(TX, ok_write(0x1010, 1))]);
    assert_eq!(parameters(&mut boot(cycled(&mut b))), p(700, 0x77), "the new set after a power cycle");
    // A restore in stages too: the defaults from the next start on.
    deliver(&mut b, RX, &LOAD);
    assert!(b.node.storing());
    assert_eq!(finish(&mut b).1, [(TX, ok_write(0x1011, 1))]);
    assert_eq!(parameters(&mut boot(cycled(&mut b))), p(0, 0x11), "the defaults after a power cycle");
}

#[test]
fn a_power_cut_after_any_stage_leaves_the_old_or_the_new_set() {
    let stages = {
        let mut b = old_stored_new_in_ram();
        deliver(&mut b, RX, &SAVE);
        finish(&mut b).0
    };
    for k in 0..stages {
        let mut b = old_stored_new_in_ram();
        deliver(&mut b, RX, &SAVE);
        for _ in 0..k {
            stage(&mut b);
        }
        assert!(b.node.storing(), "stage {k} of {stages}: not done yet");
        let mut after = boot(cycled(&mut b));
        assert_eq!(parameters(&mut after), p(300, 0x33), "a cut after stage {k} of {stages}: the old set");
        // The node after the cut stores again.
        assert_eq!(after.sdo_download(ID, 0x1010, 1, b"save"), Ok(()));
        assert_eq!(parameters(&mut boot(cycled(&mut after))), p(300, 0x33));
    }
}

#[test]
fn a_power_cut_at_any_erase_or_program_of_a_staged_save_leaves_the_old_or_the_new_set() {
    let steps = {
        let mut b = old_stored_new_in_ram();
        let before = b.node.storage_mut().steps();
        deliver(&mut b, RX, &SAVE);
        finish(&mut b);
        b.node.storage_mut().steps() - before
    };
    let (mut old, mut new) = (0, 0);
    for k in 1..=steps {
        let mut b = old_stored_new_in_ram();
        b.node.storage_mut().cut_after(k);
        deliver(&mut b, RX, &SAVE);
        let (_, sent) = finish(&mut b);
        // The stage that met the cut ends the store: "hardware error".
        assert_eq!(sent, [(TX, vec![0x80, 0x10, 0x10, 0x01, 0x00, 0x00, 0x06, 0x06])], "cut at step {k} of {steps}");
        let mut after = boot(cycled(&mut b));
        let got = parameters(&mut after);
        if got == p(300, 0x33) {
            old += 1;
        } else {
            assert_eq!(got, p(700, 0x77), "cut at step {k} of {steps}: a mix");
            new += 1;
        }
        assert!(after.node.storage_mut().violations().is_empty(), "{:?}", after.node.storage_mut().violations());
    }
    // The header goes last: only a cut in its last half-word leaves the new set.
    assert!(old >= steps - 1 && old + new == steps, "{old} old, {new} new of {steps}");
}

#[test]
fn a_staged_save_that_does_not_fit_the_storage_is_answered_cannot_store() {
    // Regions of 16 bytes: not even a set's header fits.
    let mut b = boot(MemStorage::new(16));
    deliver(&mut b, RX, &SAVE);
    assert!(b.node.storing());
    // Abort 0x08000020 (CiA 301 §7.2.4.3.17) for 0x1010 sub 1, after the stage that found it.
    assert_eq!(finish(&mut b).1, [(TX, vec![0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08])]);
}

#[test]
fn a_request_from_the_same_client_during_a_store_is_served_and_the_store_ends_unanswered() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    stage(&mut b);
    // The client gave up waiting and reads 0x1000: answered at once.
    deliver(&mut b, RX, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(b.node.transmit().map(|f| f.data()[..4].to_vec()), Some(vec![0x43, 0x00, 0x10, 0x00]));
    // The store goes on, and its answer is not sent: the client would take it for the next request's.
    assert!(b.node.storing());
    assert_eq!(finish(&mut b).1, []);
    assert_eq!(parameters(&mut boot(cycled(&mut b))), p(700, 0x77));
}

#[test]
fn a_client_abort_during_a_store_ends_the_wait_not_the_store() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    stage(&mut b);
    deliver(&mut b, RX, &[0x80, 0x10, 0x10, 0x01, 0x00, 0x00, 0x04, 0x05]);
    assert_eq!(finish(&mut b).1, [], "no answer after the client's abort");
    assert_eq!(parameters(&mut boot(cycled(&mut b))), p(700, 0x77));
}

#[test]
fn a_second_store_during_a_store_is_refused_as_the_device_state_forbids_it() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    stage(&mut b);
    // 0x1011 while the save runs: abort 0x08000022, at once; the save goes on.
    deliver(&mut b, RX, &LOAD);
    assert_eq!(b.node.transmit().map(|f| f.data().to_vec()), Some(vec![0x80, 0x11, 0x10, 0x01, 0x22, 0x00, 0x00, 0x08]));
    assert_eq!(finish(&mut b).1, []);
    assert_eq!(parameters(&mut boot(cycled(&mut b))), p(700, 0x77), "the save, not the restore");
    // Once it is done, a store is taken again.
    assert_eq!(b.sdo_download(ID, 0x1011, 1, b"load"), Ok(()));
}

#[test]
fn an_nmt_reset_during_a_store_waits_for_it_and_loads_the_new_set() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    stage(&mut b);
    deliver(&mut b, 0x000, &[0x81, ID]);
    assert_eq!(b.node.state(), NmtState::Initialising);
    let mut sent = Vec::new();
    let mut calls = 0;
    while b.node.storing() || b.node.resetting() {
        sent.extend(stage(&mut b).1);
        calls += 1;
        assert!(calls < 64);
    }
    // The reset ends every SDO transfer: no answer to the save, only the boot-up.
    assert_eq!(sent, [(0x704, vec![0x00])]);
    assert_eq!(parameters(&mut b), p(700, 0x77), "the reset loaded the set stored before it");
}

#[test]
fn other_frames_are_served_between_stages_and_a_value_written_meanwhile_is_stored_whole() {
    let mut b = old_stored_new_in_ram();
    deliver(&mut b, RX, &SAVE);
    stage(&mut b);
    // NMT start, then RPDO1 (0x2100 sub 1–4 on the interop fixture) between two stages.
    deliver(&mut b, 0x000, &[0x01, ID]);
    assert_eq!(b.node.state(), NmtState::Operational);
    stage(&mut b);
    let od = b.node.od();
    let before: Vec<Vec<u8>> = (1..=4u8).map(|sub| od.dictionary().read(od.image(), 0x2100, sub).unwrap().to_vec()).collect();
    deliver(&mut b, 0x204, &[0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08]);
    // The answer, and TPDO1 (event-driven) on the RPDO's change, with the last stage.
    assert_eq!(finish(&mut b).1, [(0x184, vec![0x77, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44]), (TX, ok_write(0x1010, 1))]);
    let rpdo = b.sdo_upload(ID, 0x2100, 1).unwrap();
    assert_eq!(rpdo, [0x01, 0x02], "RPDO1 written during the store");
    // Each value is stored as it was before the RPDO or after it, whole.
    let mut after = boot(cycled(&mut b));
    assert_eq!(parameters(&mut after), p(700, 0x77));
    for sub in 1..=4u8 {
        let v = after.sdo_upload(ID, 0x2100, sub).unwrap();
        let written = vec![2 * sub - 1, 2 * sub];
        let before = &before[usize::from(sub) - 1];
        assert!(v == written || v == *before, "0x2100 sub {sub}: {v:02x?}");
    }
}

/// NMT reset node, the `process` calls it takes to its boot-up.
fn reset_node_calls(b: &mut Interop) -> usize {
    deliver(b, 0x000, &[0x81, ID]);
    let mut calls = 0;
    while {
        let (_, sent) = stage(b);
        calls += 1;
        assert!(calls < 64);
        sent.is_empty()
    } {}
    assert!(!b.node.resetting());
    calls
}

#[test]
fn a_reset_over_a_broken_newer_set_checks_the_older_one_in_a_call_of_its_own() {
    let (steps, intact) = {
        let mut b = old_stored_new_in_ram();
        let before = b.node.storage_mut().steps();
        deliver(&mut b, RX, &SAVE);
        finish(&mut b);
        let steps = b.node.storage_mut().steps() - before;
        set(&mut b, 0, 0x11);
        let calls = reset_node_calls(&mut b);
        assert_eq!(parameters(&mut b), p(700, 0x77));
        (steps, calls)
    };
    // A cut in the header's last half-word: the newer header is there, its CRC is not.
    let mut b = old_stored_new_in_ram();
    b.node.storage_mut().cut_after(steps);
    deliver(&mut b, RX, &SAVE);
    finish(&mut b);
    let mut b = boot(cycled(&mut b));
    assert_eq!(parameters(&mut b), p(300, 0x33), "power-on loads the older set");
    set(&mut b, 0, 0x11);
    // One CRC per call: the newer set's, then the older one's.
    assert_eq!(reset_node_calls(&mut b), intact + 1);
    assert_eq!(parameters(&mut b), p(300, 0x33), "the reset loads the older set");
}
