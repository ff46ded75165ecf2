//! PDO traffic between nodes on the virtual bus at 1 Mbit/s: node A's TPDO
//! is node B's RPDO, configured over SDO by the master, and B's objects
//! change at the instant the frame's EOF ends (event-driven RPDO) or at the
//! next SYNC's (synchronous RPDO). CiA 301 v4.2 §7.2.2 (PDO), §7.2.5
//! (SYNC), §7.5.2.35–38 (the mapping procedure).
//!
//! The nodes are interop fixtures (`tests/eds/interop.eds`). TPDO1
//! (0x180 + node-ID, event-driven) maps 0x2000 u8, 0x2001 u16, 0x2003 u32;
//! TPDO2 (0x280 + node-ID, synchronous every SYNC) maps 0x2004 i32 and
//! 0x2007 f32.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::services::nmt::NmtState;
use common::net::{Net, NodeHandle, bits, us};
use hal_host::bus::{BitRate, PortId};
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::storage::MemStorage;

type Interop = Node<NoApplication, MemStorage>;

/// The master and nodes 1..=n (all booted at t = 0), at t = 1 ms.
fn network(name: &str, n: u8) -> (Net, PortId, Vec<NodeHandle>) {
    let mut net = Net::new(name, BitRate::MBIT_1);
    let master = net.add_master();
    let nodes = (1..=n).map(|id| net.add_node(Interop::new(Ram::new(id), NoApplication, MemStorage::new(4096), id, us(0)))).collect();
    net.run_until(us(1000));
    (net, master, nodes)
}

fn u32le(v: u32) -> [u8; 4] {
    v.to_le_bytes()
}

#[test]
fn tpdo_of_node_a_is_rpdo_of_node_b() {
    let (mut net, m, nodes) = network("tpdo_of_node_a_is_rpdo_of_node_b", 2);
    let (a, b) = (nodes[0], nodes[1]);
    // B's RPDO1 takes A's TPDO1: invalidate, map the same three objects, and
    // make it valid on A's CAN-ID (the mapping procedure of §7.5.2.36).
    net.configure(m, 2, 0x1400, 1, &u32le(0x8000_0202));
    net.configure(m, 2, 0x1600, 0, &[0]);
    net.configure(m, 2, 0x1600, 1, &u32le(0x2000_0008));
    net.configure(m, 2, 0x1600, 2, &u32le(0x2001_0010));
    net.configure(m, 2, 0x1600, 3, &u32le(0x2003_0020));
    net.configure(m, 2, 0x1600, 0, &[3]);
    net.configure(m, 2, 0x1400, 1, &u32le(0x0000_0181));
    net.configure(m, 1, 0x2000, 0, &[0x5A]);
    net.configure(m, 1, 0x2001, 0, &0xBEEFu16.to_le_bytes());
    net.configure(m, 1, 0x2003, 0, &u32le(0xCAFE_F00D));
    net.run_until(us(10_000));
    assert_eq!(net.frames_since(us(3449)), [], "no PDO in Pre-operational");

    // NMT start all. Both nodes send their TPDO1 once on entering
    // Operational; 0x181 wins arbitration. B's objects take A's values
    // at the EOF of 0x181, so B's own TPDO1, already in a mailbox with the
    // defaults, goes next, and then again with the changed data.
    net.send(m, 0x000, &[0x01, 0x00]);
    net.run_until(us(10_174));
    let word = |net: &Net| net.node::<Interop>(b).od().word_value();
    assert_eq!(word(&net), 0x2222);
    net.run_until(us(10_175));
    assert_eq!(word(&net), 0xBEEF);
    let od = net.node::<Interop>(b).od();
    assert_eq!((od.byte_value(), od.double_word_value()), (0x5A, 0xCAFE_F00D));

    // At 20 ms A's application changes 0x2001: A sends at once, B has it at the EOF.
    net.run_until(us(20_000));
    net.node_mut::<Interop>(a).od_mut().set_word_value(0x1234);
    net.run_until(us(20_105));
    assert_eq!(word(&net), 0xBEEF);
    net.run_until(us(20_106));
    assert_eq!(word(&net), 0x1234);
    net.run_until(us(30_000));
    let expected = "\
(0000000000.010065) vcan0 000#0100
(0000000000.010175) vcan0 181#5AEFBE0DF0FECA
(0000000000.010280) vcan0 182#11222244444444
(0000000000.010391) vcan0 182#5AEFBE0DF0FECA
(0000000000.020106) vcan0 181#5A34120DF0FECA
(0000000000.020217) vcan0 182#5A34120DF0FECA
";
    assert_eq!(net.candump_since(us(10_000)), expected);
    // 0x181 was queued at 20 000 µs on an idle bus: 106 bits to its EOF.
    assert_eq!(bits(0x181, &[0x5A, 0x34, 0x12, 0x0D, 0xF0, 0xFE, 0xCA]).0, 106);
    assert_eq!(net.node::<Interop>(b).counters().malformed, 0);
}

