//! The Lawicel SLCAN ASCII protocol (CAN232/CANUSB manuals), adapter side:
//! what a serial CAN adapter understands from its host and what it answers.
//!
//! Host → adapter, each line ended by CR (LF is accepted too; empty lines are
//! ignored, as python-can sends one after `S6`):
//!
//! | command | meaning | answer |
//! |---|---|---|
//! | `tiiildd…` / `Tiiiiiiiildd…` | send an 11/29-bit data frame | `z` / `Z` + CR |
//! | `riiil` / `Riiiiiiiil` | send an 11/29-bit remote frame | `z` / `Z` + CR |
//! | `O` / `L` / `C` | open / open listen-only / close the channel | CR |
//! | `S0`…`S8` | 10, 20, 50, 100, 125, 250, 500, 800 kbit/s, 1 Mbit/s | CR |
//! | `sxxyy` | BTR0/BTR1 of an SJA1000 (recorded, not applied) | CR |
//! | `V` / `v` / `N` | version `V1013`, `v1013`, serial number `NHOST` | line + CR |
//! | `F` | status flags `Fxx` (cleared when read) | line + CR |
//! | `Z0`/`Z1`, `X0`/`X1` | timestamps off/on, auto-poll off/on | CR |
//! | `Mxxxxxxxx` / `mxxxxxxxx` | acceptance code / mask (tolerated, not applied) | CR |
//!
//! Every malformed line and every command the channel state forbids (a
//! frame while closed or listen-only, `O` while open, `C` while closed,
//! `S`/`s`/`Z`/`X`/`M`/`m` while open, `F` while closed) is answered with
//! BEL (0x07). Adapter → host, received frames are the same `t`/`T`/`r`/`R`
//! lines, followed by a 4-digit millisecond timestamp (0–59999) when `Z1`
//! is on. Nothing here panics or allocates without bound on garbage input.
//!
//! [`SlcanServer`] serves this protocol over TCP, so python-can's `slcan`
//! interface can drive a node with `channel="socket://127.0.0.1:PORT"`;
//! every client is an adapter on the same bus, and a client the server had
//! to drop frames for finds the data overrun bit (3) set in its `F` flags.

mod credit;
mod outbox;
mod server;
#[cfg(test)]
mod server_tests;
#[cfg(test)]
mod tests;
mod wire;

pub use server::{ClientStatus, FrameSender, ServerOptions, SlcanChannels, SlcanServer};

use crate::bus::BitRate;
use canopen_core::frame::CanFrame;
use embedded_can::{ExtendedId, Frame, StandardId};

/// The byte that answers an erroneous command.
pub const BEL: u8 = 0x07;
/// The byte that ends every line.
pub const CR: u8 = b'\r';
/// The longest line the decoder buffers (the longest valid one, an extended
/// frame with 8 bytes, is 26 characters).
pub const MAX_LINE: usize = 32;

/// One decoded host command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `t`, `T`, `r`, `R`: a frame to send on the bus.
    Transmit(CanFrame),
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `S0`..`S8`: a standard bit rate.
    SetBitRate(BitRate),
    /// `sxxyy`: SJA1000 bit timing registers.
    SetBtr {
        /// BTR0.
        btr0: u8,
        /// BTR1.
        btr1: u8,
    },
    /// `V`: hardware and software version.
    Version,
    /// `v`: detailed (software) version.
    DetailedVersion,
    /// `N`: serial number.
    SerialNumber,
    /// `F`: read and clear the status flags.
    StatusFlags,
    /// `Z0`/`Z1`: timestamps on received frames.
    Timestamps(bool),
    /// `X0`/`X1`: auto-poll (always on here; recorded only).
    AutoPoll(bool),
    /// `Mxxxxxxxx`: acceptance code (tolerated, not applied).
    AcceptanceCode(u32),
    /// `mxxxxxxxx`: acceptance mask (tolerated, not applied).
    AcceptanceMask(u32),
}

