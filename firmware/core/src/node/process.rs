//! The node's timers and queued work ([`Node::process`]): boot-up,
//! heartbeat and guarding, SDO timeouts, the SYNC producer, TPDOs and EMCY.

use crate::od::index;
use crate::od::{ObjectAccess, ObjectDictionary};
use crate::services::heartbeat::ConsumerEvent;
use crate::services::nmt::{NmtState, Transition};
use crate::services::pdo::ALL_TPDOS;
use crate::services::sdo_server::SdoServers;
use crate::storage::Storage;
use crate::time::{At, Instant, NEVER, at_since};
use crate::txq::TxQueue;
use crate::wire::nmt::{NmtStateCode, error_control_cob_id};

use super::router::Router;
use super::sinks::{PdoSink, SdoSink};
use super::{Application, Node, SDO_BUFFER, Source, TX_QUEUE};

/// While its frames cannot leave, the node is called at least this often
/// (µs): its timers (an SDO or heartbeat timeout, the end of an LSS switch
/// delay) are then late by less than this. Room in the queue brings a call
/// at once (`Node::due_again`).
const ROOM_RETRY: At = 1_000;

/// DS 301 V3's boot-up leaves on the EMCY's pre-defined identifier, 0x80 + node-ID.
const V3_BOOT_UP_BASE: u16 = 0x80;

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Runs timers and queued work; returns when it wants to be called again
    /// (earlier is harmless, later delays heartbeats and timeouts).
    ///
    /// Only what may have work runs: the services besides SDO and PDO when
    /// something changed them (`stale`) or their earliest deadline is due,
    /// the SDO servers while one is busy, the TPDOs a write may have
    /// changed or whose timers are due.
    ///
    /// Work that waits for room in the transmit queue asks for a call at
    /// once, but not twice while no frame has left meanwhile: then it asks
    /// for one a millisecond later, and the board calls again when its
    /// controller takes a frame (a controller that cannot send does not
    /// make the board spin).
    // In line: each image calls it at one place (the `CanNode` trampoline,
    // the size images' loop), so that place is the function.
    #[inline(always)]
    pub fn process(&mut self, now: Instant) -> Option<Instant> {
        let now = self.tick(now);
        let deadline = self.process_at::<true>(now);
        self.instant_of(deadline)
    }

    /// [`Node::process`] without its short path for a node that has only
    /// PDO work ([`Node::process_pdos`]): every call that is not idle
    /// takes the full path. What it sends and answers is what
    /// [`Node::process`] sends and answers; tests hold the short path to it.
    #[doc(hidden)]
    pub fn process_without_short_path(&mut self, now: Instant) -> Option<Instant> {
        let now = self.tick(now);
        let deadline = self.process_at::<false>(now);
        self.instant_of(deadline)
    }

    /// [`Node::process`]: its deadlines folded as [`At`]s, one compare each.
    /// `SHORT`: a node with only PDO work takes [`Node::process_pdos`]
    /// (if the device has the short path, [`Application::PDO_SHORT_PATH`]).
    #[inline(always)]
    fn process_at<const SHORT: bool>(&mut self, now: At) -> At {
        let now_at = now;
        // A store goes on a stage per call, alone in its call but for the
        // last, whose SDO poll below sends the answer; a reset that came
        // meanwhile waits for it, so it loads what was stored.
        if O::SERVICES.storage && self.hook.store.busy() {
            self.store_step();
            if self.hook.store.busy() || self.resetting() {
                return now_at;
            }
        }
        // A reset in progress goes on a stage per call; the call of its last
        // stage goes on below. A device with CANopen off starts none (power-on
        // completes its own), so for it this is left out.
        if self.app.canopen() && self.resetting() {
            self.reset_step(now);
            if self.resetting() {
                return now_at;
            }
        }
        // The device's timers first: what they write goes out in this call's TPDOs.
        let app_deadline = match self.app_due.skip(now) {
            Some(deadline) if A::POLL_WHEN_DUE => deadline,
            // Out of line: a device that polls when due does so on few calls.
            _ if A::POLL_WHEN_DUE => self.poll_app_due(now),
            _ => self.with_app_cold(now, |app, ctx| {
                let deadline = app.poll(ctx);
                at_since(ctx.hook.epoch, deadline)
            }),
        };
        if !self.app.canopen() {
            return app_deadline;
        }
        if self.quiet && !self.stale {
            if self.touched == 0 && now_at < self.next {
                return self.next.min(app_deadline);
            }
            // Nothing but the PDOs can have work before `others_next`.
            if SHORT && A::PDO_SHORT_PATH && now_at < self.others_next {
                return self.process_pdos(now).min(app_deadline);
            }
        }
        self.process_full(now, false).min(app_deadline)
    }

    /// The device's poll, for a device that polls when due
    /// ([`Application::POLL_WHEN_DUE`]); its deadline.
    #[inline(never)]
    fn poll_app_due(&mut self, now: At) -> At {
        let mut wake = false;
        let deadline = self.with_app_cold(now, |app, ctx| {
            let deadline = app.poll(ctx);
            let deadline = at_since(ctx.hook.epoch, deadline);
            wake = core::mem::take(&mut ctx.hook.wake);
            deadline
        });
        // A poll that asks for it runs again at the next process, whenever that is.
        self.app_due = super::PollDue::after(deadline, wake);
        deadline
    }

    /// The PDOs' part of [`Node::process`] alone, for a quiet node (no SDO
    /// transfer, no EMCY waiting) with nothing stale whose other services
    /// have nothing due before `others_next`: what the full call does for
    /// it (its checks of the core services, the SDO servers, the SYNC
    /// producer and the CAN controller would find nothing), without them.
    #[inline(always)]
    fn process_pdos(&mut self, now: At) -> At {
        // As in the full call (`others_next` is 0 in a state without PDOs).
        let pdo_deadline = self.poll_pdos(now);
        // A refused TPDO counted an overflow; an RPDO's hook may have raised
        // an EMCY: the full call goes on from its PDOs, polled here.
        if self.emcy_due() {
            self.next = pdo_deadline;
            return self.process_full(now, true);
        }
        let deadline = self.others_next.min(pdo_deadline);
        self.next = deadline;
        // No EMCY queued (`emcy_due`).
        self.quiet = true;
        deadline
    }

    /// The PDOs' poll, for both paths of [`Node::process`]: the PDOs'
    /// deadline after it. Building a TPDO to detect changes costs more than
    /// anything else here: only the TPDOs a write may have changed, and
    /// those whose timers are due, not for every heartbeat of another node.
    // In line: one copy in each path, as the short path needs it (a shared
    // out-of-line poll made the CiA 402 row 16 dearer).
    #[inline(always)]
    fn poll_pdos(&mut self, now: At) -> At {
        // A TPDO a write may have changed makes the poll due: no deadline to ask for.
        let mut pdo_deadline = NEVER;
        let due = self.touched != 0 || {
            pdo_deadline = self.comm.pdos.due();
            pdo_deadline <= now
        };
        if due {
            // A poll for any TPDO retries every TPDO waiting to (the poll sees which).
            let marked = core::mem::take(&mut self.touched);
            let Node { od, comm, txq, .. } = self;
            let comm = &mut **comm;
            let mut sink = PdoSink::<A>::new(txq, &mut comm.emcy);
            pdo_deadline = comm.pdos.poll_marked(now, marked, od.image(), &mut sink);
            let (received, errors) = (sink.received, sink.errors);
            // Most polls have nothing to tell (no call).
            if received | errors != 0 {
                self.pdo_events(now, received, errors);
            }
        }
        pdo_deadline
    }

    /// Whether EMCY has work in a call that is not full: the transmit
    /// queue's overflow to report or to clear, or a message queued.
    #[inline(always)]
    fn emcy_due(&self) -> bool {
        self.txq.overflows() != self.reported_overflows
            || (self.txq.is_empty() && self.comm.emcy.tx_overflow_active())
            || self.comm.emcy.has_queued()
    }

    /// Every service that may have work: [`Node::process`] past the store,
    /// the reset and the device's timers, for a call that is not idle; or
    /// the rest of the PDOs' short path when EMCY has work (`polled`: the
    /// short path polled the PDOs and left their deadline in `next`; this
    /// call does not poll again, which would count a TPDO the full queue
    /// refused twice).
    // Out of line: the idle call and the PDOs' short path do without its frame.
    #[inline(never)]
    fn process_full(&mut self, now: At, polled: bool) -> At {
        let now_at = now;
        // Before the boot-up is queued below: nothing may precede it in the queue.
        let booted = !self.boot_pending;
        let full = self.stale || self.core_deadline <= now_at;
        if full {
            // `process_core` clears `stale` (after what it ran, which may set it again).
            self.process_core(now);
        }
        let mut sdo_deadline = NEVER;
        // Idle servers have no timer and nothing to send: skip building the router for them.
        // Quiet since the last full call: no server is busy (a busy one has a
        // deadline, and a state that stopped them is stale, so full).
        if (full || !self.quiet) && self.nmt.state().sdo_allowed() && !self.sdo.all_idle() {
            sdo_deadline = self.poll_sdo(now);
        }
        if full && self.nmt.state().sdo_allowed() {
            // The SYNC producer (0x1005 bit 30): the node runs its own synchronous PDOs too.
            if let Some(event) = self.comm.sync.poll(now) {
                let mut buf = [0u8; 1];
                let cob_id = self.comm.sync.cob_id();
                let data = event.message().emit(&mut buf);
                if self.push(cob_id, data) {
                    self.synchronise(now, event.counter);
                }
            }
        }
        let pdo_allowed = self.nmt.state().pdo_allowed();
        let pdo_deadline = if polled {
            self.next
        } else if pdo_allowed {
            self.poll_pdos(now)
        } else {
            NEVER
        };
        let controller_deadline = self.controller.poll::<A>(now, booted, &mut self.comm.emcy);
        if core::mem::take(&mut self.controller.bus_off_unheard) {
            self.bus_off_at(now);
        }
        // EMCY: what the PDOs, the SDO servers or the hooks raised in this
        // call goes out in it, as does the queue overflow's.
        if full || self.emcy_due() {
            self.process_emcy(now, booted);
            self.core_deadline = self.core_deadline.min(self.emcy_deadline());
        }
        let others = self.core_deadline.min(controller_deadline);
        // The controller's deadline holds until a controller event (which
        // makes the node stale); the core services' until their deadline
        // or a change (stale too). Without PDOs there is no short path;
        // a device without it never reads `others_next`.
        if A::PDO_SHORT_PATH {
            self.others_next = if pdo_allowed { others } else { 0 };
        }
        let mut deadline = others.min(sdo_deadline).min(pdo_deadline);
        if deadline <= now_at {
            deadline = self.due_again(now_at);
        }
        self.next = deadline;
        // No SDO deadline: every server is idle (or the state stopped them all).
        self.quiet = sdo_deadline == NEVER && !self.comm.emcy.has_queued();
        deadline
    }

    /// The SDO servers' timers and what they have to send (a block
    /// upload's segments); their earliest deadline.
    // In line: out of line cost 20 bytes. The block upload's loop inside
    // is sensitive to what the full call around it holds (a sub-block cost
    // from 31 fewer to 119 more instructions as the full call changed):
    // `cargo xtask icount`'s worst single call watches it.
    #[inline(always)]
    fn poll_sdo(&mut self, now: At) -> At {
        let mut sdo_deadline = NEVER;
        let block = O::SERVICES.block_sdo;
        // Every server with identifiers, through either way into the node.
        let mut poll = |sdo: &mut SdoServers<SDO_BUFFER, SDO>,
                        ids: &[Option<(u16, u16)>; SDO],
                        od: &mut dyn ObjectAccess,
                        txq: &mut TxQueue<TX_QUEUE>| {
            for (i, ids) in ids.iter().enumerate() {
                if let Some((_, tx)) = *ids {
                    let deadline = sdo.poll_with(i, now, block, od, &mut SdoSink { txq, cob_id: tx, hold: None });
                    sdo_deadline = sdo_deadline.min(deadline);
                }
            }
        };
        // A constant: each image links one of the two.
        let effects = if A::SDO_HOOKS {
            let (mut ctx, app, sdo, txq, sdo_cob_ids) = self.split_sdo(now);
            let mut router = Router { ctx: &mut ctx, app, by: Source::Sdo, od: core::marker::PhantomData::<O>, staged: None };
            poll(sdo, sdo_cob_ids, &mut router, txq);
            ctx.effects
        } else {
            let (mut parts, sdo, txq, sdo_cob_ids) = self.sdo_parts(now, None);
            poll(sdo, sdo_cob_ids, &mut parts, txq);
            parts.effects
        };
        self.queue_raw();
        self.follow_sdo(effects);
        sdo_deadline
    }

    /// Whether a [`super::ServiceOptions`] switch (object sub 0, mask) is on.
    pub(super) fn option_set(&self, (index, mask): (u16, u32)) -> bool {
        self.od.dictionary().read_u32(self.od.image(), index, 0).unwrap_or(0) & mask != 0
    }

    /// The services besides SDO, PDO and EMCY: the LSS bit-rate switch,
    /// boot-up and the node's own start, heartbeat and guarding, the
    /// heartbeat consumers; their earliest deadline into `core_deadline`.
    fn process_core(&mut self, now: At) {
        let switch_deadline = self.process_switch(now);
        if self.boot_pending {
            let sent = match A::OPTIONS.boot_up_v3 {
                Some(switch) if self.option_set(switch) => {
                    let id = V3_BOOT_UP_BASE | u16::from(self.hook.node_id);
                    self.push(id, &[]) && self.push(id, &[0; 8])
                }
                _ => self.push(error_control_cob_id(self.hook.node_id), &[NmtStateCode::BootUp.code()]),
            };
            if sent {
                self.boot_pending = false;
                // 0x1F80 bit 2: the node starts itself (CiA 302-2), without waiting for NMT
                // (read as a `u32`, as the device switches: one read call for both).
                let auto_start = self.option_set((index::NMT_STARTUP, 0x04))
                    || A::OPTIONS.start_operational.is_some_and(|switch| self.option_set(switch));
                let state = self.nmt.boot_up_done(false);
                // The heartbeat producer from the boot-up on: reset communication
                // configured it from 0x1017, and every write since applied
                // itself (a download, `Ctx::write_object`); that also disarmed
                // guarding if the producer runs. A value set without side
                // effects (`Ctx::set_value`, `Ctx::set_at`) is not applied:
                // 0x1017 is the master's to configure, through the services.
                self.comm.heartbeat.restart(now);
                self.entered(state, now);
                self.start_pending = auto_start;
            }
        }
        if self.start_pending && self.txq.is_empty() {
            self.start_pending = false;
            if let Transition::Entered(s) = self.nmt.enter(NmtState::Operational) {
                self.entered(s, now);
            }
        }
        if self.nmt.state() != NmtState::Initialising && self.comm.heartbeat.poll(now) {
            let id = error_control_cob_id(self.hook.node_id);
            self.push(id, &[self.nmt.state().reported().code()]);
        }
        let consumers_deadline = loop {
            match self.comm.consumers.expire(now) {
                Ok(ConsumerEvent::Timeout { node_id }) => self.communication_error(node_id, now),
                Err(deadline) => break deadline,
            }
        };
        if O::SERVICES.guarding && self.comm.guarding.poll(now) {
            self.communication_error(0, now);
        }
        let mut deadline = self.comm.heartbeat.deadline().min(consumers_deadline).min(switch_deadline);
        if self.boot_pending || self.start_pending {
            // Due now: an earlier deadline is as due (the folded deadlines
            // only ever meet `now` and later moments).
            deadline = now;
        }
        if O::SERVICES.guarding {
            deadline = deadline.min(self.comm.guarding.deadline());
        }
        if self.nmt.state().sdo_allowed() {
            deadline = deadline.min(self.comm.sync.deadline());
        }
        // The EMCY deadline joins after this call's EMCY work.
        self.core_deadline = deadline;
        // What ran here may have changed a service again (a state entered):
        // the SYNC producer and EMCY of this call see it, the next call need not.
        self.stale = false;
    }

    /// The deadline of a call whose work is not done: `now`, unless no
    /// frame has left the queue since the last call that asked for it.
    /// Then what waits is room in the queue (an SDO answer or segment, an
    /// EMCY, the node's own start), which only [`Node::transmit`] makes: a
    /// board calls again when its controller takes a frame (its TX-empty
    /// interrupt wakes it), else after [`ROOM_RETRY`]. A node whose frames
    /// cannot leave (nobody acknowledges them, or an LSS bit-rate switch
    /// keeps it silent) would otherwise have its board spin.
    // Rare: a call asks to be called again at once only while something
    // waits for room. Not `#[cold]`: cold, the compiler laid its caller's
    // set-up out again around it (4 bytes more on both references). The count is kept to its low byte
    // (room in the node's padding: a wider one cost a hot path an
    // instruction per frame); 256 frames exactly since the last ask read
    // as none, which costs one call a retry.
    fn due_again(&mut self, now: At) -> At {
        let mark = (self.counters.tx as u8).wrapping_add(1);
        let stuck = self.tx_mark == mark;
        self.tx_mark = mark;
        if stuck { now.wrapping_add(ROOM_RETRY) } else { now }
    }

    /// The transmit queue's overflow EMCY, then the EMCY messages.
    // Out of line: few calls have EMCY work (in line, every full call paid
    // for its registers).
    #[inline(never)]
    fn process_emcy(&mut self, now: At, booted: bool) {
        // Transmit queue overflow (0x8110, once), cleared once the queue drained.
        if self.txq.overflows() != self.reported_overflows {
            self.reported_overflows = self.txq.overflows();
            self.comm.emcy.tx_overflow(A::CAN_EMCY.overrun, self.reported_overflows);
        } else if self.txq.is_empty() {
            self.comm.emcy.tx_drained();
        }
        // Not in the call that queues the boot-up: the queue sends by
        // priority, and an EMCY (0x80 + id) would leave before the boot-up
        // (0x700 + id), which CiA 301 forbids. The EMCY deadline brings the next call.
        if booted && self.nmt.state().sdo_allowed() {
            // EMCY off: errors still reach the error register and the history.
            while let Some((cob_id, e)) = self.comm.emcy.next(now, self.txq.free() > 0) {
                let dict = self.od.dictionary();
                self.comm.record(dict, self.od.image_mut(), &e);
                self.touched = ALL_TPDOS;
                if let Some(cob_id) = cob_id {
                    self.push(cob_id, &e);
                }
            }
        }
    }

    /// When EMCY next has work (only outside Initialising and Stopped).
    fn emcy_deadline(&self) -> At {
        if self.nmt.state().sdo_allowed() { self.comm.emcy.deadline() } else { NEVER }
    }
}
