//! SDO server. CiA 301 v4.2 §7.2.4; protocols §7.2.4.3 (figures 21–45);
//! abort codes §7.2.4.3.17. The node owns the server parameter objects
//! 0x1200–0x127F and routes this server's rx COB-ID here.
//!
//! Read first: CiA 301 §7.2.4.3.3–7.2.4.3.8 (expedited and segmented
//! transfers, toggle bit), §7.2.4.3.9–7.2.4.3.16 (block transfers: blksize,
//! seqno, ackseq, pst, CRC) and the wire formats in [`crate::wire::sdo`] and
//! [`crate::wire::sdo_block`].
//!
//! The work is split by job:
//! - this file: the public API, dispatch by state, the response slot and
//!   the SDO timeout;
//! - `expedited.rs`: initiate requests (expedited transfers, and the choice
//!   between expedited and segmented upload);
//! - `segmented.rs`: segmented download and upload with the toggle bit;
//! - `block.rs`: block download and upload, with CRC and retransmission.
//!
//! Every frame costs bounded work: at most 7 data bytes are copied or
//! CRC'd per frame received or sent, and the dictionary is reached only
//! through [`ObjectAccess`] lookups by (index, sub-index). Downloads other
//! than expedited ones are collected in an `N`-byte buffer and written whole
//! with [`ObjectAccess::write`] when the last segment arrives, so a value is
//! never left half-written. Uploads read the value in 7-byte pieces with
//! [`ObjectAccess::read`] and need no buffer.
//!
//! Not supported: SDO block download of a value larger than `N`
//! (aborted with 0x05040005), and resuming a block download whose last
//! segment of a block was lost (the transfer times out, as nothing tells the
//! server that the block ended).
#![deny(clippy::indexing_slicing, clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::arithmetic_side_effects)]

mod block;
mod expedited;
mod segmented;
#[cfg(test)]
mod tests;

use crate::abort::AbortCode;
use crate::od::ObjectAccess;
use crate::time::{Duration, Instant};
use crate::wire::sdo::{SdoParseError, SdoRequest, SdoResponse};
use crate::wire::sdo_block::{BlockDownloadRequest, BlockSegment, BlockUploadRequest};

/// Where the server's responses go; false = TX queue full (try again on the next poll).
pub trait SdoTx {
    /// Queues one frame on the server's tx COB-ID (0x580 + node-ID for the
    /// default server); returns false if there is no room.
    fn send(&mut self, data: [u8; 8]) -> bool;
}

/// The SDO timeout a new server starts with.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(1);

/// Object index and sub-index of a transfer (the SDO "multiplexer").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Mux {
    index: u16,
    sub: u8,
}

impl Mux {
    /// The multiplexer of an abort that belongs to no transfer.
    const NONE: Mux = Mux { index: 0, sub: 0 };
}

/// What the server is doing.
#[derive(Clone, Copy, Debug)]
enum State {
    Idle,
    SegmentedDownload(segmented::Download),
    SegmentedUpload(segmented::Upload),
    BlockDownload(block::Download),
    BlockUpload(block::Upload),
}

impl State {
    fn mux(&self) -> Option<Mux> {
        match self {
            State::Idle => None,
            State::SegmentedDownload(d) => Some(d.mux),
            State::SegmentedUpload(u) => Some(u.mux),
            State::BlockDownload(d) => Some(d.mux),
            State::BlockUpload(u) => Some(u.mux),
        }
    }
}

/// Whether a request opens a new transfer (whatever the server is doing).
fn starts_transfer(request: &SdoRequest) -> bool {
    matches!(
        request,
        SdoRequest::InitiateDownload { .. }
            | SdoRequest::InitiateUpload { .. }
            | SdoRequest::BlockDownload(BlockDownloadRequest::Initiate { .. })
            | SdoRequest::BlockUpload(BlockUploadRequest::Initiate { .. })
    )
}

/// A CiA 301 SDO server with an `N`-byte download buffer.
///
/// Drive it with [`on_request`](Self::on_request) for every frame on its rx
/// COB-ID and [`poll`](Self::poll) after every `on_request` and at the
/// deadline `poll` returns. `on_request` answers with one frame at most
/// (plus a timeout abort if `poll` was late); block upload segments go out
/// from `poll` only, so that `on_request` stays short enough for an RX
/// interrupt.
#[derive(Debug)]
pub struct SdoServer<const N: usize> {
    state: State,
    timeout: Duration,
    /// When the transfer in progress times out (meaningless when idle).
    deadline: Instant,
    /// A response `tx` refused, sent again by the next `poll`.
    pending: Option<[u8; 8]>,
    malformed: u32,
    buf: [u8; N],
}

impl<const N: usize> Default for SdoServer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SdoServer<N> {
    /// An idle server with the [`DEFAULT_TIMEOUT`] of 1 s.
    pub const fn new() -> Self {
        SdoServer { state: State::Idle, timeout: DEFAULT_TIMEOUT, deadline: Instant::ZERO, pending: None, malformed: 0, buf: [0; N] }
    }

    /// Sets the time the server waits for the client's next frame (or for
    /// room to send its own) before it aborts with 0x05040000. Takes effect
    /// from the next frame.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// Whether no transfer is in progress and no response is waiting to be sent.
    pub fn is_idle(&self) -> bool {
        matches!(self.state, State::Idle) && self.pending.is_none()
    }

