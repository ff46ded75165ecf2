//! The CAN frame the core exchanges with boards and hosts.
//!
//! It implements [`embedded_can::Frame`], so any driver's frame converts to
//! and from it; inside the core, services see only a COB-ID and the data.

use embedded_can::{ExtendedId, Id, StandardId};

/// A classic CAN data or remote frame (at most 8 data bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: Id,
    rtr: bool,
    dlc: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A data frame on COB-ID 0 with no data, all zero bits: what a free
    /// slot of a queue holds ([`crate::node`]).
    pub(crate) const EMPTY: CanFrame = CanFrame { id: Id::Standard(StandardId::ZERO), rtr: false, dlc: 0, data: [0; 8] };

    /// A data frame with an 11-bit identifier; `None` if `cob_id` > 0x7FF or `data` > 8 bytes.
    pub fn standard(cob_id: u16, data: &[u8]) -> Option<Self> {
        embedded_can::Frame::new(StandardId::new(cob_id)?, data)
    }

    /// A remote frame with an 11-bit identifier asking for `dlc` bytes.
    pub fn remote(cob_id: u16, dlc: usize) -> Option<Self> {
        embedded_can::Frame::new_remote(StandardId::new(cob_id)?, dlc)
    }

    /// The 11-bit identifier, or `None` for an extended frame (CANopen uses 11 bits).
    pub fn cob_id(&self) -> Option<u16> {
        match self.id {
            Id::Standard(id) => Some(id.as_raw()),
            Id::Extended(_) => None,
        }
    }

    /// The raw identifier (11 or 29 bits).
    pub fn raw_id(&self) -> u32 {
        match self.id {
            Id::Standard(id) => u32::from(id.as_raw()),
            Id::Extended(id) => id.as_raw(),
        }
    }

    /// Whether the identifier is 29 bits.
    pub fn is_extended_id(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    /// Arbitration priority: lower wins. Standard frames win over extended
    /// ones with the same 11 leading bits, data frames over remote frames.
    pub fn priority(&self) -> u32 {
        let (base, ide, ext) = match self.id {
            Id::Standard(id) => (u32::from(id.as_raw()), 0, 0),
            Id::Extended(id) => (id.as_raw() >> 18, 1, id.as_raw() & 0x3_FFFF),
        };
        // After the 11 base bits: RTR (standard) or SRR = 1 (extended), then IDE.
        let bit20 = if ide == 1 { 1 } else { u32::from(self.rtr) };
        (base << 21) | (bit20 << 20) | (ide << 19) | (ext << 1) | u32::from(self.rtr && ide == 1)
    }
}

impl embedded_can::Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let mut buf = [0u8; 8];
        buf.get_mut(..data.len())?.copy_from_slice(data);
        Some(CanFrame { id: id.into(), rtr: false, dlc: data.len() as u8, data: buf })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| CanFrame { id: id.into(), rtr: true, dlc: dlc as u8, data: [0; 8] })
    }

    fn is_extended(&self) -> bool {
        self.is_extended_id()
    }

    fn is_remote_frame(&self) -> bool {
        self.rtr
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }

    fn data(&self) -> &[u8] {
        if self.rtr { &[] } else { self.data.get(..usize::from(self.dlc)).unwrap_or(&self.data) }
    }
}

impl CanFrame {
    /// An extended (29-bit) data frame; `None` if the id or length is out of range.
    pub fn extended(id: u32, data: &[u8]) -> Option<Self> {
        embedded_can::Frame::new(ExtendedId::new(id)?, data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::Frame;

    #[test]
    fn builds_and_reads_frames() {
        let f = CanFrame::standard(0x601, &[0x40, 0x00, 0x10, 0x00]).unwrap();
        assert_eq!(f.cob_id(), Some(0x601));
        assert_eq!(f.data(), &[0x40, 0x00, 0x10, 0x00]);
        assert_eq!(f.dlc(), 4);
        assert!(CanFrame::standard(0x800, &[]).is_none());
        assert!(CanFrame::standard(0x1, &[0; 9]).is_none());
        let r = CanFrame::remote(0x701, 1).unwrap();
        assert!(r.is_remote_frame() && r.data().is_empty() && r.dlc() == 1);
        let x = CanFrame::extended(0x1ABC_DEF0, &[1]).unwrap();
        assert_eq!((x.cob_id(), x.raw_id(), x.is_extended()), (None, 0x1ABC_DEF0, true));
    }

    #[test]
    fn arbitration_order_follows_iso_11898() {
        let a = CanFrame::standard(0x100, &[]).unwrap();
        let b = CanFrame::standard(0x101, &[]).unwrap();
        let a_rtr = CanFrame::remote(0x100, 0).unwrap();
        let a_ext = CanFrame::extended(0x100 << 18, &[]).unwrap();
        assert!(a.priority() < b.priority());
        assert!(a.priority() < a_rtr.priority());
        assert!(a_rtr.priority() < a_ext.priority(), "SRR is recessive: a standard RTR beats an extended frame");
        assert!(a_ext.priority() < b.priority());
    }
}
