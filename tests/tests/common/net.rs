//! A virtual CAN network for scenario tests: any number of nodes (of any
//! dictionary) and master ports on one hal-host [`Bus`], on virtual time.
//!
//! Each node sits behind a modelled CAN controller with
//! [`TX_MAILBOXES`] transmit mailboxes used in FIFO order (bxCAN with
//! transmit FIFO priority on, as the style guide asks): the harness moves
//! frames from the node's queue (`Node::transmit`, highest priority first)
//! into free mailboxes, i.e. onto the port's FIFO on the bus, and a mailbox
//! frees up at the frame's tx-complete note. Frames the bus delivers reach
//! `Node::on_frame` stamped with the end of their EOF, and the node's
//! `process` runs at that same instant (unless the node counted the frame
//! as ignored), whenever one of its frames has left (so an SDO block upload
//! refills the queue at once), and at every deadline it asked for.
//!
//! [`Net`] implements the master's [`Network`] trait, so hal-host's
//! `sdo_upload`/`sdo_download` drivers run transfers against the nodes.
//! [`Net::run_until`] advances time event by event (bus events and node
//! deadlines); nothing reads a wall clock.
//!
//! The bus records a trace. A test that panics while it owns a `Net` leaves
//! the trace in `target/traces/<name>.log` in `candump -L` format (the
//! style guide's §2.6), written by `Net`'s `Drop`.

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::{Duration, Instant};
use embedded_can::Frame;
use hal_host::bus::{BitRate, Bus, PortController, PortId, frame_bits};
use hal_host::master::{self, DownloadMode, Network, SdoClientError, UploadMode};
use hal_host::trace::{CandumpWriter, TraceEntry};
use std::any::Any;
use std::path::{Path, PathBuf};

/// Transmit mailboxes of each node's controller (bxCAN has three).
pub const TX_MAILBOXES: usize = 3;

/// Steps at one instant [`Net::run_until`] takes before it calls the
/// simulation stuck (the bus reporting an event "now" without end).
const MAX_STEPS_AT_ONE_INSTANT: u32 = 10_000;

/// The node API the harness drives, over every dictionary type.
pub trait Device: Any {
    /// `Node::on_frame`; returns whether the node used the frame (did not
    /// count it as ignored), i.e. whether it needs a `process` call.
    fn on_frame(&mut self, now: Instant, frame: &CanFrame) -> bool;
    /// `Node::process`.
    fn process(&mut self, now: Instant) -> Option<Instant>;
    /// `Node::transmit`.
    fn transmit(&mut self) -> Option<CanFrame>;
    /// `Node::apply_bit_rate`: an LSS bit-rate switch reaches the port.
    fn apply_bit_rate(&mut self, controller: &mut PortController<'_>) -> bool {
        let _ = controller;
        false
    }
}

impl<O, A, S, const R: usize, const T: usize, const HB: usize, const SDO: usize> Device for Node<O, A, S, R, T, HB, SDO>
where
    O: ObjectDictionary + 'static,
    A: Application + 'static,
    S: Storage + 'static,
{
    fn on_frame(&mut self, now: Instant, frame: &CanFrame) -> bool {
        let ignored = self.counters().ignored;
        Node::on_frame(self, now, frame);
        // A frame the node counted as ignored changed nothing in it.
        self.counters().ignored == ignored
    }
    fn process(&mut self, now: Instant) -> Option<Instant> {
        // A reset goes on a stage per call, as the firmware's task steps it, until the boot-up is queued.
        loop {
            let deadline = Node::process(self, now);
            if !self.resetting() && !self.storing() {
                return deadline;
            }
        }
    }
    fn transmit(&mut self) -> Option<CanFrame> {
        Node::transmit(self)
    }
    fn apply_bit_rate(&mut self, controller: &mut PortController<'_>) -> bool {
        Node::apply_bit_rate(self, controller)
    }
}

/// One node on the bus.
struct Attached {
    device: Box<dyn Device>,
    port: PortId,
    /// Frames handed to the bus whose tx-complete note has not come yet.
    in_mailboxes: usize,
    /// What the node's last `process` returned.
    deadline: Option<Instant>,
    /// Something happened to the node outside the bus (power-on, a test
    /// changed its dictionary): process it at the next poll.
    wake: bool,
}

/// How often the harness called into the nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Calls {
    /// `on_frame` calls (one per node and frame it received).
    pub on_frame: u64,
    /// Of those, frames the node used (did not count as ignored).
    pub used: u64,
    /// `process` calls.
    pub process: u64,
}

/// A handle on a node of a [`Net`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeHandle {
    index: usize,
    /// The node's port on the bus (for fault injection, statistics, traces).
    pub port: PortId,
}

