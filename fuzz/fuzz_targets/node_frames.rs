//! A node survives any sequence of frames, time steps and process calls,
//! and afterwards an NMT reset communication brings it back: it answers an
//! SDO upload of 0x1000 with exactly the expected frame (on the node-id LSS
//! may have configured meanwhile). The UNITEK DS speaks its own register
//! protocol instead (CANopen is off): afterwards it answers a READ of its
//! firmware register 0x1B on its RX/TX ids, whatever the frames made of them.
//!
//! Input layout (every read past the end gives zeros):
//! - byte 0: the dictionary (`% 8`: 1..=5 one of the five devices in
//!   `firmware::devices::ALL` order, anything else the interop test node);
//! - byte 1: the node-id (`1 + b % 127`);
//! - then operations, one tag byte each (`tag % 8`):
//!   - 0 frame: 2 bytes little-endian `r`, id = `r & 0x7FF`, length =
//!     `min((r >> 11) & 0xF, 8)`, remote frame if `r & 0x8000` (its DLC is
//!     the length); a data frame then takes 8 bytes, the first `length` of
//!     which are its data;
//!   - 1 small step: 1 byte, time += byte × 100 µs;
//!   - 2 large step: 8 bytes little-endian, time += that many µs (saturating);
//!   - 3 process, then send every queued frame;
//!   - 4 go to the deadline the last process returned (if it is later);
//!   - 5 send one queued frame;
//!   - 6 take one queued frame and put it back (the controller was busy);
//!   - 7 frame to this node's SDO server: 8 data bytes follow.
//!
//! Checked on the way: every frame sent is a standard frame of at most 8
//! bytes, and `process` does not keep asking to be called again at once
//! (a firmware would spin).
#![no_main]

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, NoApplication, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::time::{Duration, Instant};
use embedded_can::Frame;
use firmware::devices::{agile, bmaxx4400, ec5000, sendix, unitek_ds};
use hal_host::fixtures::interop;
use hal_host::storage::MemStorage;
use libfuzzer_sys::fuzz_target;

/// The operations, read from the input.
struct Ops<'a> {
    data: &'a [u8],
}

impl Ops<'_> {
    fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    fn bytes<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        for b in &mut out {
            *b = self.byte();
        }
        out
    }
}

fuzz_target!(|data: &[u8]| {
    let mut ops = Ops { data };
    let which = ops.byte() % 8;
    let node_id = 1 + ops.byte() % 127;
    // The counts are const parameters of the node; each dictionary names its
    // own. The expected device type comes from the generated accessor (the
    // EDS default, in flash), not through the SDO server.
    // Each device runs with its own application, as its image does.
    macro_rules! device {
        ($od:path, $app:expr) => {{
            use $od as od;
            let device_type = od::Ram::new(node_id).device_type();
            run::<od::Ram, _, { od::RPDO_COUNT }, { od::TPDO_COUNT }, { od::HB_CONSUMER_COUNT }>(
                od::Ram::new(node_id),
                $app,
                node_id,
                device_type,
                ops,
            )
        }};
    }
    match which {
        1 => device!(ec5000::od, ec5000::App::NEW),
        2 => device!(unitek_ds::od, unitek_ds::App::NEW),
        3 => device!(sendix::od, sendix::App::NEW),
        4 => device!(bmaxx4400::od, bmaxx4400::App::NEW),
        5 => device!(agile::od, agile::App::NEW),
        _ => device!(interop::od, NoApplication),
    }
});

type Dut<O, A, const R: usize, const T: usize, const HB: usize> = Node<O, A, MemStorage, R, T, HB>;

/// Sends one queued frame, checking it.
fn send_one<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    node: &mut Dut<O, A, R, T, HB>,
) -> Option<CanFrame> {
    let f = node.transmit()?;
    assert!(f.cob_id().is_some(), "the node sent an extended frame: {f:?}");
    assert!(f.dlc() <= 8 && f.data().len() <= 8, "the node sent more than 8 bytes: {f:?}");
    Some(f)
}

fn drain<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    node: &mut Dut<O, A, R, T, HB>,
) -> Vec<CanFrame> {
    let mut out = Vec::new();
    while let Some(f) = send_one(node) {
        out.push(f);
        assert!(out.len() <= 1024, "transmit() never runs dry");
    }
    out
}

/// `process`, then sends everything; repeats while the node asks to be
/// called again at once, which must settle.
fn process<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    node: &mut Dut<O, A, R, T, HB>,
    now: Instant,
) -> Option<Instant> {
    let mut rounds = 0;
    loop {
        let next = node.process(now);
        drain(node);
        match next {
            // At the end of time every deadline saturates to `now`; that is
            // not a bug, but a reset or a store still runs its stages, one per call.
            Some(d) if d <= now && now.as_micros() >= u64::MAX / 2 => {
                rounds += 1;
                let busy = node.state() == canopen_core::services::nmt::NmtState::Initialising || node.storing();
                if !busy || rounds >= 64 {
                    return next;
                }
            }
            Some(d) if d <= now => {
                rounds += 1;
                // A store (a stage per call) and a reset waiting for it take some 30 calls.
                assert!(rounds < 64, "process({now:?}) keeps returning a deadline not after now ({d:?}) state {:?} storing {}", node.state(), node.storing());
            }
            _ => return next,
        }
    }
}

