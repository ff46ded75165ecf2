//! Block download and upload. CiA 301 §7.2.4.3.9–16, figures 34–45.
//!
//! Download: the server offers a blksize that fits its buffer, collects
//! each sub-block of up to `blksize` segments (seqno 1, 2, …) and confirms
//! it with the sequence number of the last segment received in order
//! (ackseq). After a missing segment the rest of the block is ignored and
//! the client sends again from ackseq + 1. The CRC is worked out once, over
//! the value in the buffer, when the end request says where it ends: the
//! end request, which writes the value whole anyway, costs about 9
//! instructions a byte more (3,422 thumbv7m instructions for 200 bytes,
//! about 11,000 for the node's full 896-byte buffer: below a reset's
//! longest stage, 13,509), and no segment carries CRC code.
//!
//! Upload: after the client's start command `poll` sends the segments of a
//! block as fast as `tx` takes them; the client's ack may confirm fewer
//! (ackseq < blksize), and the next block then starts at the segment after
//! ackseq. Each byte enters the CRC the first time it is sent, so resent
//! segments cost no CRC work and no buffer is needed.

use super::{Buffer, Channel, SdoTx, State, Transfer, UNSIZED, Whole};
use crate::abort::AbortCode;
use crate::od::ObjectAccess;
use crate::time::At;
use crate::wire::sdo::SdoResponse;
use crate::wire::sdo_block::{BlockDownloadResponse, BlockSegment, MAX_BLKSIZE, SEGMENT_DATA, crc16, crc16_update};

/// The fields of an initiate block upload request.
#[derive(Clone, Copy, Debug)]
pub(super) struct UploadInitiate {
    /// The client supports a CRC.
    pub(super) crc: bool,
    /// Segments per block the client takes.
    pub(super) blksize: u8,
    /// Protocol switch threshold: a value of at most this many bytes (not
    /// 0) goes as an expedited or segmented upload instead.
    pub(super) pst: u8,
}

impl Transfer {
    /// Block upload: bytes of the current block's segments sent so far
    /// (at most 127 × 7).
    fn block_sent(&self) -> usize {
        usize::from(self.seq).wrapping_mul(SEGMENT_DATA)
    }

    /// Block upload: bytes of the value from the current block's start on.
    /// A block starts at most at the value's end (pos ≤ size), so no
    /// offset below is computed past the size: nothing wraps.
    fn block_rest(&self) -> usize {
        self.size.wrapping_sub(self.pos)
    }

    /// Block upload: a segment of the current block is still to send,
    /// fewer than blksize sent and the value's end not yet reached. The
    /// first segment always goes: a block starts before the value's end
    /// (after an ackseq that did not reach it), and an empty value (rest
    /// 0, hence the `max`) still takes one, c = 1 and n = 7 in the end
    /// request. No division for the count of the block's segments.
    fn block_unsent(&self) -> bool {
        self.seq < self.blksize && self.block_sent() < self.block_rest().max(1)
    }
}

/// [`Transfer::seq`]'s bit 7 in a block download: a segment of the
/// current block went missing, the rest of it is ignored (seq is at most
/// 127 otherwise).
const GAP: u8 = 0x80;

fn valid_blksize(blksize: u8) -> bool {
    (1..=MAX_BLKSIZE).contains(&blksize)
}

impl Channel {
    /// The blksize to offer when `total` of the buffer's `capacity` bytes
    /// are already collected: the segments it still has room for, 1..=127.
    fn download_blksize(capacity: usize, total: usize) -> u8 {
        // A rounding-up division (`div_ceil` computes the remainder too:
        // larger); + 6 cannot wrap a buffer's length, and total is at most
        // 7 past it, where the room, 0, becomes 1 as before.
        let room = capacity.wrapping_add(SEGMENT_DATA - 1).saturating_sub(total) / SEGMENT_DATA;
        u8::try_from(room.clamp(1, usize::from(MAX_BLKSIZE))).unwrap_or(MAX_BLKSIZE)
    }

    /// Initiate block download, once [`Channel::start_download`] has
    /// checked it and set the size: the first blksize the `capacity` bytes
    /// of the buffer have room for, which the caller's answer carries.
    pub(super) fn start_block_download(&mut self, crc: bool, capacity: usize) -> u8 {
        let blksize = Self::download_blksize(capacity, 0);
        self.state = State::BlockDownload;
        // `start_segments` set the size and pos 0; the block's own fields
        // (crc and crc_len are the upload's).
        self.t.crc_on = crc;
        self.t.blksize = blksize;
        self.t.seq = 0;
        blksize
    }

