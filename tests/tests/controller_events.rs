//! CAN controller events → EMCY (CiA 301 v4.2 table 21), as the boards
//! report them through `Node::controller_event`: exact frames at exact
//! times on the interop fixture (node 4, EMCY on 0x084, no heartbeat).
//!
//! Received frames lost (0x8110) and a bus-off recovery (0x8140) stay
//! active until they have not recurred for 1 s; error passive (0x8120)
//! lasts until the controller is error active again. The error register
//! (byte 2) has the generic and the communication bit while any is active;
//! clearing the last sends "error reset" (0x0000).

mod common;

use canopen_core::node::{ControllerEvent, NoApplication, TRANSIENT_ERROR_HOLD};
use canopen_core::time::Instant;
use common::{Bench, F, ms};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const EMCY: u16 = 0x084;
const ERROR_RESET: [u8; 8] = [0; 8];

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

/// Reports `event` at `t`, then runs the node there: what it sends.
fn report(b: &mut Interop, t: Instant, event: ControllerEvent) -> Vec<F> {
    b.node.controller_event(event, t);
    b.at(t)
}

fn emcy(data: [u8; 8]) -> Vec<(Instant, F)> {
    vec![(Instant::ZERO, (EMCY, data.to_vec()))]
}

/// `frames` with their times replaced by `t` (for comparing with [`emcy`]).
fn at(t: Instant, frames: Vec<(Instant, F)>) -> Vec<(Instant, F)> {
    frames
        .into_iter()
        .map(|(when, f)| {
            assert_eq!(when, t, "{f:x?} at {when:?}, expected {t:?}");
            (Instant::ZERO, f)
        })
        .collect()
}

#[test]
fn lost_frames_raise_0x8110_with_the_count_and_clear_after_a_quiet_second() {
    let mut b = interop();
    assert_eq!(TRANSIENT_ERROR_HOLD.as_micros(), 1_000_000);
    // Bytes 3–6: frames lost so far (3).
    assert_eq!(report(&mut b, ms(10), ControllerEvent::RxOverrun { lost: 3 }), [(EMCY, vec![0x10, 0x81, 0x11, 3, 0, 0, 0, 0])]);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x11]), "generic + communication");
    // Active already: nothing new is sent, but the error is held 1 s from this loss.
    assert_eq!(report(&mut b, ms(500), ControllerEvent::RxOverrun { lost: 2 }), []);
    assert_eq!(b.node.process(ms(501)), Some(ms(1500)), "the node wakes to clear it");
    assert_eq!(at(ms(1500), b.run_until(ms(2000))), emcy(ERROR_RESET));
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x00]));
    // The count goes on: 3 + 2 + 1.
    assert_eq!(report(&mut b, ms(2100), ControllerEvent::RxOverrun { lost: 1 }), [(EMCY, vec![0x10, 0x81, 0x11, 6, 0, 0, 0, 0])]);
    assert_eq!(at(ms(3100), b.run_until(ms(4000))), emcy(ERROR_RESET));
}

#[test]
fn no_frame_lost_is_no_event() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::RxOverrun { lost: 0 }), []);
    assert_eq!(b.node.process(ms(11)), None, "nothing to clear");
}

#[test]
fn error_passive_raises_0x8120_until_error_active() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::ErrorPassive), [(EMCY, vec![0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(report(&mut b, ms(20), ControllerEvent::ErrorPassive), [], "still the same error");
    assert_eq!(b.run_until(ms(5000)), [], "a state, not cleared by time");
    assert_eq!(report(&mut b, ms(5000), ControllerEvent::ErrorActive), [(EMCY, ERROR_RESET.to_vec())]);
    assert_eq!(report(&mut b, ms(5010), ControllerEvent::ErrorActive), [], "error active already");
    // 0x1003: the newest entry first.
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![0x01]));
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0x20, 0x81, 0x00, 0x00]));
}

