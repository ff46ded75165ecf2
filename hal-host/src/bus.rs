//! A virtual CAN bus on virtual time.
//!
//! Any number of ports (nodes, masters, sniffers) [`attach`](Bus::attach) and
//! get a [`PortId`]. [`send`](Bus::send) queues a frame in the port's
//! transmit FIFO; [`run_until`](Bus::run_until) simulates the wire:
//!
//! - whenever the bus is idle and frames are pending, arbitration picks the
//!   lowest [`CanFrame::priority`] among the *head* frames of all ports (one
//!   pending mailbox per controller, so each port's frames keep FIFO order;
//!   equal priorities from two ports go to the lower port index);
//! - the frame occupies the bus for its exact length ([`frame_bits`]: stuff
//!   bits counted over SOF..CRC, then CRC delimiter, ACK, EOF, intermission)
//!   at the sender's bit rate;
//! - at the end of EOF it is delivered to every other port at the same bit
//!   rate, stamped with that instant; a port at another bit rate sees nothing
//!   and the bus counts a bit-rate error; the sender gets a tx-complete note;
//! - the bus is free again after the 3-bit intermission.
//!
//! Time inside the bus is kept in nanoseconds (one bit at 800 kbit/s is
//! 1.25 µs); the [`Instant`]s it hands out are rounded *up* to the next
//! microsecond, so nobody sees a frame before it has ended.
//!
//! Error confinement is modelled coarsely: a transmit error adds 8 to the
//! sender's TEC and 1 to each receiver's REC, a success subtracts 1; a TEC
//! above 255 puts the port bus-off. Error-passive ports behave like
//! error-active ones (no suspend-transmission time). Missing ACKs are not
//! modelled: a frame nobody can receive still completes. Fault injection
//! lives in [`crate::fault`].

mod stats;
mod timing;

#[cfg(test)]
mod tests;

pub use stats::{BusStats, PortStats};
pub use timing::{
    BitRate, CRC_ERROR_DETECT_BITS, ERROR_FRAME_BITS, FrameBits, INTERMISSION_BITS, RECESSIVE_TAIL_BITS, TRAILER_BITS, crc15, frame_bits,
    frame_time_ns,
};

use crate::fault::{Faults, Outcome};
use crate::trace::TraceEntry;
use canopen_core::frame::CanFrame;
use canopen_core::time::Instant;
use std::collections::VecDeque;

/// A port's handle on one [`Bus`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PortId(usize);

impl PortId {
    /// The port's index: 0 for the first port attached, and so on.
    pub const fn index(self) -> usize {
        self.0
    }
}

/// Why a bus call was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusError {
    /// The [`PortId`] belongs to no port of this bus.
    UnknownPort,
}

impl core::fmt::Display for BusError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BusError::UnknownPort => f.write_str("unknown port"),
        }
    }
}

impl std::error::Error for BusError {}

/// A port's fault confinement state (ISO 11898-1 §12.1.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorState {
    /// Both error counters below 128.
    Active,
    /// An error counter at 128 or more.
    Passive,
    /// Off the bus until 128 × 11 recessive bits have gone by.
    BusOff,
}

/// A frame waiting in a port's transmit FIFO.
struct Queued {
    frame: CanFrame,
    /// When the frame may enter arbitration (send time plus the port's delay).
    ready_ns: u64,
}

/// A bus-off port counting recessive bits towards recovery.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BusOff {
    /// Complete sequences of 11 recessive bits seen so far.
    pub(crate) sequences: u64,
    /// Nothing before this instant counts (the time the port went bus-off,
    /// or the end of the last run already counted).
    pub(crate) from_ns: u64,
}

/// Sequences of 11 recessive bits that end bus-off (ISO 11898-1 §12.1.4.2).
pub(crate) const RECOVERY_SEQUENCES: u64 = 128;

pub(crate) struct Port {
    pub(crate) bitrate: BitRate,
    txq: VecDeque<Queued>,
    rxq: VecDeque<(Instant, CanFrame)>,
    tx_done: VecDeque<(Instant, CanFrame)>,
    /// Extra time every newly queued frame waits before arbitration.
    pub(crate) delay_ns: u64,
    pub(crate) tec: u16,
    pub(crate) rec: u16,
    pub(crate) bus_off: Option<BusOff>,
    pub(crate) stats: PortStats,
}

