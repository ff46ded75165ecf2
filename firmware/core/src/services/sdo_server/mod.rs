//! SDO server. CiA 301 v4.2 §7.2.4; protocols §7.2.4.3 (figures 21–45);
//! abort codes §7.2.4.3.17. The node owns the server parameter objects
//! 0x1200–0x127F and routes each server's rx COB-ID here: [`SdoServer`] is
//! one server with its own buffer, [`SdoServers`] the default server and
//! further ones (0x1201 …) sharing one buffer.
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
//! CRC'd per frame received or sent, but for a download's last frame, and
//! the dictionary is reached only through [`ObjectAccess`] lookups by
//! (index, sub-index). Downloads other than expedited ones are collected in
//! an `N`-byte buffer and written whole with [`ObjectAccess::write`] when
//! the last segment arrives, so a value is never left half-written: that
//! frame (for a block download the end request, with its CRC over the
//! value) costs work in proportion to the value. Uploads read the value in
//! 7-byte pieces with [`ObjectAccess::read`] and need no buffer.
//!
//! Not supported: SDO block download of a value larger than `N`
//! (aborted with 0x05040005), and resuming a block download whose last
//! segment of a block was lost (the transfer times out, as nothing tells the
//! server that the block ended).
#![deny(clippy::arithmetic_side_effects)]

mod block;
mod expedited;
mod segmented;
#[cfg(test)]
mod tests;

use crate::abort::AbortCode;
use crate::od::ObjectAccess;
use crate::time::{At, Duration, NEVER, at_by, deadline_of, later, shift, span};
use crate::wire::sdo::{RequestKind, SdoResponse, frame, is_initiate_upload, mux_word, segment_fields, with_mux_word};
use crate::wire::sdo_block::BlockUploadRequest;

/// Where the server's responses go; false = TX queue full (try again on the next poll).
pub trait SdoTx {
    /// Queues one frame on the server's tx COB-ID (0x580 + node-ID for the
    /// default server); returns false if there is no room.
    fn send(&mut self, data: [u8; 8]) -> bool;
}

/// The SDO timeout a new server starts with.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(1);

/// [`DEFAULT_TIMEOUT`] in µs.
const DEFAULT_TIMEOUT_US: u32 = 1_000_000;

/// Object index and sub-index of a transfer (the SDO "multiplexer") as
/// one word, `index | sub << 16` ([`mux_word`]): the index is its low half,
/// as the dictionary takes it, and an answer's first word is this word
/// shifted up with byte 0 in (each answer was built from both halves):
/// ds301 −120, ds301-lean +6 bytes, the devices 0 to −136. (The word
/// `index << 8 | sub << 24` made the look-ups' arguments dearer.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Mux(u32);

impl Mux {
    /// The multiplexer of an abort that belongs to no transfer.
    const NONE: Mux = Mux(0);

    /// The multiplexer of a request as received (8 bytes), from its first
    /// word read again, not from its copy `f`: ds301 −76 bytes, ds301-lean
    /// +46, ec5000 −96, sendix −80 (LLVM builds the word out of `f`'s bytes).
    fn of(raw: &[u8]) -> Mux {
        Mux(raw.first_chunk().map_or(0, mux_word))
    }

    /// The object index.
    fn index(self) -> u16 {
        self.0 as u16
    }

    /// The sub-index.
    fn sub(self) -> u8 {
        (self.0 >> 16) as u8
    }

    /// A response about this object: byte 0, the multiplexer, bytes 4–7.
    fn frame(self, byte0: u8, tail: [u8; 4]) -> [u8; 8] {
        with_mux_word(byte0, self.0, tail)
    }
}

/// What the server is doing; the fields of the transfer in progress are
/// in [`Transfer`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Idle,
    SegmentedUpload,
    SegmentedDownload,
    /// Block download: collecting sub-blocks.
    BlockDownload,
    /// Block download: the segment with c = 1 has been accepted, the end
    /// request is next (the client's frames are no sub-block segments now).
    BlockDownloadEnd,
    /// Block upload: initiate response sent; waiting for the client's start command.
    // 5, 6, 7: each plus the cs it takes is 8 (`Channel::block_upload`).
    BlockUploadStart = 5,
    /// Block upload: sending the segments of a block, or waiting for its ack.
    BlockUpload = 6,
    /// Block upload: end request sent; waiting for the client's end response.
    BlockUploadEnd = 7,
}

