//! SDO client: one transfer at a time with one SDO server. CiA 301 v4.2
//! §7.2.4.3 (SDO protocols: expedited and segmented, figures 21–33; block,
//! §7.2.4.3.9–16, figures 34–45); abort codes §7.2.4.3.17.
//!
//! Read first: the server side, `canopen_core::services::sdo_server`, and
//! the formats in [`canopen_core::wire::sdo`] and
//! [`canopen_core::wire::sdo_block`], which this client reuses.
//!
//! An [`SdoClient`] holds the settings of one client/server channel;
//! [`SdoClient::upload`] and [`SdoClient::download`] start an
//! [`SdoTransfer`], a sans-IO state machine:
//! - [`on_frame`](SdoTransfer::on_frame) takes every frame received on the
//!   response COB-ID (0x580 + node-ID for the default server);
//! - [`pop_tx`](SdoTransfer::pop_tx) hands out the frames to send on the
//!   request COB-ID (0x600 + node-ID), a whole sub-block at a time;
//! - [`process`](SdoTransfer::process) runs the timeout and returns the deadline;
//! - [`into_result`](SdoTransfer::into_result) gives the value or the error.
//!
//! The client is strict, because it exists to test servers: any response
//! that CiA 301 does not allow at that point ends the transfer with an abort
//! frame and a [`ProtocolError`]. Not supported: recovering a block upload
//! whose sub-block lost its last segment (nothing tells the client that the
//! sub-block ended, so the transfer times out, as on the server side).

mod block;

use super::SendError;
use canopen_core::abort::AbortCode;
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::sdo::{InitiateData, SdoParseError, SdoRequest, SdoResponse};
use canopen_core::wire::sdo_block::{BlockDownloadRequest, BlockUploadRequest, MAX_BLKSIZE, SEGMENT_DATA};
use std::collections::VecDeque;

/// How long a new client waits for each answer of the server.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(1);

/// The largest value a new client accepts in an upload (1 MiB), so that a
/// broken server cannot make a test allocate without end.
pub const DEFAULT_MAX_UPLOAD: usize = 1 << 20;

/// Settings of one SDO channel, from which transfers start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SdoClient {
    /// COB-ID of client → server frames (0x600 + node-ID for the default server).
    pub request_cob_id: u16,
    /// COB-ID of server → client frames (0x580 + node-ID for the default server).
    pub response_cob_id: u16,
    /// How long to wait for each answer before aborting with 0x05040000.
    pub timeout: Duration,
    /// The largest value an upload accepts before aborting with 0x05040005.
    pub max_upload: usize,
}

/// How to ask for an upload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UploadMode {
    /// Initiate SDO upload (ccs = 2): the server picks expedited or segmented.
    ExpeditedOrSegmented,
    /// SDO block upload (ccs = 5).
    Block {
        /// Segments per sub-block the client accepts (1..=127).
        blksize: u8,
        /// Protocol switch threshold: a value of at most `pst` bytes may come
        /// back expedited or segmented instead (0 = no switch).
        pst: u8,
        /// Whether the client asks for a CRC check.
        crc: bool,
    },
}

/// How to send a download.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DownloadMode {
    /// Expedited for 1..=4 bytes, segmented otherwise.
    Auto,
    /// Expedited (1..=4 bytes).
    Expedited,
    /// Segmented, size indicated.
    Segmented,
    /// SDO block download, size indicated.
    Block {
        /// Whether the client offers a CRC.
        crc: bool,
    },
}

/// Why a transfer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoClientError {
    /// The server sent an abort frame.
    ServerAbort {
        /// Index in the abort frame.
        index: u16,
        /// Sub-index in the abort frame.
        sub: u8,
        /// The abort code as sent; see [`abort_code`](SdoClientError::abort_code).
        code: u32,
    },
    /// The server did not answer in time; the client sent abort 0x05040000.
    Timeout,
    /// The server broke the protocol; the client sent the abort of
    /// [`ProtocolError::abort_code`].
    Protocol(ProtocolError),
    /// The transfer cannot be asked for as given; nothing was sent.
    InvalidRequest(RequestError),
    /// The bus driver could not queue a frame.
    Send(SendError),
}

