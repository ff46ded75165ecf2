//! `Node::process` folds the services' deadlines into its answer (as
//! `time::At`s, with `min`, and from what its last full call kept while it
//! is quiet). Whatever it skips or keeps, its answer must be the earliest
//! of the services' own deadlines, asked after the call: later would delay
//! a heartbeat, a SYNC, an EMCY or a TPDO; earlier, unless "at once",
//! would wake the board for nothing. Driven at random: heartbeat producer and consumer, life
//! guarding, the SYNC producer, EMCY with an inhibit time, event-driven
//! TPDOs with event timers and inhibit times, RPDOs, NMT state changes,
//! calls on time, early and late.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::{NoApplication, Node};
use canopen_core::services::nmt::NmtState;
use canopen_core::time::{At, Instant, NEVER};
use canopen_core::wire::emcy::EmcyCode;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 5;

type Interop = Node<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

/// The earliest deadline of the services `process` runs, asked of each.
fn earliest_of_the_services(node: &Interop) -> At {
    let comm = node.comm();
    let running = node.state() != NmtState::Stopped && node.state() != NmtState::Initialising;
    let candidates = [
        comm.heartbeat.deadline(),
        comm.consumers.deadline(),
        comm.guarding.deadline(),
        if running { comm.sync.deadline() } else { NEVER },
        if running { comm.emcy.deadline() } else { NEVER },
        comm.pdos.due(),
    ];
    candidates.into_iter().min().unwrap_or(NEVER)
}

/// An expedited SDO download (the answer is drained with the other frames).
fn sdo_download(node: &mut Interop, now: Instant, index: u16, sub: u8, data: &[u8]) {
    frame(node, now, 0x600 + u16::from(ID), &common::expedited_download(index, sub, data));
}

fn frame(node: &mut Interop, now: Instant, cob_id: u16, data: &[u8]) {
    node.on_frame(now, &CanFrame::standard(cob_id, data).expect("valid frame"));
}

#[test]
fn the_node_answers_the_earliest_of_its_services_deadlines() {
    let mut node: Interop = Node::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID, Instant::ZERO);
    let (mut t, mut seed) = (0u64, 0x9E37_79B9u32);
    let mut deadline = node.process(Instant::ZERO);
    let (mut checked, mut timed, mut sent) = (0, 0, 0);
    // EMCY inhibit 3.7 ms; SYNC producer every 7 ms (on or off at random below).
    sdo_download(&mut node, Instant::ZERO, 0x1015, 0, &37u16.to_le_bytes());
    sdo_download(&mut node, Instant::ZERO, 0x1006, 0, &7_000u32.to_le_bytes());
    // Life time factor 3: a guard time written below makes life guarding run.
    sdo_download(&mut node, Instant::ZERO, 0x100D, 0, &[3]);
    for step in 0..4000 {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        let r = seed >> 8;
        // Mostly at the node's deadline (as a board's timer calls it), else early or late.
        t = match (deadline, r % 4) {
            (Some(d), 0 | 1) if d.as_micros() >= t => d.as_micros(),
            _ => t + u64::from(r % 3_000),
        };
        let now = Instant::from_micros(t);
        match (r >> 4) % 16 {
            0 => frame(&mut node, now, 0x000, &[[0x01, 0x80, 0x02][(r >> 10) as usize % 3], ID]),
            1 => frame(&mut node, now, 0x700 + 10, &[0x05]),
            2 => sdo_download(&mut node, now, 0x1016, 1, &((10u32 << 16) | ((r >> 12) % 40 * 5)).to_le_bytes()),
            3 => sdo_download(&mut node, now, 0x1017, 0, &[0u16, 20, 45, 100][(r >> 10) as usize % 4].to_le_bytes()),
            4 => sdo_download(&mut node, now, 0x100C, 0, &[0u16, 15, 40][(r >> 10) as usize % 3].to_le_bytes()),
            5 => node.on_frame(now, &CanFrame::remote(0x700 + u16::from(ID), 1).expect("valid frame")),
            6 => sdo_download(&mut node, now, 0x1005, 0, &[0x80u32, 0x4000_0080][(r >> 10) as usize % 2].to_le_bytes()),
            7 => node.raise_error(EmcyCode(0x5000 | ((r >> 10) as u16 % 4)), [0; 5]),
            8 => node.clear_error(EmcyCode(0x5000 | ((r >> 10) as u16 % 4))),
            9 => sdo_download(&mut node, now, 0x2000, 0, &[(r >> 10) as u8 % 3]),
            10 => frame(&mut node, now, 0x200 + u16::from(ID), &[(r >> 10) as u8, 0, 0, 0]),
            11 => sdo_download(&mut node, now, 0x1800, 5, &[0u16, 4, 9][(r >> 10) as usize % 3].to_le_bytes()),
            12 => sdo_download(&mut node, now, 0x1800, 3, &[0u16, 25, 60][(r >> 10) as usize % 3].to_le_bytes()),
            13 => sdo_download(&mut node, now, 0x2003, 0, &(r >> 10).to_le_bytes()),
            _ => {}
        }
        // As a board does: process, send, and again at once while the answer is "now".
        let mut calls = 0;
        let answer = loop {
            deadline = node.process(now);
            while node.resetting() {
                deadline = node.process(now);
            }
            while node.transmit().is_some() {
                sent += 1;
            }
            calls += 1;
            // The clock stays below 2^31 µs: the node's epoch is 0, an `At` the same microseconds.
            let answer = deadline.map_or(NEVER, |d| At::try_from(d.as_micros()).expect("below 2^31 µs"));
            // The next call is made at once; it folds again, after the
            // SYNC producer armed or sent (the other services were folded before it).
            let why = format!("step {step} at {t} µs, call {calls}: the node answers {deadline:?}");
            assert!(answer <= earliest_of_the_services(&node), "later than a service: {why}");
            if u64::from(answer) > t || calls == 4 {
                break answer;
            }
        };
        let services = earliest_of_the_services(&node);
        assert!(u64::from(answer) > t, "step {step} at {t} µs: still due after {calls} calls");
        assert_eq!(answer, services, "step {step} at {t} µs: earlier than every service");
        timed += usize::from(answer != NEVER);
        checked += 1;
    }
    assert!(checked == 4000 && timed > 1000 && sent > 1000, "{timed} deadlines, {sent} frames");
}
