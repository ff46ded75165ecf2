//! NMT module control from the master. CiA 301 v4.2 §7.2.8.3.1: a 2-byte
//! frame on COB-ID 0x000, command specifier then node-ID (0 = all nodes).
//! The format itself is [`canopen_core::wire::nmt`].

use super::SendError;
use crate::bus::{Bus, PortId};
use canopen_core::wire::nmt::NmtRequest;
pub use canopen_core::wire::nmt::{NMT_COB_ID, NmtCommand};

/// Node-ID 0 in an NMT command: every node.
pub const ALL_NODES: u8 = 0;

/// The two data bytes of `command` for node `node_id` ([`ALL_NODES`] for a broadcast).
pub fn command(command: NmtCommand, node_id: u8) -> [u8; 2] {
    NmtRequest { command, node_id }.emit()
}

/// The two data bytes of `command` for every node.
pub fn broadcast(command: NmtCommand) -> [u8; 2] {
    self::command(command, ALL_NODES)
}

/// Queues `command` for node `node_id` ([`ALL_NODES`] for every node) on
/// `port` at the bus's current time.
pub fn send(bus: &mut Bus, port: PortId, command: NmtCommand, node_id: u8) -> Result<(), SendError> {
    super::send(bus, port, NMT_COB_ID, &self::command(command, node_id))
}
