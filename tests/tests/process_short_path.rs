//! `Node::process` has a short path for a node whose only work is its PDOs
//! (quiet: no SDO transfer, no EMCY waiting; nothing stale; no other
//! service due): the TPDO poll and the deadline, without the checks of the
//! other services. It must send what the full path sends, when it sends
//! it, and answer the same deadline. Two identical nodes get the same
//! random steps; one is run by `process`, the other by
//! `process_without_short_path`; after every call their frames and their
//! answers must be equal. Driven at random: the interop node (event-driven
//! TPDOs with event timers and inhibit times, data written by SDO and by
//! RPDOs, an RPDO timeout, heartbeat producer and consumer, the SYNC
//! producer, EMCY, NMT) and the EC5000 with its CiA 402 application (its
//! RPDOs through the profile to event-driven TPDOs, SYNC, heartbeat loss
//! and its reaction), with the transmit queue left undrained at times so
//! that it overflows.

mod common;
use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, ControllerEvent, Ctx, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use embedded_can::Frame;
use firmware::devices::ec5000;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 5;

type Interop = Node<interop::Ram, Plain, MemStorage, 4, 4, 4>;

/// `NoApplication` with the short path, which `NoApplication` leaves out
/// (`Application::PDO_SHORT_PATH`): the dictionary answers everything.
struct Plain;

impl Application for Plain {
    const SDO_HOOKS: bool = false;
    const PDO_SHORT_PATH: bool = true;

    fn rpdo_written(&mut self, ctx: &mut Ctx<'_>, n: u8) {
        let _ = (ctx, n);
    }
}
type Ec5000 = Node<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

/// A step's random number generator (xorshift32).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0 >> 8
    }
}

fn frame<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    node: &mut Node<O, A, S, R, T, HB>,
    now: Instant,
    cob_id: u16,
    data: &[u8],
) {
    node.on_frame(now, &CanFrame::standard(cob_id, data).expect("valid frame"));
}

/// An expedited SDO download (its answer leaves with the other frames).
fn sdo_download<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    node: &mut Node<O, A, S, R, T, HB>,
    now: Instant,
    index: u16,
    sub: u8,
    data: &[u8],
) {
    frame(node, now, 0x600 + u16::from(ID), &common::expedited_download(index, sub, data));
}

/// A CAN controller's report: its errors hold for a while, then clear (a deadline of their own).
fn controller_event(r: u32) -> ControllerEvent {
    match (r >> 10) % 4 {
        0 => ControllerEvent::RxOverrun { lost: 1 + (r >> 12) % 3 },
        1 => ControllerEvent::ErrorPassive,
        2 => ControllerEvent::ErrorActive,
        _ => ControllerEvent::BusOffRecovered,
    }
}

/// Up to `n` frames from the queue, as (COB-ID, data).
fn drain<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    node: &mut Node<O, A, S, R, T, HB>,
    n: usize,
) -> Vec<(u16, Vec<u8>)> {
    let mut out = Vec::new();
    while out.len() < n {
        let Some(f) = node.transmit() else { break };
        out.push((f.cob_id().expect("11-bit"), f.data().to_vec()));
    }
    out
}

/// What the two nodes did over a run.
#[derive(Debug, Default)]
struct Seen {
    /// Calls compared.
    calls: usize,
    /// Frames compared.
    frames: usize,
    /// Frames of each TPDO COB-ID 0x180..=0x4FF.
    tpdos: usize,
    /// Transmit queue overflows reported (the device's overrun EMCY).
    overflows: usize,
}

