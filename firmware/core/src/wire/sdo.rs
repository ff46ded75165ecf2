//! SDO frame formats: expedited and segmented transfer, abort. CiA 301 v4.2
//! §7.2.4.3 (SDO protocols), figures 21–33; abort codes §7.2.4.3.17.
//!
//! Every SDO frame has exactly 8 data bytes. Byte 0 carries the command
//! specifier in bits 7–5 (ccs from the client, scs from the server) and the
//! protocol flags; bytes 1–2 are the index (little-endian) and byte 3 the
//! sub-index (together the *multiplexer*); bytes 4–7 carry data, a size or an
//! abort code. Block transfer frames (ccs 5 and 6, scs 5 and 6) are decoded in
//! [`super::sdo_block`]; [`SdoRequest`] and [`SdoResponse`] wrap them so that
//! one `parse` covers every frame outside a block-download sub-block.
//!
//! The same byte 0 means different things in the two directions, so requests
//! (client → server, COB-ID 0x600 + node-ID) and responses (server → client,
//! 0x580 + node-ID) have their own types. Parsers never panic; reserved bits
//! ("x" in CiA 301) are ignored on input and sent as 0.

use super::sdo_block::{BlockDownloadRequest, BlockDownloadResponse, BlockUploadRequest, BlockUploadResponse};

/// Data bytes in every SDO frame.
pub const SDO_FRAME_LEN: usize = 8;

/// Why a frame is not an SDO frame of the expected direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoParseError {
    /// The frame does not have exactly 8 data bytes (the length it had).
    Length(usize),
    /// The command specifier in byte 0 is not one CiA 301 defines for this
    /// direction; the server answers abort 0x05040001 for the multiplexer given.
    UnknownCommand {
        /// Byte 0 as received.
        command: u8,
        /// Bytes 1–2, as an index would be.
        index: u16,
        /// Byte 3, as a sub-index would be.
        sub: u8,
    },
}

/// Bytes 4–7 of an initiate download request or an initiate upload response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InitiateData {
    /// e = 1: the value itself. `size` is 4 − n when s = 1 (1..=4 bytes of
    /// `data` are valid); `None` when s = 0 ("unspecified number of bytes").
    Expedited {
        /// Bytes 4–7 as sent.
        data: [u8; 4],
        /// Number of valid bytes, 1..=4, if indicated.
        size: Option<u8>,
    },
    /// e = 0: a segmented transfer follows; `size` is bytes 4–7 when s = 1.
    Segmented {
        /// Total bytes to transfer, if indicated.
        size: Option<u32>,
    },
}

/// An SDO frame from the client (ccs in bits 7–5 of byte 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoRequest {
    /// ccs = 1: initiate SDO download (`001x nnes`).
    InitiateDownload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Expedited data or segmented size.
        data: InitiateData,
    },
    /// ccs = 0: download SDO segment (`000t nnnc`).
    DownloadSegment {
        /// Toggle bit t.
        toggle: bool,
        /// Bytes 1–7 as sent.
        data: [u8; 7],
        /// Valid bytes of `data`, 7 − n (0..=7).
        len: u8,
        /// c: no more segments follow.
        last: bool,
    },
    /// ccs = 2: initiate SDO upload (`010x xxxx`).
    InitiateUpload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// ccs = 3: upload SDO segment (`011t xxxx`).
    UploadSegment {
        /// Toggle bit t.
        toggle: bool,
    },
    /// ccs = 4: abort SDO transfer.
    Abort {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Abort code as sent (kept raw: a client may send any value).
        code: u32,
    },
    /// ccs = 6: block download requests outside the sub-block phase.
    BlockDownload(BlockDownloadRequest),
    /// ccs = 5: block upload requests.
    BlockUpload(BlockUploadRequest),
}