/// A frame on the wire.
#[derive(Clone, Copy)]
struct Transmission {
    port: PortId,
    frame: CanFrame,
    bits: FrameBits,
    rate: BitRate,
    start_ns: u64,
    outcome: Outcome,
}

impl Transmission {
    fn at_bit(&self, bits: u32) -> u64 {
        self.start_ns.saturating_add(self.rate.bits_to_ns(u64::from(bits)))
    }

    fn eof_ns(&self) -> u64 {
        self.at_bit(self.bits.to_eof())
    }

    /// When the transmission's fate is sealed: end of EOF, or the error flag.
    fn event_ns(&self) -> u64 {
        match self.outcome {
            Outcome::Deliver | Outcome::Drop => self.eof_ns(),
            Outcome::Corrupt => self.at_bit(self.bits.stuffed() + CRC_ERROR_DETECT_BITS),
        }
    }
}

enum Activity {
    Idle,
    Frame(Transmission),
    /// The rest of a frame after EOF, or an error frame: busy until `until_ns`.
    Busy {
        until_ns: u64,
    },
}

/// A virtual CAN bus; see the [module docs](self).
pub struct Bus {
    pub(crate) ports: Vec<Port>,
    default_rate: BitRate,
    pub(crate) now_ns: u64,
    activity: Activity,
    /// Start of the current (or last) run of recessive bits on the wire.
    pub(crate) recessive_from_ns: u64,
    busy_since_ns: Option<u64>,
    stats: BusStats,
    /// Transmissions started so far, retransmissions included.
    pub(crate) attempts: u64,
    pub(crate) faults: Faults,
    trace: Option<Vec<TraceEntry>>,
}

fn to_instant(ns: u64) -> Instant {
    Instant::from_micros(ns.div_ceil(1_000))
}

impl Bus {
    /// An empty, idle bus at time zero; ports attach at `rate` by default.
    pub fn new(rate: BitRate) -> Bus {
        Bus {
            ports: Vec::new(),
            default_rate: rate,
            now_ns: 0,
            activity: Activity::Idle,
            recessive_from_ns: 0,
            busy_since_ns: None,
            stats: BusStats::default(),
            attempts: 0,
            faults: Faults::default(),
            trace: None,
        }
    }

    /// Attaches a port at the bus's default bit rate.
    pub fn attach(&mut self) -> PortId {
        self.attach_with_bitrate(self.default_rate)
    }

    /// Attaches a port at `rate`.
    pub fn attach_with_bitrate(&mut self, rate: BitRate) -> PortId {
        self.ports.push(Port {
            bitrate: rate,
            txq: VecDeque::new(),
            rxq: VecDeque::new(),
            tx_done: VecDeque::new(),
            delay_ns: 0,
            tec: 0,
            rec: 0,
            bus_off: None,
            stats: PortStats::default(),
        });
        PortId(self.ports.len() - 1)
    }

    pub(crate) fn port_mut(&mut self, port: PortId) -> Result<&mut Port, BusError> {
        self.ports.get_mut(port.0).ok_or(BusError::UnknownPort)
    }

    pub(crate) fn port(&self, port: PortId) -> Option<&Port> {
        self.ports.get(port.0)
    }

    /// The bit rate `port` sends and receives at.
    pub fn bitrate(&self, port: PortId) -> Option<BitRate> {
        self.port(port).map(|p| p.bitrate)
    }

    /// Switches `port` to `rate` (as a node does after an LSS bit timing
    /// change); frames already queued go out at the new rate.
    pub fn set_bitrate(&mut self, port: PortId, rate: BitRate) -> Result<(), BusError> {
        self.port_mut(port)?.bitrate = rate;
        Ok(())
    }

    /// The bus's time: the last instant passed to [`run_until`](Self::run_until).
    pub fn now(&self) -> Instant {
        to_instant(self.now_ns)
    }

    /// Queues `frame` at the back of `port`'s transmit FIFO, at the bus's
    /// current time (call [`run_until`](Self::run_until) with the sender's
    /// time first).
    pub fn send(&mut self, port: PortId, frame: CanFrame) -> Result<(), BusError> {
        let now = self.now_ns;
        let p = self.port_mut(port)?;
        let ready = now.saturating_add(p.delay_ns).max(p.txq.back().map_or(0, |q| q.ready_ns));
        p.txq.push_back(Queued { frame, ready_ns: ready });
        Ok(())
    }