impl SdoClientError {
    /// The abort code that ended the transfer, if one did and CiA 301 defines it.
    pub fn abort_code(&self) -> Option<AbortCode> {
        match *self {
            SdoClientError::ServerAbort { code, .. } => AbortCode::from_code(code),
            SdoClientError::Timeout => Some(AbortCode::Timeout),
            SdoClientError::Protocol(p) => Some(p.abort_code()),
            SdoClientError::InvalidRequest(_) | SdoClientError::Send(_) => None,
        }
    }
}

impl core::fmt::Display for SdoClientError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SdoClientError::ServerAbort { index, sub, code } => write!(f, "server aborted {index:#06x}:{sub} with {code:#010x}"),
            SdoClientError::Timeout => f.write_str("SDO timeout"),
            SdoClientError::Protocol(p) => write!(f, "SDO protocol error: {p:?}"),
            SdoClientError::InvalidRequest(r) => write!(f, "invalid SDO request: {r:?}"),
            SdoClientError::Send(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SdoClientError {}

/// A server response the client did not accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProtocolError {
    /// The frame did not have 8 data bytes (the length it had).
    Malformed(usize),
    /// Byte 0 is not a response allowed at this point of the transfer.
    UnexpectedCommand(u8),
    /// An initiate response for another object.
    WrongMultiplexer {
        /// Index in the response.
        index: u16,
        /// Sub-index in the response.
        sub: u8,
    },
    /// A segment or confirmation with the wrong toggle bit.
    Toggle,
    /// The value received does not have the size the server indicated.
    SizeMismatch {
        /// The size the server indicated.
        indicated: u32,
        /// The bytes received.
        received: usize,
    },
    /// The value is larger than [`SdoClient::max_upload`].
    TooLong,
    /// A blksize outside 1..=127 from the server.
    BlockSize(u8),
    /// A sub-block segment with a sequence number outside the block, or an
    /// ackseq beyond the segments sent.
    Sequence(u8),
    /// The CRC of a block upload does not match the data.
    Crc {
        /// The CRC the server sent.
        received: u16,
        /// The CRC of the data received.
        computed: u16,
    },
}

impl ProtocolError {
    /// The abort code the client sends for this error.
    pub fn abort_code(&self) -> AbortCode {
        match self {
            ProtocolError::Malformed(_) | ProtocolError::UnexpectedCommand(_) => AbortCode::InvalidCommand,
            // CiA 301 names no code for this; CANopenNode's client sends 0x06040043.
            ProtocolError::WrongMultiplexer { .. } => AbortCode::ParameterIncompatible,
            ProtocolError::Toggle => AbortCode::ToggleBit,
            ProtocolError::SizeMismatch { .. } => AbortCode::LengthMismatch,
            ProtocolError::TooLong => AbortCode::OutOfMemory,
            ProtocolError::BlockSize(_) => AbortCode::InvalidBlockSize,
            ProtocolError::Sequence(_) => AbortCode::InvalidSequence,
            ProtocolError::Crc { .. } => AbortCode::CrcError,
        }
    }
}

impl From<SdoParseError> for ProtocolError {
    fn from(e: SdoParseError) -> Self {
        match e {
            SdoParseError::Length(n) => ProtocolError::Malformed(n),
            SdoParseError::UnknownCommand { command, .. } => ProtocolError::UnexpectedCommand(command),
        }
    }
}

/// Why a transfer could not be started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RequestError {
    /// An expedited download of other than 1..=4 bytes (the length asked for).
    ExpeditedLength(usize),
    /// A download longer than the 32-bit size field allows (the length asked for).
    TooLong(usize),
    /// A block upload blksize outside 1..=127.
    BlockSize(u8),
}

impl SdoClient {
    /// The client of node `node_id`'s default SDO server (COB-IDs 0x600 +
    /// node-ID and 0x580 + node-ID), with [`DEFAULT_TIMEOUT`] and [`DEFAULT_MAX_UPLOAD`].
    pub fn new(node_id: u8) -> Self {
        Self::with_cob_ids(0x600 + u16::from(node_id), 0x580 + u16::from(node_id))
    }

    /// A client on other COB-IDs (0x1280 client parameters), with the default settings.
    pub fn with_cob_ids(request_cob_id: u16, response_cob_id: u16) -> Self {
        SdoClient { request_cob_id, response_cob_id, timeout: DEFAULT_TIMEOUT, max_upload: DEFAULT_MAX_UPLOAD }
    }