/// An SDO frame from the server (scs in bits 7–5 of byte 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoResponse {
    /// scs = 3: initiate SDO download response (`011x xxxx`).
    InitiateDownload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// scs = 1: download SDO segment response (`001t xxxx`).
    DownloadSegment {
        /// Toggle bit t, as in the request it confirms.
        toggle: bool,
    },
    /// scs = 2: initiate SDO upload response (`010x nnes`).
    InitiateUpload {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Expedited data or segmented size.
        data: InitiateData,
    },
    /// scs = 0: upload SDO segment response (`000t nnnc`).
    UploadSegment {
        /// Toggle bit t, as in the request it answers.
        toggle: bool,
        /// Bytes 1–7 as sent.
        data: [u8; 7],
        /// Valid bytes of `data`, 7 − n (0..=7).
        len: u8,
        /// c: no more segments follow.
        last: bool,
    },
    /// cs = 4: abort SDO transfer.
    Abort {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Abort code (CiA 301 table 22 for this server's own aborts).
        code: u32,
    },
    /// scs = 5: block download responses.
    BlockDownload(BlockDownloadResponse),
    /// scs = 6: block upload responses outside the sub-block phase.
    BlockUpload(BlockUploadResponse),
}

/// Checks that a frame has exactly [`SDO_FRAME_LEN`] bytes.
pub(crate) fn frame(data: &[u8]) -> Result<[u8; 8], SdoParseError> {
    <[u8; 8]>::try_from(data).map_err(|_| SdoParseError::Length(data.len()))
}

/// Bytes 1–3 of a frame: (index, sub-index).
pub(crate) fn multiplexer(f: &[u8; 8]) -> (u16, u8) {
    let [_, i0, i1, sub, ..] = *f;
    (u16::from_le_bytes([i0, i1]), sub)
}

/// A frame with byte 0, the multiplexer and bytes 4–7.
pub(crate) fn with_multiplexer(byte0: u8, index: u16, sub: u8, tail: [u8; 4]) -> [u8; 8] {
    with_mux_word(byte0, u32::from(index) | u32::from(sub) << 16, tail)
}

/// Bytes 1–3 of a frame (index, sub-index) as one word, `index | sub << 16`:
/// the frame's first word (`head`, bytes 0–3) shifted down by a byte. The index is its low
/// half, and a response about the same object is this word shifted up
/// with byte 0 in place ([`with_mux_word`]): one shift and an OR, where
/// the index and sub-index apart take a shift and an OR each.
pub(crate) fn mux_word(head: &[u8; 4]) -> u32 {
    u32::from_le_bytes(*head) >> 8
}

/// [`with_multiplexer`] with the multiplexer as a [`mux_word`].
pub(crate) fn with_mux_word(byte0: u8, mux: u32, tail: [u8; 4]) -> [u8; 8] {
    let [b0, i0, i1, sub] = (mux << 8 | u32::from(byte0)).to_le_bytes();
    let [d0, d1, d2, d3] = tail;
    [b0, i0, i1, sub, d0, d1, d2, d3]
}

/// Bytes 4–7 as a little-endian u32.
fn tail_u32(f: &[u8; 8]) -> u32 {
    let [.., d0, d1, d2, d3] = *f;
    u32::from_le_bytes([d0, d1, d2, d3])
}

/// Bytes 4–7.
fn tail(f: &[u8; 8]) -> [u8; 4] {
    let [.., d0, d1, d2, d3] = *f;
    [d0, d1, d2, d3]
}

/// Bytes 1–7.
fn segment_data(f: &[u8; 8]) -> [u8; 7] {
    let [_, d @ ..] = *f;
    d
}

/// A frame of byte 0 followed by seven data bytes.
fn segment_frame(byte0: u8, d: [u8; 7]) -> [u8; 8] {
    let [d0, d1, d2, d3, d4, d5, d6] = d;
    [byte0, d0, d1, d2, d3, d4, d5, d6]
}

const TOGGLE: u8 = 0x10;

