//! Received frames: which service a COB-ID goes to in which NMT state,
//! and what the node does with the result.

use crate::frame::CanFrame;
use crate::od::ObjectDictionary;
use crate::services::lss::UNCONFIGURED;
use crate::services::nmt::State;
use crate::services::sync::SyncEvent;
use crate::storage::Storage;
use crate::time::Instant;
use crate::wire::lss::MASTER_COB_ID as LSS_MASTER_COB_ID;
use crate::wire::nmt::{ERROR_CONTROL_BASE, NMT_COB_ID, NmtRequest, NmtState};
use crate::wire::time_stamp::TimeOfDay;

use super::router::{Router, SdoEffects};
use super::sinks::{PdoSink, SdoSink};
use super::{Application, Node};

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Handles one received frame. Bounded work, but an NMT reset or a
    /// stored set takes long (docs/firmware.md, "Longest step"): call it
    /// from a task that owns the node, not from the CAN RX interrupt.
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
        if cob_id == LSS_MASTER_COB_ID && self.lss_active && !rtr {
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
    pub(super) fn synchronise(&mut self, now: Instant, event: &SyncEvent) {
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

    pub(super) fn sdo_request(&mut self, i: usize, now: Instant, data: &[u8], tx_cob: u16) {
        let Node { od, app, storage, comm, sdo, txq, node_id, .. } = self;
        let dict = od.dictionary();
        let mut router = Router { dict, image: od.image_mut(), app, comm, storage, node_id: *node_id, now, effects: SdoEffects::default() };
        let mut sink = SdoSink { txq, cob_id: tx_cob };
        sdo.on_request(i, now, data, &mut router, &mut sink);
        let effects = router.effects;
        self.follow_sdo(effects);
    }

    /// Follows up what SDO accesses changed beyond their objects (from a
    /// request, or from a server's timers in `process`).
    #[inline(always)]
    pub(super) fn follow_sdo(&mut self, effects: SdoEffects) {
        self.touched |= effects.written;
        if effects.sdo_changed {
            self.configure_sdo();
        }
        if effects.consumed_changed {
            self.refresh_acceptance();
        }
    }
}