fn run<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    od: O,
    app: A,
    node_id: u8,
    device_type: u32,
    mut ops: Ops,
) {
    let region = od.dictionary().defaults.len + 64;
    let mut now = Instant::ZERO;
    let mut node: Dut<O, A, R, T, HB> = Node::new(od, app, MemStorage::new(region), node_id, now);
    let mut deadline = None;
    while !ops.data.is_empty() {
        match ops.byte() % 8 {
            0 => {
                let r = u16::from_le_bytes(ops.bytes());
                let id = r & 0x7FF;
                let len = usize::from((r >> 11) & 0xF).min(8);
                let frame = if r & 0x8000 != 0 {
                    CanFrame::remote(id, len)
                } else {
                    let data: [u8; 8] = ops.bytes();
                    CanFrame::standard(id, &data[..len])
                };
                node.on_frame(now, &frame.expect("an 11-bit id and at most 8 bytes make a frame"));
            }
            1 => now += Duration::from_micros(u64::from(ops.byte()) * 100),
            // Up to 12.7 days a step: far past the services' 32-bit timers'
            // horizon (35.8 min, the node moves its epoch), and never near the
            // end of a u64 clock, where time stops and no timer can end.
            2 => now += Duration::from_micros(u64::from_le_bytes(ops.bytes()) & ((1 << 40) - 1)),
            3 => deadline = process(&mut node, now),
            4 => {
                if let Some(d) = deadline.take() {
                    now = now.max(d);
                }
            }
            5 => {
                send_one(&mut node);
            }
            6 => {
                if let Some(f) = send_one(&mut node) {
                    node.requeue(f);
                }
            }
            _ => {
                let data: [u8; 8] = ops.bytes();
                let sdo = CanFrame::standard(0x600 + u16::from(node_id), &data).expect("valid frame");
                node.on_frame(now, &sdo);
            }
        }
    }

    // Back to a known state: time for an LSS bit-rate switch in progress to
    // end (two delays of at most 65.5 s, each ending at a process call), then
    // reset communication (broadcast), boot-up.
    for _ in 0..2 {
        now += Duration::from_secs(140);
        process(&mut node, now);
    }
    drain(&mut node);
    if !node.app().canopen() {
        return unitek_answers(&mut node, now);
    }
    // Reset communication (broadcast), boot-up.
    node.on_frame(now, &CanFrame::standard(0x000, &[0x82, 0]).expect("valid frame"));
    process(&mut node, now);
    let id = node.node_id();
    // LSS (0x7E5) may have configured another node-id, which becomes active at
    // this reset, or none (0xFF): an unconfigured node takes part in LSS only.
    if id == 0xFF {
        assert_eq!(node.state(), canopen_core::services::nmt::NmtState::Initialising, "an unconfigured node stays in Initialising");
        return;
    }
    assert!((1..=127).contains(&id), "node-id {id} after reset communication (started as {node_id})");
    assert!(node.state().sdo_allowed(), "after reset communication and boot-up the node is in {:?}", node.state());

    // An expedited upload of 0x1000 sub 0 gets exactly one answer, the device type.
    let request = CanFrame::standard(0x600 + u16::from(id), &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).expect("valid frame");
    node.on_frame(now, &request);
    node.process(now);
    let sent = drain(&mut node);
    let answers: Vec<&CanFrame> = sent.iter().filter(|f| f.cob_id() == Some(0x580 + u16::from(id))).collect();
    let [t0, t1, t2, t3] = device_type.to_le_bytes();
    let expected = CanFrame::standard(0x580 + u16::from(id), &[0x43, 0x00, 0x10, 0x00, t0, t1, t2, t3]).expect("valid frame");
    assert_eq!(answers, [&expected], "SDO upload of 0x1000 after reset communication; sent: {sent:x?}");
}

/// The register protocol still answers: `3D 1B 00` on the RX id (0x2068)
/// gets exactly `1B D8 01 00` (firmware 472) on the TX id (0x2069), DLC 6
/// if 0xDC asks for 32-bit replies. A stop first, so a cyclic read of 0x1B
/// the input may have started adds nothing.
fn unitek_answers<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(node: &mut Dut<O, A, R, T, HB>, now: Instant) {
    let register = |node: &Dut<O, A, R, T, HB>, regid: u16| {
        node.od().dictionary().read_u32(node.od().image(), 0x2000 + regid, 0).expect("a UNITEK register") as u16
    };
    let (rx, tx, wide) = (register(node, 0x68), register(node, 0x69), register(node, 0xDC) >> 8 == 0x01);
    for data in [[0x3D, 0x1B, 0xFF], [0x3D, 0x1B, 0x00]] {
        node.on_frame(now, &CanFrame::standard(rx, &data).expect("valid frame"));
    }
    node.process(now);
    let sent = drain(node);
    let answers: Vec<&CanFrame> = sent.iter().filter(|f| f.cob_id() == Some(tx) && f.data().first() == Some(&0x1B)).collect();
    let data: &[u8] = if wide { &[0x1B, 0xD8, 0x01, 0, 0, 0] } else { &[0x1B, 0xD8, 0x01, 0] };
    let expected = CanFrame::standard(tx, data).expect("valid frame");
    assert_eq!(answers, [&expected], "READ 0x1B on RX {rx:#X}; sent: {sent:x?}");
}
