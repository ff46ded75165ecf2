//! Expedited SDO uploads served in place, for a device without SDO hooks
//! ([`Application::SDO_HOOKS`]): an idle server's initiate upload of a
//! value of 1 to 4 bytes, read from the dictionary with the look-up the
//! general path uses, the answer queued as it queues it. No hook context,
//! router or parsed request is built and the server's state is not touched
//! (it stays idle): anything else (an error, another size, a full queue)
//! goes to the general path, so every abort code, the segmented transfer
//! and an answer kept for later are that path's alone. Downloads, the
//! expedited ones too, take the general path: served here they saved 169
//! instructions a frame for 100 bytes of ds301 (docs/benchmarks.md,
//! "Round 15 (dlhalf)").

use crate::od::ObjectDictionary;
use crate::od::access::small_value;
use crate::services::sdo_server::SdoTx;
use crate::storage::Storage;
use crate::wire::sdo::{expedited_upload_response, multiplexer, upload_request};

use super::sinks::SdoSink;
use super::{Application, Node};

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Serves the request `data` on server `i` in place if it is an
    /// initiate upload, and answers on `tx_cob`; false: the general path
    /// serves it (`sdo_request`).
    #[inline(always)]
    pub(super) fn sdo_in_place(&mut self, i: usize, data: &[u8], tx_cob: u16) -> bool {
        // Byte 0 before the call: every other request goes straight on.
        !A::SDO_HOOKS && upload_request(data).is_some_and(|f| self.serve_in_place(i, f, tx_cob))
    }

    // Out of line: in line (all of it in the main loop), ds301 grew by 1,412
    // bytes instead of 500, core by 920 instead of 876.
    #[inline(never)]
    fn serve_in_place(&mut self, i: usize, f: &[u8; 8], tx_cob: u16) -> bool {
        // As the general path does first: the client has given up waiting
        // for a store's answer (or aborted it). (Here, not once before both
        // paths: `on_frame` and with it the images with hooks stay as they were.)
        if O::SERVICES.storage {
            self.store_answer.drop_for(i);
        }
        if !self.sdo.is_idle(i) {
            return false;
        }
        let (index, sub) = multiplexer(f);
        let Node { od, txq, .. } = self;
        let mut sink = SdoSink { txq, cob_id: tx_cob, hold: None };
        match small_value(od.dictionary(), od.image(), index, sub) {
            Ok((head, size @ 1..=4)) => sink.send(expedited_upload_response(index, sub, head, size)),
            // Empty or longer (a segmented upload), or an abort.
            _ => false,
        }
    }
}
