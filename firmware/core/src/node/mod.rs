//! The node: owns the dictionary and every service, routes each received
//! frame by COB-ID, runs the timers, and queues what it sends.
//!
//! Sans-IO and interrupt-friendly: [`Node::on_frame`] does bounded work (a
//! handful of identifier compares, then one service; never a scan of the
//! dictionary), [`Node::process`] runs the timers and returns the next
//! deadline, and [`Node::transmit`] hands out queued frames in CAN priority
//! order. Nothing is global: any number of nodes can live in one process.

mod app;
mod comm;
mod router;

pub use app::{Application, NoApplication};
pub use comm::{Comm, EMCY_SLOTS, ErrorBehaviour};

use crate::frame::CanFrame;
use crate::od::ObjectDictionary;
use crate::services::heartbeat::ConsumerEvent;
use crate::services::nmt::{Nmt, State, Transition};
use crate::services::pdo::{PdoEvent, PdoTx};
use crate::services::sdo_server::{SdoServer, SdoTx};
use crate::services::store::{self, Part};
use crate::services::sync::SyncEvent;
use crate::storage::Storage;
use crate::time::Instant;
use crate::txq::TxQueue;
use crate::wire::emcy::code;
use crate::wire::nmt::{ERROR_CONTROL_BASE, NMT_COB_ID, NmtRequest, NmtState};
use crate::wire::time_stamp::TimeOfDay;
use router::Router;

/// Frames the transmit queue holds.
pub const TX_QUEUE: usize = 32;
/// Bytes an SDO download may carry (127 block segments of 7 bytes, rounded).
pub const SDO_BUFFER: usize = 896;
/// Queue slots an SDO transfer leaves free for heartbeat and EMCY.
const SDO_RESERVE: usize = 4;

/// What the node counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames received.
    pub rx: u32,
    /// Frames handed to the controller.
    pub tx: u32,
    /// Frames for this node that broke their service's format (counted, then ignored).
    pub malformed: u32,
    /// Frames no service of this node consumes in its state.
    pub ignored: u32,
}

/// A CANopen slave.
///
/// `R`, `T` and `HB` are the RPDO, TPDO and heartbeat-consumer counts of the
/// dictionary (its generated `RPDO_COUNT`, `TPDO_COUNT`, `HB_CONSUMER_COUNT`).
pub struct Node<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize> {
    od: O,
    app: A,
    storage: S,
    node_id: u8,
    nmt: Nmt,
    comm: Comm<R, T, HB>,
    sdo: SdoServer<SDO_BUFFER>,
    txq: TxQueue<TX_QUEUE>,
    counters: Counters,
    boot_pending: bool,
    reported_overflows: u32,
}

/// Where the SDO server's frames go: the node's queue, keeping a reserve.
struct SdoSink<'a> {
    txq: &'a mut TxQueue<TX_QUEUE>,
    cob_id: u16,
}

impl SdoTx for SdoSink<'_> {
    fn send(&mut self, data: [u8; 8]) -> bool {
        self.txq.free() > SDO_RESERVE && CanFrame::standard(self.cob_id, &data).is_some_and(|f| self.txq.push(f))
    }
}

/// Where the PDOs' frames and events go: the queue, EMCY, the application.
struct PdoSink<'a, A: Application> {
    txq: &'a mut TxQueue<TX_QUEUE>,
    emcy: &'a mut crate::services::emcy::EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>,
    app: &'a mut A,
}

