//! Fault injection tests, at 1 Mbit/s (1 bit = 1 µs) with the 53-bit frame
//! id 0x000 without data: 40 stuffed bits up to the CRC, EOF ends at bit 50.
//! A corrupted attempt takes 40 + 3 bits to the error flag, then 17 bits of
//! error frame and intermission: 60 bits.

use crate::bus::{BitRate, Bus, ErrorState, PortId};
use crate::fault::{FaultAction, Trigger};
use canopen_core::frame::CanFrame;
use canopen_core::time::{Duration, Instant};

fn t(us: u64) -> Instant {
    Instant::from_micros(us)
}

fn zero() -> CanFrame {
    CanFrame::standard(0, &[]).unwrap()
}

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn drain(bus: &mut Bus, port: PortId) -> Vec<(u64, u32)> {
    std::iter::from_fn(|| bus.recv(port)).map(|(at, f)| (at.as_micros(), f.raw_id())).collect()
}

fn two_ports() -> (Bus, PortId, PortId) {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b) = (bus.attach(), bus.attach());
    (bus, a, b)
}

#[test]
fn drop_the_nth_frame() {
    let (mut bus, a, b) = two_ports();
    bus.drop_nth(2);
    for id in 1..=3 {
        bus.send(a, std(id, &[])).unwrap();
    }
    bus.run_until(t(10_000));
    assert_eq!(drain(&mut bus, b).iter().map(|x| x.1).collect::<Vec<_>>(), [1, 3]);
    assert_eq!(std::iter::from_fn(|| bus.tx_complete(a)).count(), 3, "the sender thinks all went out");
    let s = bus.stats();
    assert_eq!((s.frames, s.dropped, s.error_frames), (3, 1, 0));
    // The rule was spent.
    bus.send(a, std(4, &[])).unwrap();
    bus.run_until(t(20_000));
    assert_eq!(drain(&mut bus, b).len(), 1);
}

#[test]
fn drop_frames_matching_a_predicate_id_or_sender() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b, c) = (bus.attach(), bus.attach(), bus.attach());
    let rule = bus.drop_where(|_, f| f.raw_id() == 0x581);
    bus.add_fault(Trigger::Sender(b), FaultAction::Drop, Some(1));
    bus.add_fault(Trigger::RawId(0x182), FaultAction::Drop, Some(2));
    bus.send(a, std(0x581, &[1])).unwrap();
    bus.send(b, std(0x701, &[5])).unwrap();
    bus.send(b, std(0x701, &[5])).unwrap();
    for _ in 0..3 {
        bus.send(a, std(0x182, &[])).unwrap();
    }
    bus.run_until(t(10_000));
    let ids: Vec<u32> = drain(&mut bus, c).into_iter().map(|x| x.1).collect();
    assert_eq!(ids, [0x182, 0x701], "0x581 always, one 0x701 and two 0x182 dropped");
    assert!(bus.remove_fault(rule));
    assert!(!bus.remove_fault(rule));
    bus.send(a, std(0x581, &[1])).unwrap();
    bus.run_until(t(20_000));
    assert_eq!(drain(&mut bus, c), [(drain_time(&std(0x581, &[1]), 10_000), 0x581)]);
}

/// When a frame sent on an idle 1 Mbit/s bus at `start` µs ends its EOF.
fn drain_time(f: &CanFrame, start: u64) -> u64 {
    start + u64::from(crate::bus::frame_bits(f).to_eof())
}

#[test]
fn a_corrupted_frame_is_retransmitted_after_the_error_frame() {
    let (mut bus, a, b) = two_ports();
    bus.corrupt_nth(1);
    bus.send(a, zero()).unwrap();
    bus.run_until(t(0));
    assert_eq!(bus.next_event(), Some(t(43)), "error flag after the ACK delimiter");
    bus.run_until(t(43));
    assert_eq!(bus.error_counters(a), Some((8, 0)));
    assert_eq!(bus.error_counters(b), Some((0, 1)));
    assert_eq!(bus.next_event(), Some(t(60)), "6 + 8 error bits, 3 intermission");
    bus.run_until(t(1_000));
    assert_eq!(drain(&mut bus, b), [(60 + 50, 0)], "received once, from the retransmission");
    assert_eq!(std::iter::from_fn(|| bus.tx_complete(a)).count(), 1);
    assert_eq!(bus.error_counters(a), Some((7, 0)));
    assert_eq!(bus.port_stats(a).map(|s| s.tx_errors), Some(1));
    assert_eq!(bus.port_stats(b).map(|s| (s.error_frames, s.rx_frames)), Some((1, 1)), "receivers see the error frame");
    let s = bus.stats();
    assert_eq!((s.frames, s.error_frames, s.bits, s.busy_ns), (1, 1, 43 + 17 + 53, 113_000));
}