    /// Starts reading (index, sub) at `now`.
    pub fn upload(&self, now: Instant, index: u16, sub: u8, mode: UploadMode) -> SdoTransfer {
        let mut t = SdoTransfer::new(*self, now, index, sub, Vec::new(), true);
        match mode {
            UploadMode::ExpeditedOrSegmented => {
                t.send(SdoRequest::InitiateUpload { index, sub });
                t.state = State::InitiateUpload;
            }
            UploadMode::Block { blksize, pst, crc } => {
                if !(1..=MAX_BLKSIZE).contains(&blksize) {
                    t.finish(Err(SdoClientError::InvalidRequest(RequestError::BlockSize(blksize))));
                    return t;
                }
                t.send(SdoRequest::BlockUpload(BlockUploadRequest::Initiate { index, sub, crc, blksize, pst }));
                t.state = State::BlockUpload(block::Upload::Initiate { crc, blksize });
            }
        }
        t
    }

    /// Starts writing `data` to (index, sub) at `now`.
    pub fn download(&self, now: Instant, index: u16, sub: u8, data: &[u8], mode: DownloadMode) -> SdoTransfer {
        let mut t = SdoTransfer::new(*self, now, index, sub, data.to_vec(), false);
        let Ok(size) = u32::try_from(data.len()) else {
            t.finish(Err(SdoClientError::InvalidRequest(RequestError::TooLong(data.len()))));
            return t;
        };
        let expedited = (1..=4).contains(&data.len());
        match mode {
            DownloadMode::Expedited | DownloadMode::Auto if expedited => {
                let mut value = [0u8; 4];
                for (v, d) in value.iter_mut().zip(data) {
                    *v = *d;
                }
                let size = Some(size as u8); // 1..=4
                t.send(SdoRequest::InitiateDownload { index, sub, data: InitiateData::Expedited { data: value, size } });
                t.state = State::InitiateDownload { segmented: false };
            }
            DownloadMode::Expedited => t.finish(Err(SdoClientError::InvalidRequest(RequestError::ExpeditedLength(data.len())))),
            DownloadMode::Auto | DownloadMode::Segmented => {
                t.send(SdoRequest::InitiateDownload { index, sub, data: InitiateData::Segmented { size: Some(size) } });
                t.state = State::InitiateDownload { segmented: true };
            }
            DownloadMode::Block { crc } => {
                t.send(SdoRequest::BlockDownload(BlockDownloadRequest::Initiate { index, sub, crc, size: Some(size) }));
                t.state = State::BlockDownload(block::Download::Initiate { crc });
            }
        }
        t
    }
}

/// Where a transfer stands.
#[derive(Clone, Copy, Debug)]
enum State {
    /// Waiting for the initiate upload response.
    InitiateUpload,
    /// Waiting for the upload segment with `toggle`.
    UploadSegment {
        toggle: bool,
        size: Option<u32>,
    },
    /// Waiting for the initiate download response.
    InitiateDownload {
        segmented: bool,
    },
    /// Waiting for the confirmation of the segment with `toggle`, which
    /// ended at byte `end` of the value.
    DownloadSegment {
        toggle: bool,
        end: usize,
    },
    BlockUpload(block::Upload),
    BlockDownload(block::Download),
    /// Ended; the result is kept until taken.
    Done,
}

/// One transfer in progress; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct SdoTransfer {
    client: SdoClient,
    index: u16,
    sub: u8,
    /// Whether `data` is the value received (upload) or the value sent (download).
    upload: bool,
    state: State,
    /// Download: the value to send. Upload: the bytes received so far.
    data: Vec<u8>,
    deadline: Instant,
    tx: VecDeque<[u8; 8]>,
    result: Option<Result<(), SdoClientError>>,
}

impl SdoTransfer {
    fn new(client: SdoClient, now: Instant, index: u16, sub: u8, data: Vec<u8>, upload: bool) -> Self {
        SdoTransfer {
            client,
            index,
            sub,
            upload,
            state: State::Done,
            data,
            deadline: now + client.timeout,
            tx: VecDeque::new(),
            result: None,
        }
    }

