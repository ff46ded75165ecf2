//! The node's frame counters (`Node::counters`): every received frame is
//! counted once, and each one no service takes (ignored) or whose service
//! cannot parse it (malformed) once more, whatever the exit of the dispatch;
//! nothing is sent for either. The interop fixture (node 4; SYNC on 0x080,
//! TIME consumed on 0x100, no heartbeat consumer).

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::{Counters, NoApplication};
use canopen_core::services::nmt::NmtState;
use common::{Bench, ms};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

/// Delivers `frame` at `t` and runs the node: the counters' change (rx,
/// ignored, malformed) and what it sent.
fn counted(b: &mut Interop, t: u64, frame: CanFrame) -> ((u32, u32, u32), Vec<common::F>) {
    let before = b.node.counters();
    b.node.on_frame(ms(t), &frame);
    let sent = b.at(ms(t));
    let Counters { rx, malformed, ignored, .. } = b.node.counters();
    ((rx - before.rx, ignored - before.ignored, malformed - before.malformed), sent)
}

fn data(cob_id: u16, bytes: &[u8]) -> CanFrame {
    CanFrame::standard(cob_id, bytes).expect("valid frame")
}

fn remote(cob_id: u16) -> CanFrame {
    CanFrame::remote(cob_id, 1).expect("valid frame")
}

#[test]
fn each_frame_is_counted_once_and_as_ignored_or_malformed_where_no_service_takes_it() {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    const TAKEN: (u32, u32, u32) = (1, 0, 0);
    const IGNORED: (u32, u32, u32) = (1, 1, 0);
    const MALFORMED: (u32, u32, u32) = (1, 0, 1);
    // Initialising (before the boot-up): a frame for a service is ignored; its process boots up.
    assert_eq!(counted(&mut b, 0, data(0x604, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])), (IGNORED, vec![(0x704, vec![0x00])]));
    assert_eq!(b.node.state(), NmtState::PreOperational);
    // 29-bit identifiers are not CANopen's.
    let extended = CanFrame::extended(0x604, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).expect("valid frame");
    assert_eq!(counted(&mut b, 1, extended), (IGNORED, vec![]));
    // An identifier no service uses, and an RPDO's in Pre-operational.
    assert_eq!(counted(&mut b, 2, data(0x123, &[1])), (IGNORED, vec![]));
    assert_eq!(counted(&mut b, 3, data(0x204, &[1, 2])), (IGNORED, vec![]));
    // The node's own error-control identifier: a data frame is no heartbeat to consume.
    assert_eq!(counted(&mut b, 4, data(0x704, &[0x05])), (IGNORED, vec![]));
    // A remote frame on the SDO server's identifier, on TIME's, on SYNC's.
    assert_eq!(counted(&mut b, 5, remote(0x604)), (IGNORED, vec![]));
    assert_eq!(counted(&mut b, 6, remote(0x100)), (IGNORED, vec![]));
    assert_eq!(counted(&mut b, 7, remote(0x080)), (IGNORED, vec![]));
    // NMT: a remote frame and a frame of one byte are malformed; a command is taken.
    assert_eq!(counted(&mut b, 8, remote(0x000)), (MALFORMED, vec![]));
    assert_eq!(counted(&mut b, 9, data(0x000, &[0x01])), (MALFORMED, vec![]));
    assert_eq!(b.node.state(), NmtState::PreOperational);
    // A heartbeat of two bytes, or of no state, is malformed; a heartbeat of a node not monitored is taken.
    assert_eq!(counted(&mut b, 10, data(0x703, &[0x05, 0x00])), (MALFORMED, vec![]));
    assert_eq!(counted(&mut b, 11, data(0x703, &[0x03])), (MALFORMED, vec![]));
    assert_eq!(counted(&mut b, 12, data(0x703, &[0x05])), (TAKEN, vec![]));
    // TIME of the wrong length is malformed; of six bytes it is taken.
    assert_eq!(counted(&mut b, 13, data(0x100, &[0; 5])), (MALFORMED, vec![]));
    assert_eq!(counted(&mut b, 14, data(0x100, &[0; 6])), (TAKEN, vec![]));
    // SYNC without a counter takes any length.
    assert_eq!(counted(&mut b, 15, data(0x080, &[])), (TAKEN, vec![]));
    assert_eq!(counted(&mut b, 16, data(0x080, &[7])), (TAKEN, vec![]));
    // An SDO request is taken (the answer: 0x1000's value).
    let (counts, sent) = counted(&mut b, 17, data(0x604, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!((counts, sent.len()), (TAKEN, 1));
    assert_eq!(b.node.counters().tx, 2, "the boot-up and the SDO answer");
    assert_eq!(b.node.counters().rx, 18);
}

#[test]
fn a_sync_of_the_wrong_length_is_malformed_and_signalled() {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    b.at(ms(0));
    // 0x1019 = 4: every SYNC carries its counter (one byte).
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[4]), Ok(()));
    let (counts, sent) = counted(&mut b, 1, data(0x080, &[]));
    assert_eq!(counts, (1, 0, 1));
    // EMCY 0x8240 (unexpected SYNC data length), error register: generic + communication.
    assert_eq!(sent, [(0x084, vec![0x40, 0x82, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(counted(&mut b, 2, data(0x080, &[1])).0, (1, 0, 0));
}