    /// Takes the oldest frame delivered to `port`, with the instant its EOF ended.
    pub fn recv(&mut self, port: PortId) -> Option<(Instant, CanFrame)> {
        self.ports.get_mut(port.0)?.rxq.pop_front()
    }

    /// Takes the oldest tx-complete note of `port`: the frame and the instant
    /// its EOF ended.
    pub fn tx_complete(&mut self, port: PortId) -> Option<(Instant, CanFrame)> {
        self.ports.get_mut(port.0)?.tx_done.pop_front()
    }

    /// Frames of `port` not yet sent (including one on the wire).
    pub fn tx_pending(&self, port: PortId) -> usize {
        self.port(port).map_or(0, |p| p.txq.len())
    }

    /// Counters of `port`.
    pub fn port_stats(&self, port: PortId) -> Option<PortStats> {
        self.port(port).map(|p| p.stats)
    }

    /// The fault confinement state of `port`.
    pub fn error_state(&self, port: PortId) -> Option<ErrorState> {
        self.port(port).map(|p| match p.bus_off {
            Some(_) => ErrorState::BusOff,
            None if p.tec >= 128 || p.rec >= 128 => ErrorState::Passive,
            None => ErrorState::Active,
        })
    }

    /// The transmit and receive error counters (TEC, REC) of `port`.
    pub fn error_counters(&self, port: PortId) -> Option<(u16, u16)> {
        self.port(port).map(|p| (p.tec, p.rec))
    }

    /// Whether nothing is on the wire (no frame, error frame or intermission).
    pub fn is_idle(&self) -> bool {
        matches!(self.activity, Activity::Idle)
    }

    /// Counters at the current time.
    pub fn stats(&self) -> BusStats {
        let mut s = self.stats;
        s.elapsed_ns = self.now_ns;
        if let Some(since) = self.busy_since_ns {
            s.busy_ns = s.busy_ns.saturating_add(self.now_ns.saturating_sub(since));
        }
        s
    }

    /// Starts recording every frame delivered on the bus (see [`crate::trace`]).
    pub fn enable_trace(&mut self) {
        self.trace.get_or_insert_with(Vec::new);
    }

    /// The frames recorded since [`enable_trace`](Self::enable_trace).
    pub fn trace(&self) -> &[TraceEntry] {
        self.trace.as_deref().unwrap_or(&[])
    }

    /// Takes the recorded frames, leaving recording on.
    pub fn take_trace(&mut self) -> Vec<TraceEntry> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// The next instant at which something happens on the bus (a frame
    /// starts or ends, an error frame, a bus-off recovery), rounded up to
    /// the microsecond; `None` if nothing will happen without new input.
    pub fn next_event(&self) -> Option<Instant> {
        self.next_event_ns().map(to_instant)
    }

    /// Simulates the bus up to and including `t`. A `t` before
    /// [`now`](Self::now) does nothing.
    pub fn run_until(&mut self, t: Instant) {
        let t_ns = t.as_micros().saturating_mul(1_000);
        if t_ns < self.now_ns {
            return;
        }
        while let Some(event) = self.next_event_ns().filter(|&e| e <= t_ns) {
            self.now_ns = event.max(self.now_ns);
            if !self.step() {
                break;
            }
        }
        self.now_ns = t_ns;
    }

    fn next_event_ns(&self) -> Option<u64> {
        let now = self.now_ns;
        let injected = self.faults.next_injection().map(|x| x.max(now));
        match &self.activity {
            Activity::Frame(tx) => {
                let cut = injected.filter(|&x| x < tx.event_ns().min(tx.eof_ns()));
                Some(cut.unwrap_or(tx.event_ns()))
            }
            Activity::Busy { until_ns } => {
                let recovery = self.next_recovery_ns().map(|r| r.max(now));
                Some(recovery.map_or(*until_ns, |r| r.min(*until_ns)))
            }
            Activity::Idle => {
                let ready =
                    self.ports.iter().filter(|p| p.bus_off.is_none()).filter_map(|p| p.txq.front()).map(|q| q.ready_ns.max(now)).min();
                let recovery = self.next_recovery_ns().map(|r| r.max(now));
                [ready, injected, recovery].into_iter().flatten().min()
            }
        }
    }