    /// The settings the transfer runs with.
    pub fn client(&self) -> &SdoClient {
        &self.client
    }

    /// The COB-ID the frames of [`pop_tx`](Self::pop_tx) go out on.
    pub fn request_cob_id(&self) -> u16 {
        self.client.request_cob_id
    }

    /// The COB-ID whose frames [`on_frame`](Self::on_frame) takes.
    pub fn response_cob_id(&self) -> u16 {
        self.client.response_cob_id
    }

    /// The object transferred: (index, sub-index).
    pub fn multiplexer(&self) -> (u16, u8) {
        (self.index, self.sub)
    }

    /// Whether the transfer has ended (frames may still wait in [`pop_tx`](Self::pop_tx)).
    pub fn is_done(&self) -> bool {
        matches!(self.state, State::Done)
    }

    /// The result once the transfer has ended: the uploaded value (empty
    /// for a download), or the error.
    pub fn result(&self) -> Option<Result<&[u8], SdoClientError>> {
        let value = if self.upload { self.data.as_slice() } else { &[] };
        self.result.map(|r| r.map(|()| value))
    }

    /// [`result`](Self::result), taking the value.
    pub fn into_result(self) -> Option<Result<Vec<u8>, SdoClientError>> {
        let SdoTransfer { result, data, upload, .. } = self;
        result.map(|r| r.map(|()| if upload { data } else { Vec::new() }))
    }

    /// Takes the oldest frame to send on the request COB-ID.
    pub fn pop_tx(&mut self) -> Option<[u8; 8]> {
        self.tx.pop_front()
    }

    /// Aborts with 0x05040000 once `now` reaches the deadline; returns the
    /// deadline, or `None` once the transfer has ended. Calling early is harmless.
    pub fn process(&mut self, now: Instant) -> Option<Instant> {
        if self.is_done() {
            return None;
        }
        if now >= self.deadline {
            self.abort(SdoClientError::Timeout, AbortCode::Timeout);
            return None;
        }
        Some(self.deadline)
    }

    /// One of the transfer's frames left the controller at `now`: the wait
    /// for the answer starts over from there.
    pub fn on_sent(&mut self, now: Instant) {
        if !self.is_done() {
            self.deadline = self.deadline.max(now + self.client.timeout);
        }
    }

    /// A frame the server sent on the response COB-ID (its data bytes).
    /// Frames after the transfer has ended are ignored.
    pub fn on_frame(&mut self, now: Instant, data: &[u8]) {
        if self.is_done() {
            return;
        }
        self.deadline = now + self.client.timeout;
        // Sub-block segments carry a sequence number where other frames have
        // a command specifier; an abort (0x80, seqno 0 with c set, never a
        // valid segment) is the only other frame the server may send then.
        if let State::BlockUpload(u) = self.state
            && u.in_sub_block()
            && !(data.len() == 8 && data.first() == Some(&0x80))
        {
            return self.block_upload_segment(u, data);
        }
        let response = match SdoResponse::parse(data) {
            Ok(r) => r,
            Err(e) => return self.protocol_error(e.into()),
        };
        if let SdoResponse::Abort { index, sub, code } = response {
            return self.finish(Err(SdoClientError::ServerAbort { index, sub, code }));
        }
        match (self.state, response) {
            (State::InitiateUpload, SdoResponse::InitiateUpload { index, sub, data }) => self.initiate_upload_response(index, sub, data),
            (State::UploadSegment { toggle, size }, SdoResponse::UploadSegment { toggle: t, data, len, last }) => {
                self.upload_segment(toggle == t, size, data.get(..usize::from(len)).unwrap_or(&data), last);
            }
            (State::InitiateDownload { segmented }, SdoResponse::InitiateDownload { index, sub }) => {
                if self.check_multiplexer(index, sub) {
                    if segmented { self.send_download_segment(0, false) } else { self.finish(Ok(())) }
                }
            }
            (State::DownloadSegment { toggle, end }, SdoResponse::DownloadSegment { toggle: t }) => {
                if toggle != t {
                    self.protocol_error(ProtocolError::Toggle);
                } else if end >= self.data.len() {
                    self.finish(Ok(()));
                } else {
                    self.send_download_segment(end, !toggle);
                }
            }
            (State::BlockUpload(u), r) => self.block_upload_response(u, r),
            (State::BlockDownload(d), r) => self.block_download_response(d, r),
            (_, r) => self.unexpected(&r),
        }
    }

