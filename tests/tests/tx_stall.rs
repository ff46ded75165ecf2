//! A node whose frames cannot leave. What waits for room in the transmit
//! queue (the EMCY of a queue overflow, an SDO answer, the node's own
//! start) makes `process` ask to be called again at once; when nothing has
//! left the queue since it last asked, it asks for a call a millisecond
//! later instead, and the board calls again when its controller takes a
//! frame.
//! Otherwise a board on a bus where nobody acknowledges its frames, or a
//! node kept silent by an LSS bit-rate switch (CiA 305 §5.2.3), would
//! spin in its loop (found by fuzzing `node_frames`).

mod common;

use canopen_core::node::{Application, NoApplication, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::{Duration, Instant};
use common::{Bench, F, ms};
use embedded_can::Frame;
use firmware::devices::sendix;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const LSS: u16 = 0x7E5;

/// What a board does at `now`: calls `process` again while it asks to be
/// called at once, without sending anything (its controller takes no
/// frame); the deadline it then waits for, and the number of calls.
fn board_at<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    node: &mut Node<O, A, S, R, T, HB>,
    now: Instant,
) -> (Option<Instant>, usize) {
    for calls in 1..=64 {
        match node.process(now) {
            Some(d) if d <= now => {}
            d => return (d, calls),
        }
    }
    panic!("process({now:?}) keeps asking to be called at once while no frame can leave");
}

fn frames<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    node: &mut Node<O, A, S, R, T, HB>,
) -> Vec<F> {
    std::iter::from_fn(|| node.transmit()).map(|f| (f.cob_id().expect("11-bit"), f.data().to_vec())).collect()
}

#[test]
fn a_node_nobody_acknowledges_waits_for_its_heartbeats_not_in_a_loop() {
    // The interop node 5, heartbeat every 10 ms; after its SDO answer no
    // frame leaves (the controller retries the first one for ever).
    let mut b =
        Bench::<interop::Ram, NoApplication, MemStorage, 4, 4, 4>::new(interop::Ram::new(5), NoApplication, MemStorage::new(4096), 5);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    assert_eq!(b.sdo_write(5, 0x1017, 0, &10u16.to_le_bytes()), [0x60, 0x17, 0x10, 0, 0, 0, 0, 0]);
    let node = &mut b.node;
    // The queue (32 frames) is full after 32 heartbeats; from the 33rd on
    // each one is refused, and the overflow EMCY waits for room. The board
    // is then called every millisecond, never again at once.
    let mut now = ms(10);
    let mut calls = 0;
    while now < ms(1010) {
        let (deadline, n) = board_at(node, now);
        assert!(n <= 2, "{n} calls at {now:?}");
        let deadline = deadline.expect("the heartbeat");
        assert!(deadline > now && deadline <= now + Duration::from_millis(10), "{deadline:?} at {now:?}");
        calls += n;
        now = deadline;
    }
    assert_eq!(now, ms(1010));
    // 32 calls at the heartbeats until the queue is full, two at 330 ms
    // (the EMCY asks once to be called at once), then one a millisecond.
    assert_eq!(calls, 32 + 2 + 679);
    assert_eq!(node.tx_overflows(), 100 - 32);
    // The bus comes back: the 32 queued heartbeats leave; the next call
    // sends the EMCY (the first refused frame counted) with the heartbeat
    // due at 1010 ms, and once the queue drained, the error reset.
    assert_eq!(frames(node), vec![(0x705, vec![0x7F]); 32]);
    assert_eq!(node.process(now), Some(ms(1020)));
    assert_eq!(frames(node), [(0x85, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 1]), (0x705, vec![0x7F])]);
    assert_eq!(node.process(now), Some(ms(1020)));
    assert_eq!(frames(node), [(0x85, vec![0, 0, 0, 0, 0, 0, 0, 0])], "EMCY error reset once the queue drained");
}

#[test]
fn a_node_silent_for_a_bit_rate_switch_waits_for_its_end_not_in_a_loop() {
    // The Sendix (LSS) at node 0x3F, heartbeat every 1 ms; "activate bit
    // timing" with 100 ms delays keeps it silent for 200 ms, in which its
    // queue fills and overflows.
    let mut b = Bench::<sendix::od::Ram, NoApplication, MemStorage, 0, 3, 0>::new(
        sendix::od::Ram::new(0x3F),
        NoApplication,
        MemStorage::new(2048),
        0x3F,
    );
    b.at(ms(0));
    assert_eq!(b.sdo_write(0x3F, 0x1017, 0, &1u16.to_le_bytes())[0], 0x60);
    b.rx(ms(0), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(0), LSS, &[0x13, 0x00, 0x02, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x13, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(0), LSS, &[0x15, 100, 0, 0, 0, 0, 0, 0]), []);
    let node = &mut b.node;
    let mut now = ms(0);
    let mut switched = None;
    while now < ms(200) {
        let (deadline, calls) = board_at(node, now);
        assert!(calls <= 2, "{calls} calls at {now:?}");
        assert!(frames(node).is_empty(), "silent at {now:?}");
        if node.take_bit_rate_change().is_some() {
            switched = Some(now);
        }
        let deadline = deadline.expect("a heartbeat or the switch");
        assert!(deadline > now && deadline <= now + Duration::from_millis(1), "{deadline:?} at {now:?}");
        now = deadline;
    }
    // The switch after the first delay, less than a millisecond late.
    assert!(switched.is_some_and(|t| t >= ms(100) && t < ms(101)), "{switched:?}");
    assert_eq!(node.bit_rate(), Some(2));
    // After the second delay the node speaks again: the heartbeats it
    // queued first, then (the queue drained) the EMCY and its error reset.
    // Nothing has left since its last call: it asks for the next in a
    // millisecond, and the board's controller takes the frames meanwhile.
    assert_eq!(board_at(node, now), (Some(ms(201)), 1));
    assert_eq!(frames(node), vec![(0x73F, vec![0x7F]); 32]);
    let _ = node.process(now);
    assert_eq!(frames(node), [(0xBF, vec![0x10, 0x81, 0x11, 1, 0, 0, 0, 1]), (0xBF, vec![0, 0, 0, 0, 0, 0, 0, 0])]);
}
