//! Bus tests: exact timing on virtual time. At 1 Mbit/s one bit is 1 µs.
//! A standard frame with id 0x000 and no data is 53 bits (40 stuffed up to
//! the CRC, EOF ends at bit 50); with eight 0x00 bytes it is 127 bits (EOF
//! ends at bit 124). See `timing.rs` for the hand computation.

use super::*;
use embedded_can::Frame;

fn t(us: u64) -> Instant {
    Instant::from_micros(us)
}

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

/// Everything `port` received, as `(µs, id)`.
fn drain(bus: &mut Bus, port: PortId) -> Vec<(u64, u32)> {
    std::iter::from_fn(|| bus.recv(port)).map(|(at, f)| (at.as_micros(), f.raw_id())).collect()
}

#[test]
fn empty_frame_takes_53_bits_and_arrives_at_end_of_eof() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b) = (bus.attach(), bus.attach());
    assert_eq!(bus.next_event(), None);
    bus.send(a, std(0, &[])).unwrap();
    assert_eq!(bus.next_event(), Some(t(0)), "an idle bus starts the frame at once");
    bus.run_until(t(0));
    assert!(!bus.is_idle());
    assert_eq!(bus.next_event(), Some(t(50)));
    bus.run_until(t(49));
    assert_eq!(bus.recv(b), None);
    bus.run_until(t(50));
    assert_eq!(bus.recv(b), Some((t(50), std(0, &[]))));
    assert_eq!(bus.tx_complete(a), Some((t(50), std(0, &[]))));
    assert_eq!(bus.recv(a), None, "no loopback to the sender");
    assert_eq!(bus.next_event(), Some(t(53)), "intermission");
    bus.run_until(t(53));
    assert!(bus.is_idle());
    assert_eq!(bus.next_event(), None);
}

#[test]
fn eight_zero_bytes_take_127_bits_and_frames_follow_back_to_back() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b) = (bus.attach(), bus.attach());
    bus.send(a, std(0, &[0; 8])).unwrap();
    bus.send(a, std(0, &[0; 8])).unwrap();
    assert_eq!(bus.tx_pending(a), 2);
    bus.run_until(t(1_000));
    assert_eq!(drain(&mut bus, b), [(124, 0), (127 + 124, 0)]);
    assert_eq!(bus.tx_pending(a), 0);
    let s = bus.stats();
    assert_eq!((s.frames, s.bits, s.busy_ns), (2, 254, 254_000));
}

#[test]
fn timing_at_other_bit_rates_is_exact_to_the_nanosecond() {
    // 800 kbit/s: 1.25 µs per bit. EOF ends at 50 bits = 62.5 µs, stamped 63.
    let mut bus = Bus::new(BitRate::KBIT_800);
    let (a, b) = (bus.attach(), bus.attach());
    bus.send(a, std(0, &[])).unwrap();
    bus.send(a, std(0, &[])).unwrap();
    bus.run_until(t(0));
    assert_eq!(bus.next_event(), Some(t(63)));
    bus.run_until(t(62));
    assert_eq!(bus.recv(b), None);
    bus.run_until(t(63));
    assert_eq!(drain(&mut bus, b), [(63, 0)]);
    // The second frame starts at 53 bits = 66.25 µs; its EOF ends at
    // 103 bits = 128.75 µs.
    bus.run_until(t(1_000));
    assert_eq!(drain(&mut bus, b), [(129, 0)]);
    // 125 kbit/s: 8 µs per bit.
    let mut slow = Bus::new(BitRate::KBIT_125);
    let (a, b) = (slow.attach(), slow.attach());
    slow.send(a, std(0, &[])).unwrap();
    slow.run_until(t(10_000));
    assert_eq!(drain(&mut slow, b), [(400, 0)]);
    assert_eq!(slow.stats().busy_ns, 424_000);
}

#[test]
fn arbitration_picks_the_lowest_priority_value() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b, c, d) = (bus.attach(), bus.attach(), bus.attach(), bus.attach());
    bus.send(a, std(0x300, &[])).unwrap();
    bus.send(b, std(0x100, &[])).unwrap();
    bus.send(c, CanFrame::remote(0x100, 0).unwrap()).unwrap();
    bus.send(d, CanFrame::extended(0x100 << 18, &[]).unwrap()).unwrap();
    bus.run_until(t(10_000));
    let order: Vec<(u32, bool, bool)> =
        std::iter::from_fn(|| bus.recv(a)).map(|(_, f)| (f.raw_id(), f.is_remote_frame(), f.is_extended())).collect();
    assert_eq!(order, [(0x100, false, false), (0x100, true, false), (0x100 << 18, false, true)]);
    assert_eq!(drain(&mut bus, b).last().map(|x| x.1), Some(0x300), "the highest id goes last");
}

#[test]
fn equal_priorities_from_two_ports_go_by_port_index() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b, sniffer) = (bus.attach(), bus.attach(), bus.attach());
    bus.send(b, std(0x80, &[2])).unwrap();
    bus.send(a, std(0x80, &[1])).unwrap();
    bus.run_until(t(1_000));
    let data: Vec<u8> = std::iter::from_fn(|| bus.recv(sniffer)).map(|(_, f)| f.data()[0]).collect();
    assert_eq!(data, [1, 2]);
}