/// `steps` random steps (`input` applied to both nodes alike, with the
/// same random number), each followed by calls at the step's time as a
/// board makes them: `short` by `process`, `full` by
/// `process_without_short_path`. Every call's answer and frames must be
/// equal. At random the board takes (almost) no frames for `hold` steps;
/// `overrun`: the device's EMCY code for a transmit queue overflow.
fn compare<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize>(
    mut short: Node<O, A, S, R, T, HB>,
    mut full: Node<O, A, S, R, T, HB>,
    steps: usize,
    seed: u32,
    (hold, overrun): (u32, u16),
    mut input: impl FnMut(&mut Node<O, A, S, R, T, HB>, Instant, u32),
) -> Seen {
    let mut rng = Rng(seed);
    let (mut t, mut deadline) = (0u64, short.process(Instant::ZERO));
    assert_eq!(deadline, full.process_without_short_path(Instant::ZERO));
    let mut seen = Seen::default();
    // Steps left while the board does not take frames from the queue.
    let mut held = 0u32;
    for step in 0..steps {
        let r = rng.next();
        // Mostly at the node's deadline, else early or late.
        t = match (deadline, r % 4) {
            (Some(d), 0 | 1) if d.as_micros() >= t => d.as_micros(),
            _ => t + u64::from(r % 3_000),
        };
        let now = Instant::from_micros(t);
        input(&mut short, now, r);
        input(&mut full, now, r);
        if held == 0 && r.is_multiple_of(97) {
            held = hold;
        }
        held = held.saturating_sub(1);
        for call in 0..4 {
            let (a, b) = (short.process(now), full.process_without_short_path(now));
            let why = format!("step {step} at {t} µs, call {call}");
            assert_eq!(a, b, "the answer: {why}");
            while short.resetting() || short.storing() {
                assert_eq!(short.process(now), full.process_without_short_path(now), "a stage: {why}");
            }
            assert!(!full.resetting() && !full.storing(), "{why}");
            // A held queue gives a frame at times, so that an overflow is followed by room.
            let n = if held > 0 { usize::from(r.is_multiple_of(7)) } else { usize::MAX };
            let (sent, expected) = (drain(&mut short, n), drain(&mut full, n));
            assert_eq!(sent, expected, "the frames: {why}");
            seen.calls += 1;
            seen.frames += sent.len();
            seen.tpdos += sent.iter().filter(|(id, _)| (0x180..0x500).contains(id) && id & 0x7F == u16::from(ID)).count();
            seen.overflows += sent.iter().filter(|(id, d)| *id == 0x80 + u16::from(ID) && d[..2] == overrun.to_le_bytes()).count();
            deadline = a;
            if a.is_none_or(|d| d.as_micros() > t) {
                break;
            }
        }
    }
    seen
}

#[test]
fn the_short_path_sends_and_answers_as_the_full_path_on_the_interop_node() {
    let new = || -> Interop { Node::new(interop::Ram::new(ID), Plain, MemStorage::new(4096), ID, Instant::ZERO) };
    let seen = compare(new(), new(), 6000, 0x9E37_79B9, (40, 0x8110), |node, now, r| match (r >> 4) % 20 {
        0 => frame(node, now, 0x000, &[[0x01, 0x80, 0x02, 0x01][(r >> 10) as usize % 4], ID]),
        1 => frame(node, now, 0x700 + 10, &[0x05]),
        2 => sdo_download(node, now, 0x1016, 1, &((10u32 << 16) | ((r >> 12) % 40 * 5)).to_le_bytes()),
        3 => sdo_download(node, now, 0x1017, 0, &[0u16, 20, 45, 100][(r >> 10) as usize % 4].to_le_bytes()),
        4 => sdo_download(node, now, 0x1005, 0, &[0x80u32, 0x4000_0080][(r >> 10) as usize % 2].to_le_bytes()),
        5 => sdo_download(node, now, 0x1006, 0, &[7_000u32, 2_500][(r >> 10) as usize % 2].to_le_bytes()),
        6 => node.raise_error(EmcyCode(0x5000 | ((r >> 10) as u16 % 4)), [0; 5]),
        7 => node.clear_error(EmcyCode(0x5000 | ((r >> 10) as u16 % 4))),
        8 => sdo_download(node, now, 0x1015, 0, &[0u16, 37][(r >> 10) as usize % 2].to_le_bytes()),
        9 => sdo_download(node, now, 0x1800 + (r >> 12) as u16 % 2, 5, &[0u16, 4, 9][(r >> 10) as usize % 3].to_le_bytes()),
        10 => sdo_download(node, now, 0x1800 + (r >> 12) as u16 % 2, 3, &[0u16, 25, 60][(r >> 10) as usize % 3].to_le_bytes()),
        // RPDO1 with an event timer of 0, 6 or 15 ms: a timeout at times.
        11 => sdo_download(node, now, 0x1400, 5, &[0u16, 6, 15][(r >> 10) as usize % 3].to_le_bytes()),
        // Writes to the TPDOs' data: by RPDO (most steps), by SDO, unchanged at times.
        12..=15 => frame(node, now, 0x200 + u16::from(ID), &[(r >> 10) as u8 % 3, (r >> 12) as u8 % 2, 0, 0]),
        16 => sdo_download(node, now, 0x2003, 0, &((r >> 10) % 3).to_le_bytes()),
        17 => sdo_download(node, now, 0x2000, 0, &[(r >> 10) as u8 % 3]),
        18 => node.controller_event(controller_event(r), now),
        _ => {}
    });
    assert!(seen.tpdos > 1000 && seen.overflows > 0 && seen.frames > 3000, "{seen:?}");
}