    /// When the earliest bus-off port recovers if the bus stays recessive.
    fn next_recovery_ns(&self) -> Option<u64> {
        self.ports
            .iter()
            .filter_map(|p| {
                let b = p.bus_off?;
                let missing = RECOVERY_SEQUENCES.saturating_sub(b.sequences);
                let from = b.from_ns.max(self.recessive_from_ns);
                Some(from.saturating_add(p.bitrate.bits_to_ns(missing * u64::from(RECESSIVE_TAIL_BITS))))
            })
            .min()
    }

    /// Handles everything due at `now_ns`; `false` if nothing was.
    fn step(&mut self) -> bool {
        let now = self.now_ns;
        match self.activity {
            Activity::Frame(tx) => {
                if self.faults.next_injection().is_some_and(|x| x <= now) && now < tx.event_ns().min(tx.eof_ns()) {
                    self.faults.pop_injection();
                    let sent = tx.rate.ns_to_bits(now.saturating_sub(tx.start_ns));
                    self.destroy(tx, sent);
                    true
                } else if tx.event_ns() <= now {
                    match tx.outcome {
                        Outcome::Corrupt => self.destroy(tx, u64::from(tx.bits.stuffed() + CRC_ERROR_DETECT_BITS)),
                        Outcome::Deliver | Outcome::Drop => self.complete(tx),
                    }
                    true
                } else {
                    false
                }
            }
            Activity::Busy { until_ns } => {
                let recovered = self.recover_due();
                if until_ns <= now {
                    self.activity = Activity::Idle;
                    if let Some(since) = self.busy_since_ns.take() {
                        self.stats.busy_ns = self.stats.busy_ns.saturating_add(now.saturating_sub(since));
                    }
                    return true;
                }
                recovered
            }
            Activity::Idle => {
                let recovered = self.recover_due();
                if self.faults.next_injection().is_some_and(|x| x <= now) {
                    self.faults.pop_injection();
                    self.end_recessive_run();
                    self.error_frame(now, self.default_rate);
                    true
                } else if let Some(port) = self.arbitrate() {
                    self.end_recessive_run();
                    self.start(port);
                    true
                } else {
                    recovered
                }
            }
        }
    }

    /// The port whose head frame wins arbitration now, if any may send.
    fn arbitrate(&self) -> Option<PortId> {
        let now = self.now_ns;
        self.ports
            .iter()
            .enumerate()
            .filter(|(_, p)| p.bus_off.is_none())
            .filter_map(|(i, p)| p.txq.front().filter(|q| q.ready_ns <= now).map(|q| (q.frame.priority(), i)))
            .min()
            .map(|(_, i)| PortId(i))
    }

    fn start(&mut self, port: PortId) {
        let Some(p) = self.ports.get(port.0) else { return };
        let Some(q) = p.txq.front() else { return };
        let (frame, rate) = (q.frame, p.bitrate);
        self.attempts += 1;
        let outcome = self.faults.decide(self.attempts, port, &frame);
        self.busy_since_ns.get_or_insert(self.now_ns);
        let tx = Transmission { port, frame, bits: frame_bits(&frame), rate, start_ns: self.now_ns, outcome };
        self.activity = Activity::Frame(tx);
    }