/// The initiate download response (scs = 3) for the multiplexer `mux` (a
/// [`mux_word`]), as [`SdoResponse::emit`] makes it.
pub(crate) fn initiate_download_response(mux: u32) -> [u8; 8] {
    with_mux_word(0x60, mux, [0; 4])
}

/// The expedited initiate upload response (scs = 2, e = 1, s = 1) for the
/// multiplexer `mux` (a [`mux_word`]) with the
/// first `size` (1 to 4) bytes of `data` valid, as [`SdoResponse::emit`]
/// makes it; the other bytes of `data` go out as they are. Only for a
/// `size` of 1 to 4 (its one caller tests it): another size has no
/// expedited answer, and its byte 0 here would be wrong.
pub(crate) fn expedited_upload_response(mux: u32, data: [u8; 4], size: usize) -> [u8; 8] {
    // 0x43 | (4 - size) << 2 for a size of 1 to 4: 0x53 - 4 size.
    with_mux_word(0x53u8.wrapping_sub((size as u8) << 2), mux, data)
}

/// Whether byte 0 `b0` is an initiate upload's (ccs = 2), as
/// [`SdoRequest::parse`] says.
#[inline(always)]
pub(crate) fn is_initiate_upload(b0: u8) -> bool {
    b0 & 0xE0 == 0x40
}

/// Decodes the `nnes` bits (bits 3–0) of an initiate frame with bytes 4–7.
// `n` is two bits: 4 − n is 1..=4.
#[allow(clippy::arithmetic_side_effects)]
pub(crate) fn initiate_data(b0: u8, f: &[u8; 8]) -> InitiateData {
    let expedited = b0 & 0x02 != 0;
    let size_indicated = b0 & 0x01 != 0;
    if expedited {
        let n = (b0 >> 2) & 0x03;
        InitiateData::Expedited { data: tail(f), size: size_indicated.then_some(4 - n) }
    } else {
        InitiateData::Segmented { size: size_indicated.then(|| tail_u32(f)) }
    }
}

/// The `nnes` bits and bytes 4–7 of an initiate frame. An expedited size
/// outside 1..=4 is sent as the nearest valid one.
// `k` is clamped to 1..=4 first.
#[allow(clippy::arithmetic_side_effects)]
#[inline(always)]
fn emit_initiate_data(data: &InitiateData) -> (u8, [u8; 4]) {
    match *data {
        InitiateData::Expedited { data, size: Some(k) } => (((4 - k.clamp(1, 4)) << 2) | 0x03, data),
        InitiateData::Expedited { data, size: None } => (0x02, data),
        InitiateData::Segmented { size: Some(s) } => (0x01, s.to_le_bytes()),
        InitiateData::Segmented { size: None } => (0x00, [0; 4]),
    }
}

/// Byte 0 of a segment: `t nnn c` in bits 4–0, with 7 − `len` unused bytes.
// `len` is cut to 7 first.
#[allow(clippy::arithmetic_side_effects)]
fn segment_byte0(cs: u8, toggle: bool, len: u8, last: bool) -> u8 {
    cs | if toggle { TOGGLE } else { 0 } | ((7 - len.min(7)) << 1) | u8::from(last)
}

/// Byte 0 of an upload segment response (scs = 0) with `len` (0..=7) data
/// bytes, as [`SdoResponse::emit`] makes it.
pub(crate) fn upload_segment_byte0(toggle: bool, len: u8, last: bool) -> u8 {
    segment_byte0(0x00, toggle, len, last)
}

/// The `len` and `last` fields of a segment's byte 0.
// Three bits: 7 − n is 0..=7.
#[allow(clippy::arithmetic_side_effects)]
pub(crate) fn segment_fields(b0: u8) -> (bool, u8, bool) {
    (b0 & TOGGLE != 0, 7 - ((b0 >> 1) & 0x07), b0 & 0x01 != 0)
}

fn unknown(f: &[u8; 8]) -> SdoParseError {
    let (index, sub) = multiplexer(f);
    let [command, ..] = *f;
    SdoParseError::UnknownCommand { command, index, sub }
}

