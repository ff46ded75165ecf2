//! NMT slave state machine. CiA 301 v4.2 §7.3.2, figure 48.
//!
//! Initialising → (boot-up) → Pre-operational ⇄ Operational ⇄ Stopped.
//! Reset node and reset communication go back through Initialising; the node
//! restores the object ranges each reset covers and sends the boot-up frame.

use crate::wire::nmt::{NmtCommand, NmtRequest, NmtStateCode};

/// The NMT state of this node. Its discriminants are not the heartbeat's
/// state codes (those are [`NmtStateCode`]) and may change: do not cast it.
// The discriminants put the two states with SDO in them above the others
// (one compare for `sdo_allowed`, which every full call asks several times:
// 36 bytes less in ds301-lean than the declaration order); Initialising is
// 0, as the node starts all zero bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtState {
    /// Before the boot-up message; nothing but the reset runs.
    Initialising = 0,
    /// Error control (and LSS) only.
    Stopped = 1,
    /// Every service.
    Operational = 2,
    /// SDO, SYNC, EMCY, TIME, error control; no PDO.
    PreOperational = 3,
}

impl NmtState {
    /// The state as heartbeat and guarding report it.
    pub const fn reported(self) -> NmtStateCode {
        match self {
            NmtState::Initialising => NmtStateCode::BootUp,
            NmtState::PreOperational => NmtStateCode::PreOperational,
            NmtState::Operational => NmtStateCode::Operational,
            NmtState::Stopped => NmtStateCode::Stopped,
        }
    }

    /// SDO, SYNC, EMCY and TIME run in Pre-operational and Operational (CiA 301 table 64).
    pub const fn sdo_allowed(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }

    /// PDOs run in Operational only.
    pub const fn pdo_allowed(self) -> bool {
        matches!(self, NmtState::Operational)
    }
}

/// What the node has to do after an NMT command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transition {
    /// Nothing (not addressed, or already in that state).
    None,
    /// The state changed to the one given.
    Entered(NmtState),
    /// Reset application: restore 0x2000 and up, then reset communication.
    ResetApplication,
    /// Reset communication: restore 0x1000–0x1FFF, boot up again.
    ResetCommunication,
}

/// The NMT slave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nmt {
    state: NmtState,
}

impl Default for Nmt {
    fn default() -> Self {
        Self::new()
    }
}

impl Nmt {
    /// A node still initialising.
    pub const fn new() -> Self {
        Nmt { state: NmtState::Initialising }
    }

    /// The current state.
    pub const fn state(&self) -> NmtState {
        self.state
    }

    /// Initialisation finished: the boot-up message went out. A self-starting
    /// node (0x1F80 bit 2, see the node) goes on to Operational.
    pub fn boot_up_done(&mut self, auto_start: bool) -> NmtState {
        self.state = if auto_start { NmtState::Operational } else { NmtState::PreOperational };
        self.state
    }

    /// Applies a command addressed to `node_id` or broadcast to 0.
    pub fn on_command(&mut self, request: NmtRequest, node_id: u8) -> Transition {
        if request.node_id != 0 && request.node_id != node_id {
            return Transition::None;
        }
        if self.state == NmtState::Initialising {
            return Transition::None;
        }
        let next = match request.command {
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::EnterPreOperational => NmtState::PreOperational,
            NmtCommand::ResetNode => {
                self.state = NmtState::Initialising;
                return Transition::ResetApplication;
            }
            NmtCommand::ResetCommunication => {
                self.state = NmtState::Initialising;
                return Transition::ResetCommunication;
            }
        };
        if next == self.state {
            return Transition::None;
        }
        self.state = next;
        Transition::Entered(next)
    }

    /// Forces a state (error behaviour 0x1029, or the application).
    pub fn enter(&mut self, state: NmtState) -> Transition {
        if state == self.state || self.state == NmtState::Initialising {
            return Transition::None;
        }
        self.state = state;
        Transition::Entered(state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(command: NmtCommand, node_id: u8) -> NmtRequest {
        NmtRequest { command, node_id }
    }

    #[test]
    fn every_command_from_every_state() {
        let mut n = Nmt::new();
        assert_eq!(n.on_command(cmd(NmtCommand::Start, 5), 5), Transition::None, "ignored while initialising");
        assert_eq!(n.boot_up_done(false), NmtState::PreOperational);
        assert_eq!(n.on_command(cmd(NmtCommand::Start, 5), 5), Transition::Entered(NmtState::Operational));
        assert_eq!(n.on_command(cmd(NmtCommand::Start, 0), 5), Transition::None);
        assert_eq!(n.on_command(cmd(NmtCommand::Stop, 0), 5), Transition::Entered(NmtState::Stopped));
        assert_eq!(n.on_command(cmd(NmtCommand::EnterPreOperational, 5), 5), Transition::Entered(NmtState::PreOperational));
        assert_eq!(n.on_command(cmd(NmtCommand::Stop, 6), 5), Transition::None, "other node");
        assert_eq!(n.on_command(cmd(NmtCommand::ResetCommunication, 5), 5), Transition::ResetCommunication);
        assert_eq!(n.state(), NmtState::Initialising);
        assert_eq!(n.boot_up_done(true), NmtState::Operational);
        assert_eq!(n.on_command(cmd(NmtCommand::ResetNode, 0), 5), Transition::ResetApplication);
    }

    #[test]
    fn services_per_state() {
        assert!(!NmtState::Stopped.sdo_allowed() && !NmtState::Stopped.pdo_allowed());
        assert!(NmtState::PreOperational.sdo_allowed() && !NmtState::PreOperational.pdo_allowed());
        assert!(NmtState::Operational.sdo_allowed() && NmtState::Operational.pdo_allowed());
        assert_eq!(NmtState::PreOperational.reported().code(), 0x7F);
    }
}