    /// Drops any transfer and unsent response without a frame (NMT reset
    /// communication, or the server disabled through 0x1200).
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.pending = None;
    }

    /// One frame from the client on this server's rx COB-ID (data as received; DLC != 8 is counted in `malformed()` and ignored).
    ///
    /// A request with an unknown command specifier is counted too, and
    /// answered with abort 0x05040001. A new initiate request while a
    /// transfer is in progress ends that transfer without a frame and is
    /// answered as if the server were idle. A frame that arrives at or after
    /// the transfer's deadline (because `poll` was late) first triggers the
    /// timeout abort; it is then served only if it initiates a new transfer.
    pub fn on_request(&mut self, now: Instant, data: &[u8], od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) {
        // A frame at or after the deadline comes too late for its transfer:
        // the timeout abort answers it, and only a new initiate is served.
        let expired = self.expire(now, tx);
        match self.state {
            // Sub-block frames carry a sequence number where other frames
            // have a command specifier; only the state tells them apart.
            State::BlockDownload(d) if d.in_sub_block() => match BlockSegment::parse(data) {
                Ok(segment) => self.block_download_segment(d, segment, tx),
                Err(_) => return self.count_malformed(),
            },
            _ => match SdoRequest::parse(data) {
                Ok(request) if expired && !starts_transfer(&request) => {}
                Ok(request) => self.request(request, od, tx),
                Err(SdoParseError::Length(_)) => return self.count_malformed(),
                Err(SdoParseError::UnknownCommand { index, sub, .. }) => {
                    self.count_malformed();
                    if !expired {
                        let mux = self.state.mux().unwrap_or(Mux { index, sub });
                        self.fail(mux, AbortCode::InvalidCommand, tx);
                    }
                }
            },
        }
        if !matches!(self.state, State::Idle) {
            self.restart_timer(now);
        }
    }

    /// Sends pending block-upload segments while `tx` accepts them; aborts with 0x05040000 on timeout; returns the next deadline (None when idle).
    ///
    /// The deadline is `now` while frames wait for room in `tx` (call again
    /// when the TX queue drains), else the timeout of the transfer in
    /// progress. Calling early is harmless.
    pub fn poll(&mut self, now: Instant, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> Option<Instant> {
        self.expire(now, tx);
        if self.flush(tx) {
            self.send_block_segments(now, od, tx);
        }
        if self.pending.is_some() || self.segments_waiting() {
            Some(now)
        } else if matches!(self.state, State::Idle) {
            None
        } else {
            Some(self.deadline)
        }
    }

    /// Frames ignored because their length was not 8, plus requests with an
    /// unknown command specifier (those were answered with an abort).
    pub fn malformed(&self) -> u32 {
        self.malformed
    }

    /// The transfer in progress times out `timeout` after `now`.
    #[allow(clippy::arithmetic_side_effects)] // Instant + Duration saturates (time.rs).
    fn restart_timer(&mut self, now: Instant) {
        self.deadline = now + self.timeout;
    }

    fn count_malformed(&mut self) {
        self.malformed = self.malformed.saturating_add(1);
    }

    /// A request outside the block download sub-block phase.
    fn request(&mut self, request: SdoRequest, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) {
        // An abort or a new initiate ends whatever was in progress.
        match request {
            SdoRequest::Abort { .. } => self.reset(),
            SdoRequest::InitiateDownload { index, sub, data } => {
                self.reset();
                self.initiate_download(Mux { index, sub }, data, od, tx);
            }
            SdoRequest::InitiateUpload { index, sub } => {
                self.reset();
                self.initiate_upload(Mux { index, sub }, od, tx);
            }
            SdoRequest::BlockDownload(BlockDownloadRequest::Initiate { index, sub, crc, size }) => {
                self.reset();
                self.start_block_download(Mux { index, sub }, crc, size, od, tx);
            }
            SdoRequest::BlockUpload(BlockUploadRequest::Initiate { index, sub, crc, blksize, pst }) => {
                self.reset();
                self.start_block_upload(Mux { index, sub }, crc, blksize, pst, od, tx);
            }
            _ => match self.state {
                State::Idle => self.fail(Mux::NONE, AbortCode::InvalidCommand, tx),
                State::SegmentedDownload(d) => self.segmented_download(d, request, od, tx),
                State::SegmentedUpload(u) => self.segmented_upload(u, request, od, tx),
                State::BlockDownload(d) => self.block_download_end(d, request, od, tx),
                State::BlockUpload(u) => self.block_upload(u, request, tx),
            },
        }
    }

    /// Aborts the transfer in progress with 0x05040000 once `now` reaches
    /// its deadline; true if it did.
    fn expire(&mut self, now: Instant, tx: &mut dyn SdoTx) -> bool {
        match self.state.mux() {
            Some(mux) if now >= self.deadline => {
                self.fail(mux, AbortCode::Timeout, tx);
                true
            }
            _ => false,
        }
    }

    /// Ends the transfer and sends an abort frame.
    fn fail(&mut self, mux: Mux, code: AbortCode, tx: &mut dyn SdoTx) {
        self.state = State::Idle;
        self.send(SdoResponse::Abort { index: mux.index, sub: mux.sub, code: code.code() }, tx);
    }

    fn send(&mut self, response: SdoResponse, tx: &mut dyn SdoTx) {
        self.emit(response.emit(), tx);
    }

    /// Sends a frame, or keeps it for the next poll. A newer response
    /// replaces an unsent older one: the client has moved on.
    fn emit(&mut self, frame: [u8; 8], tx: &mut dyn SdoTx) {
        self.pending = None;
        if !tx.send(frame) {
            self.pending = Some(frame);
        }
    }

    /// Sends the kept frame; true when nothing is left waiting.
    fn flush(&mut self, tx: &mut dyn SdoTx) -> bool {
        match self.pending {
            Some(frame) if tx.send(frame) => {
                self.pending = None;
                true
            }
            Some(_) => false,
            None => true,
        }
    }
}
