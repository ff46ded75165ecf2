//! The Lawicel SLCAN ASCII protocol (CAN232/CANUSB manuals), adapter side:
//! the one codec of the project, `no_std` and without allocation. The QEMU
//! board ([`crate::boards::qemu`]) plays an adapter with it on its UART;
//! hal-host's TCP server plays one per client, and hal-host's client reads
//! an adapter's frame lines with it.
//!
//! Host → adapter, each line ended by CR (LF is accepted too; empty lines are
//! skipped, as python-can sends one after `S6`):
//!
//! | command | meaning | allowed when the channel is |
//! |---|---|---|
//! | `tiiildd…` / `Tiiiiiiiildd…` | send an 11/29-bit data frame | open |
//! | `riiil` / `Riiiiiiiil` | send an 11/29-bit remote frame | open |
//! | `O` / `L` / `C` | open / open listen-only / close the channel | closed / closed / open |
//! | `S0`…`S8` | 10, 20, 50, 100, 125, 250, 500, 800 kbit/s, 1 Mbit/s | closed |
//! | `sxxyy` | BTR0/BTR1 of an SJA1000 | closed |
//! | `V` / `v` / `N` | version, detailed version, serial number | any |
//! | `F` | status flags `Fxx` | open |
//! | `Z0`/`Z1`, `X0`/`X1` | timestamps off/on, auto-poll off/on | closed |
//! | `Mxxxxxxxx` / `mxxxxxxxx` | acceptance code / mask | closed |
//!
//! ("open" includes listen-only except for sending frames.) [`decode`]
//! turns a line into a [`Command`] or a precise [`DecodeError`];
//! [`ChannelState::after`] says whether the channel state allows it. An
//! adapter answers a refused or malformed line with [`BEL`] and anything
//! else with its answer and CR (`z`/`Z` for a frame). Adapter → host,
//! received frames are the same `t`/`T`/`r`/`R` lines ([`encode`]), with a
//! 4-digit millisecond timestamp (0–59999) when `Z1` is on. Nothing here
//! panics on garbage input.

use canopen_core::frame::CanFrame;
use embedded_can::{ExtendedId, Frame, Id, StandardId};

#[cfg(test)]
mod tests;

/// The byte that answers an erroneous or forbidden command.
pub const BEL: u8 = 0x07;
/// The byte that ends every line.
pub const CR: u8 = b'\r';
/// The longest line the decoder buffers (the longest valid one, an extended
/// frame with 8 bytes, is 26 characters).
pub const MAX_LINE: usize = 32;
/// The longest line [`encode`] writes: an extended frame with 8 bytes and a
/// timestamp, CR included.
pub const FRAME_LINE: usize = 31;

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
    /// `S0`..`S8`: a standard bit rate, as Lawicel's code n = 0..8
    /// ([`lawicel_bit_rate`] gives its bit/s).
    SetBitRate(u8),
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
    /// `X0`/`X1`: auto-poll.
    AutoPoll(bool),
    /// `Mxxxxxxxx`: acceptance code.
    AcceptanceCode(u32),
    /// `mxxxxxxxx`: acceptance mask.
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

impl core::error::Error for DecodeError {}

/// The bit rate in bit/s of Lawicel's `Sn` (n = 0..8).
pub const fn lawicel_bit_rate(n: u8) -> Option<u32> {
    match n {
        0 => Some(10_000),
        1 => Some(20_000),
        2 => Some(50_000),
        3 => Some(100_000),
        4 => Some(125_000),
        5 => Some(250_000),
        6 => Some(500_000),
        7 => Some(800_000),
        8 => Some(1_000_000),
        _ => None,
    }
}

/// The value of the hex digit `c` at position `pos` of a line.
fn hex_digit(c: u8, pos: usize) -> Result<u32, DecodeError> {
    char::from(c).to_digit(16).ok_or(DecodeError::BadHex { pos })
}

/// Parses `line[start..start + n]` as hex.
fn hex_field(line: &[u8], start: usize, n: usize) -> Result<u32, DecodeError> {
    let digits = line.get(start..start + n).ok_or(DecodeError::BadHex { pos: line.len() })?;
    let mut value = 0;
    for (i, &c) in digits.iter().enumerate() {
        value = (value << 4) | hex_digit(c, start + i)?;
    }
    Ok(value)
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
        let pairs = line.get(header..).unwrap_or(&[]).chunks_exact(2);
        for (i, (byte, pair)) in data.iter_mut().zip(pairs).enumerate() {
            let &[high, low] = pair else { break };
            let pos = header + 2 * i;
            *byte = ((hex_digit(high, pos)? << 4) | hex_digit(low, pos + 1)?) as u8;
        }
    }
    let id: Id = if extended {
        ExtendedId::new(raw).ok_or(DecodeError::IdOutOfRange(raw))?.into()
    } else {
        u16::try_from(raw).ok().and_then(StandardId::new).ok_or(DecodeError::IdOutOfRange(raw))?.into()
    };
    let frame = if remote { CanFrame::new_remote(id, dlc) } else { CanFrame::new(id, data.get(..dlc).unwrap_or(&[])) };
    // Both constructors accept every dlc ≤ 8, which was checked above.
    frame.ok_or(DecodeError::BadDlc(dlc_char))
}