/// The transfer in progress: one set of fields for every kind, as only one
/// runs at a time. Each handler updates the fields it changes in place;
/// a state enum with a struct per kind (as before) copied the whole struct
/// out and back for every frame.
#[derive(Clone, Copy, Debug)]
struct Transfer {
    /// Size the client indicated (downloads; [`UNSIZED`] if it did not)
    /// or the server announced (uploads, always).
    size: usize,
    /// Segmented download: bytes collected in the buffer; segmented
    /// upload: bytes of the value already sent; block download: bytes of
    /// the segments accepted so far (7 per segment); block upload: offset
    /// in the value of segment 1 of the current block.
    pos: usize,
    /// Segmented: the toggle bit the next segment (download) or request
    /// (upload) must carry.
    toggle: bool,
    /// Block download: the client asked for a CRC (the server always
    /// supports one; a block upload's choice is in `crc_len`).
    crc_on: bool,
    /// Block upload: CRC of bytes `0..crc_len` of the value (a block
    /// download's is worked out over its buffer at the end request);
    /// crc_len is `usize::MAX` when the client asked for no CRC, an offset
    /// no segment has, so the register stays 0.
    crc: u16,
    crc_len: usize,
    /// Block: segments in the current block (download), or per block as
    /// the client last asked (upload).
    blksize: u8,
    /// Block download: the last segment of the current block received in
    /// order (ackseq, 0 = none yet), bit 7 set once one went missing
    /// (`GAP` in block.rs); block upload: segments of the current block sent so far.
    seq: u8,
}

impl Transfer {
    const NEW: Transfer = Transfer { size: 0, pos: 0, toggle: false, crc_on: false, crc: 0, crc_len: 0, blksize: 0, seq: 0 };
}

/// [`Transfer::size`] of a download whose client indicated no size: above
/// any size a download is started with (those fit the buffer), so that
/// "more than indicated" is one comparison.
const UNSIZED: usize = usize::MAX;

/// Whether a request (as received) may start a transfer that takes the
/// download buffer: an initiate download that is not expedited (ccs 1,
/// e = 0) or a block download request (ccs 6). A channel holding the buffer
/// is the only one in a download state, and no other request of an idle
/// or uploading channel uses it.
fn may_take_buffer(data: &[u8]) -> bool {
    matches!(data.first(), Some(&b0) if b0 & 0xE2 == 0x20 || b0 & 0xE0 == 0xC0)
}

/// A download's value, whole (an expedited download's bytes, or a
/// segmented or block download's buffer up to its length, every check
/// made), to be written; and the answer once it is.
struct Whole<'a> {
    value: &'a [u8],
    answer: [u8; 8],
}

/// The download buffer as one server sees it: `Some` when it may use the
/// buffer, `None` while another server of an [`SdoServers`] holds it for a
/// download of its own.
pub(super) type Buffer<'a> = Option<&'a mut [u8]>;

/// Everything of one SDO server but the download buffer: the protocol
/// state, the timeout, an unsent response and the malformed-frame count.
/// About 80 bytes, so that further servers (0x1201–0x127F) are cheap.
#[derive(Clone, Debug)]
struct Channel {
    state: State,
    /// The fields of the transfer in progress (meaningless when idle).
    t: Transfer,
    /// The object of the transfer in progress, or of the initiate request
    /// being answered; kept here rather than in each state so that every
    /// abort names it without the caller passing it.
    mux: Mux,
    /// The timeout in microseconds (1 to [`crate::time::MAX_SPAN`]) less
    /// [`DEFAULT_TIMEOUT_US`], wrapping: 0 is the default, so that a new
    /// server is all zero bits ([`crate::node`]), and the timer's restart
    /// is one add of a constant (an `Option` took a test and a select too).
    timeout_offset_us: u32,
    /// When the transfer in progress times out (meaningless when idle).
    deadline: At,
    /// A response `tx` refused, sent again by the next `poll`.
    pending: Option<[u8; 8]>,
    malformed: u32,
    /// Unused: keeps [`Channel`] (and so every field of the node after
    /// its SDO servers) where it was before the block transfer's phase and
    /// end flag became states (without it ds301-lean +4 B, sendix +32,
    /// b maXX +36: the node's later fields moved by 4 B a server). Here
    /// rather than in [`Transfer`], which each handler copies: ds301 −4.
    _spare: [u8; 4],
}

