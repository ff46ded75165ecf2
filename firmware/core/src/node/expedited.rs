//! Expedited SDO transfers served in place, for a device without SDO hooks
//! ([`Application::SDO_HOOKS`]): an idle server's initiate upload of a
//! value of 1 to 4 bytes, and its expedited download with a size to an
//! object from 0x2000 on (no service owns those), read from and written
//! to the dictionary with the look-up, checks and store the general path
//! uses, the answer queued as it queues it. No hook context, router or
//! parsed request is built, the server's state is not touched (it stays
//! idle), and nothing is undone: anything else (an error, another size, a
//! communication object, a full queue) goes to the general path before a
//! byte changes, so every abort code, the segmented transfer and an answer
//! kept for later are that path's alone.

use crate::od::access::small_value;
use crate::od::{ObjectDictionary, index, precheck, store_checked};
use crate::services::sdo_server::SdoTx;
use crate::storage::Storage;
use crate::wire::sdo::{Expedited, expedited_request, expedited_upload_response, initiate_download_response};

use super::router::SdoEffects;
use super::sinks::SdoSink;
use super::{Application, Node};

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Serves the request `data` on server `i` in place and answers on
    /// `tx_cob`; false: the general path serves it (`sdo_request`).
    #[inline(always)]
    pub(super) fn sdo_in_place(&mut self, i: usize, data: &[u8], tx_cob: u16) -> bool {
        !A::SDO_HOOKS && self.serve_in_place(i, data, tx_cob)
    }

    // Out of line: in line (all of it in the main loop), ds301 grew by 1,412
    // bytes instead of 500, core by 920 instead of 876.
    #[inline(never)]
    fn serve_in_place(&mut self, i: usize, data: &[u8], tx_cob: u16) -> bool {
        // As the general path does first: the client has given up waiting
        // for a store's answer (or aborted it). (Here, not once before both
        // paths: `on_frame` and with it the images with hooks stay as they were.)
        if O::SERVICES.storage {
            self.store_answer.drop_for(i);
        }
        if !self.sdo.is_idle(i) {
            return false;
        }
        let Some(request) = expedited_request(data) else { return false };
        let Node { od, txq, .. } = self;
        let dict = od.dictionary();
        let mut sink = SdoSink { txq, cob_id: tx_cob, hold: None };
        match request {
            Expedited::Upload { index, sub } => {
                match small_value(dict, od.image(), index, sub) {
                    Ok((head, size @ 1..=4)) => sink.send(expedited_upload_response(index, sub, head, size)),
                    // Empty or longer (a segmented upload), or an abort.
                    _ => false,
                }
            }
            Expedited::Download { index, sub, data, len } => {
                let data = data.get(..len).unwrap_or(&data);
                if index < index::MANUFACTURER_SPECIFIC {
                    return false;
                }
                // A constant: one of the two is linked.
                let checked =
                    if O::HAS_LIMITS { precheck::<true>(dict, index, sub, data) } else { precheck::<false>(dict, index, sub, data) };
                let Ok(entry) = checked else { return false };
                // Room for the answer before the write: written again by the
                // general path, the value would have changed nothing.
                if !sink.room() {
                    return false;
                }
                let Ok(changed) = store_checked(od.image_mut(), entry, data) else { return false };
                sink.send(initiate_download_response(index, sub));
                if changed {
                    // As `Ctx::write_plain`: the TPDOs mapping these bytes look for a change.
                    self.follow_sdo(SdoEffects { wrote: (entry.offset, entry.len.into()), ..SdoEffects::default() });
                }
                true
            }
        }
    }
}
