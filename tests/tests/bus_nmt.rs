//! NMT and heartbeat across nodes on the virtual bus: boot-up messages
//! that meet on the wire, NMT commands addressed to one node, and a
//! heartbeat consumer watching a producer on another node that falls
//! silent. CiA 301 v4.2 §7.2.8.3.1 (NMT), §7.2.8.3.2 (heartbeat),
//! §7.2.8.3.3 (boot-up), §7.2.7 (EMCY 0x8130), §7.5.2.32 (0x1029).

mod common;

use canopen_core::node::NoApplication;
use canopen_core::services::nmt::NmtState;
use common::net::{Net, bits, us};
use hal_host::bus::BitRate;
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::master::UploadMode;
use hal_host::storage::MemStorage;

type Interop = Node<NoApplication, MemStorage>;

fn interop(id: u8) -> Interop {
    Interop::new(Ram::new(id), NoApplication, MemStorage::new(4096), id, us(0))
}

#[test]
fn boot_ups_meet_on_the_wire_and_leave_in_identifier_order() {
    // 500 kbit/s: one bit is 2 µs. Four nodes power on at the same instant,
    // attached in the order 4, 2, 3, 1; arbitration sends their boot-up
    // messages by identifier, back to back (56 bits each up to EOF, + 3).
    let mut net = Net::new("boot_ups_meet_on_the_wire_and_leave_in_identifier_order", BitRate::KBIT_500);
    let m = net.add_master();
    let nodes: Vec<_> = [4, 2, 3, 1].into_iter().map(|id| net.add_node(interop(id))).collect();
    net.run_until(us(1000));
    assert_eq!(bits(0x701, &[0x00]).0, 56);
    // Start node 3, reset node 2, both queued at 1000 µs. Node 3's TPDO1
    // (sent once on entering Operational) is queued at the first command's
    // EOF but loses arbitration to the second command; node 2's boot-up
    // (queued at the second command's EOF) loses to the TPDO.
    net.send(m, 0x000, &[0x01, 3]);
    net.send(m, 0x000, &[0x81, 2]);
    net.run_until(us(3000));
    let expected = "\
(0000000000.000112) vcan0 701#00
(0000000000.000230) vcan0 702#00
(0000000000.000348) vcan0 703#00
(0000000000.000464) vcan0 704#00
(0000000000.001130) vcan0 000#0103
(0000000000.001266) vcan0 000#8102
(0000000000.001476) vcan0 183#11222244444444
(0000000000.001594) vcan0 702#00
";
    assert_eq!(net.candump_since(us(0)), expected);
    let states: Vec<_> = nodes.iter().map(|&n| net.node::<Interop>(n).state()).collect();
    assert_eq!(states, [NmtState::PreOperational, NmtState::PreOperational, NmtState::Operational, NmtState::PreOperational]);
}

#[test]
fn heartbeat_consumer_on_one_node_watches_a_producer_on_another() {
    let mut net = Net::new("heartbeat_consumer_on_one_node_watches_a_producer_on_another", BitRate::MBIT_1);
    let m = net.add_master();
    let a = net.add_node(interop(1));
    let b = net.add_node(interop(2));
    net.run_until(us(1000));
    // B consumes node 1's heartbeat with 150 ms; A produces every 100 ms,
    // counted from the instant it received the download (1358 µs).
    net.configure(m, 2, 0x1016, 1, &0x0001_0096u32.to_le_bytes());
    net.configure(m, 1, 0x1017, 0, &100u16.to_le_bytes());
    net.run_until(us(2000));
    net.send(m, 0x000, &[0x01, 0x00]);
    net.run_until(us(350_000));
    assert_eq!(net.node::<Interop>(b).state(), NmtState::Operational);

    // A's link breaks: its frames still go out, nobody receives them. B's
    // consumer expires 150 ms after the last heartbeat it received
    // (301 413 µs): EMCY 0x8130 for node 1 (error register 0x11) at
    // 451 413 µs, 118 bits to EOF, and B falls back to Pre-operational
    // (0x1029 sub 1 = 0).
    let port = a.port;
    let cut = net.bus().drop_where(move |p, _| p == port);
    net.run_until(us(451_412));
    assert_eq!(net.node::<Interop>(b).state(), NmtState::Operational);
    net.run_until(us(451_413));
    assert_eq!(net.node::<Interop>(b).state(), NmtState::PreOperational);
    assert_eq!(bits(0x082, &[0x30, 0x81, 0x11, 0x01, 0, 0, 0, 0]).0, 118);

    // The link comes back: B hears A again from 501 413 µs on, and with no
    // monitored node in error any more 0x8130 clears: EMCY "error reset"
    // (error register 0) right after that heartbeat. B stays
    // Pre-operational until the NMT master starts it; 0x1003 keeps the
    // history.
    assert!(net.bus().remove_fault(cut));
    net.run_until(us(800_000));
    assert_eq!(net.node::<Interop>(b).state(), NmtState::PreOperational);
    let expected = "\
(0000000000.002065) vcan0 000#0100
(0000000000.002169) vcan0 181#11222244444444
(0000000000.002274) vcan0 182#11222244444444
(0000000000.101413) vcan0 701#05
(0000000000.201413) vcan0 701#05
(0000000000.301413) vcan0 701#05
(0000000000.451531) vcan0 082#3081110100000000
(0000000000.501413) vcan0 701#05
(0000000000.501538) vcan0 082#0000000000000000
(0000000000.601413) vcan0 701#05
(0000000000.701413) vcan0 701#05
";
    assert_eq!(net.candump_since(us(2000)), expected);
    assert_eq!(net.bus().stats().dropped, 1, "the heartbeat of 401 413 µs");
    assert_eq!(bits(0x082, &[0; 8]).0, 122);
    assert_eq!(net.sdo_upload(m, 2, 0x1001, 0, UploadMode::ExpeditedOrSegmented), Ok(vec![0x00]));
    assert_eq!(net.sdo_upload(m, 2, 0x1003, 1, UploadMode::ExpeditedOrSegmented), Ok(0x0001_8130u32.to_le_bytes().to_vec()));
}
