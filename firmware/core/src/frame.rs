//! The CAN frame the core exchanges with boards and hosts.
//!
//! It implements [`embedded_can::Frame`], so any driver's frame converts to
//! and from it; inside the core, services see only a COB-ID and the data.

use embedded_can::{ExtendedId, Id, StandardId};

/// A classic CAN data or remote frame (at most 8 data bytes).
///
/// 16 bytes, word-aligned, and so is `Option<CanFrame>` (the `bool`s give
/// it a niche): the queue, its pushes and pops move it as four words, where
/// the 20 bytes of an `embedded_can::Id` inside took a `memcpy` call.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CanFrame {
    /// The identifier's raw bits (11 or 29).
    raw: u32,
    data: [u8; 8],
    dlc: u8,
    rtr: bool,
    /// A 29-bit identifier.
    extended: bool,
}

impl CanFrame {
    /// A data frame on COB-ID 0 with no data, all zero bits: what a free
    /// slot of a queue holds ([`crate::node`]).
    pub(crate) const EMPTY: CanFrame = CanFrame { raw: 0, data: [0; 8], dlc: 0, rtr: false, extended: false };

    /// A data frame with an 11-bit identifier; `None` if `cob_id` > 0x7FF or `data` > 8 bytes.
    pub fn standard(cob_id: u16, data: &[u8]) -> Option<Self> {
        embedded_can::Frame::new(StandardId::new(cob_id)?, data)
    }

    /// A remote frame with an 11-bit identifier asking for `dlc` bytes.
    pub fn remote(cob_id: u16, dlc: usize) -> Option<Self> {
        embedded_can::Frame::new_remote(StandardId::new(cob_id)?, dlc)
    }

    /// Makes this a standard data frame on `cob_id` (11 bits, unchecked)
    /// of `dlc` (at most 8) bytes and hands out its 8 data bytes, as they
    /// were, to be filled: a queue slot ([`crate::txq::TxQueue::reserve_data`]).
    pub(crate) fn standard_data(&mut self, cob_id: u16, dlc: u8) -> &mut [u8; 8] {
        (self.raw, self.dlc, self.rtr, self.extended) = (u32::from(cob_id), dlc, false, false);
        &mut self.data
    }

    /// The 11-bit identifier, or `None` for an extended frame (CANopen uses 11 bits).
    pub fn cob_id(&self) -> Option<u16> {
        if self.extended { None } else { Some(self.raw as u16) }
    }

    /// The raw identifier (11 or 29 bits).
    pub fn raw_id(&self) -> u32 {
        self.raw
    }

    /// Whether the identifier is 29 bits.
    pub fn is_extended_id(&self) -> bool {
        self.extended
    }

    /// Arbitration priority: lower wins. Standard frames win over extended
    /// ones with the same 11 leading bits, data frames over remote frames.
    pub fn priority(&self) -> u32 {
        let rtr = u32::from(self.rtr);
        if self.extended {
            // The 11 base bits, SRR = 1, IDE = 1, the 18 extension bits, RTR.
            (self.raw << 3 & !0x1F_FFFF) | 0x18_0000 | (self.raw << 1 & 0x7_FFFE) | rtr
        } else {
            // The 11 bits, RTR (IDE = 0 and the rest below).
            self.raw << 21 | rtr << 20
        }
    }
}

impl embedded_can::Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let mut buf = [0u8; 8];
        buf.get_mut(..data.len())?.copy_from_slice(data);
        let (raw, extended) = raw_of(id.into());
        Some(CanFrame { raw, data: buf, dlc: data.len() as u8, rtr: false, extended })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        let (raw, extended) = raw_of(id.into());
        (dlc <= 8).then_some(CanFrame { raw, data: [0; 8], dlc: dlc as u8, rtr: true, extended })
    }

    fn is_extended(&self) -> bool {
        self.is_extended_id()
    }

    fn is_remote_frame(&self) -> bool {
        self.rtr
    }

    fn id(&self) -> Id {
        if self.extended {
            Id::Extended(ExtendedId::new(self.raw).unwrap_or(ExtendedId::ZERO))
        } else {
            Id::Standard(StandardId::new(self.raw as u16).unwrap_or(StandardId::ZERO))
        }
    }

    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }

    fn data(&self) -> &[u8] {
        if self.rtr { &[] } else { self.data.get(..usize::from(self.dlc)).unwrap_or(&self.data) }
    }
}

/// An identifier's raw bits and whether it has 29.
fn raw_of(id: Id) -> (u32, bool) {
    match id {
        Id::Standard(id) => (u32::from(id.as_raw()), false),
        Id::Extended(id) => (id.as_raw(), true),
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

    #[test]
    fn priority_is_the_arbitration_field() {
        // The ISO 11898 arbitration field as bits: base, RTR or SRR, IDE, extension, RTR.
        fn field(f: &CanFrame) -> u32 {
            let (raw, rtr) = (f.raw_id(), u32::from(f.is_remote_frame()));
            if f.is_extended() { (raw >> 18) << 21 | 1 << 20 | 1 << 19 | (raw & 0x3_FFFF) << 1 | rtr } else { raw << 21 | rtr << 20 }
        }
        for id in 0..=0x7FF {
            for f in [CanFrame::standard(id, &[1]).unwrap(), CanFrame::remote(id, 2).unwrap()] {
                assert_eq!(f.priority(), field(&f), "{f:?}");
            }
        }
        for id in (0..=0x1FFF_FFFF).step_by(4093).chain([0x3_FFFF, 0x4_0000, 0x1FFF_FFFF]) {
            let remote = CanFrame { rtr: true, ..CanFrame::extended(id, &[]).unwrap() };
            for f in [CanFrame::extended(id, &[1]).unwrap(), remote] {
                assert_eq!(f.priority(), field(&f), "{f:?}");
            }
        }
    }

    #[test]
    fn a_frame_and_an_optional_frame_are_four_words() {
        assert_eq!((core::mem::size_of::<CanFrame>(), core::mem::size_of::<Option<CanFrame>>()), (16, 16));
        let x = CanFrame::extended(0x1ABC_DEF0, &[1, 2]).unwrap();
        assert_eq!(x.id(), Id::Extended(ExtendedId::new(0x1ABC_DEF0).unwrap()));
        let r = CanFrame::remote(0x7FF, 0).unwrap();
        assert_eq!(r.id(), Id::Standard(StandardId::new(0x7FF).unwrap()));
    }
}