/// What a client frame asks for, from byte 0 alone: the SDO server's
/// dispatch, which then decodes only the fields of that request
/// ([`initiate_data`], [`segment_fields`] with the data cut from the frame,
/// the block requests' `decode`). [`SdoRequest::parse`] says the same of every frame
/// (tested for every byte 0); the server does not build an `SdoRequest`, so
/// that each request's fields stay in registers on the way to its handler.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RequestKind {
    /// ccs = 0.
    DownloadSegment,
    /// ccs = 1.
    InitiateDownload,
    /// ccs = 2.
    InitiateUpload,
    /// ccs = 3.
    UploadSegment,
    /// ccs = 4.
    Abort,
    /// ccs = 5, cs = 0: initiate block upload.
    BlockUploadInitiate,
    /// ccs = 5, the other client subcommands (start, ack, end).
    BlockUpload,
    /// ccs = 6, cs = 0: initiate block download.
    BlockDownloadInitiate,
    /// ccs = 6, cs = 1: end block download.
    BlockDownloadEnd,
    /// ccs = 7: none CiA 301 defines.
    Unknown,
}

impl RequestKind {
    /// The kind of a client frame with byte 0 `b0`: a byte table indexed
    /// by the ccs (bits 7–5) and bit 0, smaller than a jump over the ccs.
    pub(crate) fn of(b0: u8) -> RequestKind {
        const KINDS: [RequestKind; 16] = {
            use RequestKind::*;
            // [ccs << 1 | bit 0]; for ccs 5 (block upload) bit 1 is looked at below.
            [
                DownloadSegment,
                DownloadSegment,
                InitiateDownload,
                InitiateDownload,
                InitiateUpload,
                InitiateUpload,
                UploadSegment,
                UploadSegment,
                Abort,
                Abort,
                BlockUploadInitiate,
                BlockUpload,
                BlockDownloadInitiate,
                BlockDownloadEnd,
                Unknown,
                Unknown,
            ]
        };
        let kind = KINDS.get(usize::from((b0 >> 4) & 0x0E | b0 & 0x01)).copied().unwrap_or(RequestKind::Unknown);
        // ccs 5: initiate only with cs (bits 1-0) 0.
        if kind == RequestKind::BlockUploadInitiate && b0 & 0x02 != 0 { RequestKind::BlockUpload } else { kind }
    }

    /// Whether the request opens a new transfer (whatever the server is doing).
    pub(crate) fn starts_transfer(self) -> bool {
        matches!(
            self,
            RequestKind::InitiateDownload
                | RequestKind::InitiateUpload
                | RequestKind::BlockUploadInitiate
                | RequestKind::BlockDownloadInitiate
        )
    }
}

impl SdoRequest {
    /// Decodes a client frame; exactly 8 bytes are required.
    ///
    /// Frames of a block download sub-block do not carry a command specifier
    /// and must be decoded with [`super::sdo_block::BlockSegment::parse`] instead.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, ..] = f;
        let (index, sub) = multiplexer(&f);
        Ok(match b0 >> 5 {
            0 => {
                let (toggle, len, last) = segment_fields(b0);
                SdoRequest::DownloadSegment { toggle, data: segment_data(&f), len, last }
            }
            1 => SdoRequest::InitiateDownload { index, sub, data: initiate_data(b0, &f) },
            2 => SdoRequest::InitiateUpload { index, sub },
            3 => SdoRequest::UploadSegment { toggle: b0 & TOGGLE != 0 },
            4 => SdoRequest::Abort { index, sub, code: tail_u32(&f) },
            5 => SdoRequest::BlockUpload(BlockUploadRequest::parse(data)?),
            6 => SdoRequest::BlockDownload(BlockDownloadRequest::parse(data)?),
            _ => return Err(unknown(&f)),
        })
    }

    /// The 8 data bytes of this request.
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            SdoRequest::InitiateDownload { index, sub, ref data } => {
                let (bits, tail) = emit_initiate_data(data);
                with_multiplexer(0x20 | bits, index, sub, tail)
            }
            SdoRequest::DownloadSegment { toggle, data, len, last } => segment_frame(segment_byte0(0x00, toggle, len, last), data),
            SdoRequest::InitiateUpload { index, sub } => with_multiplexer(0x40, index, sub, [0; 4]),
            SdoRequest::UploadSegment { toggle } => [0x60 | if toggle { TOGGLE } else { 0 }, 0, 0, 0, 0, 0, 0, 0],
            SdoRequest::Abort { index, sub, code } => with_multiplexer(0x80, index, sub, code.to_le_bytes()),
            SdoRequest::BlockDownload(ref r) => r.emit(),
            SdoRequest::BlockUpload(ref r) => r.emit(),
        }
    }
}

