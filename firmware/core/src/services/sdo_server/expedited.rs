//! Initiate requests: expedited download and upload (CiA 301 §7.2.4.3.3,
//! §7.2.4.3.6), and the choice between an expedited and a segmented upload.

use super::{Channel, Mux, SdoTx, State, Whole, block};
use crate::abort::AbortCode;
use crate::od::ObjectAccess;
use crate::wire::sdo::{expedited_upload_response, initiate_download_response};

/// Largest value an expedited transfer carries.
const EXPEDITED_MAX: usize = 4;

impl Channel {
    /// Expedited SDO download (byte 0 `b0`, e = 1): the value, bytes 4..
    /// of the request as received (`raw`, 8 bytes), to be written whole,
    /// and its answer; `None` if its length (no size indicated) was refused.
    #[inline(always)]
    pub(super) fn expedited_download<'b, O: ObjectAccess>(
        &mut self,
        b0: u8,
        raw: &'b [u8],
        od: &mut O,
        tx: &mut dyn SdoTx,
    ) -> Option<Whole<'b>> {
        let len = if b0 & 0x01 != 0 {
            // s = 1: n (bits 3-2) bytes do not hold data.
            expedited_len(b0)
        } else {
            match unsized_expedited_len(od, self.mux) {
                Ok(k) => k,
                Err(code) => {
                    self.abort(code, tx);
                    return None;
                }
            }
        };
        // Bytes 4..4 + len of the request; len is 1 to 4, the sum cannot wrap.
        let value = raw.get(4..4usize.wrapping_add(len)).unwrap_or(&[]);
        Some(Whole { value, answer: initiate_download_response(self.mux.0) })
    }

    /// Initiate SDO upload, or initiate block upload (`block`): one answer
    /// for a value of 1 to 4 bytes, else the start of a segmented upload
    /// (also an empty value, which an expedited response cannot express),
    /// or of a block upload. A block upload that switches protocol (pst)
    /// answers as an initiate upload: one copy of each answer.
    pub(super) fn initiate_upload<O: ObjectAccess>(&mut self, block: Option<block::UploadInitiate>, od: &mut O, tx: &mut dyn SdoTx) {
        let mux = self.mux;
        let (index, sub) = (mux.index(), mux.sub());
        let mut data = [0u8; EXPEDITED_MAX];
        // `read`: the value's first bytes are still to be read into `data`;
        // `started`: a block upload started.
        let (size, read, started) = match block {
            None => match od.upload_small(index, sub, &mut data) {
                Ok(size) => (size, false, false),
                Err(code) => return self.abort(code, tx),
            },
            Some(request) => match self.start_block_upload(request, od, tx) {
                Some((size, started)) => (size, true, started),
                None => return,
            },
        };
        if !started && (1..=EXPEDITED_MAX).contains(&size) {
            if read
                && let Some(buf) = data.get_mut(..size)
                && let Err(code) = od.read(index, sub, 0, buf)
            {
                return self.abort(code, tx);
            }
            self.emit(expedited_upload_response(mux.0, data, size), tx);
        } else {
            if !started {
                self.state = State::SegmentedUpload;
                self.start_segments(size);
            }
            // One answer for both, the size in bytes 4-7: initiate upload
            // response (scs 2, s = 1) or initiate block upload response
            // (scs 6, sc = 1, s = 1).
            let b0 = if started { 0xC6 } else { 0x41 };
            self.emit(mux.frame(b0, u32::try_from(size).unwrap_or(u32::MAX).to_le_bytes()), tx);
        }
    }
}

/// The length of an expedited download with its size indicated (byte 0
/// `b0`, s = 1): 4 − n, n the bytes that hold no data (bits 3-2).
// `n` is two bits: 4 − n is 1..=4.
#[allow(clippy::arithmetic_side_effects)]
fn expedited_len(b0: u8) -> usize {
    usize::from(4 - ((b0 >> 2) & 0x03))
}

/// The length of an expedited download without size indicated (e = 1,
/// s = 0: "unspecified number of bytes", CiA 301 §7.2.4.3.3). Many clients
/// send 4 bytes whatever the type; the value is as long as the entry is, so
/// take the largest of 4, 3, 2, 1 bytes that `download_check` accepts, as
/// CANopenNode does with the entry length. Four lookups at most, no side
/// effects. Every check answers for the entry (no object, read only, …)
/// before it looks at a size, so the first one also stands for the check
/// without a size.
fn unsized_expedited_len(od: &mut dyn ObjectAccess, mux: Mux) -> Result<usize, AbortCode> {
    for len in (1..=EXPEDITED_MAX).rev() {
        match od.download_check(mux.index(), mux.sub(), Some(len)) {
            Ok(()) => return Ok(len),
            Err(AbortCode::LengthTooHigh) => continue,
            Err(code) => return Err(code),
        }
    }
    Err(AbortCode::LengthTooHigh)
}