impl Channel {
    const NEW: Channel = Channel {
        state: State::Idle,
        t: Transfer::NEW,
        mux: Mux::NONE,
        timeout_offset_us: 0,
        deadline: 0,
        pending: None,
        malformed: 0,
        _spare: [0; 4],
    };

    /// A zero timeout is kept as 1 µs (the shortest timeout kept before);
    /// one beyond 35.8 minutes as 35.8 minutes.
    fn set_timeout(&mut self, timeout: Duration) {
        self.timeout_offset_us = span(timeout).max(1).wrapping_sub(DEFAULT_TIMEOUT_US);
    }

    /// Whether this server holds the download buffer (a segmented or block
    /// download in progress).
    fn holds_buffer(&self) -> bool {
        matches!(self.state, State::SegmentedDownload | State::BlockDownload | State::BlockDownloadEnd)
    }

    fn is_idle(&self) -> bool {
        matches!(self.state, State::Idle) && self.pending.is_none()
    }

    fn reset(&mut self) {
        self.state = State::Idle;
        self.pending = None;
    }

    /// The object of the transfer in progress.
    fn transfer(&self) -> Option<Mux> {
        (!matches!(self.state, State::Idle)).then_some(self.mux)
    }
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
    channel: Channel,
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
        SdoServer { channel: Channel::NEW, buf: [0; N] }
    }

    /// Sets the time the server waits for the client's next frame (or for
    /// room to send its own) before it aborts with 0x05040000. Takes effect
    /// from the next frame.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.channel.set_timeout(timeout);
    }

    /// Whether no transfer is in progress and no response is waiting to be sent.
    pub fn is_idle(&self) -> bool {
        self.channel.is_idle()
    }

    /// Drops any transfer and unsent response without a frame (NMT reset
    /// communication, or the server disabled through 0x1200).
    pub fn reset(&mut self) {
        self.channel.reset();
    }

    /// One frame from the client on this server's rx COB-ID (data as received; DLC != 8 is counted in `malformed()` and ignored).
    ///
    /// A request with an unknown command specifier is counted too, and
    /// answered with abort 0x05040001. A new initiate request while a
    /// transfer is in progress ends that transfer without a frame and is
    /// answered as if the server were idle. A frame that arrives at or after
    /// the transfer's deadline (because `poll` was late) first triggers the
    /// timeout abort; it is then served only if it initiates a new transfer.
    pub fn on_request(&mut self, now: At, data: &[u8], mut od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) {
        self.channel.on_request(now, data, true, true, Some(&mut self.buf), &mut od, tx);
    }

    /// Sends pending block-upload segments while `tx` accepts them; aborts with 0x05040000 on timeout; returns the next deadline (None when idle).
    ///
    /// The deadline is `now` while frames wait for room in `tx` (call again
    /// when the TX queue drains), else the timeout of the transfer in
    /// progress. Calling early is harmless.
    pub fn poll(&mut self, now: At, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> Option<At> {
        deadline_of(self.channel.poll(now, true, od, tx))
    }

    /// Frames ignored because their length was not 8, plus requests with an
    /// unknown command specifier (those were answered with an abort).
    pub fn malformed(&self) -> u32 {
        self.channel.malformed
    }
}