/// Decodes one host line (without its CR).
// Out of line: inlined into the QEMU board's UART handler it costs more
// flash than the call saves time.
#[inline(never)]
pub fn decode(line: &[u8]) -> Result<Command, DecodeError> {
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
            match c {
                b'0'..=b'8' => Ok(Command::SetBitRate(c - b'0')),
                _ => Err(DecodeError::BadBitRate(c)),
            }
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

/// Splits the byte stream from the host, arriving in pieces of any size,
/// into lines and decodes them.
#[derive(Clone, Debug)]
pub struct Decoder {
    line: [u8; MAX_LINE],
    len: usize,
    overflow: bool,
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder::new()
    }
}

impl Decoder {
    /// A decoder at the start of a line.
    pub const fn new() -> Self {
        Decoder { line: [0; MAX_LINE], len: 0, overflow: false }
    }

    /// Takes one byte; at the end of a non-empty line, returns its decoding
    /// ([`DecodeError::TooLong`] for a line longer than [`MAX_LINE`]).
    pub fn push(&mut self, byte: u8) -> Option<Result<Command, DecodeError>> {
        if byte != CR && byte != b'\n' {
            match self.line.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflow = true,
            }
            return None;
        }
        let line = self.line.get(..self.len).unwrap_or(&[]);
        let result = if self.overflow { Some(Err(DecodeError::TooLong)) } else { (!line.is_empty()).then(|| decode(line)) };
        self.len = 0;
        self.overflow = false;
        result
    }
}

/// The channel state of an adapter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChannelState {
    /// Closed: configuration commands allowed, no frames either way.
    #[default]
    Closed,
    /// Open: frames both ways.
    Open,
    /// Open listen-only: frames to the host only.
    ListenOnly,
}

impl ChannelState {
    /// The state after `command`, or `None` when this state forbids it
    /// (the adapter answers [`BEL`] and stays as it is): frames need an
    /// open channel, `O` and `L` a closed one, `C` and `F` an open or
    /// listen-only one, settings a closed one; `V`, `v` and `N` are always
    /// answered.
    pub fn after(self, command: &Command) -> Option<ChannelState> {
        use ChannelState::{Closed, ListenOnly, Open};
        match (command, self) {
            (Command::Transmit(_), Open) => Some(Open),
            (Command::Open, Closed) => Some(Open),
            (Command::ListenOnly, Closed) => Some(ListenOnly),
            (Command::Close, Open | ListenOnly) => Some(Closed),
            (Command::Version | Command::DetailedVersion | Command::SerialNumber, _) => Some(self),
            (Command::StatusFlags, Open | ListenOnly) => Some(self),
            (
                Command::SetBitRate(_)
                | Command::SetBtr { .. }
                | Command::Timestamps(_)
                | Command::AutoPoll(_)
                | Command::AcceptanceCode(_)
                | Command::AcceptanceMask(_),
                Closed,
            ) => Some(Closed),
            _ => None,
        }
    }
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

/// Writes `frame` as an adapter → host line into `out`, with `timestamp_ms`
/// (taken modulo 60000, as 4 hex digits) when `Z1` is on, then CR; returns
/// its length.
pub fn encode(frame: &CanFrame, timestamp_ms: Option<u16>, out: &mut [u8; FRAME_LINE]) -> usize {
    let (letter, digits) = match (frame.is_extended(), frame.is_remote_frame()) {
        (false, false) => (b't', 3),
        (true, false) => (b'T', 8),
        (false, true) => (b'r', 3),
        (true, true) => (b'R', 8),
    };
    let mut len = 0;
    let mut put = |byte: u8| {
        if let Some(slot) = out.get_mut(len) {
            *slot = byte;
            len += 1;
        }
    };
    let nibble = |n: u32| HEX.get(n as usize & 0xF).copied().unwrap_or(b'0');
    put(letter);
    let raw = frame.raw_id();
    for i in (0..digits).rev() {
        put(nibble(raw >> (4 * i)));
    }
    // A `CanFrame`'s DLC is at most 8.
    put(b'0' + frame.dlc() as u8);
    for &byte in frame.data() {
        put(nibble(u32::from(byte >> 4)));
        put(nibble(u32::from(byte)));
    }
    if let Some(ms) = timestamp_ms {
        let ms = u32::from(ms % 60_000);
        for i in (0..4).rev() {
            put(nibble(ms >> (4 * i)));
        }
    }
    put(CR);
    len
}
