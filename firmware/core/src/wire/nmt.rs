//! NMT module control and error control formats. CiA 301 v4.2 §7.2.8.3.

/// An NMT module control command (COB-ID 0x000, 2 bytes: command, node-id).
/// The discriminant is the command specifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtCommand {
    /// 0x01 Start remote node.
    Start = 0x01,
    /// 0x02 Stop remote node.
    Stop = 0x02,
    /// 0x80 Enter pre-operational.
    EnterPreOperational = 0x80,
    /// 0x81 Reset node (application).
    ResetNode = 0x81,
    /// 0x82 Reset communication.
    ResetCommunication = 0x82,
}

/// A decoded NMT frame: the command and the node-id it addresses (0 = all).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NmtRequest {
    /// The command.
    pub command: NmtCommand,
    /// Addressed node, 0 for all.
    pub node_id: u8,
}

/// Why an NMT frame was not understood.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtError {
    /// DLC is not 2.
    Length,
    /// The command specifier is not one of CiA 301's.
    UnknownCommand(u8),
}

impl NmtRequest {
    /// Parses the data of a frame on COB-ID 0x000.
    pub fn parse(data: &[u8]) -> Result<Self, NmtError> {
        let [cs, node_id] = *data else { return Err(NmtError::Length) };
        let command = match cs {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            other => return Err(NmtError::UnknownCommand(other)),
        };
        Ok(NmtRequest { command, node_id })
    }

    /// The two data bytes.
    pub fn emit(&self) -> [u8; 2] {
        [self.command as u8, self.node_id]
    }
}

/// The NMT state byte as heartbeat and node guarding report it (CiA 301
/// table 57): the wire form of [`crate::services::nmt::NmtState`].
/// The discriminant is the code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtStateCode {
    /// 0x00: boot-up.
    BootUp = 0x00,
    /// 0x04: stopped.
    Stopped = 0x04,
    /// 0x05: operational.
    Operational = 0x05,
    /// 0x7F: pre-operational.
    PreOperational = 0x7F,
}

impl NmtStateCode {
    /// The state code (bits 0..6 of the error-control byte).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The state with this code; bit 7 (the guarding toggle) is ignored.
    pub const fn from_code(code: u8) -> Option<NmtStateCode> {
        Some(match code & 0x7F {
            0x00 => NmtStateCode::BootUp,
            0x04 => NmtStateCode::Stopped,
            0x05 => NmtStateCode::Operational,
            0x7F => NmtStateCode::PreOperational,
            _ => return None,
        })
    }
}

/// COB-ID of NMT module control.
pub const NMT_COB_ID: u16 = 0x000;
/// Base COB-ID of error control (heartbeat, boot-up, guarding): 0x700 + node-id.
pub const ERROR_CONTROL_BASE: u16 = 0x700;

/// The error control COB-ID of node `node_id` (0x700 + node-ID). A `u8`
/// sits below bit 8, so the OR is the sum and cannot carry.
pub const fn error_control_cob_id(node_id: u8) -> u16 {
    ERROR_CONTROL_BASE | node_id as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command_and_rejects_the_rest() {
        // CiA 301 §7.2.8.3.1: "01 05" starts node 5, "82 00" resets communication of all.
        assert_eq!(NmtRequest::parse(&[0x01, 0x05]), Ok(NmtRequest { command: NmtCommand::Start, node_id: 5 }));
        assert_eq!(NmtRequest::parse(&[0x82, 0x00]), Ok(NmtRequest { command: NmtCommand::ResetCommunication, node_id: 0 }));
        for cs in [0x01, 0x02, 0x80, 0x81, 0x82] {
            assert_eq!(NmtRequest::parse(&[cs, 7]).map(|r| r.emit()), Ok([cs, 7]));
        }
        assert_eq!(NmtRequest::parse(&[0x03, 1]), Err(NmtError::UnknownCommand(3)));
        assert_eq!(NmtRequest::parse(&[0x01]), Err(NmtError::Length));
        assert_eq!(NmtRequest::parse(&[0x01, 1, 0]), Err(NmtError::Length));
        assert_eq!(NmtRequest::parse(&[]), Err(NmtError::Length));
    }

    #[test]
    fn state_codes() {
        for s in [NmtStateCode::BootUp, NmtStateCode::Stopped, NmtStateCode::Operational, NmtStateCode::PreOperational] {
            assert_eq!(NmtStateCode::from_code(s.code()), Some(s));
            assert_eq!(NmtStateCode::from_code(s.code() | 0x80), Some(s));
        }
        assert_eq!(NmtStateCode::from_code(0x01), None);
    }
}
