//! SYNC message and COB-ID SYNC formats. CiA 301 v4.2 §7.2.5.3.1 (SYNC
//! write service), §7.5.2.5 (0x1005 COB-ID SYNC message), §7.5.2.22
//! (0x1019 synchronous counter overflow value).
//!
//! A SYNC frame carries no data, or exactly one byte, the SYNC counter
//! (1..=0x1019), when the synchronous counter overflow value 0x1019 is
//! greater than 0.

/// A SYNC message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SyncMessage {
    /// The SYNC counter, when the producer uses one (0x1019 > 0).
    pub counter: Option<u8>,
}

/// Why bytes are not a SYNC message or a COB-ID SYNC value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncError {
    /// The data length is neither 0 nor 1.
    Length,
    /// A COB-ID SYNC with a 29-bit identifier (bit 29) or with bits 11..28
    /// set: CANopen here uses 11-bit identifiers only.
    ExtendedId,
}

/// Default COB-ID of the SYNC message (CiA 301 §7.3.5, pre-defined connection set).
pub const SYNC_COB_ID: u16 = 0x080;

impl SyncMessage {
    /// Parses the data of a SYNC frame: 0 bytes, or 1 byte of counter.
    pub fn parse(data: &[u8]) -> Result<Self, SyncError> {
        match *data {
            [] => Ok(SyncMessage { counter: None }),
            [counter] => Ok(SyncMessage { counter: Some(counter) }),
            _ => Err(SyncError::Length),
        }
    }

    /// The data bytes, written into `buf`: empty, or the counter.
    pub fn emit<'a>(&self, buf: &'a mut [u8; 1]) -> &'a [u8] {
        match self.counter {
            Some(counter) => {
                *buf = [counter];
                buf.as_slice()
            }
            None => &[],
        }
    }
}

/// The value of 0x1005 COB-ID SYNC message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CobIdSync {
    /// The 11-bit CAN identifier (bits 0..10).
    pub can_id: u16,
    /// Bit 30 "gen": this node produces the SYNC.
    pub producer: bool,
}

/// Bit 30 of 0x1005: the node is the SYNC producer.
const GEN: u32 = 1 << 30;
/// Bit 29 (29-bit frame) and the extended identifier bits 11..28.
const EXTENDED: u32 = 0x3FFF_F800;

impl CobIdSync {
    /// Decodes an 0x1005 value. Bit 31 is "do not care" (CiA 301 table 45).
    pub const fn from_u32(value: u32) -> Result<Self, SyncError> {
        if value & EXTENDED != 0 {
            return Err(SyncError::ExtendedId);
        }
        Ok(CobIdSync { can_id: (value & 0x7FF) as u16, producer: value & GEN != 0 })
    }

    /// The 0x1005 value.
    pub const fn to_u32(self) -> u32 {
        self.can_id as u32 | if self.producer { GEN } else { 0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_both_forms_and_rejects_the_rest() {
        // CiA 301 §7.2.5.3.1: "80h" with no data, or with one counter byte.
        assert_eq!(SyncMessage::parse(&[]), Ok(SyncMessage { counter: None }));
        assert_eq!(SyncMessage::parse(&[0x05]), Ok(SyncMessage { counter: Some(5) }));
        for n in 2..=8 {
            assert_eq!(SyncMessage::parse(&[1; 8][..n]), Err(SyncError::Length), "{n} bytes");
        }
    }

    #[test]
    fn emits_what_it_parses() {
        let mut buf = [0u8; 1];
        assert_eq!(SyncMessage { counter: None }.emit(&mut buf), &[] as &[u8]);
        assert_eq!(SyncMessage { counter: Some(240) }.emit(&mut buf), &[240]);
        for m in [SyncMessage { counter: None }, SyncMessage { counter: Some(1) }] {
            assert_eq!(SyncMessage::parse(m.emit(&mut buf)), Ok(m));
        }
    }

    #[test]
    fn cob_id_sync_values() {
        // 0x00000080: consumer of 0x80 (the default); 0x40000080: producer.
        assert_eq!(CobIdSync::from_u32(0x0000_0080), Ok(CobIdSync { can_id: 0x80, producer: false }));
        assert_eq!(CobIdSync::from_u32(0x4000_0080), Ok(CobIdSync { can_id: 0x80, producer: true }));
        assert_eq!(CobIdSync::from_u32(0x8000_0080), Ok(CobIdSync { can_id: 0x80, producer: false }), "bit 31 is ignored");
        assert_eq!(CobIdSync::from_u32(0x2000_0080), Err(SyncError::ExtendedId));
        assert_eq!(CobIdSync::from_u32(0x0000_0880), Err(SyncError::ExtendedId));
        assert_eq!(CobIdSync { can_id: 0x81, producer: true }.to_u32(), 0x4000_0081);
    }
}
