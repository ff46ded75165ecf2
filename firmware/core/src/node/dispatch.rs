//! Received frames: which service a COB-ID goes to in which NMT state,
//! and what the node does with the result.

use core::cell::Cell;

use crate::frame::CanFrame;
use crate::od::ObjectDictionary;
use crate::services::lss::UNCONFIGURED;
use crate::services::nmt::NmtState;
use crate::services::pdo::ALL_TPDOS;
use crate::storage::Storage;
use crate::time::{At, Instant};
use crate::wire::lss::MASTER_COB_ID as LSS_MASTER_COB_ID;
use crate::wire::nmt::{ERROR_CONTROL_BASE, NMT_COB_ID, NmtRequest, NmtStateCode, error_control_cob_id};
use crate::wire::time_stamp::TimeOfDay;

use super::router::{Follow, Router, SdoEffects, SdoParts};
use super::sinks::{LENGTH_ERRORS, PdoSink, SdoSink};
use super::{Application, CommError, Ctx, NmtEvent, Node, SDO_BUFFER, Source, TX_QUEUE, comm, store};
use crate::services::sdo_server::SdoServers;
use crate::txq::TxQueue;

/// Calls `f` with each set bit of `bits` (its number), lowest first.
/// `bounded`: the loop also counts its turns (at most 32), a bound the
/// compiler sees, so that where `f` does nothing (a zero-sized device's
/// default hooks) no loop is left; a device with hooks pays no count.
#[inline(always)]
fn each_bit(mut bits: u32, bounded: bool, mut f: impl FnMut(u8)) {
    let mut turns = 0u32;
    while bits != 0 && (!bounded || turns < u32::BITS) {
        f(bits.trailing_zeros() as u8);
        bits &= bits.wrapping_sub(1); // clears the lowest set bit (bits != 0)
        turns = turns.wrapping_add(1);
    }
}