#[test]
fn the_short_path_sends_and_answers_as_the_full_path_on_the_ec5000() {
    let new = || -> Ec5000 { Node::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID, Instant::ZERO) };
    let seen = compare(new(), new(), 6000, 0x1234_5677, (120, 0xFFD1), |node, now, r| match (r >> 4) % 24 {
        0 if r.is_multiple_of(3) => frame(node, now, 0x000, &[[0x80, 0x02][(r >> 10) as usize % 2], ID]),
        0 => frame(node, now, 0x000, &[0x01, ID]),
        // TPDO3 (0x6041, 0x606C) event-driven or back on SYNC, its inhibit time and event timer.
        1 => sdo_download(node, now, 0x1802, 1, &(0x8000_0385u32).to_le_bytes()),
        2 => sdo_download(node, now, 0x1802, 2, &[[255u8, 254, 255, 1][(r >> 10) as usize % 4]]),
        3 => sdo_download(node, now, 0x1802, 1, &(0x385u32).to_le_bytes()),
        4 => sdo_download(node, now, 0x1800 + (r >> 12) as u16 % 3, 3, &[0u16, 0, 20, 1000][(r >> 10) as usize % 4].to_le_bytes()),
        5 => sdo_download(node, now, 0x1800 + (r >> 12) as u16 % 3, 5, &[0u16, 3, 2000][(r >> 10) as usize % 3].to_le_bytes()),
        6 => frame(node, now, 0x080, &[]),
        // A heartbeat consumer of node 10 (50 ms) and its heartbeats: a loss at times (0x6007).
        7 => sdo_download(node, now, 0x1016, 1, &((10u32 << 16) | [0u32, 50][(r >> 10) as usize % 2]).to_le_bytes()),
        8 => frame(node, now, 0x700 + 10, &[0x05]),
        9 => sdo_download(node, now, 0x1017, 0, &[0u16, 30, 100][(r >> 10) as usize % 3].to_le_bytes()),
        11 => node.controller_event(controller_event(r), now),
        // Enable in pv (RPDO1: controlword, mode 3), then RPDO3: controlword and target velocity.
        10 => frame(node, now, 0x205, &[[0x06, 0x07, 0x0F, 0x80][(r >> 10) as usize % 4], 0, 3, 0, 0, 0, 0]),
        _ => {
            let [v0, v1, v2, v3] = (((r >> 12) % 5) as i32 * 40 - 80).to_le_bytes();
            frame(node, now, 0x405, &[[0x06, 0x07, 0x0F, 0x0F, 0x0F][(r >> 10) as usize % 5], 0, v0, v1, v2, v3]);
        }
    });
    assert!(seen.tpdos > 1000 && seen.overflows > 0 && seen.frames > 2000, "{seen:?}");
}