/// Nodes and master ports on one bus; see the [module docs](self).
pub struct Net {
    bus: Bus,
    nodes: Vec<Attached>,
    mailboxes: usize,
    /// Frames delivered so far (the bus's frame count at the last poll).
    frames_seen: u64,
    /// Some node has `wake` set.
    woken: bool,
    /// The earliest node deadline after the last poll's instant.
    next_deadline: Option<Instant>,
    name: String,
    calls: Calls,
    /// Frames a master port received during an SDO transfer that the
    /// transfer did not claim (heartbeats, EMCY, PDOs).
    pub unclaimed: Vec<(Instant, CanFrame)>,
}

impl Net {
    /// An empty network at `rate`, recording a trace; `name` names the
    /// trace file a failing test leaves behind.
    pub fn new(name: &str, rate: BitRate) -> Net {
        let mut net = Net::untraced(name, rate);
        net.bus.enable_trace();
        net
    }

    /// An empty network without a trace (benchmarks: the trace of a long
    /// run takes memory and time).
    pub fn untraced(name: &str, rate: BitRate) -> Net {
        Net {
            bus: Bus::new(rate),
            nodes: Vec::new(),
            mailboxes: TX_MAILBOXES,
            frames_seen: 0,
            woken: false,
            next_deadline: None,
            name: name.to_owned(),
            calls: Calls::default(),
            unclaimed: Vec::new(),
        }
    }

    /// Attaches a node; its `process` runs at the next poll (boot-up).
    pub fn add_node<D: Device>(&mut self, device: D) -> NodeHandle {
        let port = self.bus.attach();
        self.nodes.push(Attached { device: Box::new(device), port, in_mailboxes: 0, deadline: None, wake: true });
        self.woken = true;
        NodeHandle { index: self.nodes.len() - 1, port }
    }

    /// Attaches a master port (frames it receives wait in the bus for
    /// [`Bus::recv`] or for an SDO transfer).
    pub fn add_master(&mut self) -> PortId {
        self.bus.attach()
    }

    /// The bus (time, statistics, faults, trace).
    pub fn bus(&mut self) -> &mut Bus {
        &mut self.bus
    }

    /// How often the harness called into the nodes so far.
    pub fn calls(&self) -> Calls {
        self.calls
    }

    /// The bus's time.
    pub fn now(&self) -> Instant {
        self.bus.now()
    }

    /// The node behind `h`, as its concrete type.
    ///
    /// Panics if the node is of another type.
    pub fn node<D: Device>(&self, h: NodeHandle) -> &D {
        let device: &dyn Any = &*self.nodes[h.index].device;
        device.downcast_ref().expect("the node's type")
    }

    /// The node behind `h`, mutably; it is processed again at the next
    /// poll, so that what the test changed takes effect at the bus's time.
    pub fn node_mut<D: Device>(&mut self, h: NodeHandle) -> &mut D {
        let attached = &mut self.nodes[h.index];
        attached.wake = true;
        self.woken = true;
        let device: &mut dyn Any = &mut *attached.device;
        device.downcast_mut().expect("the node's type")
    }

    /// Queues a data frame on a master port at the bus's time.
    pub fn send(&mut self, port: PortId, cob_id: u16, data: &[u8]) {
        master::send(&mut self.bus, port, cob_id, data).expect("a valid frame on a known port");
    }

    /// Runs the network up to and including `t`, event by event.
    pub fn run_until(&mut self, t: Instant) {
        let mut same_instant = 0;
        loop {
            let now = self.bus.now();
            let nodes = Network::poll(self, now);
            let Some(next) = [self.bus.next_event(), nodes].into_iter().flatten().min().filter(|&n| n <= t) else { break };
            if next <= now {
                same_instant += 1;
                assert!(same_instant < MAX_STEPS_AT_ONE_INSTANT, "the simulation is stuck at {now:?}");
            } else {
                same_instant = 0;
            }
            self.bus.run_until(next.max(now));
        }
        self.bus.run_until(t);
        Network::poll(self, t);
    }

    /// Runs the network for `d` from now.
    pub fn run_for(&mut self, d: Duration) {
        let t = self.now() + d;
        self.run_until(t);
    }

    /// Reads (index, sub) from node `node_id` over SDO from master port `port`.
    pub fn sdo_upload(&mut self, port: PortId, node_id: u8, index: u16, sub: u8, mode: UploadMode) -> Result<Vec<u8>, SdoClientError> {
        master::sdo_upload(self, port, node_id, index, sub, mode)
    }

    /// Writes `data` to (index, sub) of node `node_id` over SDO from master port `port`.
    pub fn sdo_download(
        &mut self,
        port: PortId,
        node_id: u8,
        index: u16,
        sub: u8,
        data: &[u8],
        mode: DownloadMode,
    ) -> Result<(), SdoClientError> {
        master::sdo_download(self, port, node_id, index, sub, data, mode)
    }