/// What became of a received frame: each kind counted once, where
/// [`Node::on_frame`] reads it.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Taken {
    /// A service took it (or a device's protocol).
    Handled,
    /// No service of the node's state listens on its identifier.
    Ignored,
    /// Its service could not parse it.
    Malformed,
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Handles one received frame. Bounded work, but an NMT reset or a
    /// stored set takes long (docs/firmware.md, "Longest step"): call it
    /// from a task that owns the node, not from the CAN RX interrupt.
    // In line: each board and image calls it at one place (the firmware's
    // `CanNode` trampoline, the size images' loop), which then is the
    // dispatch itself instead of a tail call through a stack argument.
    #[inline(always)]
    pub fn on_frame(&mut self, now: Instant, frame: &CanFrame) {
        let now = self.tick(now);
        self.counters.count_rx();
        // Counted at one place: each outcome a branch here, not a count at
        // every exit (an LSS request counts its own malformed frames).
        match self.take_frame(now, frame) {
            Taken::Handled => {}
            Taken::Ignored => self.counters.count_ignored(),
            Taken::Malformed => self.counters.count_malformed(),
        }
    }

    /// [`Node::on_frame`] past the clock and the receive count: what
    /// became of the frame.
    #[inline(always)]
    fn take_frame(&mut self, now: At, frame: &CanFrame) -> Taken {
        use embedded_can::Frame;
        // CANopen uses 11-bit identifiers only.
        let Some(cob_id) = frame.cob_id() else {
            return Taken::Ignored;
        };
        let rtr = frame.is_remote_frame();
        let data = frame.data();
        // A device's own protocol sees every frame first, whatever the NMT state.
        if self.with_app(now, |app, ctx| app.on_frame(ctx, cob_id, rtr, data)) {
            return Taken::Handled;
        }
        if !self.app.canopen() {
            return Taken::Ignored;
        }
        if !rtr && self.plain_rpdo(now, cob_id, data) {
            return Taken::Handled;
        }
        if cob_id == LSS_MASTER_COB_ID && self.lss_on() && !rtr {
            self.stale = true;
            self.lss_request(now, data);
            return Taken::Handled;
        }
        if self.hook.node_id == UNCONFIGURED {
            return Taken::Ignored;
        }
        if cob_id == NMT_COB_ID {
            self.stale = true;
            return match NmtRequest::parse(data) {
                Ok(request) if !rtr => {
                    // A master's command comes before the node's own start.
                    self.start_pending = false;
                    self.nmt_command(request, now);
                    Taken::Handled
                }
                _ => self.broken_frame(now),
            };
        }
        let state = self.nmt.state();
        // Until the boot-up, a reset's stages included (CiA 301 §7.3.2.2.1).
        if state == NmtState::Initialising {
            return Taken::Ignored;
        }
        // 0x601..=0x67F is restricted for every object but the SDO servers'
        // own pre-defined identifiers (CiA 301 §7.3.5): a request there
        // skips the checks for the other services (about 70 thumbv7m instructions).
        if !(0x601..=0x67F).contains(&cob_id) {
            if cob_id == error_control_cob_id(self.hook.node_id) {
                if O::SERVICES.guarding && rtr && !self.comm.heartbeat.active() {
                    self.stale = true;
                    let expired = self.comm.guarding.is_expired();
                    let byte = self.comm.guarding.on_request(state.reported(), now);
                    self.push(cob_id, &[byte]);
                    if expired {
                        self.communication_recovered();
                    }
                    return Taken::Handled;
                }
                return Taken::Ignored;
            }
            if (ERROR_CONTROL_BASE + 1..=ERROR_CONTROL_BASE + 0x7F).contains(&cob_id) && !rtr {
                self.stale = true;
                // The low byte of 0x701..=0x77F is the producer's node-ID.
                let Some(s) = (match data {
                    [b] => NmtStateCode::from_code(*b),
                    _ => None,
                }) else {
                    return self.broken_frame(now);
                };
                if self.comm.consumers.on_heartbeat(cob_id as u8, s, now) {
                    self.communication_recovered();
                }
                return Taken::Handled;
            }
            // A received SYNC moves no deadline of the node's own (its errors
            // queue an EMCY, which the next process sends).
            if state.sdo_allowed() && cob_id == self.comm.sync.cob_id() && !rtr {
                let taken = match self.comm.sync.on_frame(now, data) {
                    Ok(event) => {
                        self.synchronise(now, event.counter);
                        Taken::Handled
                    }
                    Err(e) => {
                        self.comm.emcy.signal(e.emcy_code(), [0; 5]);
                        Taken::Malformed
                    }
                };
                self.quiet &= !self.comm.emcy.has_queued();
                return taken;
            }
            if state.pdo_allowed() {
                let Node { od, comm, txq, .. } = self;
                let comm = &mut **comm;
                let mut sink = PdoSink::<A>::new(txq, &mut comm.emcy);
                // Some(the TPDOs whose mapped data the frame wrote) if a PDO took it.
                let reached = if rtr {
                    comm.pdos.on_rtr(now, cob_id, od.image(), &mut sink).then_some(0)
                } else {
                    comm.pdos.on_frame_reaching(now, cob_id, data, od.image_mut(), &mut sink)
                };
                let (received, errors) = (sink.received, sink.errors);
                if let Some(reached) = reached {
                    self.after_pdo(now, reached, received, errors);
                    return Taken::Handled;
                }
            }
        }
        if state.sdo_allowed() {
            let server =
                self.sdo_cob_ids.iter().enumerate().find_map(|(i, ids)| ids.filter(|(rx, _)| *rx == cob_id).map(|(_, tx)| (i, tx)));
            if let Some((i, tx)) = server
                && !rtr
            {
                self.sdo_request(i, now, data, tx);
                // A transfer goes on, or an answer waits for room in the queue.
                self.quiet &= self.sdo.is_idle(i);
                return Taken::Handled;
            }
            if O::SERVICES.time && Some(cob_id) == self.comm.time_cob_id && !rtr {
                self.stale = true;
                return match TimeOfDay::parse(data) {
                    Some(t) => {
                        self.with_app_cold(now, |app, ctx| app.on_time(ctx, t));
                        Taken::Handled
                    }
                    None => Taken::Malformed,
                };
            }
        }
        Taken::Ignored
    }

    /// The usual RPDO frame ([`crate::services::pdo::Pdos::on_plain_frame`])
    /// on its short path: true if it was one, and then handled as the path
    /// through every check would. Only a data frame in CiA 301's
    /// pre-defined PDO range 0x181..=0x57F (in Operational, with a node-ID):
    /// of the services the full path looks at before the PDOs, only SYNC
    /// can live there (0x1005 is writable), and it goes first.
    #[inline(always)]
    fn plain_rpdo(&mut self, now: At, cob_id: u16, data: &[u8]) -> bool {
        if !(0x181..=0x57F).contains(&cob_id)
            || !self.nmt.state().pdo_allowed()
            || self.hook.node_id == UNCONFIGURED
            || cob_id == self.comm.sync.cob_id()
        {
            return false;
        }
        let Some((n, reached)) = self.comm.pdos.on_plain_frame(cob_id, data, self.od.image_mut()) else { return false };
        self.after_pdo(now, reached, super::sinks::bit(n), 0);
        true
    }

    /// What follows a frame a PDO took: `reached` the TPDOs its data
    /// reaches, `received` and `errors` as [`PdoSink`] collects them.
    // Out of line: the short path and the full one share it (in line at
    // both, the device's RPDO hook was in the main loop twice).
    #[inline(never)]
    fn after_pdo(&mut self, now: At, reached: u32, received: u32, errors: u32) {
        // Only the TPDOs this RPDO writes to look for a change.
        self.touched |= reached;
        // A timer started (or an RTR changed a TPDO), or an error was signalled.
        // Without an RPDO timer running the PDOs' deadline stayed where it was.
        match self.comm.pdos.settled() {
            Some(deadline) if self.comm.pdos.rpdo_timers() => self.next = self.next.min(deadline),
            Some(_) => {}
            None => self.quiet = false,
        }
        self.quiet &= !self.comm.emcy.has_queued();
        self.pdo_events(now, received, errors);
        // A poll for any TPDO retries every TPDO waiting to (an RTR
        // may have left its TPDO so): only if nothing else brings one.
        if self.touched == 0 {
            self.touched = self.retrying();
        }
    }

    /// An NMT command or heartbeat message the node cannot parse: ignored,
    /// and the device's protocol warning raised if it has one.
    /// Malformed: [`Node::on_frame`] counts it.
    #[cold]
    fn broken_frame(&mut self, now: At) -> Taken {
        if let Some(code) = A::CAN_EMCY.protocol {
            // The next `process` sends it and takes the clearing's deadline, as for a controller event.
            self.stale = true;
            super::controller::ControllerErrors::protocol_error(now, &mut self.comm.emcy, code);
        }
        Taken::Malformed
    }

    /// A SYNC arrived or was produced: synchronous PDOs run (in Operational).
    /// The device samples first, so the synchronous TPDOs carry its values.
    // The event (its window, 0x1007 as it was before the device's hook) built
    // here from the counter: one copy for the received and the produced
    // SYNC, not one at each caller.
    pub(super) fn synchronise(&mut self, now: At, counter: Option<u8>) {
        let event = self.comm.sync.event(now, counter);
        self.with_app_cold(now, |app, ctx| app.sample(ctx));
        if self.nmt.state().pdo_allowed() {
            let Node { od, comm, txq, .. } = self;
            let comm = &mut **comm;
            let mut sink = PdoSink::<A>::new(txq, &mut comm.emcy);
            comm.pdos.on_sync(&event, od.image_mut(), &mut sink);
            let (received, errors) = (sink.received, sink.errors);
            // The synchronous RPDOs' objects, or else the TPDOs left to retry.
            let reached = if received != 0 { self.comm.pdos.reaches(received) } else { 0 };
            self.touched |= if reached != 0 { reached } else { self.retrying() };
            // Checked here too: most SYNCs have nothing to tell (no call).
            if received | errors != 0 {
                self.pdo_events(now, received, errors);
            }
        }
    }

    /// Tells the device which RPDOs wrote their objects (bit n: RPDO n) and
    /// which timed out or had a frame of a wrong length (`errors`, as
    /// [`PdoSink`] collects them).
    pub(super) fn pdo_events(&mut self, now: At, received: u32, errors: u32) {
        if received | errors == 0 {
            return;
        }
        let mut wake = false;
        self.with_app_follow(now, |app, ctx| {
            each_bit(received, Self::FOLD_HOOKS, |n| app.rpdo_written(ctx, n));
            each_bit(errors, Self::FOLD_HOOKS, |n| {
                let error = match n.checked_sub(LENGTH_ERRORS as u8) {
                    Some(n) => CommError::RpdoLength(n),
                    None => CommError::RpdoTimeout(n),
                };
                app.on_nmt(ctx, NmtEvent::CommunicationError(error));
            });
            if A::POLL_WHEN_DUE {
                wake = core::mem::take(&mut ctx.hook.wake);
            }
        });
        // The RPDO's hook alone leaves the device's timers to their deadline unless it asked for them.
        if A::POLL_WHEN_DUE && (wake || errors != 0) {
            self.app_due.waits = false;
        }
    }

    pub(super) fn sdo_request(&mut self, i: usize, now: At, data: &[u8], tx_cob: u16) {
        // The client has given up waiting for a store's answer (or aborted it).
        if O::SERVICES.storage {
            self.store_answer.drop_for(i);
        }
        let staged = Cell::new(None);
        // Without storage no store starts: the compiler leaves the answer's holding out.
        let staged_ref = if O::SERVICES.storage { Some(&staged) } else { None };
        let block = O::SERVICES.block_sdo;
        // A constant: each image links one of the two.
        let effects = if A::SDO_HOOKS {
            let (mut ctx, app, sdo, txq, _) = self.split_sdo(now);
            let mut router = Router { ctx: &mut ctx, app, by: Source::Sdo, od: core::marker::PhantomData::<O>, staged: staged_ref };
            sdo.on_request_with(i, now, data, block, false, &mut router, &mut SdoSink { txq, cob_id: tx_cob, hold: staged_ref });
            ctx.effects
        } else {
            let (mut parts, sdo, txq, _) = self.sdo_parts(now, staged_ref);
            sdo.on_request_with(i, now, data, block, true, &mut parts, &mut SdoSink { txq, cob_id: tx_cob, hold: staged_ref });
            parts.effects
        };
        if let (true, Some((index, sub))) = (O::SERVICES.storage, staged.get()) {
            self.store_answer = store::StoreAnswer::sdo(i, tx_cob, index, sub);
        }
        self.queue_raw();
        self.follow_sdo(effects);
        // After the answer: the SDO sink has queued it.
        if effects.reset_node {
            self.reset_application();
        }
    }

    /// The TPDOs waiting to retry a refused frame. A TPDO waits only after
    /// the queue refused it, which counts an overflow: while the count is
    /// what it was when a walk last found none, none waits, and the PDOs are
    /// not walked (a saturated count always walks).
    // Out of line: three callers.
    #[inline(never)]
    pub(super) fn retrying(&mut self) -> u32 {
        let overflows = self.txq.overflows();
        if overflows == self.retry_free_at && overflows != u32::MAX {
            return 0;
        }
        let mask = self.comm.pdos.retrying();
        if mask == 0 {
            self.retry_free_at = overflows;
        }
        mask
    }

    /// Which TPDOs look for changed data after the writes of an access
    /// (`wrote`, `follow`: its [`SdoEffects`]' parts, passed in registers),
    /// whether the next process runs every service, and the SDO servers
    /// and the acceptance list read again where their objects changed.
    // Out of line: `with_app` is inlined at every hook call.
    #[inline(never)]
    fn follow_writes(&mut self, wrote: (u16, u16), follow: Follow) {
        if follow.written {
            self.touched = ALL_TPDOS;
        } else if wrote.1 != 0 {
            let (offset, len) = wrote;
            // A poll for any TPDO retries every TPDO waiting to ([`crate::services::pdo::Pdos::poll_changed`]).
            let mask = self.comm.pdos.tpdos_mapping(offset, len);
            self.touched |= if mask != 0 { mask } else { self.retrying() };
        }
        self.stale |= follow.services;
        if follow.sdo_changed {
            self.configure_sdo();
        }
        if follow.consumed_changed {
            self.refresh_acceptance();
        }
    }

    /// The SDO servers with what they need: the hooks and their context,
    /// and beside them the transmit queue and the servers' COB-IDs.
    #[allow(clippy::type_complexity)]
    pub(super) fn split_sdo(
        &mut self,
        now: At,
    ) -> (Ctx<'_>, &mut A, &mut SdoServers<SDO_BUFFER, SDO>, &mut TxQueue<TX_QUEUE>, &[Option<(u16, u16)>; SDO]) {
        // The SDO server's hooks may change what the device's timers do.
        self.poll_app_next();
        let Node { od, app, storage, comm, sdo, txq, nmt, hook, sdo_cob_ids, .. } = self;
        let dict = od.dictionary();
        let ctx = Ctx {
            dict,
            image: od.image_mut(),
            services: comm,
            storage,
            state: nmt.state(),
            now,
            options: &A::OPTIONS,
            effects: SdoEffects::default(),
            hook,
        };
        (ctx, app, sdo, txq, sdo_cob_ids)
    }

    /// [`Node::split_sdo`] for a device without SDO hooks
    /// ([`Application::SDO_HOOKS`]): the parts of the node the servers'
    /// accesses reach, the hooks' context built only for a write
    /// ([`SdoParts`]; `staged`: as [`super::router::Router::staged`]).
    #[allow(clippy::type_complexity)]
    pub(super) fn sdo_parts<'a>(
        &'a mut self,
        now: At,
        staged: Option<&'a Cell<Option<(u16, u8)>>>,
    ) -> (
        SdoParts<'a, A, O, comm::Hooked<A, O, R, T, HB>, S>,
        &'a mut SdoServers<SDO_BUFFER, SDO>,
        &'a mut TxQueue<TX_QUEUE>,
        &'a [Option<(u16, u16)>; SDO],
    ) {
        // As `split_sdo`: the write's hooks may change what the device's timers do.
        self.poll_app_next();
        let Node { od, app, storage, comm, sdo, txq, nmt, hook, sdo_cob_ids, .. } = self;
        let parts = SdoParts { od, app, services: comm, storage, hook, state: nmt.state(), now, staged, effects: SdoEffects::default() };
        (parts, sdo, txq, sdo_cob_ids)
    }

    /// Follows up what SDO accesses changed beyond their objects (from a
    /// request, or from a server's timers in `process`).
    #[inline(always)]
    pub(super) fn follow_sdo(&mut self, effects: SdoEffects) {
        if effects.follow != Follow::default() || effects.wrote.1 != 0 {
            self.follow_writes(effects.wrote, effects.follow);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::each_bit;

    fn bits(value: u32, bounded: bool) -> std::vec::Vec<u8> {
        let mut seen = std::vec::Vec::new();
        each_bit(value, bounded, |n| seen.push(n));
        seen
    }

    #[test]
    fn each_bit_calls_once_per_set_bit_lowest_first_bounded_or_not() {
        for bounded in [false, true] {
            assert_eq!(bits(0, bounded), [], "{bounded}");
            assert_eq!(bits(0b1010_0001, bounded), [0, 5, 7], "{bounded}");
            assert_eq!(bits(u32::MAX, bounded), (0..32).collect::<std::vec::Vec<u8>>(), "every bit, {bounded}");
        }
    }
}
