//! NMT state changes: commands from the master, the effect of entering a
//! state on the services, and communication errors and their 0x1029
//! error behaviour.

use crate::od::ObjectDictionary;
use crate::services::nmt::{NmtState, Transition};
use crate::services::pdo::ALL_TPDOS;
use crate::storage::Storage;
use crate::time::At;
use crate::wire::emcy::EmcyCode;
use crate::wire::nmt::NmtRequest;

use super::{Application, CommError, NmtEvent, Node};

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    pub(super) fn nmt_command(&mut self, request: NmtRequest, now: At) {
        match self.nmt.on_command(request, self.hook.node_id) {
            Transition::None => {}
            Transition::Entered(state) => self.entered(state, now),
            // One start for both: a copy of it in line, not two.
            t @ (Transition::ResetApplication | Transition::ResetCommunication) => self.begin_reset(t == Transition::ResetApplication),
        }
    }

    pub(super) fn entered(&mut self, state: NmtState, now: At) {
        self.touched = ALL_TPDOS;
        self.stale = true;
        if state.pdo_allowed() {
            if A::OPTIONS.pdo_rewrite_while_valid {
                // Mapping entries written in Pre-operational apply now.
                let dict = self.od.dictionary();
                self.comm.pdos.reload_mappings(dict, self.od.image());
                self.refresh_acceptance();
            }
            self.comm.pdos.enter_operational(now);
        } else {
            self.comm.pdos.stop();
        }
        if !state.sdo_allowed() {
            // Stopped: a transfer in progress ends without a frame (CiA 301 table 64).
            self.sdo.reset_all();
        }
        self.with_app_cold(now, |app, ctx| app.on_nmt(ctx, NmtEvent::Entered(state)));
    }

    /// A communication error (heartbeat or life guarding): EMCY 0x8130 and
    /// 0x1029. Every heartbeat event sends its EMCY (with the node-ID, 0 for
    /// life guarding), also while an earlier one is still active.
    pub(super) fn communication_error(&mut self, node: u8, now: At) {
        self.comm.emcy.raise_each(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [node, 0, 0, 0, 0]);
        let error = if node == 0 { CommError::LifeGuarding } else { CommError::Heartbeat(node) };
        self.with_app_cold(now, |app, ctx| app.on_nmt(ctx, NmtEvent::CommunicationError(error)));
        self.device_error(1, now);
    }

    /// An error of 0x1029 class `class`: the state change that sub-index asks for.
    pub(super) fn device_error(&mut self, class: u8, now: At) {
        self.stale = true;
        let dict = self.od.dictionary();
        // 0x1029's code, decided on as the number: the codes of
        // `Comm::error_behaviour_of` (0 pre-operational, 1 no change, 2
        // stopped, any other pre-operational), which builds the enum for the
        // API; building it here too cost 12 B (core). Keep the two in step.
        let code = match A::OPTIONS.communication_error_pre_operational {
            Some(switch) if class == 1 => u32::from(!self.option_set(switch)),
            _ => dict.read_u32(self.od.image(), crate::od::index::ERROR_BEHAVIOUR, class).unwrap_or(0),
        };
        let next = match code {
            1 => None,
            2 => Some(NmtState::Stopped),
            _ if self.nmt.state() == NmtState::Operational => Some(NmtState::PreOperational),
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
    pub(super) fn communication_recovered(&mut self) {
        // Without node guarding (the dictionary's services) it never expires.
        let guarding_expired = O::SERVICES.guarding && self.comm.guarding.is_expired();
        if !self.comm.consumers.any_timed_out() && !guarding_expired {
            self.comm.emcy.clear(EmcyCode::LIFE_GUARD_OR_HEARTBEAT);
        }
    }
}