#[test]
fn bus_off_recovery_raises_0x8140_and_clears_after_a_second() {
    let mut b = interop();
    // Bytes 3–6: recoveries so far.
    assert_eq!(report(&mut b, ms(10), ControllerEvent::BusOffRecovered), [(EMCY, vec![0x40, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    assert_eq!(at(ms(1010), b.run_until(ms(1500))), emcy(ERROR_RESET));
    assert_eq!(report(&mut b, ms(1600), ControllerEvent::BusOffRecovered), [(EMCY, vec![0x40, 0x81, 0x11, 2, 0, 0, 0, 0])]);
}

#[test]
fn error_reset_waits_for_the_last_active_error() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::ErrorPassive), [(EMCY, vec![0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(report(&mut b, ms(20), ControllerEvent::RxOverrun { lost: 1 }), [(EMCY, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    // The loss clears at 1.02 s, but error passive is still active: no "error reset".
    assert_eq!(b.run_until(ms(2000)), []);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x11]));
    assert_eq!(report(&mut b, ms(2000), ControllerEvent::ErrorActive), [(EMCY, ERROR_RESET.to_vec())]);
}

#[test]
fn in_stopped_the_emcy_waits_for_pre_operational() {
    let mut b = interop();
    assert_eq!(b.nmt(0x02, ID), [], "stopped");
    assert_eq!(report(&mut b, ms(10), ControllerEvent::RxOverrun { lost: 4 }), [], "no EMCY in Stopped");
    assert_eq!(b.rx(ms(20), 0x000, &[0x80, ID]), [(EMCY, vec![0x10, 0x81, 0x11, 4, 0, 0, 0, 0])], "pre-operational");
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0x10, 0x81, 0x04, 0x00]), "code and the low half of the count");
    assert_eq!(at(ms(1010), b.run_until(ms(2000))), emcy(ERROR_RESET), "held from the loss, not from the message");
}

#[test]
fn reset_communication_raises_error_passive_again() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::ErrorPassive), [(EMCY, vec![0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(report(&mut b, ms(20), ControllerEvent::RxOverrun { lost: 1 }), [(EMCY, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    // Reset communication forgets every error; the controller is still error
    // passive, so that one is raised again after the boot-up; the loss is over.
    assert_eq!(b.rx(ms(30), 0x000, &[0x82, ID]), [(0x704, vec![0x00])], "the boot-up first");
    assert_eq!(b.at(ms(30)), [(EMCY, vec![0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(b.run_until(ms(3000)), [], "nothing left to clear by time");
    assert_eq!(report(&mut b, ms(3000), ControllerEvent::ErrorActive), [(EMCY, ERROR_RESET.to_vec())]);
}

#[test]
fn a_loss_reported_while_reset_communication_runs_clears_a_second_later() {
    let mut b = interop();
    b.node.on_frame(ms(30), &canopen_core::frame::CanFrame::standard(0x000, &[0x82, ID]).unwrap());
    // A reset goes on a stage per call: the loss comes after the stage that
    // reset EMCY (and with it the held errors), while the reset still runs.
    let mut stages = 0;
    while stages < 3 && b.node.resetting() {
        b.node.process(ms(30));
        stages += 1;
    }
    assert!(b.node.resetting(), "the report comes while the reset runs");
    b.node.controller_event(ControllerEvent::RxOverrun { lost: 1 }, ms(30));
    assert_eq!(b.at(ms(30)), [(0x704, vec![0x00])], "the boot-up first");
    assert_eq!(b.at(ms(31)), [(EMCY, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    // Held from the loss, as any other: it clears 1 s later, not never.
    assert_eq!(at(ms(1030), b.run_until(ms(3000))), emcy(ERROR_RESET));
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x00]));
}

#[test]
fn a_loss_and_a_recovery_each_clear_a_quiet_second_after_themselves() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::RxOverrun { lost: 1 }), [(EMCY, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    assert_eq!(report(&mut b, ms(900), ControllerEvent::BusOffRecovered), [(EMCY, vec![0x40, 0x81, 0x11, 1, 0, 0, 0, 0])]);
    // 0x8110 clears at 1.01 s, silently: 0x8140 is still active (register still 0x11).
    assert_eq!(b.run_until(ms(1899)), []);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x11]));
    assert_eq!(at(ms(1900), b.run_until(ms(3000))), emcy(ERROR_RESET));
}

/// Queues `n` node-guarding answers without sending them (remote frames on 0x704).
fn fill_queue(b: &mut Interop, t: Instant, n: usize) {
    for _ in 0..n {
        b.node.on_frame(t, &canopen_core::frame::CanFrame::remote(0x704, 1).unwrap());
    }
}

const TX_OVERFLOW: [u8; 8] = [0x10, 0x81, 0x11, 1, 0, 0, 0, 1];

#[test]
fn a_transmit_queue_overflow_is_one_0x8110_then_error_reset_once_drained() {
    let mut b = interop();
    // 33 answers for a 32-frame queue: one refused.
    fill_queue(&mut b, ms(10), 33);
    assert_eq!(b.node.tx_overflows(), 1);
    let out = b.at(ms(10));
    assert_eq!(out.len(), 32, "the queue's 32 answers; the EMCY waits for room");
    assert!(out.iter().all(|f| f.0 == 0x704));
    // Bytes 3–6: frames refused so far; byte 7 = 1: the transmit queue. The
    // queue drained, so the error clears in the same call.
    assert_eq!(b.at(ms(11)), [(EMCY, TX_OVERFLOW.to_vec()), (EMCY, ERROR_RESET.to_vec())]);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x00]));
    assert_eq!(b.run_until(ms(3000)), [], "nothing more");
}

#[test]
fn a_transmit_queue_overflow_is_raised_once_while_frames_keep_being_refused() {
    let mut b = interop();
    fill_queue(&mut b, ms(10), 33);
    // Not drained: the node sends nothing (the board's mailboxes are full).
    b.node.process(ms(10));
    fill_queue(&mut b, ms(11), 5);
    b.node.process(ms(11));
    assert_eq!(b.node.tx_overflows(), 6);
    assert!(b.node.comm().emcy.tx_overflow_active());
    assert_eq!(b.node.comm().emcy.register(), 0x11);
    let out = b.at(ms(12));
    assert!(out.len() == 32 && out.iter().all(|f| f.0 == 0x704), "the queued answers; the EMCY waits for room");
    // One 0x8110 for the whole overflow (raised at the first refusal), then its end.
    assert_eq!(b.at(ms(13)), [(EMCY, TX_OVERFLOW.to_vec()), (EMCY, ERROR_RESET.to_vec())]);
}

#[test]
fn a_transmit_queue_overflow_and_lost_received_frames_clear_apart() {
    let mut b = interop();
    assert_eq!(report(&mut b, ms(10), ControllerEvent::RxOverrun { lost: 3 }), [(EMCY, vec![0x10, 0x81, 0x11, 3, 0, 0, 0, 0])]);
    fill_queue(&mut b, ms(20), 33);
    assert_eq!(b.at(ms(20)).len(), 32);
    // Its own 0x8110, though the receive overrun's is active; drained, it
    // clears without "error reset": the receive overrun still is.
    assert_eq!(b.at(ms(21)), [(EMCY, TX_OVERFLOW.to_vec())]);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x11]));
    // The receive overrun clears 1 s after its loss: now "error reset".
    assert_eq!(at(ms(1010), b.run_until(ms(3000))), emcy(ERROR_RESET));
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x00]));
}

#[test]
fn a_broken_nmt_or_heartbeat_frame_is_counted_and_sends_nothing_with_cia301_codes() {
    // `CanEmcyCodes::CIA301` has no protocol code (the EC5000's 0xFFD3 is its manual's).
    let mut b = interop();
    assert_eq!(b.rx(ms(10), 0x000, &[0x01]), []);
    assert_eq!(b.rx(ms(20), 0x705, &[0x05, 0x00]), []);
    assert_eq!(b.node.counters().malformed, 2);
    assert_eq!(b.node.process(ms(21)), None, "nothing to clear");
}