    /// An expedited download that must succeed.
    pub fn configure(&mut self, port: PortId, node_id: u8, index: u16, sub: u8, data: &[u8]) {
        let r = self.sdo_download(port, node_id, index, sub, data, DownloadMode::Expedited);
        assert_eq!(r, Ok(()), "node {node_id}: download to {index:#06x}:{sub}");
    }

    /// The frames on the bus from `since` on (inclusive), as
    /// `(EOF time, sender, COB-ID, data)`.
    pub fn frames_since(&self, since: Instant) -> Vec<(Instant, PortId, u16, Vec<u8>)> {
        self.bus
            .trace()
            .iter()
            .filter(|e| e.time >= since)
            .map(|e| (e.time, e.port, e.frame.cob_id().expect("11-bit identifier"), e.frame.data().to_vec()))
            .collect()
    }

    /// The trace from `since` on as `candump -L` text, one line per frame.
    pub fn candump_since(&self, since: Instant) -> String {
        let entries: Vec<TraceEntry> = self.bus.trace().iter().filter(|e| e.time >= since).copied().collect();
        let mut w = CandumpWriter::new(Vec::new(), "vcan0");
        w.write_entries(&entries).expect("writing to memory");
        String::from_utf8(w.into_inner().expect("writing to memory")).expect("ASCII")
    }

    /// Where a failing test's trace goes: `target/traces/<name>.log`.
    pub fn trace_path(&self) -> PathBuf {
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap_or(Path::new(".")).join("target"));
        target.join("traces").join(format!("{}.log", self.name))
    }

    /// Hands every frame the bus delivered to each node, runs the nodes
    /// that have something to do, and moves their frames to free mailboxes.
    fn poll_nodes(&mut self, now: Instant) -> Option<Instant> {
        let frames = self.bus.stats().frames;
        // Deliveries and tx-complete notes happen only when a frame completes.
        let delivered = frames != self.frames_seen;
        self.frames_seen = frames;
        if !delivered && !self.woken && self.next_deadline.is_none_or(|d| d > now) {
            return self.next_deadline;
        }
        self.woken = false;
        let mut next: Option<Instant> = None;
        for n in &mut self.nodes {
            let mut work = n.wake || n.deadline.is_some_and(|d| d <= now);
            n.wake = false;
            if delivered {
                while let Some((at, frame)) = self.bus.recv(n.port) {
                    let used = n.device.on_frame(at, &frame);
                    self.calls.on_frame += 1;
                    self.calls.used += u64::from(used);
                    work |= used;
                }
                while self.bus.tx_complete(n.port).is_some() {
                    n.in_mailboxes = n.in_mailboxes.saturating_sub(1);
                    work = true;
                }
            }
            if work {
                loop {
                    n.deadline = n.device.process(now);
                    self.calls.process += 1;
                    // The board's part of LSS "activate bit timing": switch the controller.
                    n.device.apply_bit_rate(&mut PortController { bus: &mut self.bus, port: n.port });
                    let mut moved = false;
                    while n.in_mailboxes < self.mailboxes {
                        let Some(frame) = n.device.transmit() else { break };
                        self.bus.send(n.port, frame).expect("the node's own port");
                        n.in_mailboxes += 1;
                        moved = true;
                    }
                    // Room in the node's queue again: let it refill at once.
                    if !moved {
                        break;
                    }
                }
            }
            // A deadline of "now" means "when the queue has room": the next
            // tx-complete note brings the node back.
            if let Some(d) = n.deadline.filter(|&d| d > now) {
                next = Some(next.map_or(d, |x| x.min(d)));
            }
        }
        self.next_deadline = next;
        next
    }
}

impl Network for Net {
    fn bus(&mut self) -> &mut Bus {
        &mut self.bus
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.poll_nodes(now)
    }

    fn unclaimed(&mut self, at: Instant, frame: &CanFrame) {
        self.unclaimed.push((at, *frame));
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        if !std::thread::panicking() || self.bus.trace().is_empty() {
            return;
        }
        let path = self.trace_path();
        let written = path.parent().map_or(Ok(()), std::fs::create_dir_all).and_then(|()| {
            let mut w = CandumpWriter::new(std::fs::File::create(&path)?, "vcan0");
            w.write_bus_trace(&self.bus)?;
            w.into_inner().map(|_| ())
        });
        match written {
            Ok(()) => eprintln!("candump trace of the failed test: {}", path.display()),
            Err(e) => eprintln!("could not write the trace to {}: {e}", path.display()),
        }
    }
}

/// Microseconds as an instant.
pub fn us(t: u64) -> Instant {
    Instant::from_micros(t)
}

/// Bits `frame` occupies on the wire up to the end of EOF, and in all
/// (with the 3-bit intermission): at 1 Mbit/s, microseconds.
pub fn bits(cob_id: u16, data: &[u8]) -> (u64, u64) {
    let b = frame_bits(&CanFrame::standard(cob_id, data).expect("valid frame"));
    (u64::from(b.to_eof()), u64::from(b.total()))
}
