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
mod filter;
mod lss;
mod router;

pub use app::{Application, NoApplication};
pub use comm::{Comm, EMCY_SLOTS, ErrorBehaviour};
pub use filter::{ACCEPTANCE_CAPACITY, AcceptanceList, AcceptedId};
pub use lss::BitRateControl;

use crate::frame::CanFrame;
use crate::id::CobId;
use crate::od::ObjectDictionary;
use crate::services::heartbeat::ConsumerEvent;
use crate::services::lss::{LssSlave, UNCONFIGURED};
use crate::services::nmt::{Nmt, State, Transition};
use crate::services::pdo::{PdoEvent, PdoTx};
use crate::services::sdo_server::{SdoServers, SdoTx};
use crate::services::store::{self, Part, StoredSet};
use crate::services::sync::SyncEvent;
use crate::storage::Storage;
use crate::time::{Instant, earliest};
use crate::txq::TxQueue;
use crate::wire::emcy::code;
use crate::wire::lss::MASTER_COB_ID as LSS_MASTER_COB_ID;
use crate::wire::nmt::{ERROR_CONTROL_BASE, NMT_COB_ID, NmtRequest, NmtState};
use crate::wire::time_stamp::TimeOfDay;
use router::Router;

/// Frames the transmit queue holds.
pub const TX_QUEUE: usize = 32;
/// Bytes an SDO download may carry (127 block segments of 7 bytes, rounded).
/// One buffer serves every SDO server of the node (see [`SdoServers`]).
pub const SDO_BUFFER: usize = 896;
/// SDO servers a node runs unless its type says otherwise: the default
/// server (0x1200) and three further ones (0x1201–0x1203). A server whose
/// parameter object the dictionary lacks, or whose COB-IDs are not valid,
/// stays off; each costs about 80 bytes of RAM, the download buffer is shared.
pub const SDO_SERVERS: usize = 4;
/// First SDO server parameter object.
const SDO_SERVER_PARAMETER: u16 = 0x1200;
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
/// `SDO` is the number of SDO servers (0x1200, 0x1201, …) the node runs, at
/// least the dictionary's `SDO_SERVER_COUNT` to serve all of them;
/// [`SDO_SERVERS`] unless given.
pub struct Node<
    O: ObjectDictionary,
    A: Application,
    S: Storage,
    const R: usize,
    const T: usize,
    const HB: usize,
    const SDO: usize = SDO_SERVERS,