/// `K` SDO servers (the default one, 0x1200, and further ones, 0x1201 …)
/// that share one `N`-byte download buffer. CiA 301 §7.2.4.1.
///
/// Uploads and expedited downloads need no buffer, so every server runs
/// them at any time. A segmented or block download needs the buffer until
/// its last frame: while one server holds it, a download started on another
/// server is refused with abort 0x060A0023 ("resource not available: SDO
/// connection"), and the holder is never disturbed. Each server costs its
/// protocol state only (about 80 bytes), not a buffer.
#[derive(Debug)]
pub struct SdoServers<const N: usize, const K: usize> {
    channels: [Channel; K],
    buf: [u8; N],
}

impl<const N: usize, const K: usize> Default for SdoServers<N, K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const K: usize> SdoServers<N, K> {
    /// `K` idle servers with the [`DEFAULT_TIMEOUT`] of 1 s.
    pub const fn new() -> Self {
        SdoServers { channels: [Channel::NEW; K], buf: [0; N] }
    }

    /// Sets the timeout of server `i` (0-based: 0 is 0x1200), as [`SdoServer::set_timeout`].
    pub fn set_timeout(&mut self, i: usize, timeout: Duration) {
        if let Some(c) = self.channels.get_mut(i) {
            c.set_timeout(timeout);
        }
    }

    /// Whether server `i` has no transfer in progress and no response waiting.
    pub fn is_idle(&self, i: usize) -> bool {
        self.channels.get(i).is_none_or(Channel::is_idle)
    }

    /// Whether no server has a transfer in progress or a response waiting:
    /// then polling them has nothing to do and no deadline to give.
    pub fn all_idle(&self) -> bool {
        self.channels.iter().all(Channel::is_idle)
    }

    /// Drops the transfer of server `i` without a frame (its COB-ID became invalid).
    pub fn reset(&mut self, i: usize) {
        if let Some(c) = self.channels.get_mut(i) {
            c.reset();
        }
    }

    /// Drops every transfer without a frame (reset communication, Stopped).
    pub fn reset_all(&mut self) {
        self.channels.iter_mut().for_each(Channel::reset);
    }

    /// A frame on the rx COB-ID of server `i`, as [`SdoServer::on_request`].
    pub fn on_request(&mut self, i: usize, now: At, data: &[u8], mut od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) {
        self.on_request_with(i, now, data, true, true, &mut od, tx);
    }