    /// The server's answer to an initiate upload (also to a block upload
    /// initiate, when it switched protocol because of pst).
    fn initiate_upload_response(&mut self, index: u16, sub: u8, data: InitiateData) {
        if !self.check_multiplexer(index, sub) {
            return;
        }
        match data {
            InitiateData::Expedited { data, size } => {
                // s = 0: "unspecified number of bytes", all four are taken.
                self.data = data.into_iter().take(size.map_or(4, usize::from)).collect();
                self.finish(Ok(()));
            }
            InitiateData::Segmented { size } => {
                if !self.fits(size) {
                    return self.protocol_error(ProtocolError::TooLong);
                }
                self.send(SdoRequest::UploadSegment { toggle: false });
                self.state = State::UploadSegment { toggle: false, size };
            }
        }
    }

    fn upload_segment(&mut self, toggle_ok: bool, size: Option<u32>, data: &[u8], last: bool) {
        if !toggle_ok {
            return self.protocol_error(ProtocolError::Toggle);
        }
        self.data.extend_from_slice(data);
        if self.data.len() > self.client.max_upload {
            return self.protocol_error(ProtocolError::TooLong);
        }
        let State::UploadSegment { toggle, .. } = self.state else { return };
        if last {
            self.finish_upload(size);
        } else {
            self.send(SdoRequest::UploadSegment { toggle: !toggle });
            self.state = State::UploadSegment { toggle: !toggle, size };
        }
    }

    /// Ends an upload, checking the size the server indicated.
    fn finish_upload(&mut self, size: Option<u32>) {
        match size {
            Some(s) if usize::try_from(s).ok() != Some(self.data.len()) => {
                self.protocol_error(ProtocolError::SizeMismatch { indicated: s, received: self.data.len() });
            }
            _ => self.finish(Ok(())),
        }
    }

    /// Sends the segment of the value starting at byte `start`.
    fn send_download_segment(&mut self, start: usize, toggle: bool) {
        let (data, len) = chunk(&self.data, start);
        let end = start.saturating_add(usize::from(len));
        self.send(SdoRequest::DownloadSegment { toggle, data, len, last: end >= self.data.len() });
        self.state = State::DownloadSegment { toggle, end };
    }

    /// Whether an indicated upload size is within [`SdoClient::max_upload`].
    fn fits(&self, size: Option<u32>) -> bool {
        size.is_none_or(|s| usize::try_from(s).is_ok_and(|s| s <= self.client.max_upload))
    }

    /// Checks the multiplexer of an initiate response; aborts if it is another object's.
    fn check_multiplexer(&mut self, index: u16, sub: u8) -> bool {
        let ok = (index, sub) == (self.index, self.sub);
        if !ok {
            self.protocol_error(ProtocolError::WrongMultiplexer { index, sub });
        }
        ok
    }

    /// Aborts on a response CiA 301 does not allow at this point.
    fn unexpected(&mut self, response: &SdoResponse) {
        let [command, ..] = response.emit();
        self.protocol_error(ProtocolError::UnexpectedCommand(command));
    }

    fn send(&mut self, request: SdoRequest) {
        self.tx.push_back(request.emit());
    }

    fn protocol_error(&mut self, e: ProtocolError) {
        self.abort(SdoClientError::Protocol(e), e.abort_code());
    }

    /// Ends the transfer with an abort frame.
    fn abort(&mut self, error: SdoClientError, code: AbortCode) {
        self.send(SdoRequest::Abort { index: self.index, sub: self.sub, code: code.code() });
        self.finish(Err(error));
    }

    fn finish(&mut self, result: Result<(), SdoClientError>) {
        self.state = State::Done;
        self.result = Some(result);
    }
}

/// Up to 7 bytes of `data` from `start`, and how many there are.
fn chunk(data: &[u8], start: usize) -> ([u8; SEGMENT_DATA], u8) {
    let mut out = [0u8; SEGMENT_DATA];
    let mut len = 0u8;
    for (o, d) in out.iter_mut().zip(data.iter().skip(start)) {
        *o = *d;
        len += 1;
    }
    (out, len)
}