#[test]
fn a_retransmission_arbitrates_again() {
    let (mut bus, a, b) = two_ports();
    let c = bus.attach();
    bus.corrupt_nth(1);
    bus.send(a, std(0x300, &[])).unwrap();
    bus.run_until(t(10));
    bus.send(b, std(0x100, &[])).unwrap();
    bus.run_until(t(1_000));
    let ids: Vec<u32> = drain(&mut bus, c).into_iter().map(|x| x.1).collect();
    assert_eq!(ids, [0x100, 0x300]);
}

#[test]
fn persistent_corruption_drives_the_sender_bus_off_and_it_recovers() {
    let (mut bus, a, b) = two_ports();
    let rule = bus.corrupt_where(|port, _| port.index() == 0);
    bus.send(a, zero()).unwrap();
    // 16 errors: TEC 128, error passive.
    bus.run_until(t(15 * 60 + 43));
    assert_eq!(bus.error_counters(a), Some((128, 0)));
    assert_eq!(bus.error_counters(b), Some((0, 16)));
    assert_eq!(bus.error_state(a), Some(ErrorState::Passive));
    assert_eq!(bus.error_state(b), Some(ErrorState::Active));
    // The 32nd error (at 31 × 60 + 43) takes TEC above 255.
    bus.run_until(t(31 * 60 + 42));
    assert_eq!(bus.error_state(a), Some(ErrorState::Passive));
    bus.run_until(t(31 * 60 + 43));
    assert_eq!(bus.error_state(a), Some(ErrorState::BusOff));
    assert!(bus.is_bus_off(a));
    assert_eq!(bus.port_stats(a).map(|s| (s.tx_errors, s.bus_off_count)), Some((32, 1)));
    assert!(bus.remove_fault(rule));
    // Recessive from the end of the error flag (1903 + 6) on: 128 × 11 bits.
    let recovery = 31 * 60 + 43 + 6 + 128 * 11;
    assert_eq!(bus.next_event(), Some(t(32 * 60)), "the error frame ends first");
    bus.run_until(t(32 * 60));
    assert_eq!(bus.next_event(), Some(t(recovery)));
    bus.run_until(t(recovery - 1));
    assert!(bus.is_bus_off(a));
    bus.run_until(t(recovery));
    assert_eq!(bus.error_state(a), Some(ErrorState::Active));
    assert_eq!(bus.error_counters(a), Some((0, 0)));
    bus.run_until(t(10_000));
    assert_eq!(drain(&mut bus, b), [(recovery + 50, 0)], "the queued frame goes out after recovery");
    assert_eq!(bus.stats().error_frames, 32);
}

#[test]
fn a_delayed_port_enters_arbitration_late_but_in_order() {
    let (mut bus, a, b) = two_ports();
    let c = bus.attach();
    bus.set_tx_delay(a, Duration::from_micros(100)).unwrap();
    bus.send(a, std(0x001, &[])).unwrap();
    bus.send(a, std(0x000, &[])).unwrap();
    bus.send(b, std(0x700, &[])).unwrap();
    bus.run_until(t(10_000));
    let got = drain(&mut bus, c);
    assert_eq!(got.iter().map(|x| x.1).collect::<Vec<_>>(), [0x700, 0x001, 0x000]);
    assert_eq!(got.get(1).map(|x| x.0), Some(drain_time(&std(1, &[]), 100)));
    assert_eq!(drain(&mut bus, b).len(), 2);
    bus.set_tx_delay(a, Duration::ZERO).unwrap();
    bus.send(a, zero()).unwrap();
    bus.run_until(t(20_000));
    assert_eq!(drain(&mut bus, b), [(10_050, 0)]);
}

#[test]
fn an_injected_error_frame_on_an_idle_bus_occupies_it() {
    let (mut bus, a, b) = two_ports();
    bus.inject_error_frame(t(10));
    assert_eq!(bus.next_event(), Some(t(10)));
    bus.run_until(t(20));
    bus.send(a, zero()).unwrap();
    assert_eq!(bus.next_event(), Some(t(27)), "error frame 10..27");
    bus.run_until(t(1_000));
    assert_eq!(drain(&mut bus, b), [(27 + 50, 0)]);
    assert_eq!(bus.error_counters(a), Some((0, 0)));
    let s = bus.stats();
    assert_eq!((s.error_frames, s.bits, s.busy_ns), (1, 17 + 53, 70_000));
}