    /// As [`SdoServers::on_request`]; without `block`, a block transfer
    /// request is refused with abort 0x05040001 like any unknown command.
    /// `block` is a compile-time constant of the node (`Services::block_sdo`),
    /// so without it the compiler leaves the block transfer code out. The
    /// initiate requests and every download's final write call `od`
    /// directly (the node's router or `SdoParts`), the others through `dyn
    /// ObjectAccess`, one copy of their code whatever `O` is. With `quick`
    /// (a constant too: the node passes it for a device without SDO hooks),
    /// an initiate upload or initiate block upload is served before the
    /// other requests are decoded: the same answers, fewer instructions for
    /// the commonest request.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn on_request_with<O: ObjectAccess>(
        &mut self,
        i: usize,
        now: At,
        data: &[u8],
        block: bool,
        quick: bool,
        od: &mut O,
        tx: &mut dyn SdoTx,
    ) {
        // With one server (`K` a constant) no other can hold the buffer:
        // the compiler leaves the scan and every refusal for a lent buffer out.
        // Only a request that may start a download needs to know (the holder
        // itself is the only one in a download state): the scan is left
        // out of uploads and expedited downloads.
        let lent = K > 1 && may_take_buffer(data) && self.channels.iter().enumerate().any(|(j, c)| j != i && c.holds_buffer());
        let Some(channel) = self.channels.get_mut(i) else { return };
        let buf = if lent { None } else { Some(self.buf.as_mut_slice()) };
        channel.on_request(now, data, block, quick, buf, od, tx);
    }

    /// Timers and pending frames of server `i`, as [`SdoServer::poll`].
    pub fn poll(&mut self, i: usize, now: At, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> Option<At> {
        deadline_of(self.poll_with(i, now, true, od, tx))
    }

    /// As [`SdoServers::poll`], with block transfer served only if `block`
    /// (see [`SdoServers::on_request_with`]); the deadline as an [`At`].
    #[inline(always)]
    pub fn poll_with(&mut self, i: usize, now: At, block: bool, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> At {
        self.channels.get_mut(i).map_or(NEVER, |c| c.poll(now, block, od, tx))
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        let by = at_by(by);
        self.channels.iter_mut().for_each(|c| shift(&mut c.deadline, by));
    }

    /// Malformed frames server `i` counted, as [`SdoServer::malformed`].
    pub fn malformed(&self, i: usize) -> u32 {
        self.channels.get(i).map_or(0, |c| c.malformed)
    }
}

impl Channel {
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn on_request<O: ObjectAccess>(
        &mut self,
        now: At,
        data: &[u8],
        block: bool,
        quick: bool,
        buf: Buffer<'_>,
        od: &mut O,
        tx: &mut dyn SdoTx,
    ) {
        // A frame at or after the deadline comes too late for its transfer:
        // the timeout abort answers it, and only a new initiate is served.
        // The idle state first (`expire` tests it too): the compiler then
        // branches on it instead of computing both tests for every request
        // (ds301 −76 bytes; the general path's requests −5 to −7 instructions).
        let expired = !matches!(self.state, State::Idle) && self.expire(now, tx);
        match self.state {
            // Sub-block frames carry a sequence number where other frames
            // have a command specifier; only the state tells them apart.
            State::BlockDownload if block => match frame(data) {
                Ok([b0, ..]) => self.block_download_segment(b0, data.get(1..).unwrap_or(&[]), buf, tx),
                Err(_) => return self.count_malformed(),
            },
            _ => {
                let Ok(f) = frame(data) else { return self.count_malformed() };
                let [b0, ..] = f;
                // An initiate upload (ccs 2), or with `block` an initiate
                // block upload (ccs 5, cs 0), starts a transfer whatever the
                // server was doing (a late frame too): served before the
                // other requests' decode, the most common request in the
                // fewest instructions. A block upload initiate is served as
                // an initiate upload with the block's fields (a value of at
                // most pst bytes is answered as that would be): one copy of
                // the initiate.
                if quick && (is_initiate_upload(b0) || (block && b0 & 0xE3 == 0xA0)) {
                    let upload_block = match (block && b0 & 0x80 != 0).then(|| BlockUploadRequest::decode(&f)) {
                        Some(BlockUploadRequest::Initiate { crc, blksize, pst, .. }) => Some(block::UploadInitiate { crc, blksize, pst }),
                        _ => None,
                    };
                    self.start(Mux::of(data));
                    self.initiate_upload(upload_block, od, tx);
                } else {
                    let kind = RequestKind::of(b0);
                    if expired && !kind.starts_transfer() {
                        // Too late for its transfer; an unknown command is still counted.
                        if kind == RequestKind::Unknown {
                            self.count_malformed();
                        }
                    } else {
                        self.request(kind, f, data, block, quick, buf, od, tx);
                    }
                }
            }
        }
        if !matches!(self.state, State::Idle) {
            self.restart_timer(now);
        }
    }

    fn poll(&mut self, now: At, block: bool, od: &mut dyn ObjectAccess, tx: &mut dyn SdoTx) -> At {
        self.expire(now, tx);
        // A frame still pending (`flush` false) brings the next poll anyway.
        let waiting = self.flush(tx) && block && self.send_block_segments(now, od, tx);
        if self.pending.is_some() || waiting {
            now
        } else if matches!(self.state, State::Idle) {
            NEVER
        } else {
            self.deadline
        }
    }

    /// The transfer in progress times out `timeout` after `now`.
    fn restart_timer(&mut self, now: At) {
        self.deadline = later(now, self.timeout_offset_us.wrapping_add(DEFAULT_TIMEOUT_US));
    }

    // Out of line: four sites in the request path, none of them taken by a
    // well-formed frame.
    #[inline(never)]
    fn count_malformed(&mut self) {
        self.malformed = self.malformed.saturating_add(1);
    }

    /// A request outside the block download sub-block phase, of `kind`;
    /// block transfer requests only if `block`. `f` is the frame `raw` as
    /// received (8 bytes), copied to registers; a download segment's data
    /// and an expedited download's value are cut from `raw`, so that no
    /// copy of them is made.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn request<'b, O: ObjectAccess>(
        &mut self,
        kind: RequestKind,
        f: [u8; 8],
        raw: &'b [u8],
        block: bool,
        quick: bool,
        buf: Buffer<'b>,
        od: &mut O,
        tx: &mut dyn SdoTx,
    ) {
        let mux = Mux::of(raw);
        let [b0, ..] = f;
        // Without `quick`, the initiate uploads come here: an initiate
        // block upload is served as an initiate upload with the block's
        // fields. `block` first: without block transfer the compiler knows
        // there is none. The kind before the decode: every other request skips it.
        let upload_block = match (!quick && block && kind == RequestKind::BlockUploadInitiate).then(|| BlockUploadRequest::decode(&f)) {
            Some(BlockUploadRequest::Initiate { crc, blksize, pst, .. }) => Some(block::UploadInitiate { crc, blksize, pst }),
            _ => None,
        };
        let kind = if upload_block.is_some() { RequestKind::InitiateUpload } else { kind };
        // An abort or a new initiate ends whatever was in progress. Each
        // other request belongs to one kind of transfer: served by its
        // handler if that transfer is in progress, refused if not.
        let whole = match (kind, block) {
            (RequestKind::Abort, _) => {
                self.reset();
                None
            }
            // An expedited download (e = 1): its value cut from the request
            // as received, no decode into an enum, no call.
            (RequestKind::InitiateDownload, _) if b0 & 0x02 != 0 => {
                self.start(mux);
                self.expedited_download(b0, raw, od, tx)
            }
            // Segmented and block downloads start alike (one copy of the
            // checks): the block initiate's multiplexer is bytes 1-3 too.
            (RequestKind::InitiateDownload, _) | (RequestKind::BlockDownloadInitiate, true) => {
                self.start(mux);
                // The size in bytes 4-7 if s = 1: bit 0 of an initiate download,
                // bit 1 of a block one (whose cc, bit 2, asks for a CRC).
                let segmented = !block || kind == RequestKind::InitiateDownload;
                let s = if segmented { 0x01 } else { 0x02 };
                let [.., s0, s1, s2, s3] = f;
                let size = (b0 & s != 0).then_some(u32::from_le_bytes([s0, s1, s2, s3]));
                let crc = (!segmented).then_some(b0 & 0x04 != 0);
                // Both initiates answered here: byte 0 and blksize from `start_download`.
                if let Some((b0, blksize)) = self.start_download(size, crc, buf, od, tx) {
                    self.emit(mux.frame(b0, [blksize, 0, 0, 0]), tx);
                }
                None
            }
            (RequestKind::InitiateUpload, _) if !quick => {
                self.start(mux);
                self.initiate_upload(upload_block, od, tx);
                None
            }
            (RequestKind::DownloadSegment, _) if self.state == State::SegmentedDownload => {
                let (toggle, len, last) = segment_fields(b0);
                // Bytes 1..=len of the frame as received (8 bytes long), not of its copy `f`.
                let data = raw.get(1..=usize::from(len)).unwrap_or(&[]);
                self.segmented_download(segmented::Segment { toggle, data, last }, buf, tx)
            }
            (RequestKind::UploadSegment, _) if self.state == State::SegmentedUpload => {
                self.segmented_upload(segment_fields(b0).0, od, tx);
                None
            }
            (RequestKind::BlockDownloadEnd, true) if self.state == State::BlockDownloadEnd => {
                // n (bits 4-2) and the CRC (bytes 1-2): `kind` says cs = 1.
                let [_, c0, c1, ..] = f;
                self.block_download_end((b0 >> 2) & 0x07, u16::from_le_bytes([c0, c1]), buf, tx)
            }
            (RequestKind::BlockUpload, true)
                if matches!(self.state, State::BlockUploadStart | State::BlockUpload | State::BlockUploadEnd) =>
            {
                // cs (bits 1-0: 3 start, 2 ack, 1 end), an ack's ackseq and blksize (bytes 1-2).
                let [_, ackseq, blksize, ..] = f;
                self.block_upload(b0 & 0x03, ackseq, blksize, tx);
                None
            }
            // A request of a transfer that is not in progress (abort
            // 0x05040001 for the one in progress, or for no object when
            // idle), or an unknown command specifier or a block transfer
            // request without block transfer, which are counted too (and
            // named by their own object when they would start a transfer).
            // One arm for all: ds301 −18, ds301-lean −42 bytes against four.
            _ => {
                let segment = matches!(kind, RequestKind::DownloadSegment | RequestKind::UploadSegment)
                    || (block && matches!(kind, RequestKind::BlockDownloadEnd | RequestKind::BlockUpload));
                if !segment {
                    self.count_malformed();
                }
                let mux = if kind == RequestKind::Unknown || kind.starts_transfer() { mux } else { Mux::NONE };
                self.fail(self.transfer().unwrap_or(mux), AbortCode::InvalidCommand, tx);
                None
            }
        };
        // Every download ends in one write of its whole value (one copy of
        // the call and its refusal for the expedited, segmented and block
        // downloads), then its own answer.
        if let Some(Whole { value, answer }) = whole {
            match od.write(self.mux.index(), self.mux.sub(), value) {
                Ok(()) => {
                    self.state = State::Idle;
                    self.emit(answer, tx);
                }
                Err(code) => self.abort(code, tx),
            }
        }
    }

    /// An initiate request for `mux`: whatever was in progress ends.
    fn start(&mut self, mux: Mux) {
        self.reset();
        self.mux = mux;
    }

    /// Aborts the transfer in progress with 0x05040000 once `now` reaches
    /// its deadline; true if it did.
    fn expire(&mut self, now: At, tx: &mut dyn SdoTx) -> bool {
        if matches!(self.state, State::Idle) || now < self.deadline {
            return false;
        }
        self.abort(AbortCode::Timeout, tx);
        true
    }

    /// Ends the transfer and sends an abort frame for `mux`.
    fn fail(&mut self, mux: Mux, code: AbortCode, tx: &mut dyn SdoTx) {
        self.mux = mux;
        self.abort(code, tx);
    }

    /// Ends the transfer (or refuses the initiate request) of `self.mux`
    /// and sends an abort frame.
    // Out of line: some forty call sites.
    #[inline(never)]
    fn abort(&mut self, code: AbortCode, tx: &mut dyn SdoTx) {
        self.state = State::Idle;
        // SdoResponse::Abort's frame, from the multiplexer word.
        self.emit(self.mux.frame(0x80, code.code().to_le_bytes()), tx);
    }

    /// [`Channel::abort`] for a request whose handler tells its caller
    /// what to answer: `None`, the abort was the answer.
    fn refuse<T>(&mut self, code: AbortCode, tx: &mut dyn SdoTx) -> Option<T> {
        self.abort(code, tx);
        None
    }

    // In line, with `SdoResponse::emit`: each site knows its response, so
    // the frame is built there and no general encoder is linked.
    #[inline(always)]
    fn send(&mut self, response: SdoResponse, tx: &mut dyn SdoTx) {
        self.emit(response.emit(), tx);
    }

    /// Sends a frame, or keeps it for the next poll. A newer response
    /// replaces an unsent older one: the client has moved on.
    // Out of line: every response of the server ends here (ten sites).
    // One store of the outcome (no clearing before the send): 14 bytes less.
    #[inline(never)]
    fn emit(&mut self, frame: [u8; 8], tx: &mut dyn SdoTx) {
        self.pending = (!tx.send(frame)).then_some(frame);
    }

    /// Sends the kept frame; true when nothing is left waiting.
    fn flush(&mut self, tx: &mut dyn SdoTx) -> bool {
        // Sent again through `emit` (one store of the outcome): 22 bytes less.
        let Some(frame) = self.pending else { return true };
        self.emit(frame, tx);
        self.pending.is_none()
    }
}
