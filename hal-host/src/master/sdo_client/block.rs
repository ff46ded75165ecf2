//! SDO block upload and download, client side. CiA 301 v4.2
//! §7.2.4.3.9–16, figures 34–45; formats in [`canopen_core::wire::sdo_block`].
//!
//! Upload: the client picks blksize and pst, answers each sub-block with
//! the sequence number of the last segment it got in order (segments after
//! a gap are dropped, and the server starts the next sub-block after that
//! number), and checks size and CRC when the server ends the transfer.
//!
//! Download: the server picks blksize (in its initiate response and in
//! each acknowledgement); an ackseq below the segments sent makes the
//! client send the rest again, renumbered from 1, in the next sub-block.

use super::{ProtocolError, SdoTransfer, State, chunk};
use canopen_core::wire::sdo::{SdoRequest, SdoResponse};
use canopen_core::wire::sdo_block::{
    BlockDownloadRequest, BlockDownloadResponse, BlockSegment, BlockUploadRequest, BlockUploadResponse, MAX_BLKSIZE, SEGMENT_DATA, crc16,
};

/// Where a block upload stands.
#[derive(Clone, Copy, Debug)]
pub(super) enum Upload {
    /// Waiting for the initiate block upload response (or, with pst, for an
    /// initiate upload response).
    Initiate { crc: bool, blksize: u8 },
    /// Receiving a sub-block; `expected` is the next sequence number in order.
    SubBlock { crc: bool, blksize: u8, size: Option<u32>, expected: u8 },
    /// The last segment is in; waiting for the end block upload.
    End { crc: bool, size: Option<u32> },
}

impl Upload {
    /// Whether the server's next frames are segments without a command specifier.
    pub(super) fn in_sub_block(&self) -> bool {
        matches!(self, Upload::SubBlock { .. })
    }
}

/// Where a block download stands.
#[derive(Clone, Copy, Debug)]
pub(super) enum Download {
    /// Waiting for the initiate block download response.
    Initiate { crc: bool },
    /// A sub-block of `sent` segments, starting at segment `first` of the
    /// value (counting from 0), waits for its acknowledgement.
    SubBlock { crc: bool, first: usize, sent: u8 },
    /// Waiting for the end block download response.
    End,
}

/// Segments a block download of `len` bytes takes (an empty value takes one,
/// with 7 unused bytes).
fn segments(len: usize) -> usize {
    len.div_ceil(SEGMENT_DATA).max(1)
}

impl SdoTransfer {
    /// A server frame of a block upload outside the sub-block phase.
    pub(super) fn block_upload_response(&mut self, u: Upload, response: SdoResponse) {
        match (u, response) {
            (
                Upload::Initiate { crc, blksize },
                SdoResponse::BlockUpload(BlockUploadResponse::Initiate { index, sub, crc: server_crc, size }),
            ) => {
                if !self.check_multiplexer(index, sub) {
                    return;
                }
                if !self.fits(size) {
                    return self.protocol_error(ProtocolError::TooLong);
                }
                self.send(SdoRequest::BlockUpload(BlockUploadRequest::Start));
                self.state = State::BlockUpload(Upload::SubBlock { crc: crc && server_crc, blksize, size, expected: 1 });
            }
            // Protocol switch (pst): the server answered as to an initiate upload.
            (Upload::Initiate { .. }, SdoResponse::InitiateUpload { index, sub, data }) => self.initiate_upload_response(index, sub, data),
            (Upload::End { crc, size }, SdoResponse::BlockUpload(BlockUploadResponse::End { unused, crc: received })) => {
                // The last segment came whole; n says how much of it is padding.
                let len = self.data.len().saturating_sub(usize::from(unused));
                self.data.truncate(len);
                let computed = crc16(&self.data);
                if crc && computed != received {
                    return self.protocol_error(ProtocolError::Crc { received, computed });
                }
                if let Some(s) = size
                    && usize::try_from(s).ok() != Some(len)
                {
                    return self.protocol_error(ProtocolError::SizeMismatch { indicated: s, received: len });
                }
                self.send(SdoRequest::BlockUpload(BlockUploadRequest::End));
                self.finish(Ok(()));
            }
            (_, r) => self.unexpected(&r),
        }
    }