/// Why a host line was rejected (it is answered with [`BEL`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The line was empty (the streaming decoder skips these).
    Empty,
    /// The first character is no command.
    UnknownCommand(u8),
    /// The line has `got` characters where the command needs `expected`
    /// (for a frame whose DLC could not be read yet: at least `expected`).
    BadLength {
        /// Characters the command needs.
        expected: usize,
        /// Characters received, the command letter included.
        got: usize,
    },
    /// The character at `pos` (0 = the command letter) should be a hex digit.
    BadHex {
        /// Position in the line.
        pos: usize,
    },
    /// An identifier above 0x7FF (`t`, `r`) or 0x1FFF_FFFF (`T`, `R`).
    IdOutOfRange(u32),
    /// The DLC character is not `0`..`8`.
    BadDlc(u8),
    /// The `S` argument is not `0`..`8`.
    BadBitRate(u8),
    /// The `Z`/`X` argument is not `0` or `1`.
    BadFlag(u8),
    /// The line was longer than [`MAX_LINE`].
    TooLong,
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DecodeError::Empty => f.write_str("empty line"),
            DecodeError::UnknownCommand(c) => write!(f, "unknown command {:?}", char::from(*c)),
            DecodeError::BadLength { expected, got } => write!(f, "{got} characters, expected {expected}"),
            DecodeError::BadHex { pos } => write!(f, "character {pos} is not a hex digit"),
            DecodeError::IdOutOfRange(id) => write!(f, "identifier {id:#x} out of range"),
            DecodeError::BadDlc(c) => write!(f, "DLC {:?} is not 0..8", char::from(*c)),
            DecodeError::BadBitRate(c) => write!(f, "bit rate {:?} is not 0..8", char::from(*c)),
            DecodeError::BadFlag(c) => write!(f, "flag {:?} is not 0 or 1", char::from(*c)),
            DecodeError::TooLong => write!(f, "line longer than {MAX_LINE} characters"),
        }
    }
}

impl std::error::Error for DecodeError {}

/// The bit rate of Lawicel's `Sn` (n = 0..8).
pub const fn lawicel_bitrate(n: u8) -> Option<BitRate> {
    match n {
        0 => Some(BitRate::KBIT_10),
        1 => Some(BitRate::KBIT_20),
        2 => Some(BitRate::KBIT_50),
        3 => Some(BitRate::KBIT_100),
        4 => Some(BitRate::KBIT_125),
        5 => Some(BitRate::KBIT_250),
        6 => Some(BitRate::KBIT_500),
        7 => Some(BitRate::KBIT_800),
        8 => Some(BitRate::MBIT_1),
        _ => None,
    }
}

fn hex_value(c: u8) -> Option<u32> {
    char::from(c).to_digit(16)
}

/// Parses `line[start..start + n]` as hex.
fn hex_field(line: &[u8], start: usize, n: usize) -> Result<u32, DecodeError> {
    (start..start + n).try_fold(0u32, |acc, pos| {
        let digit = line.get(pos).copied().and_then(hex_value).ok_or(DecodeError::BadHex { pos })?;
        Ok((acc << 4) | digit)
    })
}

fn exact_len(line: &[u8], expected: usize) -> Result<(), DecodeError> {
    if line.len() == expected { Ok(()) } else { Err(DecodeError::BadLength { expected, got: line.len() }) }
}

/// `0`/`1` at position 1 of a two-character line.
fn flag(line: &[u8]) -> Result<bool, DecodeError> {
    exact_len(line, 2)?;
    match line.get(1) {
        Some(b'0') => Ok(false),
        Some(b'1') => Ok(true),
        Some(&c) => Err(DecodeError::BadFlag(c)),
        None => Err(DecodeError::BadLength { expected: 2, got: line.len() }),
    }
}

fn decode_frame(line: &[u8], extended: bool, remote: bool) -> Result<CanFrame, DecodeError> {
    let id_len = if extended { 8 } else { 3 };
    let header = 1 + id_len + 1;
    if line.len() < header {
        return Err(DecodeError::BadLength { expected: header, got: line.len() });
    }
    let raw = hex_field(line, 1, id_len)?;
    let dlc_char = line.get(header - 1).copied().unwrap_or(0);
    let dlc = match dlc_char {
        b'0'..=b'8' => usize::from(dlc_char - b'0'),
        _ => return Err(DecodeError::BadDlc(dlc_char)),
    };
    let expected = if remote { header } else { header + 2 * dlc };
    exact_len(line, expected)?;
    let mut data = [0u8; 8];
    if !remote {
        for (i, byte) in data.iter_mut().take(dlc).enumerate() {
            *byte = hex_field(line, header + 2 * i, 2)? as u8;
        }
    }
    let id: embedded_can::Id = if extended {
        ExtendedId::new(raw).ok_or(DecodeError::IdOutOfRange(raw))?.into()
    } else {
        u16::try_from(raw).ok().and_then(StandardId::new).ok_or(DecodeError::IdOutOfRange(raw))?.into()
    };
    let frame = if remote { CanFrame::new_remote(id, dlc) } else { CanFrame::new(id, data.get(..dlc).unwrap_or(&[])) };
    // Both constructors accept every dlc ≤ 8, which was checked above.
    frame.ok_or(DecodeError::BadDlc(dlc_char))
}

