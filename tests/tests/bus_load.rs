//! Bus load and latency of a scenario on the virtual bus at 1 Mbit/s:
//! eight interop nodes, each with a heartbeat every 100 ms and TPDO1 on an
//! event timer of 10 ms (CiA 301 v4.2 §7.2.2.2, §7.5.2.37 sub 5). One NMT
//! command starts them all, so their event timers run in step and every
//! 10 ms eight TPDOs fall due at the same instant: arbitration sends them by
//! identifier, and each waits for those before it.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use common::net::{Net, us};
use hal_host::bus::{BitRate, frame_bits};
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::storage::MemStorage;

type Interop = Node<NoApplication, MemStorage>;

#[test]
fn eight_nodes_with_10_ms_tpdos_load_the_bus_to_the_bit() {
    let mut net = Net::new("eight_nodes_with_10_ms_tpdos_load_the_bus_to_the_bit", BitRate::MBIT_1);
    let m = net.add_master();
    for id in 1..=8u8 {
        net.add_node(Interop::new(Ram::new(id), NoApplication, MemStorage::new(4096), id, us(0)));
    }
    net.run_until(us(1000));
    for id in 1..=8u8 {
        net.configure(m, id, 0x1800, 5, &10u16.to_le_bytes());
        net.configure(m, id, 0x1017, 0, &100u16.to_le_bytes());
    }
    net.run_until(us(10_000));
    let before = net.bus().stats();
    net.send(m, 0x000, &[0x01, 0x00]);
    net.run_until(us(1_010_000));
    let after = net.bus().stats();

    // The load is the busy time over the span; the bus was idle at both
    // ends, so the busy time is the sum of the frames' lengths (stuff bits
    // and intermission included, 1 µs per bit).
    let frames = net.frames_since(us(10_000));
    let wire_us: u64 = frames.iter().map(|f| u64::from(frame_bits(&CanFrame::standard(f.2, &f.3).unwrap()).total())).sum();
    assert_eq!(after.busy_ns - before.busy_ns, wire_us * 1000);
    assert_eq!(after.frames - before.frames, frames.len() as u64);
    // NMT, 8 × 100 TPDOs (one on entering Operational, then every 10 ms up
    // to 1 000 065 µs), 8 × 10 heartbeats: 881 frames, 8.8 % of the second.
    assert_eq!(frames.len(), 1 + 800 + 80);
    assert_eq!(wire_us, 88_128);
    assert_eq!(after.load_since(&before), 0.088_128);

    // Latency: the event timers restart at the transmission on entering
    // Operational (10 065 µs, the NMT command's EOF), so the TPDOs fall due
    // at 20 065 µs + k × 10 ms. Node n's TPDO ends its EOF after the n - 1
    // before it and its own frame: 101 µs for 0x181, 831 µs for 0x188.
    let tpdo = |id: u16| CanFrame::standard(0x180 + id, &[0x11, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44]).unwrap();
    let expected: Vec<u64> = (1..=8u16)
        .map(|n| (1..n).map(|k| u64::from(frame_bits(&tpdo(k)).total())).sum::<u64>() + u64::from(frame_bits(&tpdo(n)).to_eof()))
        .collect();
    assert_eq!(expected, [101, 206, 311, 415, 518, 622, 726, 831]);
    for k in 0..99u64 {
        let due = 20_065 + k * 10_000;
        let latencies: Vec<u64> = frames
            .iter()
            .filter(|f| (0x181..=0x188).contains(&f.2) && f.0.as_micros() > due && f.0.as_micros() < due + 10_000)
            .map(|f| f.0.as_micros() - due)
            .collect();
        assert_eq!(latencies, expected, "TPDOs due at {due} µs");
    }
    // No heartbeat ever met a burst: node n's falls due 100 ms after it got
    // its 0x1017 download, between 1.4 and 4.8 ms into a 10 ms cycle.
    let beats: Vec<u64> = frames.iter().filter(|f| (0x701..=0x708).contains(&f.2)).map(|f| f.0.as_micros() % 10_000).collect();
    assert!(beats.iter().all(|&phase| (1_000..5_000).contains(&phase)), "{beats:?}");
}
