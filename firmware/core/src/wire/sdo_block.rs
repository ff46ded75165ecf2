//! SDO block transfer formats and their CRC. CiA 301 v4.2 §7.2.4.3.9–16
//! (block download and upload), figures 34–45.
//!
//! Block frames are 8 bytes like every SDO frame:
//!
//! | frame                       | dir | byte 0           | bytes 1–7                         |
//! |-----------------------------|-----|------------------|-----------------------------------|
//! | initiate block download     | C→S | `110x x cc s 0`  | index, sub, size (s = 1)          |
//! | initiate download response  | S→C | `101x x sc 00`   | index, sub, blksize               |
//! | sub-block segment           | both| `c seqno(7)`     | 7 data bytes                      |
//! | block download response     | S→C | `101x xx 10`     | ackseq, blksize                   |
//! | end block download          | C→S | `110 nnn x 1`    | CRC (little-endian)               |
//! | end block download response | S→C | `101x xx 01`     | —                                 |
//! | initiate block upload       | C→S | `101x x cc 00`   | index, sub, blksize, pst          |
//! | initiate upload response    | S→C | `110x x sc s 0`  | index, sub, size (s = 1)          |
//! | start upload                | C→S | `101x xx 11`     | —                                 |
//! | block upload response       | C→S | `101x xx 10`     | ackseq, blksize                   |
//! | end block upload            | S→C | `110 nnn x 1`    | CRC                               |
//! | end block upload response   | C→S | `101x xx 01`     | —                                 |
//!
//! Sub-block segments carry no command specifier: whoever receives them
//! knows from its state that a sub-block is under way.

use super::sdo::{SdoParseError, frame, multiplexer, with_multiplexer};

/// Largest number of segments in a block (blksize is 1..=127).
pub const MAX_BLKSIZE: u8 = 127;

/// Data bytes in one sub-block segment.
pub const SEGMENT_DATA: usize = 7;

/// CRC-16 of a whole buffer as block transfer uses it: CRC-16-CCITT,
/// polynomial x^16 + x^12 + x^5 + 1 (0x1021), initial value 0, no
/// reflection, no final XOR (CiA 301 §7.2.4.3.16).
pub fn crc16(data: &[u8]) -> u16 {
    crc16_update(0, data)
}

/// Continues a [`crc16`] over more bytes, so a transfer can be checked a
/// segment at a time.
///
/// A byte at a time without a table: the top byte of the register XOR
/// the data byte, folded as `x ^ x >> 4`, is what the polynomial's terms
/// x^12, x^5 and 1 shift back in. Measured on thumbv7m-none-eabi against
/// the nibble table it replaced (32 bytes of table, two look-ups a byte):
/// smaller and faster (see docs/benchmarks.md, round 12b).
// Out of line: two callers (block download end, block upload).
#[inline(never)]
pub fn crc16_update(crc: u16, data: &[u8]) -> u16 {
    // In a u32: the bits shifted past bit 15 are never read (the high byte
    // is bits 8-15) and are cut once at the end, not after every byte.
    let mut crc = u32::from(crc);
    for &byte in data {
        let x = u32::from((crc >> 8) as u8 ^ byte);
        let x = x ^ (x >> 4);
        crc = (crc << 8) ^ (x << 12) ^ (x << 5) ^ x;
    }
    crc as u16
}

/// Block download frames from the client (ccs = 6), outside the sub-block phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockDownloadRequest {
    /// cs = 0: initiate block download.
    Initiate {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// cc: the client supports CRC.
        crc: bool,
        /// Bytes 4–7 when s = 1.
        size: Option<u32>,
    },
    /// cs = 1: end block download.
    End {
        /// n: bytes of the last segment that carry no data (0..=7).
        unused: u8,
        /// CRC of all data bytes (valid if both sides support CRC).
        crc: u16,
    },
}

/// Block download frames from the server (scs = 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockDownloadResponse {
    /// ss = 0: initiate block download response.
    Initiate {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// sc: the server supports CRC.
        crc: bool,
        /// Segments per block the server accepts (1..=127).
        blksize: u8,
    },
    /// ss = 2: block download response, confirming a sub-block.
    Ack {
        /// Sequence number of the last segment received in order (0 = none).
        ackseq: u8,
        /// Segments in the next block.
        blksize: u8,
    },
    /// ss = 1: end block download response.
    End,
}