impl<A: Application> PdoTx for PdoSink<'_, A> {
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool {
        CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f))
    }

    fn event(&mut self, event: PdoEvent) {
        match event {
            PdoEvent::Received(n) => self.app.on_rpdo(n),
            PdoEvent::Error { rpdo, code } => {
                self.emcy.raise(code, [rpdo as u8 + 1, 0, 0, 0, 0]);
            }
            PdoEvent::ErrorCleared { code, .. } => self.emcy.clear(code),
        }
    }
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize> Node<O, A, S, R, T, HB> {
    /// Powers the node on: loads the stored parameters, resets application
    /// and communication, and queues the boot-up message for the first
    /// [`Node::process`].
    pub fn new(od: O, app: A, storage: S, node_id: u8, now: Instant) -> Self {
        let mut node = Node {
            od,
            app,
            storage,
            node_id,
            nmt: Nmt::new(),
            comm: Comm::default(),
            sdo: SdoServer::new(),
            txq: TxQueue::default(),
            counters: Counters::default(),
            boot_pending: false,
            reported_overflows: 0,
        };
        node.reset_application(now);
        node
    }

    fn reset_application(&mut self, now: Instant) {
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_application(image, self.node_id);
        store::load(dict, image, self.node_id, &mut self.storage, Part::Application);
        self.reset_communication(now);
    }

    fn reset_communication(&mut self, now: Instant) {
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_communication(image, self.node_id);
        store::load(dict, image, self.node_id, &mut self.storage, Part::Communication);
        self.comm.configure(dict, image, self.node_id, now);
        self.sdo.reset();
        self.nmt = Nmt::new();
        self.boot_pending = true;
        self.app.on_state(State::Initialising);
    }

    /// The node-id.
    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    /// The NMT state.
    pub fn state(&self) -> State {
        self.nmt.state()
    }

    /// The dictionary (the generated `Ram` with its typed accessors).
    pub fn od(&self) -> &O {
        &self.od
    }

    /// The dictionary, for the application to write; change-of-state TPDOs
    /// see the new values at the next [`Node::process`].
    pub fn od_mut(&mut self) -> &mut O {
        &mut self.od
    }

    /// The device's hooks.
    pub fn app(&self) -> &A {
        &self.app
    }

    /// The device's hooks, mutably.
    pub fn app_mut(&mut self) -> &mut A {
        &mut self.app
    }

    /// The storage.
    pub fn storage_mut(&mut self) -> &mut S {
        &mut self.storage
    }

    /// Frame counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Frames refused by the full transmit queue.
    pub fn tx_overflows(&self) -> u32 {
        self.txq.overflows()
    }

    /// The communication services (for inspection in tests and tools).
    pub fn comm(&self) -> &Comm<R, T, HB> {
        &self.comm
    }

    /// Raises an application error: EMCY with `code`, error register, 0x1003.
    pub fn raise_error(&mut self, code: u16, info: [u8; 5]) {
        self.comm.emcy.raise(code, info);
    }

    /// Clears an application error; the last one cleared sends "error reset".
    pub fn clear_error(&mut self, code: u16) {
        self.comm.emcy.clear(code);
    }

    /// The next frame to send, highest priority first.
    pub fn transmit(&mut self) -> Option<CanFrame> {
        let f = self.txq.pop()?;
        self.counters.tx = self.counters.tx.wrapping_add(1);
        Some(f)
    }

    /// Puts back a frame the controller could not send (it goes out first).
    pub fn requeue(&mut self, frame: CanFrame) {
        if self.txq.push_front(frame) {
            self.counters.tx = self.counters.tx.wrapping_sub(1);
        }
    }

    /// Handles one received frame. Bounded work; call it from the CAN RX interrupt.
    pub fn on_frame(&mut self, now: Instant, frame: &CanFrame) {
        use embedded_can::Frame;
        self.counters.rx = self.counters.rx.wrapping_add(1);
        // CANopen uses 11-bit identifiers only.
        let Some(cob_id) = frame.cob_id() else {
            self.counters.ignored += 1;
            return;
        };
        let rtr = frame.is_remote_frame();
        let data = frame.data();
        if cob_id == NMT_COB_ID {
            match NmtRequest::parse(data) {
                Ok(request) if !rtr => self.nmt_command(request, now),
                _ => self.counters.malformed += 1,
            }
            return;
        }
        let state = self.nmt.state();
        if state == State::Initialising {
            self.counters.ignored += 1;
            return;
        }
        if cob_id == ERROR_CONTROL_BASE + u16::from(self.node_id) {
            if rtr && !self.comm.heartbeat.active() {
                let byte = self.comm.guarding.on_request(state.reported(), now);
                self.push(cob_id, &[byte]);
            } else {
                self.counters.ignored += 1;
            }
            return;
        }
        if (ERROR_CONTROL_BASE + 1..=ERROR_CONTROL_BASE + 0x7F).contains(&cob_id) && !rtr {
            match data {
                [b] => match NmtState::from_code(*b) {
                    Some(s) => self.comm.consumers.on_heartbeat((cob_id - ERROR_CONTROL_BASE) as u8, s, now),
                    None => self.counters.malformed += 1,
                },
                _ => self.counters.malformed += 1,
            }
            return;
        }
        if state.sdo_allowed() && cob_id == self.comm.sync.cob_id() && !rtr {
            match self.comm.sync.on_frame(now, data) {
                Ok(event) => self.synchronise(now, &event),
                Err(e) => {
                    self.counters.malformed += 1;
                    self.comm.emcy.signal(e.emcy_code(), [0; 5]);
                }
            }
            return;
        }
        if state.pdo_allowed() {
            let Node { od, app, comm, txq, .. } = self;
            let dict = od.dictionary();
            let mut sink = PdoSink { txq, emcy: &mut comm.emcy, app };
            let matched = if rtr {
                comm.pdos.on_rtr(now, cob_id, dict, od.image(), &mut sink)
            } else {
                comm.pdos.on_frame(now, cob_id, data, od.image_mut(), &mut sink)
            };
            if matched {
                return;
            }
        }
        if state.sdo_allowed() {
            if let Some((rx, tx)) = self.comm.sdo_cob_ids
                && cob_id == rx
                && !rtr
            {
                self.sdo_request(now, data, tx);
                return;
            }
            if Some(cob_id) == self.comm.time_cob_id && !rtr {
                match TimeOfDay::parse(data) {
                    Some(t) => self.app.on_time(t),
                    None => self.counters.malformed += 1,
                }
                return;
            }
        }
        self.counters.ignored += 1;
    }

    /// A SYNC arrived or was produced: synchronous PDOs run (in Operational).
    fn synchronise(&mut self, now: Instant, event: &SyncEvent) {
        let _ = now;
        if self.nmt.state().pdo_allowed() {
            let Node { od, app, comm, txq, .. } = self;
            let dict = od.dictionary();
            let mut sink = PdoSink { txq, emcy: &mut comm.emcy, app };
            comm.pdos.on_sync(event, dict, od.image_mut(), &mut sink);
        }
        self.app.on_sync();
    }

    fn sdo_request(&mut self, now: Instant, data: &[u8], tx_cob: u16) {
        let Node { od, app, storage, comm, sdo, txq, node_id, .. } = self;
        let dict = od.dictionary();
        let mut router = Router { dict, image: od.image_mut(), app, comm, storage, node_id: *node_id, now };
        let mut sink = SdoSink { txq, cob_id: tx_cob };
        sdo.on_request(now, data, &mut router, &mut sink);
    }

    fn nmt_command(&mut self, request: NmtRequest, now: Instant) {
        match self.nmt.on_command(request, self.node_id) {
            Transition::None => {}
            Transition::Entered(state) => self.entered(state, now),
            Transition::ResetApplication => self.reset_application(now),
            Transition::ResetCommunication => self.reset_communication(now),
        }
    }

    fn entered(&mut self, state: State, now: Instant) {
        if state.pdo_allowed() {
            self.comm.pdos.enter_operational(now);
        } else {
            self.comm.pdos.stop();
        }
        if !state.sdo_allowed() {
            // Stopped: a transfer in progress ends without a frame (CiA 301 table 64).
            self.sdo.reset();
        }
        self.app.on_state(state);
    }

    fn push(&mut self, cob_id: u16, data: &[u8]) -> bool {
        CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f))
    }

    /// A communication error (heartbeat or life guarding): EMCY 0x8130 and 0x1029.
    fn communication_error(&mut self, node: u8, now: Instant) {
        self.comm.emcy.raise(code::HEARTBEAT, [node, 0, 0, 0, 0]);
        let dict = self.od.dictionary();
        let next = match Comm::<R, T, HB>::error_behaviour(dict, self.od.image()) {
            ErrorBehaviour::PreOperational if self.nmt.state() == State::Operational => Some(State::PreOperational),
            ErrorBehaviour::Stopped => Some(State::Stopped),
            _ => None,
        };
        if let Some(s) = next
            && let Transition::Entered(s) = self.nmt.enter(s)
        {
            self.entered(s, now);
        }
    }

    /// Runs timers and queued work; returns when it wants to be called again
    /// (earlier is harmless, later delays heartbeats and timeouts).
    pub fn process(&mut self, now: Instant) -> Option<Instant> {
        if self.boot_pending {
            let id = ERROR_CONTROL_BASE + u16::from(self.node_id);
            if self.push(id, &[NmtState::BootUp.code()]) {
                self.boot_pending = false;
                // 0x1F80 bit 2: the node starts itself (CiA 302-2), without waiting for NMT.
                let auto_start =
                    self.od.dictionary().read(self.od.image(), 0x1F80, 0).ok().and_then(|v| v.first().copied()).unwrap_or(0) & 0x04 != 0;
                let state = self.nmt.boot_up_done(auto_start);
                let dict = self.od.dictionary();
                self.comm.reconfigure(0x1017, dict, self.od.image(), self.node_id, now);
                self.entered(state, now);
            }
        }
        if self.nmt.state() != State::Initialising && self.comm.heartbeat.poll(now) {
            let id = ERROR_CONTROL_BASE + u16::from(self.node_id);
            self.push(id, &[self.nmt.state().reported().code()]);
        }
        while let Some(ConsumerEvent::Timeout { node_id }) = self.comm.consumers.poll(now) {
            self.communication_error(node_id, now);
        }
        if self.comm.guarding.poll(now) {
            self.communication_error(0, now);
        }
        let mut sdo_deadline = None;
        if self.nmt.state().sdo_allowed()
            && let Some((_, tx)) = self.comm.sdo_cob_ids
        {
            let Node { od, app, storage, comm, sdo, txq, node_id, .. } = self;
            let dict = od.dictionary();
            let mut router = Router { dict, image: od.image_mut(), app, comm, storage, node_id: *node_id, now };
            sdo_deadline = sdo.poll(now, &mut router, &mut SdoSink { txq, cob_id: tx });
        }
        if self.nmt.state().sdo_allowed() {
            // The SYNC producer (0x1005 bit 30): the node runs its own synchronous PDOs too.
            if let Some(event) = self.comm.sync.poll(now) {
                let mut buf = [0u8; 1];
                let cob_id = self.comm.sync.cob_id();
                let data = event.message().emit(&mut buf);
                if CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f)) {
                    self.synchronise(now, &event);
                }
            }
        }
        let mut pdo_deadline = None;
        if self.nmt.state().pdo_allowed() {
            let Node { od, app, comm, txq, .. } = self;
            let dict = od.dictionary();
            let mut sink = PdoSink { txq, emcy: &mut comm.emcy, app };
            pdo_deadline = comm.pdos.poll(now, dict, od.image(), &mut sink);
        }
        if self.txq.overflows() != self.reported_overflows {
            self.reported_overflows = self.txq.overflows();
            self.comm.emcy.signal(code::CAN_OVERRUN, [0; 5]);
        }
        if self.nmt.state().sdo_allowed() {
            while self.txq.free() > 0 {
                let Some((cob_id, e)) = self.comm.emcy.poll(now) else { break };
                let dict = self.od.dictionary();
                self.comm.record(dict, self.od.image_mut(), &e);
                self.push(cob_id, &e.emit());
            }
        }
        let deadlines = [
            self.boot_pending.then_some(now),
            self.comm.heartbeat.deadline(),
            self.comm.consumers.deadline(),
            self.comm.guarding.deadline(),
            if self.nmt.state().sdo_allowed() { self.comm.emcy.deadline() } else { None },
            sdo_deadline,
            pdo_deadline,
            if self.nmt.state().sdo_allowed() { self.comm.sync.deadline() } else { None },
        ];
        deadlines.into_iter().flatten().min()
    }
}