    /// EOF of a frame that got through (or was dropped by fault injection).
    fn complete(&mut self, tx: Transmission) {
        let stamp = to_instant(self.now_ns);
        let deliver = tx.outcome == Outcome::Deliver;
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i == tx.port.0 {
                p.txq.pop_front();
                p.tx_done.push_back((stamp, tx.frame));
                p.tec = p.tec.saturating_sub(1);
                p.stats.tx_frames += 1;
            } else if p.bus_off.is_some() || !deliver {
                continue;
            } else if p.bitrate == tx.rate {
                p.rxq.push_back((stamp, tx.frame));
                p.rec = p.rec.saturating_sub(1);
                p.stats.rx_frames += 1;
            } else {
                p.stats.bitrate_errors += 1;
                self.stats.bitrate_errors += 1;
            }
        }
        if deliver {
            if let Some(trace) = &mut self.trace {
                trace.push(TraceEntry { time: stamp, port: tx.port, frame: tx.frame });
            }
        } else {
            self.stats.dropped += 1;
        }
        self.stats.frames += 1;
        self.stats.bits += u64::from(tx.bits.total());
        // Recessive from the ACK delimiter on (after CRC delimiter and ACK slot).
        self.recessive_from_ns = tx.at_bit(tx.bits.stuffed() + 2);
        self.activity = Activity::Busy { until_ns: tx.at_bit(tx.bits.total()) };
    }

    /// An error destroys `tx` after `sent` bits; the frame stays at the head
    /// of its port's FIFO and is retried after the error frame.
    fn destroy(&mut self, tx: Transmission, sent: u64) {
        self.stats.bits += sent;
        if let Some(p) = self.ports.get_mut(tx.port.0) {
            p.stats.tx_errors += 1;
            p.tec = p.tec.saturating_add(8);
        }
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i != tx.port.0 && p.bus_off.is_none() && p.bitrate == tx.rate {
                p.rec = p.rec.saturating_add(1);
            }
        }
        if self.ports.get(tx.port.0).is_some_and(|p| p.tec > 255) {
            self.enter_bus_off(tx.port);
        }
        self.error_frame(self.now_ns, tx.rate);
    }

    /// An error flag and delimiter starting at `at`, then intermission.
    fn error_frame(&mut self, at: u64, rate: BitRate) {
        self.busy_since_ns.get_or_insert(at);
        self.stats.error_frames += 1;
        for p in self.ports.iter_mut().filter(|p| p.bus_off.is_none()) {
            p.stats.error_frames += 1;
        }
        self.stats.bits += u64::from(ERROR_FRAME_BITS + INTERMISSION_BITS);
        self.recessive_from_ns = at.saturating_add(rate.bits_to_ns(6));
        let until_ns = at.saturating_add(rate.bits_to_ns(u64::from(ERROR_FRAME_BITS + INTERMISSION_BITS)));
        self.activity = Activity::Busy { until_ns };
    }

    pub(crate) fn enter_bus_off(&mut self, port: PortId) {
        let now = self.now_ns;
        if let Some(p) = self.ports.get_mut(port.0) {
            if p.bus_off.is_none() {
                p.stats.bus_off_count += 1;
            }
            p.bus_off = Some(BusOff { sequences: 0, from_ns: now });
        }
    }

    /// The bus turns dominant now: credit bus-off ports with the complete
    /// 11-bit sequences of the recessive run that just ended.
    fn end_recessive_run(&mut self) {
        let (now, run_start) = (self.now_ns, self.recessive_from_ns);
        for p in &mut self.ports {
            if let Some(b) = &mut p.bus_off {
                let from = b.from_ns.max(run_start);
                let bits = p.bitrate.ns_to_bits(now.saturating_sub(from));
                b.sequences = b.sequences.saturating_add(bits / u64::from(RECESSIVE_TAIL_BITS));
                b.from_ns = now;
            }
        }
    }

    /// Ends bus-off for every port whose recovery is due; `true` if any.
    fn recover_due(&mut self) -> bool {
        let (now, run_start) = (self.now_ns, self.recessive_from_ns);
        let mut any = false;
        for p in &mut self.ports {
            if let Some(b) = p.bus_off {
                let from = b.from_ns.max(run_start);
                let bits = p.bitrate.ns_to_bits(now.saturating_sub(from));
                if from <= now && b.sequences.saturating_add(bits / u64::from(RECESSIVE_TAIL_BITS)) >= RECOVERY_SEQUENCES {
                    p.bus_off = None;
                    p.tec = 0;
                    p.rec = 0;
                    any = true;
                }
            }
        }
        any
    }
}

/// One port of the bus as a node's CAN controller sees it: LSS "activate bit
/// timing" switches the port, after which frames at the old rate are not
/// understood (counted as bit-rate errors).
pub struct PortController<'a> {
    /// The bus.
    pub bus: &'a mut Bus,
    /// The node's port.
    pub port: PortId,
}

impl canopen_core::node::BitRateControl for PortController<'_> {
    fn set_bit_rate(&mut self, index: u8) {
        if let Some(rate) = BitRate::from_cia_index(index) {
            // An unknown port cannot happen for a port the bus handed out.
            let _ = self.bus.set_bitrate(self.port, rate);
        }
    }
}