/// Block upload frames from the client (ccs = 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockUploadRequest {
    /// cs = 0: initiate block upload.
    Initiate {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// cc: the client supports CRC.
        crc: bool,
        /// Segments per block the client accepts (valid 1..=127).
        blksize: u8,
        /// Protocol switch threshold: if the value has at most `pst` bytes
        /// the server may answer with an expedited or segmented upload instead
        /// (0 = no switch).
        pst: u8,
    },
    /// cs = 3: start upload.
    Start,
    /// cs = 2: block upload response, confirming a sub-block.
    Ack {
        /// Sequence number of the last segment received in order (0 = none).
        ackseq: u8,
        /// Segments in the next block (valid 1..=127).
        blksize: u8,
    },
    /// cs = 1: end block upload response.
    End,
}

/// Block upload frames from the server (scs = 6), outside the sub-block phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockUploadResponse {
    /// ss = 0: initiate block upload response.
    Initiate {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// sc: the server supports CRC.
        crc: bool,
        /// Bytes 4–7 when s = 1.
        size: Option<u32>,
    },
    /// ss = 1: end block upload.
    End {
        /// n: bytes of the last segment that carry no data (0..=7).
        unused: u8,
        /// CRC of all data bytes (valid if both sides support CRC).
        crc: u16,
    },
}

/// One segment of a sub-block, in either direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockSegment {
    /// Sequence number in the block (1..=blksize when valid; 0..=127 on the wire).
    pub seqno: u8,
    /// c: the last segment of the transfer.
    pub last: bool,
    /// Seven data bytes (the unused tail of the last one is given at the end).
    pub data: [u8; 7],
}

const CRC_FLAG: u8 = 0x04;
const SIZE_FLAG: u8 = 0x02;

fn flag(on: bool, bit: u8) -> u8 {
    if on { bit } else { 0 }
}

/// Byte 0 of an end frame: `ccc nnn x 1`.
fn end_byte0(cs: u8, unused: u8) -> u8 {
    cs | ((unused.min(7)) << 2) | 0x01
}

/// Bytes 1–2 as a little-endian CRC.
fn crc_of(f: &[u8; 8]) -> u16 {
    let [_, c0, c1, ..] = *f;
    u16::from_le_bytes([c0, c1])
}

/// Bytes 4–7 as a little-endian u32.
fn size_of(f: &[u8; 8]) -> u32 {
    let [.., d0, d1, d2, d3] = *f;
    u32::from_le_bytes([d0, d1, d2, d3])
}

fn command_error(f: &[u8; 8]) -> SdoParseError {
    let (index, sub) = multiplexer(f);
    let [command, ..] = *f;
    SdoParseError::UnknownCommand { command, index, sub }
}

impl BlockDownloadRequest {
    /// Decodes a client frame with ccs = 6.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, ..] = f;
        if b0 >> 5 != 6 {
            return Err(command_error(&f));
        }
        Ok(Self::decode(&f))
    }

    /// Decodes a frame whose ccs is 6 (not checked).
    pub(crate) fn decode(f: &[u8; 8]) -> Self {
        let [b0, ..] = *f;
        let (index, sub) = multiplexer(f);
        if b0 & 0x01 == 0 {
            BlockDownloadRequest::Initiate { index, sub, crc: b0 & CRC_FLAG != 0, size: (b0 & SIZE_FLAG != 0).then(|| size_of(f)) }
        } else {
            BlockDownloadRequest::End { unused: (b0 >> 2) & 0x07, crc: crc_of(f) }
        }
    }

    /// The 8 data bytes.
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            BlockDownloadRequest::Initiate { index, sub, crc, size } => {
                with_multiplexer(0xC0 | flag(crc, CRC_FLAG) | flag(size.is_some(), SIZE_FLAG), index, sub, size.unwrap_or(0).to_le_bytes())
            }
            BlockDownloadRequest::End { unused, crc } => {
                let [c0, c1] = crc.to_le_bytes();
                [end_byte0(0xC0, unused), c0, c1, 0, 0, 0, 0, 0]
            }
        }
    }
}