    /// One frame of a download sub-block: its byte 0 (c and seqno) and
    /// its seven data bytes, cut from the frame as received (no copy).
    pub(super) fn block_download_segment(&mut self, b0: u8, data: &[u8], buf: Buffer<'_>, tx: &mut dyn SdoTx) {
        let (seqno, last) = (b0 & 0x7F, b0 & 0x80 != 0);
        if seqno == 0 && last {
            // 0x80 is an abort from the client (ccs = 4): seqno 0 is never a segment.
            return self.reset();
        }
        let d = self.t;
        if seqno == 0 || seqno > d.blksize {
            return self.abort(AbortCode::InvalidSequence, tx);
        }
        // This server holds the buffer while its download runs (see `SdoServers`).
        let Some(buf) = buf else { return self.abort(AbortCode::NoResource, tx) };
        let capacity = buf.len();
        let mut total = d.pos;
        // With the gap mark until the ack.
        let mut ackseq = d.seq;
        // After a gap seq + 1 is above any seqno (bit 7 set, or 0 once
        // wrapped, refused above): the rest of the block is ignored. pos is
        // at most 7 past the buffer's end (a last segment's unused tail):
        // its sum cannot wrap.
        if seqno == d.seq.wrapping_add(1) {
            let start = d.pos;
            let end = start.wrapping_add(SEGMENT_DATA);
            if !last {
                // Every byte of a segment but the last is data.
                if end > d.size {
                    return self.abort(AbortCode::LengthTooHigh, tx);
                }
                if end > capacity {
                    return self.abort(AbortCode::OutOfMemory, tx);
                }
            }
            // The unused tail of the last segment need not fit: the end request says how much is data.
            // A byte loop over what fits, smaller than a bounded `copy_from_slice` (a memcpy call).
            for (dst, src) in buf.get_mut(start..).unwrap_or(&mut []).iter_mut().zip(data) {
                *dst = *src;
            }
            total = end;
            ackseq = seqno;
            self.t.pos = end;
            if last {
                self.state = State::BlockDownloadEnd;
            }
        } else if seqno > d.seq {
            // A segment went missing: the client sends again from ackseq + 1.
            ackseq = d.seq | GAP;
        }
        // Otherwise a repeat of a segment already accepted: ignored.
        if seqno == d.blksize || last {
            let blksize = Self::download_blksize(capacity, total);
            self.send(SdoResponse::BlockDownload(BlockDownloadResponse::Ack { ackseq: ackseq & !GAP, blksize }), tx);
            self.t.blksize = blksize;
            self.t.seq = 0;
        } else {
            self.t.seq = ackseq;
        }
    }