    /// A frame of a block upload sub-block.
    pub(super) fn block_upload_segment(&mut self, u: Upload, data: &[u8]) {
        let Upload::SubBlock { crc, blksize, size, expected } = u else { return };
        let segment = match BlockSegment::parse(data) {
            Ok(s) => s,
            Err(e) => return self.protocol_error(e.into()),
        };
        if segment.seqno == 0 || segment.seqno > blksize {
            return self.protocol_error(ProtocolError::Sequence(segment.seqno));
        }
        // A segment out of order (one before it was lost, or a repeat) is
        // dropped; the acknowledgement tells the server where to go on.
        let in_order = segment.seqno == expected;
        let expected = if in_order {
            self.data.extend_from_slice(&segment.data);
            if self.data.len() > self.client.max_upload.saturating_add(SEGMENT_DATA) {
                return self.protocol_error(ProtocolError::TooLong);
            }
            expected.saturating_add(1)
        } else {
            expected
        };
        let next = if segment.seqno == blksize || segment.last {
            self.send(SdoRequest::BlockUpload(BlockUploadRequest::Ack { ackseq: expected.saturating_sub(1), blksize }));
            if in_order && segment.last { Upload::End { crc, size } } else { Upload::SubBlock { crc, blksize, size, expected: 1 } }
        } else {
            Upload::SubBlock { crc, blksize, size, expected }
        };
        self.state = State::BlockUpload(next);
    }

    /// A server frame of a block download.
    pub(super) fn block_download_response(&mut self, d: Download, response: SdoResponse) {
        match (d, response) {
            (
                Download::Initiate { crc },
                SdoResponse::BlockDownload(BlockDownloadResponse::Initiate { index, sub, crc: server_crc, blksize }),
            ) => {
                if self.check_multiplexer(index, sub) {
                    self.send_sub_block(crc && server_crc, 0, blksize);
                }
            }
            (Download::SubBlock { crc, first, sent }, SdoResponse::BlockDownload(BlockDownloadResponse::Ack { ackseq, blksize })) => {
                if ackseq > sent {
                    return self.protocol_error(ProtocolError::Sequence(ackseq));
                }
                let next = first.saturating_add(usize::from(ackseq));
                let total = segments(self.data.len());
                if next < total {
                    return self.send_sub_block(crc, next, blksize);
                }
                let padding = total.saturating_mul(SEGMENT_DATA).saturating_sub(self.data.len());
                // Without CRC support on both sides the field is not valid; send 0.
                let crc = if crc { crc16(&self.data) } else { 0 };
                self.send(SdoRequest::BlockDownload(BlockDownloadRequest::End { unused: u8::try_from(padding).unwrap_or(0), crc }));
                self.state = State::BlockDownload(Download::End);
            }
            (Download::End, SdoResponse::BlockDownload(BlockDownloadResponse::End)) => self.finish(Ok(())),
            (_, r) => self.unexpected(&r),
        }
    }

    /// Sends up to `blksize` segments from segment `first` of the value.
    fn send_sub_block(&mut self, crc: bool, first: usize, blksize: u8) {
        if !(1..=MAX_BLKSIZE).contains(&blksize) {
            return self.protocol_error(ProtocolError::BlockSize(blksize));
        }
        let total = segments(self.data.len());
        let mut sent = 0u8;
        for n in first..total.min(first.saturating_add(usize::from(blksize))) {
            let (data, _) = chunk(&self.data, n.saturating_mul(SEGMENT_DATA));
            sent = sent.saturating_add(1);
            self.tx.push_back(BlockSegment { seqno: sent, last: n.saturating_add(1) == total, data }.emit());
        }
        self.state = State::BlockDownload(Download::SubBlock { crc, first, sent });
    }
}
