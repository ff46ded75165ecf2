//! Where the services' frames and events go: the node's transmit queue,
//! EMCY and the application, borrowed field by field so that a service and
//! its sink can be used at once.

use crate::frame::CanFrame;
use crate::services::emcy::EmcyProducer;
use crate::services::pdo::{PdoEvent, PdoTx};
use crate::services::sdo_server::SdoTx;
use crate::txq::TxQueue;

use super::{Application, EMCY_SLOTS, TX_QUEUE};

/// Queue slots an SDO transfer leaves free for heartbeat and EMCY.
const SDO_RESERVE: usize = 4;

/// Where the SDO server's frames go: the node's queue, keeping a reserve.
pub(super) struct SdoSink<'a> {
    pub(super) txq: &'a mut TxQueue<TX_QUEUE>,
    pub(super) cob_id: u16,
}

impl SdoTx for SdoSink<'_> {
    fn send(&mut self, data: [u8; 8]) -> bool {
        self.txq.free() > SDO_RESERVE && CanFrame::standard(self.cob_id, &data).is_some_and(|f| self.txq.push(f))
    }
}

/// Where the PDOs' frames and events go: the queue, EMCY, the application.
pub(super) struct PdoSink<'a, A: Application> {
    pub(super) txq: &'a mut TxQueue<TX_QUEUE>,
    pub(super) emcy: &'a mut EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>,
    pub(super) app: &'a mut A,
}

impl<A: Application> PdoTx for PdoSink<'_, A> {
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool {
        CanFrame::standard(cob_id, data).is_some_and(|f| self.txq.push(f))
    }

    fn event(&mut self, event: PdoEvent) {
        match event {
            PdoEvent::Received(n) => self.app.on_rpdo(n),
            PdoEvent::Error { rpdo, code } => {
                self.emcy.raise(code, [rpdo as u8 + 1, 0, 0, 0, 0]);
            }
            PdoEvent::ErrorCleared { code, .. } => self.emcy.clear(code),
        }
    }
}