impl BlockDownloadResponse {
    /// Decodes a server frame with scs = 5.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, b1, b2, _, b4, ..] = f;
        if b0 >> 5 != 5 {
            return Err(command_error(&f));
        }
        let (index, sub) = multiplexer(&f);
        Ok(match b0 & 0x03 {
            0 => BlockDownloadResponse::Initiate { index, sub, crc: b0 & CRC_FLAG != 0, blksize: b4 },
            1 => BlockDownloadResponse::End,
            2 => BlockDownloadResponse::Ack { ackseq: b1, blksize: b2 },
            _ => return Err(command_error(&f)),
        })
    }

    /// The 8 data bytes.
    #[inline(always)]
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            BlockDownloadResponse::Initiate { index, sub, crc, blksize } => {
                with_multiplexer(0xA0 | flag(crc, CRC_FLAG), index, sub, [blksize, 0, 0, 0])
            }
            BlockDownloadResponse::Ack { ackseq, blksize } => [0xA2, ackseq, blksize, 0, 0, 0, 0, 0],
            BlockDownloadResponse::End => [0xA1, 0, 0, 0, 0, 0, 0, 0],
        }
    }
}

impl BlockUploadRequest {
    /// Decodes a client frame with ccs = 5.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, ..] = f;
        if b0 >> 5 != 5 {
            return Err(command_error(&f));
        }
        Ok(Self::decode(&f))
    }

    /// Decodes a frame whose ccs is 5 (not checked).
    pub(crate) fn decode(f: &[u8; 8]) -> Self {
        let [b0, b1, b2, _, b4, b5, ..] = *f;
        let (index, sub) = multiplexer(f);
        match b0 & 0x03 {
            0 => BlockUploadRequest::Initiate { index, sub, crc: b0 & CRC_FLAG != 0, blksize: b4, pst: b5 },
            1 => BlockUploadRequest::End,
            2 => BlockUploadRequest::Ack { ackseq: b1, blksize: b2 },
            _ => BlockUploadRequest::Start,
        }
    }

    /// The 8 data bytes.
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            BlockUploadRequest::Initiate { index, sub, crc, blksize, pst } => {
                with_multiplexer(0xA0 | flag(crc, CRC_FLAG), index, sub, [blksize, pst, 0, 0])
            }
            BlockUploadRequest::Start => [0xA3, 0, 0, 0, 0, 0, 0, 0],
            BlockUploadRequest::Ack { ackseq, blksize } => [0xA2, ackseq, blksize, 0, 0, 0, 0, 0],
            BlockUploadRequest::End => [0xA1, 0, 0, 0, 0, 0, 0, 0],
        }
    }
}

impl BlockUploadResponse {
    /// Decodes a server frame with scs = 6.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, ..] = f;
        if b0 >> 5 != 6 {
            return Err(command_error(&f));
        }
        let (index, sub) = multiplexer(&f);
        Ok(if b0 & 0x01 == 0 {
            BlockUploadResponse::Initiate { index, sub, crc: b0 & CRC_FLAG != 0, size: (b0 & SIZE_FLAG != 0).then(|| size_of(&f)) }
        } else {
            BlockUploadResponse::End { unused: (b0 >> 2) & 0x07, crc: crc_of(&f) }
        })
    }

    /// The 8 data bytes.
    #[inline(always)]
    pub fn emit(&self) -> [u8; 8] {
        match *self {
            BlockUploadResponse::Initiate { index, sub, crc, size } => {
                with_multiplexer(0xC0 | flag(crc, CRC_FLAG) | flag(size.is_some(), SIZE_FLAG), index, sub, size.unwrap_or(0).to_le_bytes())
            }
            BlockUploadResponse::End { unused, crc } => {
                let [c0, c1] = crc.to_le_bytes();
                [end_byte0(0xC0, unused), c0, c1, 0, 0, 0, 0, 0]
            }
        }
    }
}

impl BlockSegment {
    /// Decodes a sub-block segment. Any byte 0 is a segment; whether its
    /// sequence number fits the block is for the receiver to judge.
    pub fn parse(data: &[u8]) -> Result<Self, SdoParseError> {
        let f = frame(data)?;
        let [b0, d @ ..] = f;
        Ok(BlockSegment { seqno: b0 & 0x7F, last: b0 & 0x80 != 0, data: d })
    }

    /// The 8 data bytes (`seqno` is cut to 7 bits).
    pub fn emit(&self) -> [u8; 8] {
        let [d0, d1, d2, d3, d4, d5, d6] = self.data;
        [Self::byte0(self.seqno, self.last), d0, d1, d2, d3, d4, d5, d6]
    }