/// Decodes one host line (without its CR).
pub fn decode_command(line: &[u8]) -> Result<Command, DecodeError> {
    let Some(&letter) = line.first() else { return Err(DecodeError::Empty) };
    let simple = |cmd: Command| exact_len(line, 1).map(|()| cmd);
    match letter {
        b't' => decode_frame(line, false, false).map(Command::Transmit),
        b'T' => decode_frame(line, true, false).map(Command::Transmit),
        b'r' => decode_frame(line, false, true).map(Command::Transmit),
        b'R' => decode_frame(line, true, true).map(Command::Transmit),
        b'O' => simple(Command::Open),
        b'L' => simple(Command::ListenOnly),
        b'C' => simple(Command::Close),
        b'V' => simple(Command::Version),
        b'v' => simple(Command::DetailedVersion),
        b'N' => simple(Command::SerialNumber),
        b'F' => simple(Command::StatusFlags),
        b'S' => {
            exact_len(line, 2)?;
            let c = line.get(1).copied().unwrap_or(0);
            c.checked_sub(b'0').and_then(lawicel_bitrate).map(Command::SetBitRate).ok_or(DecodeError::BadBitRate(c))
        }
        b's' => {
            exact_len(line, 5)?;
            let v = hex_field(line, 1, 4)?;
            Ok(Command::SetBtr { btr0: (v >> 8) as u8, btr1: v as u8 })
        }
        b'Z' => flag(line).map(Command::Timestamps),
        b'X' => flag(line).map(Command::AutoPoll),
        b'M' | b'm' => {
            exact_len(line, 9)?;
            let v = hex_field(line, 1, 8)?;
            Ok(if letter == b'M' { Command::AcceptanceCode(v) } else { Command::AcceptanceMask(v) })
        }
        other => Err(DecodeError::UnknownCommand(other)),
    }
}

/// Splits a byte stream, arriving in chunks of any size, into host lines.
#[derive(Clone, Debug)]
pub struct StreamDecoder {
    buf: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        StreamDecoder { buf: [0; MAX_LINE], len: 0, overflow: false }
    }
}

impl StreamDecoder {
    /// A decoder at the start of a line.
    pub fn new() -> Self {
        StreamDecoder::default()
    }

    /// Takes one byte; at the end of a non-empty line, returns its decoding.
    pub fn push(&mut self, byte: u8) -> Option<Result<Command, DecodeError>> {
        if byte == CR || byte == b'\n' {
            let (len, overflow) = (self.len, self.overflow);
            self.len = 0;
            self.overflow = false;
            return if overflow {
                Some(Err(DecodeError::TooLong))
            } else if len == 0 {
                None
            } else {
                Some(decode_command(self.buf.get(..len).unwrap_or(&[])))
            };
        }
        match self.buf.get_mut(self.len) {
            Some(slot) if !self.overflow => {
                *slot = byte;
                self.len += 1;
            }
            _ => self.overflow = true,
        }
        None
    }

    /// Takes a chunk; returns the decodings of the lines it completed.
    pub fn push_all(&mut self, bytes: &[u8]) -> Vec<Result<Command, DecodeError>> {
        bytes.iter().filter_map(|&b| self.push(b)).collect()
    }
}

fn push_hex(out: &mut Vec<u8>, value: u32, digits: u32) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    for i in (0..digits).rev() {
        out.push(HEX.get(((value >> (4 * i)) & 0xF) as usize).copied().unwrap_or(b'0'));
    }
}

/// Appends the adapter → host line for a received frame: `t`/`T`/`r`/`R`,
/// upper-case hex, the DLC, the data, an optional millisecond timestamp
/// (4 hex digits, taken modulo 60000), then CR.
pub fn encode_frame(frame: &CanFrame, timestamp_ms: Option<u64>, out: &mut Vec<u8>) {
    let (letter, digits) = match (frame.is_extended_id(), frame.is_remote_frame()) {
        (false, false) => (b't', 3),
        (true, false) => (b'T', 8),
        (false, true) => (b'r', 3),
        (true, true) => (b'R', 8),
    };
    out.push(letter);
    push_hex(out, frame.raw_id(), digits);
    out.push(b'0' + frame.dlc().min(8) as u8);
    for &b in frame.data() {
        push_hex(out, u32::from(b), 2);
    }
    if let Some(ms) = timestamp_ms {
        push_hex(out, (ms % 60_000) as u32, 4);
    }
    out.push(CR);
}

/// The channel state of an adapter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChannelState {
    /// Closed: configuration commands allowed, no frames.
    #[default]
    Closed,
    /// Open: frames both ways.
    Open,
    /// Open listen-only: frames to the host only.
    ListenOnly,
}