#[test]
fn each_port_keeps_fifo_order() {
    // Port a queues 0x300 then 0x100: 0x100 cannot overtake 0x300 (one
    // pending mailbox per controller), even though it would win arbitration.
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b, sniffer) = (bus.attach(), bus.attach(), bus.attach());
    bus.send(a, std(0x300, &[])).unwrap();
    bus.send(a, std(0x100, &[])).unwrap();
    bus.send(b, std(0x200, &[])).unwrap();
    bus.run_until(t(10_000));
    let ids: Vec<u32> = drain(&mut bus, sniffer).into_iter().map(|x| x.1).collect();
    assert_eq!(ids, [0x200, 0x300, 0x100]);
    let done: Vec<u32> = std::iter::from_fn(|| bus.tx_complete(a)).map(|(_, f)| f.raw_id()).collect();
    assert_eq!(done, [0x300, 0x100]);
}

#[test]
fn a_frame_queued_while_the_bus_is_busy_waits_for_intermission() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, b) = (bus.attach(), bus.attach());
    bus.send(a, std(0, &[])).unwrap();
    bus.run_until(t(10));
    bus.send(b, std(0x001, &[])).unwrap();
    assert_eq!(bus.next_event(), Some(t(50)));
    bus.run_until(t(52));
    assert_eq!(bus.next_event(), Some(t(53)), "starts after the 3-bit intermission");
    bus.run_until(t(1_000));
    assert_eq!(drain(&mut bus, a).len(), 1);
}

#[test]
fn bus_load_over_an_interval() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let (a, _b) = (bus.attach(), bus.attach());
    let start = bus.stats();
    // One 53-bit frame every 100 µs: 53 % load.
    for i in 0..10 {
        bus.run_until(t(i * 100));
        bus.send(a, std(0, &[])).unwrap();
    }
    bus.run_until(t(1_000));
    let end = bus.stats();
    assert_eq!(end.busy_ns, 530_000);
    assert!((end.load_since(&start) - 0.53).abs() < 1e-12);
    // Mid-frame snapshots count the part already on the wire.
    bus.send(a, std(0, &[])).unwrap();
    bus.run_until(t(1_020));
    assert_eq!(bus.stats().busy_ns, 550_000);
    let idle = bus.stats();
    bus.run_until(t(1_053));
    bus.run_until(t(2_053));
    assert!((bus.stats().load_since(&idle) - 33.0 / 1_033.0).abs() < 1e-12);
    assert_eq!(idle.load_since(&idle), 0.0);
    assert!((bus.stats().load() - 583.0 / 2_053.0).abs() < 1e-12);
}

#[test]
fn a_port_at_another_bit_rate_sees_nothing() {
    let mut bus = Bus::new(BitRate::KBIT_250);
    let (master, node, other) = (bus.attach(), bus.attach(), bus.attach_with_bitrate(BitRate::KBIT_500));
    assert_eq!(bus.bitrate(other), Some(BitRate::KBIT_500));
    bus.send(master, std(0x7E5, &[0x04, 0x01])).unwrap();
    bus.run_until(t(10_000));
    assert_eq!(drain(&mut bus, node).len(), 1);
    assert_eq!(bus.recv(other), None);
    assert_eq!(bus.stats().bitrate_errors, 1);
    assert_eq!(bus.port_stats(other).map(|s| s.bitrate_errors), Some(1));
    // The node switches rate (LSS activate bit timing): now it is the one
    // that sees nothing from the master, and the master nothing from it.
    bus.set_bitrate(node, BitRate::KBIT_500).unwrap();
    bus.send(master, std(0x7E5, &[0x04, 0x00])).unwrap();
    bus.send(node, std(0x7E4, &[0x15])).unwrap();
    bus.run_until(t(20_000));
    assert_eq!(bus.recv(node), None);
    assert_eq!(bus.recv(master), None);
    // 0x7E4 with one byte 0x15 has 3 stuff bits: EOF ends at bit 55 = 110 µs.
    assert_eq!(drain(&mut bus, other), [(10_110, 0x7E4)]);
    // Master's first frame at `other`, then both frames of this round at
    // the port with the other rate (the master, then the node and `other`).
    assert_eq!(bus.stats().bitrate_errors, 4);
}

#[test]
fn unknown_ports_and_time_going_back_are_harmless() {
    let mut bus = Bus::new(BitRate::MBIT_1);
    let a = bus.attach();
    let mut other = Bus::new(BitRate::MBIT_1);
    other.attach();
    let stranger = other.attach();
    assert_eq!(bus.send(stranger, std(1, &[])), Err(BusError::UnknownPort));
    assert_eq!(bus.set_bitrate(stranger, BitRate::KBIT_10), Err(BusError::UnknownPort));
    assert_eq!(bus.recv(stranger), None);
    assert_eq!(bus.tx_complete(stranger), None);
    assert_eq!(bus.port_stats(stranger), None);
    assert_eq!(bus.error_state(stranger), None);
    assert_eq!(bus.tx_pending(stranger), 0);
    assert_eq!(stranger.index(), 1);
    assert_eq!(BusError::UnknownPort.to_string(), "unknown port");
    bus.run_until(t(100));
    bus.run_until(t(50));
    assert_eq!(bus.now(), t(100));
    bus.send(a, std(1, &[])).unwrap();
    bus.run_until(Instant::from_micros(u64::MAX));
    assert_eq!(bus.port_stats(a).map(|s| s.tx_frames), Some(1));
}
