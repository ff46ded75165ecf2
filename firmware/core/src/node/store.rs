//! The store in stages: an SDO download of 0x1010/0x1011 or an LSS "store
//! configuration" starts it, [`Node::process`] runs a stage per call
//! (`services::store::Job`), and its answer goes out when it ends, so that
//! no call does a whole store (docs/firmware.md, "Store and restore in stages").
//!
//! Meanwhile:
//! - a frame from the same SDO client ends its wait: the store goes on to
//!   its end, unanswered (the client gave up or aborted; an answer after
//!   its next request would be taken for that one's);
//! - a second store is refused (SDO abort 0x08000022, LSS "storage
//!   failed", `StoreError::Busy` for the device's own `Ctx::save`, …):
//!   both would write the same region; a device hook asks `Ctx::storing`
//!   and stores at its first poll after it (the EC5000 after 0x1011);
//! - an NMT reset waits for the store (the reset loads what it stored); its
//!   SDO answer is dropped, as a reset ends every SDO transfer, and so it is
//!   in Stopped;
//! - every other frame is served as usual; a value written between two
//!   stages is stored as it was before or after, whole.

use crate::od::ObjectDictionary;
use crate::services::lss::LssSlave;
use crate::storage::Storage;
use crate::wire::lss::SLAVE_COB_ID;

use super::router::store_abort;
use super::{Application, Node};
use crate::abort::AbortCode;

/// Who hears the end of the store in progress. All zero bits when nobody.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct StoreAnswer {
    /// SDO server `i` as `i + 1`; 0 for LSS.
    server: u8,
    /// The answer's COB-ID (0: no answer).
    cob_id: u16,
    /// The object an SDO abort names.
    index: u16,
    sub: u8,
}

impl StoreAnswer {
    /// No answer due.
    pub(super) const NONE: StoreAnswer = StoreAnswer { server: 0, cob_id: 0, index: 0, sub: 0 };

    /// SDO server `i` (answering on `cob_id`) holds the answer to a download of (index, sub).
    pub(super) fn sdo(i: usize, cob_id: u16, index: u16, sub: u8) -> StoreAnswer {
        StoreAnswer { server: (i as u8).wrapping_add(1), cob_id, index, sub }
    }

    /// Drops the answer if SDO server `i` holds it (its client sent a frame: the server answers that now).
    pub(super) fn drop_for(&mut self, i: usize) {
        if self.cob_id != 0 && usize::from(self.server) == i.wrapping_add(1) {
            *self = StoreAnswer::NONE;
        }
    }
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Whether a store is in progress: [`Node::process`] goes on with it a
    /// stage per call and returns `now` as its deadline until it is done.
    pub fn storing(&self) -> bool {
        self.hook.store.busy()
    }

    /// LSS "store configuration": a store in stages, answered at its end;
    /// refused at once ("storage failed") while another store runs, or
    /// without storage.
    pub(super) fn store_lss(&mut self, node_id: u8, bit_rate: u8) {
        if !O::SERVICES.storage || self.hook.store.busy() {
            self.push(SLAVE_COB_ID, &LssSlave::store_result(false));
            return;
        }
        self.hook.store.begin(crate::services::store::Job::lss(node_id, bit_rate));
        self.store_answer = StoreAnswer { server: 0, cob_id: SLAVE_COB_ID, index: 0, sub: 0 };
    }

    /// One stage of the store in progress; at its end, its answer: the
    /// SDO server's download response, which it kept unsent ([`SdoSink`]'s
    /// `hold`) and sends at this call's SDO poll, or in its place an abort;
    /// or the LSS answer.
    ///
    /// [`SdoSink`]: super::sinks::SdoSink
    pub(super) fn store_step(&mut self) {
        let Node { od, storage, hook, .. } = self;
        let Some(result) = hook.store.step(od.dictionary(), od.image(), hook.node_id, storage) else { return };
        let answer = core::mem::replace(&mut self.store_answer, StoreAnswer::NONE);
        let frame = match (answer.server, result) {
            (_, _) if answer.cob_id == 0 => return,
            (0, result) => LssSlave::store_result(result.is_ok()),
            (_, Ok(())) => return,
            (server, Err(e)) => {
                // The server drops the response it kept; the abort (CiA 301 §7.2.4.3.17) goes instead.
                self.sdo.reset(usize::from(server).wrapping_sub(1));
                // As one 64-bit value: two word stores, not eight of bytes.
                let head = 0x80 | u32::from(answer.index) << 8 | u32::from(answer.sub) << 24;
                // The code as a constant of each error (not `AbortCode::code`'s packed table, decoded at run time).
                let code = match store_abort(e) {
                    AbortCode::Hardware => const { AbortCode::Hardware.code() },
                    AbortCode::CannotStore => const { AbortCode::CannotStore.code() },
                    _ => const { AbortCode::DeviceState.code() },
                };
                (u64::from(head) | u64::from(code) << 32).to_le_bytes()
            }
        };
        self.push(answer.cob_id, &frame);
    }
}