> {
    od: O,
    app: A,
    storage: S,
    node_id: u8,
    nmt: Nmt,
    comm: Comm<R, T, HB>,
    sdo: SdoServers<SDO_BUFFER, SDO>,
    /// COB-IDs (client→server, server→client) of each SDO server, if valid.
    sdo_cob_ids: [Option<(u16, u16)>; SDO],
    txq: TxQueue<TX_QUEUE>,
    counters: Counters,
    boot_pending: bool,
    /// The RAM image may have changed since the TPDOs last compared their
    /// data (change-of-state detection runs only then, not on every call).
    touched: bool,
    reported_overflows: u32,
    /// The LSS slave, when the dictionary says `LSS_Supported`.
    lss: Option<LssSlave>,
    /// A serial number the board reports, written to 0x1018 sub 4 at every reset.
    serial: Option<u32>,
    /// The bit-rate table index in use, if known (stored or switched by LSS).
    bit_rate: Option<u8>,
    /// An LSS bit-rate switch in progress.
    switch: Option<lss::Switch>,
    /// A bit-rate change the board has not applied yet.
    bit_rate_request: Option<u8>,
    /// The identifiers the node consumes, for the board's acceptance filter.
    acceptance: filter::AcceptanceList,
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

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Powers the node on: loads the stored parameters, resets application
    /// and communication, and queues the boot-up message for the first
    /// [`Node::process`]. [`Node::unpowered`], then [`Node::power_on`].
    pub fn new(od: O, app: A, storage: S, node_id: u8, now: Instant) -> Self {
        let mut node = Self::unpowered(od, app, storage, node_id);
        node.power_on(now);
        node
    }

    /// A node before power-on, with `node_id` as its default node-id: it
    /// stays in Initialising, ignores every frame and sends nothing until
    /// [`Node::power_on`]. `od`'s contents do not matter (power-on resets
    /// the whole image). A firmware image builds it in its `static`
    /// (`StaticCell::init_with`) and powers it on there, so the powered node
    /// is never copied, as it is when [`Node::new`] returns it.
    pub fn unpowered(od: O, app: A, storage: S, node_id: u8) -> Self {
        Node {
            od,
            app,
            storage,
            node_id,
            nmt: Nmt::new(),
            comm: Comm::default(),
            sdo: SdoServers::new(),
            sdo_cob_ids: [None; SDO],
            txq: TxQueue::default(),
            counters: Counters::default(),
            boot_pending: false,
            touched: true,
            reported_overflows: 0,
            lss: None,
            serial: None,
            bit_rate: None,
            switch: None,
            bit_rate_request: None,
            acceptance: filter::AcceptanceList::default(),
        }
    }

    /// Powers on a node from [`Node::unpowered`], where it lies: loads the
    /// stored parameters (an LSS configuration overrides the default
    /// node-id), resets application and communication, and queues the
    /// boot-up message for the first [`Node::process`]. Once per node; a
    /// running node restarts through NMT reset node instead.
    pub fn power_on(&mut self, now: Instant) {
        // One check of the stored sets serves the LSS configuration and both parts of the reset.
        let stored = store::newest(self.od.dictionary(), &mut self.storage);
        self.load_lss_configuration(stored);
        self.reset_application_from(stored, now);
    }

    fn reset_application(&mut self, now: Instant) {
        let stored = store::newest(self.od.dictionary(), &mut self.storage);
        self.reset_application_from(stored, now);
    }

    /// Reset application (and then communication) with the newest stored set already found.
    fn reset_application_from(&mut self, stored: Option<StoredSet>, now: Instant) {
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_application(image, self.node_id);
        if let Some(set) = &stored {
            set.load(dict, image, self.node_id, &mut self.storage, Part::Application);
        }
        self.reset_communication_from(stored, now);
    }

    fn reset_communication(&mut self, now: Instant) {
        let stored = store::newest(self.od.dictionary(), &mut self.storage);
        self.reset_communication_from(stored, now);
    }

    /// Reset communication with the newest stored set already found.
    fn reset_communication_from(&mut self, stored: Option<StoredSet>, now: Instant) {
        // CiA 305: a node-id configured by LSS becomes active here.
        if let Some(lss) = &mut self.lss {
            self.node_id = lss.reset_communication();
        }
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_communication(image, self.node_id);
        if let Some(set) = &stored {
            set.load(dict, image, self.node_id, &mut self.storage, Part::Communication);
        }
        if let Some(serial) = self.serial {
            let _ = dict.write_unchecked(image, 0x1018, 4, &serial.to_le_bytes());
        }
        self.comm.configure(dict, image, self.node_id, now);
        self.refresh_lss();
        self.sdo.reset_all();
        self.configure_sdo();
        self.refresh_acceptance();
        self.nmt = Nmt::new();
        // An unconfigured node (0xFF) sends no boot-up and takes part in LSS only.
        self.boot_pending = self.node_id != UNCONFIGURED;
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
        self.touched = true;
        &mut self.od
    }

    /// Signals an application event for TPDO `n` (0-based; transmission
    /// types 0, 254, 255): it goes out at the next [`Node::process`] (type
    /// 0 at the next SYNC), inhibit time permitting. False if that TPDO is
    /// not valid or of another type.
    pub fn trigger_tpdo(&mut self, n: usize) -> bool {
        self.touched = true;
        self.comm.pdos.trigger(n)
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

    /// The COB-IDs (client→server, server→client) SDO server `i` (0-based:
    /// 0 is 0x1200) uses, or `None` if it is off.
    pub fn sdo_cob_ids(&self, i: usize) -> Option<(u16, u16)> {
        self.sdo_cob_ids.get(i).copied().flatten()
    }

    /// Reads the SDO server parameters 0x1200 + i sub 1 and 2 (reset
    /// communication, or after an SDO wrote one). A server whose COB-IDs
    /// changed drops its transfer. The default server exists even without
    /// 0x1200 (pre-defined connection set); a further one needs its object.
    fn configure_sdo(&mut self) {
        let dict = self.od.dictionary();
        let image = self.od.image();
        for (i, slot) in self.sdo_cob_ids.iter_mut().enumerate() {
            // 128 servers at most: 0x1280 and up are SDO client parameters.
            let Some(index) = u16::try_from(i).ok().filter(|&i| i < 0x80).map(|i| SDO_SERVER_PARAMETER + i) else { break };
            let (default_rx, default_tx) =
                if i == 0 { (Some(0x600 + u32::from(self.node_id)), Some(0x580 + u32::from(self.node_id))) } else { (None, None) };
            let rx = dict.read_u32(image, index, 1).or(default_rx);
            let tx = dict.read_u32(image, index, 2).or(default_tx);
            let new = match (rx.map(CobId), tx.map(CobId)) {
                (Some(rx), Some(tx)) if rx.is_valid() && tx.is_valid() => Some((rx.can_id(), tx.can_id())),
                _ => None,
            };
            if *slot != new {
                self.sdo.reset(i);
                *slot = new;
            }
        }
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
        // LSS "activate bit timing": silent from the request until the second delay ends.
        if self.switch.is_some() {
            return None;
        }
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
        if cob_id == LSS_MASTER_COB_ID && self.lss.is_some() && !rtr {
            self.lss_request(now, data);
            return;
        }
        if self.node_id == UNCONFIGURED {
            self.counters.ignored += 1;
            return;
        }
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
                let expired = self.comm.guarding.is_expired();
                let byte = self.comm.guarding.on_request(state.reported(), now);
                self.push(cob_id, &[byte]);
                if expired {
                    self.communication_recovered();
                }
            } else {
                self.counters.ignored += 1;
            }
            return;
        }
        if (ERROR_CONTROL_BASE + 1..=ERROR_CONTROL_BASE + 0x7F).contains(&cob_id) && !rtr {
            match data {
                [b] => match NmtState::from_code(*b) {
                    Some(s) => {
                        if self.comm.consumers.on_heartbeat((cob_id - ERROR_CONTROL_BASE) as u8, s, now) {
                            self.communication_recovered();
                        }
                    }
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
                self.touched = true;
                return;
            }
        }
        if state.sdo_allowed() {
            let server =
                self.sdo_cob_ids.iter().enumerate().find_map(|(i, ids)| ids.filter(|(rx, _)| *rx == cob_id).map(|(_, tx)| (i, tx)));
            if let Some((i, tx)) = server
                && !rtr
            {
                self.sdo_request(i, now, data, tx);
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
        self.touched = true;
        if self.nmt.state().pdo_allowed() {
            let Node { od, app, comm, txq, .. } = self;
            let dict = od.dictionary();
            let mut sink = PdoSink { txq, emcy: &mut comm.emcy, app };
            comm.pdos.on_sync(event, dict, od.image_mut(), &mut sink);
        }
        self.app.on_sync();
    }

    fn sdo_request(&mut self, i: usize, now: Instant, data: &[u8], tx_cob: u16) {
        self.touched = true;
        let Node { od, app, storage, comm, sdo, txq, node_id, .. } = self;
        let dict = od.dictionary();
        let mut router =
            Router { dict, image: od.image_mut(), app, comm, storage, node_id: *node_id, now, sdo_changed: false, consumed_changed: false };
        let mut sink = SdoSink { txq, cob_id: tx_cob };
        sdo.on_request(i, now, data, &mut router, &mut sink);
        let consumed_changed = router.consumed_changed;
        if router.sdo_changed {
            self.configure_sdo();
        }
        if consumed_changed {
            self.refresh_acceptance();
        }
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
        self.touched = true;
        if state.pdo_allowed() {
            self.comm.pdos.enter_operational(now);
        } else {
            self.comm.pdos.stop();
        }
        if !state.sdo_allowed() {
            // Stopped: a transfer in progress ends without a frame (CiA 301 table 64).
            self.sdo.reset_all();
        }
        self.app.on_state(state);
    }

    fn push(&mut self, cob_id: u16, data: &[u8]) -> bool {
        CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f))
    }

    /// A communication error (heartbeat or life guarding): EMCY 0x8130 and
    /// 0x1029. Every heartbeat event sends its EMCY (with the node-ID, 0 for
    /// life guarding), also while an earlier one is still active.
    fn communication_error(&mut self, node: u8, now: Instant) {
        let info = [node, 0, 0, 0, 0];
        if !self.comm.emcy.raise(code::HEARTBEAT, info) {
            self.comm.emcy.signal(code::HEARTBEAT, info);
        }
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

    /// A silent node was heard again, or the master resumed guarding: once
    /// no monitored node and no life guarding is in error, 0x8130 clears
    /// (and the last error cleared sends "error reset").
    fn communication_recovered(&mut self) {
        if !self.comm.consumers.any_timed_out() && !self.comm.guarding.is_expired() {
            self.comm.emcy.clear(code::HEARTBEAT);
        }
    }

    /// Runs timers and queued work; returns when it wants to be called again
    /// (earlier is harmless, later delays heartbeats and timeouts).
    pub fn process(&mut self, now: Instant) -> Option<Instant> {
        let switch_deadline = self.process_switch(now);
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
        if self.nmt.state().sdo_allowed() {
            let Node { od, app, storage, comm, sdo, txq, node_id, sdo_cob_ids, .. } = self;
            let dict = od.dictionary();
            let mut router = Router {
                dict,
                image: od.image_mut(),
                app,
                comm,
                storage,
                node_id: *node_id,
                now,
                sdo_changed: false,
                consumed_changed: false,
            };
            for (i, ids) in sdo_cob_ids.iter().enumerate() {
                if let Some((_, tx)) = *ids {
                    let deadline = sdo.poll(i, now, &mut router, &mut SdoSink { txq, cob_id: tx });
                    sdo_deadline = earliest(sdo_deadline, deadline);
                }
            }
            let consumed_changed = router.consumed_changed;
            if router.sdo_changed {
                self.configure_sdo();
            }
            if consumed_changed {
                self.refresh_acceptance();
            }
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
            // Building every TPDO to detect changes costs more than anything
            // else here: do it only when the image may have changed or a PDO
            // timer is due, not for every heartbeat of another node.
            let due = self.touched || self.comm.pdos.deadline().is_some_and(|d| d <= now);
            if due {
                self.touched = false;
                let Node { od, app, comm, txq, .. } = self;
                let dict = od.dictionary();
                let mut sink = PdoSink { txq, emcy: &mut comm.emcy, app };
                pdo_deadline = comm.pdos.poll(now, dict, od.image(), &mut sink);
            } else {
                pdo_deadline = self.comm.pdos.deadline();
            }
        }
        if self.txq.overflows() != self.reported_overflows {
            self.reported_overflows = self.txq.overflows();
            self.comm.emcy.signal(code::CAN_OVERRUN, [0; 5]);
        }
        if self.nmt.state().sdo_allowed() {
            // EMCY off: errors still reach the error register and the history.
            while let Some(e) = self.comm.emcy.take_unsent() {
                let dict = self.od.dictionary();
                self.comm.record(dict, self.od.image_mut(), &e);
                self.touched = true;
            }
            while self.txq.free() > 0 {
                let Some((cob_id, e)) = self.comm.emcy.poll(now) else { break };
                let dict = self.od.dictionary();
                self.comm.record(dict, self.od.image_mut(), &e);
                self.touched = true;
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
            switch_deadline,
        ];
        deadlines.into_iter().fold(None, earliest)
    }
}