#[test]
fn an_injected_error_frame_destroys_the_frame_on_the_wire() {
    let (mut bus, a, b) = two_ports();
    bus.send(a, zero()).unwrap();
    bus.inject_error_frame(t(20));
    bus.run_until(t(0));
    assert_eq!(bus.next_event(), Some(t(20)));
    bus.run_until(t(1_000));
    // Destroyed at bit 20, error frame to 37, retransmission 37..90.
    assert_eq!(drain(&mut bus, b), [(37 + 50, 0)]);
    assert_eq!(bus.error_counters(a), Some((7, 0)));
    assert_eq!(bus.stats().bits, 20 + 17 + 53);
}

#[test]
fn an_error_frame_due_during_intermission_waits_for_idle() {
    let (mut bus, a, b) = two_ports();
    bus.send(a, zero()).unwrap();
    bus.send(a, zero()).unwrap();
    bus.inject_error_frame(t(51));
    bus.run_until(t(1_000));
    // Frame 0..53; error frame 53..70 (the pending frame waits); frame 70..123.
    assert_eq!(drain(&mut bus, b), [(50, 0), (120, 0)]);
    assert_eq!(bus.stats().error_frames, 1);
}

#[test]
fn a_bus_off_port_neither_sends_nor_receives_until_recovered() {
    let (mut bus, a, b) = two_ports();
    bus.set_bus_off(b).unwrap();
    bus.send(b, std(0x001, &[])).unwrap();
    bus.send(a, zero()).unwrap();
    bus.run_until(t(100));
    assert_eq!(bus.recv(b), None);
    assert_eq!(bus.recv(a), None);
    assert_eq!(bus.tx_pending(b), 1);
    // a's second frame at 100 ends the recessive run that began at its
    // first frame's ACK delimiter (bit 42): 58 bits = 5 sequences of 11.
    bus.send(a, zero()).unwrap();
    bus.run_until(t(200));
    assert!(bus.is_bus_off(b));
    // Then 123 more sequences from the second ACK delimiter (100 + 42).
    let recovery = 142 + 123 * 11;
    assert_eq!(bus.next_event(), Some(t(recovery)));
    bus.run_until(t(recovery - 1));
    assert!(bus.is_bus_off(b));
    bus.run_until(t(recovery + 100));
    assert!(!bus.is_bus_off(b));
    assert_eq!(drain(&mut bus, a), [(drain_time(&std(1, &[]), recovery), 1)]);
    assert_eq!(bus.port_stats(b).map(|s| s.rx_frames), Some(0));
}

#[test]
fn bus_off_recovery_counts_bits_at_the_ports_own_rate() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let slow = bus.attach_with_bitrate(BitRate::KBIT_125);
    bus.run_until(t(1_000));
    bus.set_bus_off(slow).unwrap();
    assert_eq!(bus.next_event(), Some(t(1_000 + 128 * 11 * 8)));
    assert!(bus.set_bus_off(slow).is_ok(), "again: counting restarts");
    let mut other = Bus::new(BitRate::MBIT_1);
    other.attach();
    let stranger = other.attach();
    assert!(bus.set_bus_off(stranger).is_err());
    assert!(bus.set_tx_delay(stranger, Duration::ZERO).is_err());
    assert!(!bus.is_bus_off(stranger));
}

#[test]
fn rules_with_limits_and_clearing() {
    let (mut bus, a, b) = two_ports();
    bus.add_fault(Trigger::Nth(0), FaultAction::Drop, None);
    let none = bus.add_fault(Trigger::RawId(0), FaultAction::Drop, Some(0));
    assert!(!bus.remove_fault(none), "a rule for zero frames is never stored");
    bus.add_fault(Trigger::RawId(0), FaultAction::Corrupt, Some(2));
    bus.send(a, zero()).unwrap();
    bus.run_until(t(1_000));
    // Two corrupted attempts of 60 bits, then the frame.
    assert_eq!(drain(&mut bus, b), [(120 + 50, 0)]);
    bus.corrupt_where(|_, _| true);
    bus.inject_error_frame(t(5_000));
    bus.clear_faults();
    bus.send(a, zero()).unwrap();
    bus.run_until(t(10_000));
    assert_eq!(drain(&mut bus, b), [(1_050, 0)]);
    assert_eq!(bus.stats().error_frames, 2);
    assert_eq!(format!("{:?}", Trigger::RawId(0x10)), "RawId(0x10)");
}