#[test]
fn synchronous_rpdo_takes_effect_at_the_next_sync() {
    let (mut net, m, nodes) = network("synchronous_rpdo_takes_effect_at_the_next_sync", 3);
    let b = nodes[1];
    // B's RPDO2: synchronous (type 0), mapped like A's TPDO2, on 0x281.
    net.configure(m, 2, 0x1401, 1, &u32le(0x8000_0302));
    net.configure(m, 2, 0x1601, 0, &[0]);
    net.configure(m, 2, 0x1601, 1, &u32le(0x2004_0020));
    net.configure(m, 2, 0x1601, 2, &u32le(0x2007_0020));
    net.configure(m, 2, 0x1601, 0, &[2]);
    net.configure(m, 2, 0x1401, 2, &[0]);
    net.configure(m, 2, 0x1401, 1, &u32le(0x0000_0281));
    net.configure(m, 1, 0x2004, 0, &(-1234i32).to_le_bytes());
    net.configure(m, 1, 0x2007, 0, &2.5f32.to_le_bytes());
    // Node 3 produces the SYNC every 10 ms from the download of 0x1006.
    net.configure(m, 3, 0x1005, 0, &u32le(0x4000_0080));
    net.configure(m, 3, 0x1006, 0, &u32le(10_000));
    let written = net.frames_since(us(0)).into_iter().find(|f| f.2 == 0x603 && f.3[1..3] == [0x06, 0x10]).unwrap().0;
    assert_eq!(written, us(3554));
    net.run_until(us(15_000));
    net.send(m, 0x000, &[0x01, 0x00]);

    // B buffers A's TPDO2 of 23 724 µs and writes it at the next SYNC's
    // EOF, before its own TPDO2 samples the data for that SYNC.
    let value = |net: &Net| {
        let od = net.node::<Interop>(b).od();
        (od.signed_value(), od.real_value())
    };
    net.run_until(us(33_601));
    assert_eq!(value(&net), (-5, 1.5));
    net.run_until(us(33_602));
    assert_eq!(value(&net), (-1234, 2.5));

    net.run_until(us(40_000));
    for n in &nodes {
        assert_eq!(net.node::<Interop>(*n).state(), NmtState::Operational);
    }
    // A SYNC 10 ms after the write, 48 bits long; in Pre-operational it is
    // produced but no PDO answers. From the first SYNC in Operational on,
    // every node's TPDO2 (type 1) follows each SYNC in identifier order.
    assert_eq!(bits(0x080, &[]).0, 48);
    let expected = "\
(0000000000.013602) vcan0 080#
(0000000000.015065) vcan0 000#0100
(0000000000.015169) vcan0 181#11222244444444
(0000000000.015274) vcan0 182#11222244444444
(0000000000.015379) vcan0 183#11222244444444
(0000000000.023602) vcan0 080#
(0000000000.023724) vcan0 281#2EFBFFFF00002040
(0000000000.023847) vcan0 282#FBFFFFFF0000C03F
(0000000000.023970) vcan0 283#FBFFFFFF0000C03F
(0000000000.033602) vcan0 080#
(0000000000.033724) vcan0 281#2EFBFFFF00002040
(0000000000.033846) vcan0 282#2EFBFFFF00002040
(0000000000.033969) vcan0 283#FBFFFFFF0000C03F
";
    assert_eq!(net.candump_since(us(3679)), expected);
}