/// The protocol state of one adapter: decodes host bytes, keeps the channel
/// state and produces the answers.
#[derive(Clone, Debug, Default)]
pub struct SlcanAdapter {
    decoder: StreamDecoder,
    state: ChannelState,
    bitrate: Option<BitRate>,
    btr: Option<(u8, u8)>,
    timestamps: bool,
    status_flags: u8,
    errors: u64,
}

impl SlcanAdapter {
    /// A closed adapter with no bit rate set.
    pub fn new() -> Self {
        SlcanAdapter::default()
    }

    /// The channel state.
    pub fn state(&self) -> ChannelState {
        self.state
    }

    /// The bit rate last set with `S`.
    pub fn bitrate(&self) -> Option<BitRate> {
        self.bitrate
    }

    /// The BTR0/BTR1 pair last set with `s`.
    pub fn btr(&self) -> Option<(u8, u8)> {
        self.btr
    }

    /// Whether received frames carry timestamps (`Z1`).
    pub fn timestamps(&self) -> bool {
        self.timestamps
    }

    /// Lines answered with BEL so far.
    pub fn errors(&self) -> u64 {
        self.errors
    }

    /// ORs bits into the status flags the next `F` reports (Lawicel: bit 0
    /// receive FIFO full, 1 transmit FIFO full, 2 error warning, 3 data
    /// overrun, 5 error passive, 6 arbitration lost, 7 bus error).
    pub fn raise_status(&mut self, flags: u8) {
        self.status_flags |= flags;
    }

    /// Feeds host bytes: appends the answers to `reply` and the frames the
    /// host wants sent to `frames`.
    pub fn receive(&mut self, bytes: &[u8], reply: &mut Vec<u8>, frames: &mut Vec<CanFrame>) {
        for &b in bytes {
            if let Some(decoded) = self.decoder.push(b)
                && let Some(frame) = self.handle(decoded, reply)
            {
                frames.push(frame);
            }
        }
    }

    /// Executes one decoded line: appends its answer to `reply` and returns
    /// the frame to send, if it was an accepted transmit command.
    pub fn handle(&mut self, decoded: Result<Command, DecodeError>, reply: &mut Vec<u8>) -> Option<CanFrame> {
        let closed = self.state == ChannelState::Closed;
        let ok = match decoded {
            Err(_) => false,
            Ok(Command::Transmit(frame)) => {
                if self.state != ChannelState::Open {
                    false
                } else {
                    reply.extend_from_slice(if frame.is_extended_id() { b"Z\r" } else { b"z\r" });
                    return Some(frame);
                }
            }
            Ok(Command::Open) if closed => {
                self.state = ChannelState::Open;
                true
            }
            Ok(Command::ListenOnly) if closed => {
                self.state = ChannelState::ListenOnly;
                true
            }
            Ok(Command::Close) if !closed => {
                self.state = ChannelState::Closed;
                true
            }
            Ok(Command::SetBitRate(rate)) if closed => {
                self.bitrate = Some(rate);
                true
            }
            Ok(Command::SetBtr { btr0, btr1 }) if closed => {
                self.btr = Some((btr0, btr1));
                true
            }
            Ok(Command::Timestamps(on)) if closed => {
                self.timestamps = on;
                true
            }
            Ok(Command::AutoPoll(_) | Command::AcceptanceCode(_) | Command::AcceptanceMask(_)) if closed => true,
            Ok(Command::Version) => {
                reply.extend_from_slice(b"V1013");
                true
            }
            Ok(Command::DetailedVersion) => {
                reply.extend_from_slice(b"v1013");
                true
            }
            Ok(Command::SerialNumber) => {
                reply.extend_from_slice(b"NHOST");
                true
            }
            Ok(Command::StatusFlags) if !closed => {
                reply.push(b'F');
                push_hex(reply, u32::from(std::mem::take(&mut self.status_flags)), 2);
                true
            }
            Ok(_) => false,
        };
        if ok {
            reply.push(CR);
        } else {
            self.errors += 1;
            reply.push(BEL);
        }
        None
    }

    /// The line announcing a received frame to the host, or `None` while the
    /// channel is closed. `now_ms` is used only when timestamps are on.
    pub fn encode_rx(&self, frame: &CanFrame, now_ms: u64) -> Option<Vec<u8>> {
        if self.state == ChannelState::Closed {
            return None;
        }
        let mut out = Vec::with_capacity(MAX_LINE);
        encode_frame(frame, self.timestamps.then_some(now_ms), &mut out);
        Some(out)
    }
}