impl SdoResponse {
    /// Decodes a server frame; exactly 8 bytes are required.
    ///
    /// Frames of a block upload sub-block do not carry a command specifier
    /// and must be decoded with [`super::sdo_block::BlockSegment::parse`] instead.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, ..] = f;
        let (index, sub) = multiplexer(&f);
        Ok(match b0 >> 5 {
            0 => {
                let (toggle, len, last) = segment_fields(b0);
                SdoResponse::UploadSegment { toggle, data: segment_data(&f), len, last }
            }
            1 => SdoResponse::DownloadSegment { toggle: b0 & TOGGLE != 0 },
            2 => SdoResponse::InitiateUpload { index, sub, data: initiate_data(b0, &f) },
            3 => SdoResponse::InitiateDownload { index, sub },
            4 => SdoResponse::Abort { index, sub, code: tail_u32(&f) },
            5 => SdoResponse::BlockDownload(BlockDownloadResponse::parse(data)?),
            6 => SdoResponse::BlockUpload(BlockUploadResponse::parse(data)?),
            _ => return Err(unknown(&f)),
        })
    }

    /// The 8 data bytes of this response.
    // In line: the SDO server builds each response where it knows the
    // variant, so that only that variant's bytes are made there.
    #[inline(always)]
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            SdoResponse::InitiateDownload { index, sub } => with_multiplexer(0x60, index, sub, [0; 4]),
            SdoResponse::DownloadSegment { toggle } => [0x20 | if toggle { TOGGLE } else { 0 }, 0, 0, 0, 0, 0, 0, 0],
            SdoResponse::InitiateUpload { index, sub, ref data } => {
                let (bits, tail) = emit_initiate_data(data);
                with_multiplexer(0x40 | bits, index, sub, tail)
            }
            SdoResponse::UploadSegment { toggle, data, len, last } => segment_frame(segment_byte0(0x00, toggle, len, last), data),
            SdoResponse::Abort { index, sub, code } => with_multiplexer(0x80, index, sub, code.to_le_bytes()),
            SdoResponse::BlockDownload(ref r) => r.emit(),
            SdoResponse::BlockUpload(ref r) => r.emit(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_initiate_upload_says_what_parse_says() {
        let mut served = 0;
        for b0 in 0..=255u8 {
            let frame = [b0, 0x18, 0x10, 0x02, 0xA1, 0xB2, 0xC3, 0xD4];
            let expected = match SdoRequest::parse(&frame) {
                Ok(SdoRequest::InitiateUpload { index, sub }) => Some((index, sub)),
                _ => None,
            };
            assert_eq!(is_initiate_upload(b0).then(|| multiplexer(&frame)), expected, "byte 0 {b0:#04x}");
            served += usize::from(expected.is_some());
        }
        // 32 upload command bytes (x free).
        assert_eq!(served, 32);
    }

    #[test]
    fn request_kind_and_its_fields_say_what_parse_says() {
        for b0 in 0..=255u8 {
            let f = [b0, 0x18, 0x10, 0x02, 0xA1, 0xB2, 0xC3, 0xD4];
            let (index, sub) = multiplexer(&f);
            let (toggle, len, last) = segment_fields(b0);
            let decoded = match RequestKind::of(b0) {
                RequestKind::DownloadSegment => Ok(SdoRequest::DownloadSegment { toggle, data: segment_data(&f), len, last }),
                RequestKind::InitiateDownload => Ok(SdoRequest::InitiateDownload { index, sub, data: initiate_data(b0, &f) }),
                RequestKind::InitiateUpload => Ok(SdoRequest::InitiateUpload { index, sub }),
                RequestKind::UploadSegment => Ok(SdoRequest::UploadSegment { toggle }),
                RequestKind::Abort => Ok(SdoRequest::Abort { index, sub, code: tail_u32(&f) }),
                RequestKind::BlockUploadInitiate | RequestKind::BlockUpload => Ok(SdoRequest::BlockUpload(BlockUploadRequest::decode(&f))),
                RequestKind::BlockDownloadInitiate | RequestKind::BlockDownloadEnd => {
                    Ok(SdoRequest::BlockDownload(BlockDownloadRequest::decode(&f)))
                }
                RequestKind::Unknown => Err(SdoParseError::UnknownCommand { command: b0, index, sub }),
            };
            let parsed = SdoRequest::parse(&f);
            assert_eq!(decoded, parsed, "byte 0 {b0:#04x}");
            let starts = matches!(
                parsed,
                Ok(SdoRequest::InitiateDownload { .. }
                    | SdoRequest::InitiateUpload { .. }
                    | SdoRequest::BlockDownload(BlockDownloadRequest::Initiate { .. })
                    | SdoRequest::BlockUpload(BlockUploadRequest::Initiate { .. }))
            );
            assert_eq!(RequestKind::of(b0).starts_transfer(), starts, "byte 0 {b0:#04x}");
        }
    }

    #[test]
    fn the_multiplexer_word_holds_the_index_and_sub_index_and_gives_the_same_frames() {
        for (index, sub) in [(0x0000, 0x00), (0x1018, 0x01), (0x2003, 0x07), (0xFFFF, 0xFF), (0x80FF, 0x80)] {
            let [i0, i1] = u16::to_le_bytes(index);
            let mux = mux_word(&[0xA5, i0, i1, sub]);
            assert_eq!((mux as u16, (mux >> 16) as u8, mux >> 24), (index, sub, 0));
            for b0 in [0x00, 0x41, 0x80, 0xC6, 0xFF] {
                let tail = [b0, 2, 3, 0xFE];
                let want = [b0, i0, i1, sub, b0, 2, 3, 0xFE];
                assert_eq!((with_mux_word(b0, mux, tail), with_multiplexer(b0, index, sub, tail)), (want, want));
            }
        }
    }

    #[test]
    fn responses_built_in_place_are_the_emitted_ones() {
        assert_eq!(initiate_download_response(0x07_2003), SdoResponse::InitiateDownload { index: 0x2003, sub: 7 }.emit());
        let mux = mux_word(&[0x40, 0x18, 0x10, 1]);
        for size in 1..=4u8 {
            let data = [1, 2, 3, 4];
            let emitted =
                SdoResponse::InitiateUpload { index: 0x1018, sub: 1, data: InitiateData::Expedited { data, size: Some(size) } }.emit();
            assert_eq!(expedited_upload_response(mux, data, usize::from(size)), emitted, "size {size}");
        }
    }

    // Frames of CiA 301 §7.2.4.3 with the values of CCT cases 2.1, 2.3, 2.13
    // and 2.15 (device type 0x00020192, heartbeat 1000 ms).
    const READ_1000: [u8; 8] = [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0];
    const READ_1000_ANSWER: [u8; 8] = [0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00];
    const WRITE_1017: [u8; 8] = [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0];
    const WRITE_1017_ANSWER: [u8; 8] = [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0];
    const ABORT_READ_ONLY: [u8; 8] = [0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06];

    fn round_trip_request(r: SdoRequest) {
        assert_eq!(SdoRequest::parse(&r.emit()), Ok(r), "{r:?}");
    }

    fn round_trip_response(r: SdoResponse) {
        assert_eq!(SdoResponse::parse(&r.emit()), Ok(r), "{r:?}");
    }

    #[test]
    fn parses_expedited_frames_from_cia301() {
        assert_eq!(SdoRequest::parse(&READ_1000), Ok(SdoRequest::InitiateUpload { index: 0x1000, sub: 0 }));
        assert_eq!(
            SdoResponse::parse(&READ_1000_ANSWER),
            Ok(SdoResponse::InitiateUpload {
                index: 0x1000,
                sub: 0,
                data: InitiateData::Expedited { data: [0x92, 0x01, 0x02, 0x00], size: Some(4) }
            })
        );
        assert_eq!(
            SdoRequest::parse(&WRITE_1017),
            Ok(SdoRequest::InitiateDownload {
                index: 0x1017,
                sub: 0,
                data: InitiateData::Expedited { data: [0xE8, 0x03, 0, 0], size: Some(2) }
            })
        );
        assert_eq!(SdoResponse::parse(&WRITE_1017_ANSWER), Ok(SdoResponse::InitiateDownload { index: 0x1017, sub: 0 }));
        assert_eq!(SdoResponse::parse(&ABORT_READ_ONLY), Ok(SdoResponse::Abort { index: 0x1000, sub: 0, code: 0x0601_0002 }));
    }

    #[test]
    fn expedited_n_bits_give_the_size() {
        for (b0, size) in [(0x23, Some(4)), (0x27, Some(3)), (0x2B, Some(2)), (0x2F, Some(1)), (0x22, None)] {
            let f = [b0, 0x00, 0x20, 0x01, 1, 2, 3, 4];
            let want = SdoRequest::InitiateDownload { index: 0x2000, sub: 1, data: InitiateData::Expedited { data: [1, 2, 3, 4], size } };
            assert_eq!(SdoRequest::parse(&f), Ok(want));
            assert_eq!(want.emit(), f);
        }
        // Reserved bit 4 is ignored on input.
        assert!(matches!(SdoRequest::parse(&[0x33, 0, 0x20, 0, 0, 0, 0, 0]), Ok(SdoRequest::InitiateDownload { .. })));
    }

    #[test]
    fn segmented_frames() {
        // Initiate segmented download of 6 bytes, then the first segment "device" with n = 1, c = 1.
        let init = [0x21, 0x08, 0x10, 0x00, 0x06, 0, 0, 0];
        assert_eq!(
            SdoRequest::parse(&init),
            Ok(SdoRequest::InitiateDownload { index: 0x1008, sub: 0, data: InitiateData::Segmented { size: Some(6) } })
        );
        let seg = [0x03, b'd', b'e', b'v', b'i', b'c', b'e', 0];
        assert_eq!(SdoRequest::parse(&seg), Ok(SdoRequest::DownloadSegment { toggle: false, data: *b"device\0", len: 6, last: true }));
        assert_eq!(SdoResponse::parse(&[0x30, 0, 0, 0, 0, 0, 0, 0]), Ok(SdoResponse::DownloadSegment { toggle: true }));
        assert_eq!(SdoRequest::parse(&[0x70, 0, 0, 0, 0, 0, 0, 0]), Ok(SdoRequest::UploadSegment { toggle: true }));
        // Upload: size 6 indicated, then a toggled segment of 7 bytes that is not the last.
        assert_eq!(
            SdoResponse::parse(&[0x41, 0x08, 0x10, 0x00, 0x06, 0, 0, 0]),
            Ok(SdoResponse::InitiateUpload { index: 0x1008, sub: 0, data: InitiateData::Segmented { size: Some(6) } })
        );
        assert_eq!(
            SdoResponse::parse(&[0x10, 1, 2, 3, 4, 5, 6, 7]),
            Ok(SdoResponse::UploadSegment { toggle: true, data: [1, 2, 3, 4, 5, 6, 7], len: 7, last: false })
        );
        // n = 7 (no data) is representable: an empty last segment.
        assert_eq!(
            SdoResponse::parse(&[0x0F, 0, 0, 0, 0, 0, 0, 0]),
            Ok(SdoResponse::UploadSegment { toggle: false, data: [0; 7], len: 0, last: true })
        );
    }

    #[test]
    fn unknown_command_specifier_keeps_the_multiplexer() {
        let f = [0xE0, 0x00, 0x10, 0x00, 0, 0, 0, 0];
        assert_eq!(SdoRequest::parse(&f), Err(SdoParseError::UnknownCommand { command: 0xE0, index: 0x1000, sub: 0 }));
        assert_eq!(SdoResponse::parse(&f), Err(SdoParseError::UnknownCommand { command: 0xE0, index: 0x1000, sub: 0 }));
    }

    #[test]
    fn every_truncated_or_long_frame_is_a_length_error() {
        for f in [READ_1000, READ_1000_ANSWER, WRITE_1017, WRITE_1017_ANSWER, ABORT_READ_ONLY, [0xA3, 0, 0, 0, 0, 0, 0, 0]] {
            for len in 0..8 {
                assert_eq!(SdoRequest::parse(&f[..len]), Err(SdoParseError::Length(len)));
                assert_eq!(SdoResponse::parse(&f[..len]), Err(SdoParseError::Length(len)));
            }
            let mut long = [0u8; 9];
            long[..8].copy_from_slice(&f);
            assert_eq!(SdoRequest::parse(&long), Err(SdoParseError::Length(9)));
            assert_eq!(SdoResponse::parse(&long), Err(SdoParseError::Length(9)));
        }
    }

    #[test]
    fn every_request_round_trips() {
        for data in [
            InitiateData::Expedited { data: [1, 2, 3, 4], size: Some(1) },
            InitiateData::Expedited { data: [1, 2, 3, 4], size: Some(4) },
            InitiateData::Expedited { data: [9, 9, 9, 9], size: None },
            InitiateData::Segmented { size: Some(0x1234_5678) },
            InitiateData::Segmented { size: None },
        ] {
            round_trip_request(SdoRequest::InitiateDownload { index: 0x6040, sub: 0xFF, data });
            round_trip_response(SdoResponse::InitiateUpload { index: 0x6040, sub: 0xFF, data });
        }
        for len in 0..=7 {
            for (toggle, last) in [(false, false), (true, true)] {
                round_trip_request(SdoRequest::DownloadSegment { toggle, data: [7, 6, 5, 4, 3, 2, 1], len, last });
                round_trip_response(SdoResponse::UploadSegment { toggle, data: [7, 6, 5, 4, 3, 2, 1], len, last });
            }
        }
        round_trip_request(SdoRequest::InitiateUpload { index: 0x1018, sub: 4 });
        round_trip_request(SdoRequest::UploadSegment { toggle: false });
        round_trip_request(SdoRequest::Abort { index: 0x1018, sub: 4, code: 0x0504_0000 });
        round_trip_response(SdoResponse::InitiateDownload { index: 0x1018, sub: 4 });
        round_trip_response(SdoResponse::DownloadSegment { toggle: false });
        round_trip_response(SdoResponse::Abort { index: 0xFFFF, sub: 0xFF, code: 0xFFFF_FFFF });
    }

    #[test]
    fn emit_clamps_impossible_sizes_instead_of_panicking() {
        let r = SdoResponse::InitiateUpload { index: 1, sub: 2, data: InitiateData::Expedited { data: [0; 4], size: Some(0) } };
        assert_eq!(r.emit()[0], 0x4F);
        let s = SdoResponse::UploadSegment { toggle: false, data: [0; 7], len: 200, last: false };
        assert_eq!(s.emit()[0], 0x00);
    }
}
