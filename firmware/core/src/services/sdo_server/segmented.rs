//! Segmented download and upload. CiA 301 §7.2.4.3.4–5 (download) and
//! §7.2.4.3.7–8 (upload): seven bytes per segment, a toggle bit that
//! starts at 0 and alternates (abort 0x05030000 when it does not).

use super::{Buffer, Channel, SdoTx, State, UNSIZED, Whole};
use crate::abort::AbortCode;
use crate::od::ObjectAccess;
use crate::wire::sdo::{SdoResponse, upload_segment_byte0};

/// Data bytes in one segment.
const SEGMENT: usize = 7;

/// A download segment request's fields (`SdoRequest::DownloadSegment`),
/// its data cut to the bytes it carries.
pub(super) struct Segment<'a> {
    pub(super) toggle: bool,
    pub(super) data: &'a [u8],
    pub(super) last: bool,
}

impl Channel {
    /// The fields of a segmented transfer of `size` bytes ([`UNSIZED`]: a
    /// download of a size not indicated) before its first segment; the
    /// others are not read.
    pub(super) fn start_segments(&mut self, size: usize) {
        self.t.size = size;
        self.t.pos = 0;
        self.t.toggle = false;
    }

    /// Initiate SDO download with e = 0 (`crc` `None`), or initiate block
    /// download (`crc` whether the client asked for a CRC): checks the
    /// entry and the size before any segment arrives. One copy of the
    /// checks for both (without block transfer `crc` is always `None`).
    /// `Some`: the download started, the caller answers it with this byte
    /// 0 and byte 4 (an initiate download response, the expedited one's
    /// answer, or an initiate block download response with sc = 1 and the
    /// blksize); `None`: aborted.
    pub(super) fn start_download(
        &mut self,
        size: Option<u32>,
        crc: Option<bool>,
        buf: Buffer<'_>,
        od: &mut dyn ObjectAccess,
        tx: &mut dyn SdoTx,
    ) -> Option<(u8, u8)> {
        let size = size.map(|s| usize::try_from(s).unwrap_or(usize::MAX));
        let mux = self.mux;
        let buf = match (od.download_check(mux.index(), mux.sub(), size), buf) {
            (Err(code), _) => return self.refuse(code, tx),
            // Another server holds the shared buffer for a download of its own.
            (Ok(()), None) => return self.refuse(AbortCode::NoResource, tx),
            (Ok(()), Some(buf)) => buf,
        };
        if size.is_some_and(|s| s > buf.len()) {
            return self.refuse(AbortCode::OutOfMemory, tx);
        }
        // An indicated size fits the buffer: below `UNSIZED`.
        self.start_segments(size.unwrap_or(UNSIZED));
        Some(match crc {
            None => {
                self.state = State::SegmentedDownload;
                (0x60, 0)
            }
            Some(crc) => (0xA4, self.start_block_download(crc, buf.len())),
        })
    }

    /// A request while a segmented download is in progress: the last
    /// segment's value whole, to write and answer; the others answered here.
    pub(super) fn segmented_download<'b>(
        &mut self,
        Segment { toggle, data: chunk, last }: Segment<'_>,
        buf: Buffer<'b>,
        tx: &mut dyn SdoTx,
    ) -> Option<Whole<'b>> {
        let t = self.t;
        // `pos` is at most the buffer's length (each segment's end is
        // checked against the buffer before it is kept) and a chunk at
        // most 7 bytes: the sum cannot wrap, and without the saturation
        // each sum is one instruction.
        let end = t.pos.wrapping_add(chunk.len());
        let refused = if toggle != t.toggle {
            AbortCode::ToggleBit
        } else if end > t.size {
            AbortCode::LengthTooHigh
        } else {
            // This server holds the buffer while its download runs (see `SdoServers`).
            match buf {
                None => AbortCode::NoResource,
                Some(buf) => match buf.get_mut(t.pos..end) {
                    None => AbortCode::OutOfMemory,
                    Some(dst) => {
                        dst.copy_from_slice(chunk);
                        let answer = SdoResponse::DownloadSegment { toggle }.emit();
                        if !last {
                            self.t.pos = end;
                            self.t.toggle = !toggle;
                            self.emit(answer, tx);
                            return None;
                        }
                        if t.size != UNSIZED && end < t.size {
                            AbortCode::LengthTooLow
                        } else {
                            let buf: &'b [u8] = buf;
                            return Some(Whole { value: buf.get(..end).unwrap_or(&[]), answer });
                        }
                    }
                },
            }
        };
        self.abort(refused, tx);
        None
    }

    /// A request while a segmented upload is in progress.
    pub(super) fn segmented_upload(&mut self, toggle: bool, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) {
        let t = self.t;
        if toggle != t.toggle {
            return self.abort(AbortCode::ToggleBit, tx);
        }
        // While an upload runs `pos` is at most `size` (it moves on only
        // while below it): neither the difference nor the sum below wraps.
        let len = t.size.wrapping_sub(t.pos).min(SEGMENT);
        // The value's bytes read into the answer in place, after byte 0
        // (as the block upload's segments). A value that shrank since the
        // initiate response reads short; the rest of the announced size
        // goes out as zeros.
        let mut frame = [0u8; 8];
        let [_, data @ ..] = &mut frame;
        if let Some(buf) = data.get_mut(..len)
            && let Err(code) = od.read(self.mux.index(), self.mux.sub(), t.pos, buf)
        {
            return self.abort(code, tx);
        }
        let pos = t.pos.wrapping_add(len);
        let last = pos >= t.size;
        if last {
            self.state = State::Idle;
        } else {
            self.t.pos = pos;
            self.t.toggle = !toggle;
        }
        let [b0, ..] = &mut frame;
        *b0 = upload_segment_byte0(toggle, u8::try_from(len).unwrap_or(0), last);
        self.emit(frame, tx);
    }
}
