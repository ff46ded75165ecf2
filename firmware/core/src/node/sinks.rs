//! Where the services' frames and events go: the node's transmit queue,
//! EMCY and the application, borrowed field by field so that a service and
//! its sink can be used at once.

use core::cell::Cell;
use core::marker::PhantomData;

use crate::frame::CanFrame;
use crate::services::emcy::EmcyProducer;
use crate::services::pdo::PdoTx;
use crate::services::pdo::map::{MAX_LEN, Mapping};
use crate::services::sdo_server::SdoTx;
use crate::txq::TxQueue;

use crate::wire::emcy::EmcyCode;

use super::{Application, EMCY_SLOTS, TX_QUEUE};

/// Queue slots an SDO transfer leaves free for heartbeat and EMCY.
const SDO_RESERVE: usize = 4;

/// Where the SDO server's frames go: the node's queue, keeping a reserve.
pub(super) struct SdoSink<'a> {
    pub(super) txq: &'a mut TxQueue<TX_QUEUE>,
    pub(super) cob_id: u16,
    /// Set once the request started a store in stages: its answer is
    /// refused, so the server keeps it and sends it at its next poll, the
    /// first after the store (or drops it when its client moves on).
    pub(super) hold: Option<&'a Cell<Option<(u16, u8)>>>,
}

impl SdoTx for SdoSink<'_> {
    fn send(&mut self, data: [u8; 8]) -> bool {
        if self.hold.is_some_and(|h| h.get().is_some()) {
            return false;
        }
        // Written straight into its queue slot: no frame built and copied.
        self.room() && self.txq.push_data(self.cob_id, &data, 8)
    }
}

impl SdoSink<'_> {
    /// Whether an answer would be queued now (`send` refuses it otherwise).
    /// The 11-bit check here, ahead of `push_data`'s own: the compiler then
    /// knows every caller's identifier fits and drops that one from the
    /// TPDOs' path (4 instructions a TPDO).
    #[inline(always)]
    pub(super) fn room(&self) -> bool {
        self.cob_id <= 0x7FF && self.txq.free() > SDO_RESERVE
    }
}

/// Where the PDOs' frames and events go: the queue and EMCY; what the
/// device must hear is collected for the node to tell it once the PDOs are
/// done with the image. `A`, the device, gives its EMCY code for an RPDO
/// too long as a constant (not a field each sink is built with).
pub(super) struct PdoSink<'a, A> {
    pub(super) txq: &'a mut TxQueue<TX_QUEUE>,
    pub(super) emcy: &'a mut EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>,
    /// Bit n: RPDO n wrote its objects.
    pub(super) received: u32,
    /// The RPDO errors the device hears as communication errors: bit n
    /// RPDO n timed out, bit 16 + n a frame of RPDO n had a wrong length
    /// ([`LENGTH_ERRORS`]). One word, so that an RPDO without errors costs
    /// nothing more to collect them.
    pub(super) errors: u32,
    device: PhantomData<fn() -> A>,
}

impl<'a, A: Application> PdoSink<'a, A> {
    pub(super) fn new(txq: &'a mut TxQueue<TX_QUEUE>, emcy: &'a mut EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>) -> Self {
        PdoSink { txq, emcy, received: 0, errors: 0, device: PhantomData }
    }

    /// `code` as the device reports it (its code for an RPDO longer than
    /// its mapping: `CanEmcyCodes::rpdo_too_long`).
    fn device_code(code: EmcyCode) -> EmcyCode {
        if code == EmcyCode::PDO_LENGTH_EXCEEDED { A::CAN_EMCY.rpdo_too_long } else { code }
    }
}

/// One bit per RPDO (at most 32 are told apart; CiA 301 allows 512).
pub(super) fn bit(n: usize) -> u32 {
    1u32.checked_shl(n as u32).unwrap_or(0)
}

/// The first bit of the length errors in [`PdoSink::errors`] (the first 16 RPDOs are told apart).
pub(super) const LENGTH_ERRORS: usize = 16;

impl<A: Application> PdoTx for PdoSink<'_, A> {
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool {
        CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f))
    }

    fn send_data(&mut self, cob_id: u16, data: &[u8; MAX_LEN], len: usize) -> bool {
        self.txq.push_data(cob_id, data, u8::try_from(len).unwrap_or(u8::MAX))
    }

    fn send_mapped(&mut self, cob_id: u16, mapping: &Mapping, image: &[u8]) -> bool {
        // `len` is at most 8: one compare, no conversion.
        let Some(data) = self.txq.reserve_data(cob_id, mapping.len() as u8) else { return false };
        mapping.build(image, data);
        true
    }

    // In line: every RPDO frame ends here.
    #[inline(always)]
    fn received(&mut self, n: usize) {
        self.received |= bit(n);
    }

    // Left to the inliner since round 15: out of line it cost 96 / 76 B on
    // the references after the merges.
    fn error(&mut self, rpdo: usize, code: EmcyCode) {
        self.errors |= if code == EmcyCode::RPDO_TIMEOUT { bit(rpdo) & 0xFFFF } else { bit(rpdo) << LENGTH_ERRORS };
        // The low byte of the 1-based RPDO number (below 513: 0x1400..=0x15FF).
        self.emcy.raise(Self::device_code(code), [rpdo.wrapping_add(1) as u8, 0, 0, 0, 0]);
    }

    fn error_cleared(&mut self, _rpdo: usize, code: EmcyCode) {
        self.emcy.clear(Self::device_code(code));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `received` marks RPDO n's bit, and no error; RPDOs past 31 have no bit.
    #[test]
    fn a_received_rpdo_is_marked_by_its_bit() {
        for n in [0, 1, 5, 31, 32, 511] {
            let (mut txq, mut emcy) = (TxQueue::new(), EmcyProducer::new());
            let mut sink = PdoSink::<crate::node::NoApplication>::new(&mut txq, &mut emcy);
            sink.received(n);
            assert_eq!((sink.received, sink.errors), (if n < 32 { 1 << n } else { 0 }, 0), "RPDO {n}");
        }
    }
}