    /// Byte 0 of a segment: c and the sequence number (cut to 7 bits), for
    /// a sender that reads the data into bytes 1–7 of the frame in place.
    pub(crate) fn byte0(seqno: u8, last: bool) -> u8 {
        flag(last, 0x80) | (seqno & 0x7F)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_check_value() {
        // The CRC-16/XMODEM check value (the parameters CiA 301 gives).
        assert_eq!(crc16(b"123456789"), 0x31C3);
        assert_eq!(crc16(b""), 0);
        // Feeding in pieces gives the same as feeding at once.
        assert_eq!(crc16_update(crc16(b"1234"), b"56789"), 0x31C3);
        let data: Vec<u8> = (0..=255).collect();
        let whole = crc16(&data);
        let pieces = data.chunks(7).fold(0, crc16_update);
        assert_eq!(whole, pieces);
        // Independent value (python: binascii.crc_hqx(bytes(range(256)), 0)).
        assert_eq!(whole, 0x7E55);
    }

    #[test]
    fn block_download_frames() {
        // Initiate with CRC and size 121: 0xC6 = ccs 6, cc, s.
        let init = [0xC6, 0x10, 0x20, 0x00, 121, 0, 0, 0];
        let want = BlockDownloadRequest::Initiate { index: 0x2010, sub: 0, crc: true, size: Some(121) };
        assert_eq!(BlockDownloadRequest::parse(&init), Ok(want));
        assert_eq!(want.emit(), init);
        assert_eq!(
            BlockDownloadRequest::parse(&[0xC0, 0x10, 0x20, 0x00, 9, 9, 9, 9]),
            Ok(BlockDownloadRequest::Initiate { index: 0x2010, sub: 0, crc: false, size: None })
        );
        // End with n = 5 and CRC 0x31C3: 0xC1 | 5 << 2 = 0xD5.
        let end = [0xD5, 0xC3, 0x31, 0, 0, 0, 0, 0];
        assert_eq!(BlockDownloadRequest::parse(&end), Ok(BlockDownloadRequest::End { unused: 5, crc: 0x31C3 }));
        assert_eq!(BlockDownloadRequest::End { unused: 5, crc: 0x31C3 }.emit(), end);
        // Server side: 0xA4 = scs 5 with sc, blksize 127.
        let resp = [0xA4, 0x10, 0x20, 0x00, 127, 0, 0, 0];
        assert_eq!(
            BlockDownloadResponse::parse(&resp),
            Ok(BlockDownloadResponse::Initiate { index: 0x2010, sub: 0, crc: true, blksize: 127 })
        );
        assert_eq!(
            BlockDownloadResponse::parse(&[0xA2, 5, 127, 0, 0, 0, 0, 0]),
            Ok(BlockDownloadResponse::Ack { ackseq: 5, blksize: 127 })
        );
        assert_eq!(BlockDownloadResponse::parse(&[0xA1, 0, 0, 0, 0, 0, 0, 0]), Ok(BlockDownloadResponse::End));
        assert!(matches!(BlockDownloadResponse::parse(&[0xA3, 0, 0, 0, 0, 0, 0, 0]), Err(SdoParseError::UnknownCommand { .. })));
    }

    #[test]
    fn block_upload_frames() {
        // CCT 2.23: read 0x1008 with CRC, blksize 127, pst 0.
        let init = [0xA4, 0x08, 0x10, 0x00, 127, 0, 0, 0];
        let want = BlockUploadRequest::Initiate { index: 0x1008, sub: 0, crc: true, blksize: 127, pst: 0 };
        assert_eq!(BlockUploadRequest::parse(&init), Ok(want));
        assert_eq!(want.emit(), init);
        assert_eq!(BlockUploadRequest::parse(&[0xA3, 0, 0, 0, 0, 0, 0, 0]), Ok(BlockUploadRequest::Start));
        assert_eq!(BlockUploadRequest::parse(&[0xA2, 3, 20, 0, 0, 0, 0, 0]), Ok(BlockUploadRequest::Ack { ackseq: 3, blksize: 20 }));
        assert_eq!(BlockUploadRequest::parse(&[0xA1, 0, 0, 0, 0, 0, 0, 0]), Ok(BlockUploadRequest::End));
        let resp = [0xC6, 0x08, 0x10, 0x00, 6, 0, 0, 0];
        assert_eq!(
            BlockUploadResponse::parse(&resp),
            Ok(BlockUploadResponse::Initiate { index: 0x1008, sub: 0, crc: true, size: Some(6) })
        );
        assert_eq!(BlockUploadResponse::parse(&[0xC5, 0x34, 0x12, 0, 0, 0, 0, 0]), Ok(BlockUploadResponse::End { unused: 1, crc: 0x1234 }));
    }

    #[test]
    fn segments_carry_seqno_and_c() {
        let f = [0x85, 1, 2, 3, 4, 5, 6, 7];
        let s = BlockSegment { seqno: 5, last: true, data: [1, 2, 3, 4, 5, 6, 7] };
        assert_eq!(BlockSegment::parse(&f), Ok(s));
        assert_eq!(s.emit(), f);
        assert_eq!(BlockSegment::parse(&[0x7F, 0, 0, 0, 0, 0, 0, 0]).map(|s| (s.seqno, s.last)), Ok((127, false)));
        assert_eq!(BlockSegment { seqno: 200, last: false, data: [0; 7] }.emit()[0], 200 & 0x7F);
    }

    #[test]
    fn wrong_command_specifier_is_refused() {
        let f = [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0];
        let err = Some(SdoParseError::UnknownCommand { command: 0x40, index: 0x1000, sub: 0 });
        assert_eq!(BlockDownloadRequest::parse(&f).err(), err);
        assert_eq!(BlockDownloadResponse::parse(&f).err(), err);
        assert_eq!(BlockUploadRequest::parse(&f).err(), err);
        assert_eq!(BlockUploadResponse::parse(&f).err(), err);
    }

    #[test]
    fn every_truncated_frame_is_a_length_error() {
        let f = [0xC6, 0x10, 0x20, 0x00, 121, 0, 0, 0];
        for len in 0..8 {
            let e = Some(SdoParseError::Length(len));
            assert_eq!(BlockDownloadRequest::parse(&f[..len]).err(), e);
            assert_eq!(BlockDownloadResponse::parse(&f[..len]).err(), e);
            assert_eq!(BlockUploadRequest::parse(&f[..len]).err(), e);
            assert_eq!(BlockUploadResponse::parse(&f[..len]).err(), e);
            assert_eq!(BlockSegment::parse(&f[..len]).err(), e);
        }
        assert_eq!(BlockSegment::parse(&[0; 9]), Err(SdoParseError::Length(9)));
    }

    #[test]
    fn every_block_frame_round_trips() {
        for r in [
            BlockDownloadRequest::Initiate { index: 0x1F50, sub: 1, crc: false, size: Some(u32::MAX) },
            BlockDownloadRequest::Initiate { index: 0x1F50, sub: 1, crc: true, size: None },
            BlockDownloadRequest::End { unused: 0, crc: 0xFFFF },
            BlockDownloadRequest::End { unused: 7, crc: 0 },
        ] {
            assert_eq!(BlockDownloadRequest::parse(&r.emit()), Ok(r));
        }
        for r in [
            BlockDownloadResponse::Initiate { index: 0x1F50, sub: 1, crc: true, blksize: 1 },
            BlockDownloadResponse::Ack { ackseq: 0, blksize: 127 },
            BlockDownloadResponse::End,
        ] {
            assert_eq!(BlockDownloadResponse::parse(&r.emit()), Ok(r));
        }
        for r in [
            BlockUploadRequest::Initiate { index: 0x1F50, sub: 1, crc: false, blksize: 4, pst: 21 },
            BlockUploadRequest::Start,
            BlockUploadRequest::Ack { ackseq: 127, blksize: 1 },
            BlockUploadRequest::End,
        ] {
            assert_eq!(BlockUploadRequest::parse(&r.emit()), Ok(r));
        }
        for r in [
            BlockUploadResponse::Initiate { index: 0x1F50, sub: 1, crc: true, size: Some(1000) },
            BlockUploadResponse::Initiate { index: 0x1F50, sub: 1, crc: false, size: None },
            BlockUploadResponse::End { unused: 6, crc: 0xBEEF },
        ] {
            assert_eq!(BlockUploadResponse::parse(&r.emit()), Ok(r));
        }
    }
}