    /// A request after the last segment of a block download, the end
    /// request: the value whole, to write and answer.
    pub(super) fn block_download_end<'b>(&mut self, unused: u8, crc: u16, buf: Buffer<'b>, tx: &mut dyn SdoTx) -> Option<Whole<'b>> {
        let d = self.t;
        // The end request comes after the segment with c = 1 (`BlockDownloadEnd`),
        // so pos >= 7 >= unused: the subtraction does not wrap.
        let len = d.pos.wrapping_sub(usize::from(unused));
        let refused = match buf {
            None => AbortCode::NoResource,
            Some(buf) if len > buf.len() => AbortCode::OutOfMemory,
            Some(buf) => {
                let buf: &'b [u8] = buf;
                let value = buf.get(..len).unwrap_or(&[]);
                // The whole value's CRC here (see the module's doc).
                if d.crc_on && crc16(value) != crc {
                    AbortCode::CrcError
                } else if len > d.size {
                    AbortCode::LengthTooHigh
                } else if d.size != UNSIZED && len < d.size {
                    AbortCode::LengthTooLow
                } else {
                    let answer = SdoResponse::BlockDownload(BlockDownloadResponse::End).emit();
                    return Some(Whole { value, answer });
                }
            }
        };
        self.abort(refused, tx);
        None
    }

    /// Initiate block upload: the value's size and whether the block
    /// upload started (else the value has at most `pst` bytes and goes as
    /// an expedited or segmented upload); the caller answers either
    /// (`None`: aborted here).
    pub(super) fn start_block_upload(
        &mut self,
        UploadInitiate { crc, blksize, pst }: UploadInitiate,
        od: &mut dyn ObjectAccess,
        tx: &mut dyn SdoTx,
    ) -> Option<(usize, bool)> {
        let mux = self.mux;
        if !valid_blksize(blksize) {
            self.abort(AbortCode::InvalidBlockSize, tx);
            return None;
        }
        let size = match od.upload_size(mux.index(), mux.sub()) {
            Ok(size) => size,
            Err(code) => {
                self.abort(code, tx);
                return None;
            }
        };
        if pst != 0 && size <= usize::from(pst) {
            return Some((size, false));
        }
        self.state = State::BlockUploadStart;
        // The fields an upload reads (toggle is the segmented transfers').
        self.t.size = size;
        self.t.pos = 0;
        self.t.crc = 0;
        // Without a CRC no offset ever equals crc_len: the register stays 0.
        self.t.crc_len = if crc { 0 } else { usize::MAX };
        self.t.blksize = blksize;
        self.t.seq = 0;
        Some((size, true))
    }

    /// A request while a block upload is in progress: its cs (3 start, 2
    /// ack, 1 end) and an ack's ackseq and blksize.
    pub(super) fn block_upload(&mut self, cs: u8, ackseq: u8, blksize: u8, tx: &mut dyn SdoTx) {
        let u = self.t;
        // Each of the three states takes one cs: start (3) after the
        // initiate, an ack (2) while blocks go out, end (1) after the end
        // request; with the states' values 5, 6, 7 one sum tests all three.
        if (self.state as u8).wrapping_add(cs) != 8 {
            return self.abort(AbortCode::InvalidCommand, tx);
        }
        if cs != 2 {
            // Start (the segments go out from poll()) or end.
            self.state = if cs == 3 { State::BlockUpload } else { State::Idle };
            return;
        }
        if ackseq > u.seq {
            return self.abort(AbortCode::InvalidSequence, tx);
        }
        if !valid_blksize(blksize) {
            return self.abort(AbortCode::InvalidBlockSize, tx);
        }
        // ackseq is at most the segments sent, and each began
        // before the value's end: pos + acked cannot wrap.
        let acked = usize::from(ackseq).wrapping_mul(SEGMENT_DATA);
        let rest = u.block_rest();
        if ackseq > 0 && acked >= rest {
            // The segment with c = 1 is confirmed: its unused tail is n.
            self.state = State::BlockUploadEnd;
            // n = 0..=7, no clamp: ackseq is at most the segments
            // sent, and the block ends at the one with the value's
            // last byte (an empty value's one segment is all n).
            let unused = acked.wrapping_sub(rest) as u8;
            // Without a CRC the register stayed 0 (only a transfer with one updates it).
            let [c0, c1] = u.crc.to_le_bytes();
            self.emit([0xC1 | unused << 2, c0, c1, 0, 0, 0, 0, 0], tx);
        } else {
            // Next block, or the same one again from the segment after ackseq.
            self.t.pos = u.pos.wrapping_add(acked);
            self.t.seq = 0;
            self.t.blksize = blksize;
        }
    }

    /// Sends the unsent segments of the current upload block while `tx`
    /// takes them; whether segments of the block are left to send (`tx`
    /// was full): the poll asks this instead of a second test.
    pub(super) fn send_block_segments(&mut self, now: At, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> bool {
        if self.state != State::BlockUpload {
            return false;
        }
        while self.t.block_unsent() {
            let u = self.t;
            // Below the size, or the block's start (`block_unsent`).
            let sent = u.block_sent();
            let offset = u.pos.wrapping_add(sent);
            let left = u.block_rest().wrapping_sub(sent);
            let len = left.min(SEGMENT_DATA);
            // The value's bytes read into the frame in place, after byte 0.
            let mut frame = [0u8; 8];
            let data = frame.get_mut(1..=len).unwrap_or(&mut []);
            if let Err(code) = od.read(self.mux.index(), self.mux.sub(), offset, data) {
                self.abort(code, tx);
                return false;
            }
            let seqno = u.seq.saturating_add(1);
            // offset + 7 >= size, from the subtraction already made.
            let last = left <= SEGMENT_DATA;
            let [b0, ..] = &mut frame;
            *b0 = BlockSegment::byte0(seqno, last);
            if !tx.send(frame) {
                // This segment and the rest of the block wait for the next poll.
                return true;
            }
            // Each byte enters the CRC the first time it is sent.
            if offset == u.crc_len {
                self.t.crc = crc16_update(u.crc, frame.get(1..=len).unwrap_or(&[]));
                // At most the size: len is at most the bytes left.
                self.t.crc_len = offset.wrapping_add(len);
            }
            self.t.seq = seqno;
            self.restart_timer(now);
        }
        false
    }
}
