//! LSS (CiA 305) on real device dictionaries: the Sendix manual's sequence
//! (seed 002 §5.7.6) as exact frames, an unconfigured EC5000 that only
//! speaks LSS until it gets a node-id, the stored configuration at the next
//! power-on, "activate bit timing" with its silent delays, and fastscan
//! commissioning three unconfigured drives on one virtual bus.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::services::lss::Mode;
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Duration;
use common::net::Net;
use common::{Bench, ms};
use firmware::devices::{ec5000, sendix};
use hal_host::bus::{BitRate, Bus};
use hal_host::storage::MemStorage;

type Sendix = Bench<sendix::od::Ram, NoApplication, MemStorage, 0, 3, 0>;
type Ec5000 = Bench<ec5000::od::Ram, NoApplication, MemStorage, 4, 4, 1>;
/// With the drive's own rules (its LSS at node-ID 127).
type Ec5000App = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

fn sendix_bench(storage: MemStorage) -> Sendix {
    Bench::new(sendix::od::Ram::new(0x3F), NoApplication, storage, 0x3F)
}

const LSS: u16 = 0x7E5;

// ---- The Sendix manual's sequence --------------------------------------------------

#[test]
fn sendix_manual_sequence_configures_stores_and_boots_with_the_new_node_id() {
    let mut b = sendix_bench(MemStorage::new(2048));
    assert_eq!(b.at(ms(0)), [(0x73F, vec![0x00])]);
    assert_eq!(b.rx(ms(10), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(20), LSS, &[0x5E, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x5E, 0x3F, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(30), LSS, &[0x11, 0x2A, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(40), LSS, &[0x13, 0x00, 0x04, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x13, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(50), LSS, &[0x17, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x17, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(60), LSS, &[0x04, 0x00, 0x04, 0, 0, 0, 0, 0]), []);
    // Still node 0x3F until reset communication (CiA 305 §5.2.2).
    assert_eq!(b.sdo_read(0x3F, 0x1000, 0)[0], 0x43);
    assert_eq!(b.rx(ms(70), 0x000, &[0x82, 0x3F]), [(0x72A, vec![0x00])]);
    assert_eq!(b.node.node_id(), 0x2A);
    assert_eq!(b.sdo_read(0x2A, 0x1200, 1), [0x43, 0x00, 0x12, 0x01, 0x2A, 0x06, 0, 0]);
    // The next power-on uses the stored node-id and bit rate.
    let storage = b.node.storage_mut().clone();
    let mut again = sendix_bench(storage);
    assert_eq!(again.at(ms(0)), [(0x72A, vec![0x00])]);
    assert_eq!(again.node.bit_rate(), Some(4));
}

#[test]
fn configuration_requests_in_the_waiting_state_get_no_answer() {
    let mut b = sendix_bench(MemStorage::new(2048));
    b.at(ms(0));
    for frame in [[0x11, 0x05, 0, 0, 0, 0, 0, 0], [0x5E, 0, 0, 0, 0, 0, 0, 0], [0x17, 0, 0, 0, 0, 0, 0, 0]] {
        assert_eq!(b.rx(ms(1), LSS, &frame), []);
    }
    assert_eq!(b.rx(ms(2), LSS, &[0x04, 0x01, 0, 0]), [], "a short frame is counted, not answered");
    assert_eq!(b.node.counters().malformed, 1);
    // A command specifier CiA 305 does not define, and switch state global to mode 2: counted too.
    assert_eq!(b.rx(ms(3), LSS, &[0x99, 0, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(4), LSS, &[0x04, 0x02, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.node.counters().malformed, 3);
    assert_eq!(b.node.lss_mode(), Some(canopen_core::services::lss::Mode::Waiting));
}

#[test]
fn switch_state_selective_with_the_identity_of_0x1018() {
    let mut b = sendix_bench(MemStorage::new(2048));
    b.node.set_serial_number(0x0001_E240);
    b.at(ms(0));
    assert_eq!(b.rx(ms(1), LSS, &[0x40, 0x13, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(2), LSS, &[0x41, 0x01, 0x20, 0x68, 0x58, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(3), LSS, &[0x42, 0x66, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(4), LSS, &[0x43, 0x40, 0xE2, 0x01, 0x00, 0, 0, 0]), [(0x7E4, vec![0x44, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.node.lss_mode(), Some(Mode::Configuration));
    assert_eq!(b.rx(ms(5), LSS, &[0x5D, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x5D, 0x40, 0xE2, 0x01, 0x00, 0, 0, 0])]);
    assert_eq!(b.sdo_read(0x3F, 0x1018, 4), [0x43, 0x18, 0x10, 0x04, 0x40, 0xE2, 0x01, 0x00]);
}

// ---- Activate bit timing ----------------------------------------------------------

#[test]
fn activate_bit_timing_is_silent_for_both_delays_and_switches_in_between() {
    let mut b = sendix_bench(MemStorage::new(2048));
    b.at(ms(0));
    assert_eq!(b.sdo_write(0x3F, 0x1017, 0, &50u16.to_le_bytes())[0], 0x60);
    b.rx(ms(1), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(2), LSS, &[0x13, 0x00, 0x02, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x13, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(3), LSS, &[0x15, 100, 0, 0, 0, 0, 0, 0]), []);
    // No heartbeat during 2 × 100 ms; the controller switches at 103 ms.
    assert!(b.run_until(ms(102)).is_empty());
    assert_eq!(b.node.take_bit_rate_change(), None);
    assert!(b.run_until(ms(103)).is_empty());
    assert_eq!(b.node.take_bit_rate_change(), Some(2));
    assert_eq!(b.node.take_bit_rate_change(), None, "reported once");
    assert!(b.run_until(ms(202)).is_empty());
    let resumed = b.run_until(ms(260));
    assert!(resumed.iter().any(|(_, f)| f == &(0x73F, vec![0x7F])), "heartbeats resume after the second delay: {resumed:?}");
    assert_eq!(b.node.bit_rate(), Some(2));
}

#[test]
fn activate_bit_timing_without_a_rate_takes_the_pending_0xff() {
    // No stored configuration and no "configure bit timing": the pending rate is 0xFF,
    // which the switch hands to the board as it is (and `bit_rate` reports).
    let mut b = sendix_bench(MemStorage::new(2048));
    b.at(ms(0));
    assert_eq!(b.node.bit_rate(), None, "no rate stored");
    b.rx(ms(1), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(2), LSS, &[0x15, 10, 0, 0, 0, 0, 0, 0]), []);
    assert!(b.run_until(ms(11)).is_empty());
    assert_eq!(b.node.take_bit_rate_change(), None);
    assert!(b.run_until(ms(12)).is_empty());
    assert_eq!(b.node.take_bit_rate_change(), Some(0xFF));
    assert_eq!(b.node.take_bit_rate_change(), None, "reported once");
    assert_eq!(b.node.bit_rate(), Some(0xFF));
}

// ---- Unconfigured nodes ------------------------------------------------------------

#[test]
fn an_unconfigured_node_speaks_only_lss_until_it_gets_a_node_id() {
    let mut b: Ec5000 = Bench::new(ec5000::od::Ram::new(0xFF), NoApplication, MemStorage::new(2048), 0xFF);
    b.node.set_serial_number(77);
    assert_eq!(b.at(ms(0)), [], "no boot-up");
    assert_eq!(b.rx(ms(1), 0x000, &[0x01, 0x00]), []);
    assert_eq!(b.rx(ms(2), 0x67F, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), []);
    assert_eq!(b.node.state(), NmtState::Initialising);
    assert_eq!(b.rx(ms(3), LSS, &[0x4C, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x50, 0, 0, 0, 0, 0, 0, 0])]);
    b.rx(ms(4), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(5), LSS, &[0x5E, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x5E, 0xFF, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(6), LSS, &[0x11, 0x0A, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(7), LSS, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]), [(0x70A, vec![0x00])], "leaving configuration starts the node");
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.sdo_read(0x0A, 0x1018, 4), [0x43, 0x18, 0x10, 0x04, 77, 0, 0, 0]);
    assert_eq!(b.rx(ms(8), LSS, &[0x4C, 0, 0, 0, 0, 0, 0, 0]), [], "configured now");
}

#[test]
fn without_a_stored_configuration_the_ec5000_starts_as_node_127() {
    let mut b: Ec5000App = Bench::new(ec5000::od::Ram::new(127), ec5000::App::NEW, MemStorage::new(2048), 127);
    assert_eq!(b.at(ms(0)), [(0x77F, vec![0x00])]);
    b.rx(ms(1), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    b.rx(ms(2), LSS, &[0x11, 0x05, 0, 0, 0, 0, 0, 0]);
    // At 127 the new node-ID is "temporär aktiv" on leaving configuration (L219/L234):
    // boot-up as node 5 and its SDO server, no NMT reset needed.
    assert_eq!(b.rx(ms(3), LSS, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]), [(0x705, vec![0x00])]);
    assert_eq!(b.sdo_read(5, 0x4650, 2), [0x4F, 0x50, 0x46, 0x02, 5, 0, 0, 0], "0x4650 sub 2 NodeID Actual");
    // Not stored: a power cycle brings node 127 back.
    let storage = b.node.storage_mut().clone();
    let mut again: Ec5000App = Bench::new(ec5000::od::Ram::new(127), ec5000::App::NEW, storage, 127);
    assert_eq!(again.at(ms(0)), [(0x77F, vec![0x00])]);
}

#[test]
fn from_a_node_id_other_than_127_the_ec5000_takes_the_new_one_at_reset_communication() {
    let mut b: Ec5000App = Bench::new(ec5000::od::Ram::new(9), ec5000::App::NEW, MemStorage::new(2048), 9);
    assert_eq!(b.at(ms(0)), [(0x709, vec![0x00])]);
    b.rx(ms(1), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    b.rx(ms(2), LSS, &[0x11, 0x05, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(3), LSS, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]), [], "still node 9 (CiA 305 §5.2.2)");
    assert_eq!(b.rx(ms(4), 0x000, &[0x82, 9]), [(0x705, vec![0x00])]);
}

// ---- Fastscan on the bus -----------------------------------------------------------

/// The master's fastscan (CiA 305 §5.5) over the bus: returns the LSS
/// address found, or `None` when no unconfigured slave answers.
fn fastscan(net: &mut Net, master: hal_host::bus::PortId) -> Option<[u32; 4]> {
    let ask = |net: &mut Net, id: u32, bit: u8, sub: u8, next: u8| {
        let [a, b, c, d] = id.to_le_bytes();
        net.send(master, LSS, &[0x51, a, b, c, d, bit, sub, next]);
        let before = net.now();
        net.run_for(Duration::from_millis(5));
        let mut answered = false;
        while let Some((at, f)) = net.bus().recv(master) {
            answered |= at >= before && f.cob_id() == Some(0x7E4) && embedded_can::Frame::data(&f).first() == Some(&0x4F);
        }
        answered
    };
    if !ask(net, 0, 0x80, 0, 0) {
        return None;
    }
    let mut found = [0u32; 4];
    for sub in 0..4u8 {
        let mut id = 0u32;
        for bit in (0..32u8).rev() {
            if !ask(net, id, bit, sub, sub) {
                id |= 1 << bit;
            }
        }
        assert!(ask(net, id, 0, sub, (sub + 1) % 4), "confirmation of part {sub}");
        found[usize::from(sub)] = id;
    }
    Some(found)
}

#[test]
fn fastscan_commissions_three_unconfigured_drives_on_one_bus() {
    let mut net = Net::new("lss_fastscan", BitRate::KBIT_250);
    let master = net.add_master();
    for serial in [0x1111_0001u32, 0x0000_0042, 0x8000_0000] {
        let mut node: ec5000::od::Node<NoApplication, MemStorage> =
            ec5000::od::Node::new(ec5000::od::Ram::new(0xFF), NoApplication, MemStorage::new(2048), 0xFF, net.now());
        node.set_serial_number(serial);
        net.add_node(node);
    }
    net.run_for(Duration::from_millis(10));
    let mut serials = Vec::new();
    for node_id in [0x10u8, 0x11, 0x12] {
        let found = fastscan(&mut net, master).expect("an unconfigured drive answers");
        serials.push(found[3]);
        net.send(master, LSS, &[0x11, node_id, 0, 0, 0, 0, 0, 0]);
        net.run_for(Duration::from_millis(5));
        let t = net.now();
        net.send(master, LSS, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]);
        net.run_for(Duration::from_millis(5));
        let boot: Vec<_> = net.frames_since(t).into_iter().filter(|f| f.2 == 0x700 + u16::from(node_id)).collect();
        assert_eq!(boot.len(), 1, "node {node_id:#x} booted once");
        assert_eq!(boot[0].3, [0x00]);
    }
    assert_eq!(fastscan(&mut net, master), None, "every drive is configured");
    // Fastscan meets the smallest address first.
    assert_eq!(serials, [0x0000_0042, 0x1111_0001, 0x8000_0000]);
}

// ---- Bit-rate switch on the bus ---------------------------------------------------

#[test]
fn after_the_switch_the_node_no_longer_understands_the_old_rate() {
    let mut net = Net::new("lss_bit_rate", BitRate::KBIT_250);
    let master = net.add_master();
    let node: sendix::od::Node<NoApplication, MemStorage> =
        sendix::od::Node::new(sendix::od::Ram::new(0x3F), NoApplication, MemStorage::new(2048), 0x3F, net.now());
    let h = net.add_node(node);
    net.run_for(Duration::from_millis(5));
    for frame in [[0x04, 0x01, 0, 0, 0, 0, 0, 0], [0x13, 0x00, 0x02, 0, 0, 0, 0, 0], [0x15, 0x32, 0, 0, 0, 0, 0, 0]] {
        net.send(master, LSS, &frame);
        net.run_for(Duration::from_millis(5));
    }
    net.run_for(Duration::from_millis(200));
    assert_eq!(net.bus().bitrate(h.port), Some(BitRate::KBIT_500));
    // At the old rate the node sees nothing; at the new one it answers.
    let errors = net.bus().port_stats(h.port).map(|s| s.bitrate_errors).unwrap_or(0);
    net.send(master, 0x63F, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    net.run_for(Duration::from_millis(5));
    assert!(net.bus().port_stats(h.port).map(|s| s.bitrate_errors).unwrap_or(0) > errors);
    while net.bus().recv(master).is_some() {}
    set_rate(net.bus(), master, BitRate::KBIT_500);
    let t = net.now();
    net.send(master, 0x63F, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    net.run_for(Duration::from_millis(5));
    assert!(net.frames_since(t).iter().any(|f| f.2 == 0x5BF), "the node answers at 500 kbit/s");
}

fn set_rate(bus: &mut Bus, port: hal_host::bus::PortId, rate: BitRate) {
    bus.set_bitrate(port, rate).expect("a known port");
}
