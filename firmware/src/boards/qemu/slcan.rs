//! A no_std SLCAN (Lawicel CAN232/CANUSB ASCII) codec, adapter side: the
//! QEMU board plays a serial CAN adapter whose bus holds the node, so
//! python-can's `slcan` interface can drive it over the emulated UART.
//!
//! Host → adapter lines end with CR (LF accepted, empty lines skipped):
//! `tiiildd…`/`Tiiiiiiiildd…` (data frame), `riiil`/`Riiiiiiiil` (remote
//! frame), `O`, `L`, `C`, `Sn`, `sxxyy`, `V`, `v`, `N`, `F`, `Z0/1`, `X0/1`,
//! `Mxxxxxxxx`, `mxxxxxxxx`. Adapter → host: frames in the same `t/T/r/R`
//! form, answers as [`reply`] gives them, BEL (0x07) for anything malformed.
//! No timestamps are ever added. Bit-rate and filter settings are accepted
//! and ignored: the emulated bus has no bit rate, and the board filters
//! received frames by the node's own identifier list instead.

use canopen_core::frame::CanFrame;
use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// The byte that answers an erroneous or forbidden command.
pub const BEL: u8 = 0x07;
/// The byte that ends every line.
pub const CR: u8 = b'\r';
/// The longest host line (an extended frame with 8 bytes is 26 characters).
pub const MAX_LINE: usize = 32;
/// The longest line [`encode`] writes, CR included.
pub const FRAME_LINE: usize = 27;

/// One host command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `t`, `T`, `r`, `R`: put a frame on the bus.
    Transmit(CanFrame),
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `V`: hardware and software version.
    Version,
    /// `v`: software version.
    DetailedVersion,
    /// `N`: serial number.
    SerialNumber,
    /// `F`: status flags.
    StatusFlags,
    /// `Sn`, `sxxyy`, `Zn`, `Xn`, `M…`, `m…`: a setting that needs a closed
    /// channel and has no effect here.
    Setting,
}

/// A line the adapter refuses (it is answered with [`BEL`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The first character is no command.
    UnknownCommand(u8),
    /// Wrong number of characters for the command.
    BadLength,
    /// A character that should be a hex digit (or a digit in range) is not.
    BadDigit,
    /// An identifier above 0x7FF (`t`, `r`) or 0x1FFF_FFFF (`T`, `R`).
    IdOutOfRange,
    /// The line was longer than [`MAX_LINE`].
    TooLong,
}

fn hex(line: &[u8], start: usize, n: usize) -> Result<u32, DecodeError> {
    let digits = line.get(start..start + n).ok_or(DecodeError::BadLength)?;
    digits.iter().try_fold(0u32, |acc, &c| Ok((acc << 4) | char::from(c).to_digit(16).ok_or(DecodeError::BadDigit)?))
}

fn expect_len(line: &[u8], n: usize) -> Result<(), DecodeError> {
    if line.len() == n { Ok(()) } else { Err(DecodeError::BadLength) }
}

fn decode_frame(line: &[u8], extended: bool, remote: bool) -> Result<CanFrame, DecodeError> {
    let id_len = if extended { 8 } else { 3 };
    let raw = hex(line, 1, id_len)?;
    let dlc = match line.get(1 + id_len) {
        Some(&c @ b'0'..=b'8') => usize::from(c - b'0'),
        Some(_) => return Err(DecodeError::BadDigit),
        None => return Err(DecodeError::BadLength),
    };
    let data_start = 2 + id_len;
    expect_len(line, if remote { data_start } else { data_start + 2 * dlc })?;
    let id: Id = if extended {
        ExtendedId::new(raw).ok_or(DecodeError::IdOutOfRange)?.into()
    } else {
        u16::try_from(raw).ok().and_then(StandardId::new).ok_or(DecodeError::IdOutOfRange)?.into()
    };
    let frame = if remote {
        CanFrame::new_remote(id, dlc)
    } else {
        let mut data = [0u8; 8];
        for (i, byte) in data.iter_mut().take(dlc).enumerate() {
            *byte = hex(line, data_start + 2 * i, 2)? as u8;
        }
        CanFrame::new(id, data.get(..dlc).unwrap_or(&[]))
    };
    frame.ok_or(DecodeError::BadLength)
}

/// Decodes one host line (without its CR); `line` is not empty.
pub fn decode(line: &[u8]) -> Result<Command, DecodeError> {
    let letter = line.first().copied().unwrap_or(0);
    let simple = |cmd| expect_len(line, 1).map(|()| cmd);
    let setting = |n| expect_len(line, n).and_then(|()| hex(line, 1, n - 1)).map(|_| Command::Setting);
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
        b'S' => match setting(2)? {
            _ if hex(line, 1, 1)? > 8 => Err(DecodeError::BadDigit),
            cmd => Ok(cmd),
        },
        b'Z' | b'X' => match setting(2)? {
            _ if hex(line, 1, 1)? > 1 => Err(DecodeError::BadDigit),
            cmd => Ok(cmd),
        },
        b's' => setting(5),
        b'M' | b'm' => setting(9),
        other => Err(DecodeError::UnknownCommand(other)),
    }
}

/// Splits the byte stream from the host into lines and decodes them.
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

    /// Takes one byte; at the end of a non-empty line, returns what it said.
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

/// The channel state and the answers of the adapter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Channel {
    /// Nothing goes to or comes from the bus.
    #[default]
    Closed,
    /// Frames flow both ways.
    Open,
    /// Frames come from the bus; the host may not send.
    ListenOnly,
}

/// What the adapter does with a command: the new channel state and the
/// answer to send (without the frame itself, which the caller forwards when
/// the answer is `z`/`Z`).
pub fn reply(channel: Channel, command: &Command) -> (Channel, &'static [u8]) {
    use Channel::{Closed, ListenOnly, Open};
    match (command, channel) {
        (Command::Transmit(f), Open) => (Open, if f.is_extended() { b"Z\r" } else { b"z\r" }),
        (Command::Open, Closed) => (Open, b"\r"),
        (Command::ListenOnly, Closed) => (ListenOnly, b"\r"),
        (Command::Close, Open | ListenOnly) => (Closed, b"\r"),
        (Command::Version, _) => (channel, b"V1013\r"),
        (Command::DetailedVersion, _) => (channel, b"v1013\r"),
        (Command::SerialNumber, _) => (channel, b"NQEMU\r"),
        (Command::StatusFlags, Open | ListenOnly) => (channel, b"F00\r"),
        (Command::Setting, Closed) => (channel, b"\r"),
        _ => (channel, &[BEL]),
    }
}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

/// Writes `frame` as an adapter → host line (CR included) into `out`;
/// returns its length.
pub fn encode(frame: &CanFrame, out: &mut [u8; FRAME_LINE]) -> usize {
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
    put(b'0' + frame.dlc() as u8);
    for &byte in frame.data() {
        put(nibble(u32::from(byte >> 4)));
        put(nibble(u32::from(byte)));
    }
    put(CR);
    len
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    fn line(frame: &CanFrame) -> std::string::String {
        let mut out = [0u8; FRAME_LINE];
        let n = encode(frame, &mut out);
        std::string::String::from_utf8(out[..n].to_vec()).unwrap()
    }

    fn feed(d: &mut Decoder, s: &str) -> std::vec::Vec<Result<Command, DecodeError>> {
        s.bytes().filter_map(|b| d.push(b)).collect()
    }

    #[test]
    fn frames_round_trip() {
        let frames = [
            CanFrame::standard(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap(),
            CanFrame::standard(0x000, &[0x01, 0x7F]).unwrap(),
            CanFrame::standard(0x7FF, &[]).unwrap(),
            CanFrame::remote(0x77F, 1).unwrap(),
            CanFrame::extended(0x1FFF_FFFF, &[b'E', b'X', b'I', b'T', 0]).unwrap(),
            CanFrame::new_remote(ExtendedId::new(0x1ABC_DEF0).unwrap(), 8).unwrap(),
        ];
        let expected = ["t60584000100000000000\r", "t0002017F\r", "t7FF0\r", "r77F1\r", "T1FFFFFFF54558495400\r", "R1ABCDEF08\r"];
        let mut d = Decoder::default();
        for (f, text) in frames.iter().zip(expected) {
            assert_eq!(line(f), text);
            assert_eq!(feed(&mut d, text), [Ok(Command::Transmit(*f))]);
        }
    }

    #[test]
    fn python_can_start_up_and_shut_down() {
        // What python-can's slcan interface sends for bitrate=500000.
        let mut d = Decoder::default();
        let cmds = feed(&mut d, "C\rS6\r\rO\rt60580001000000000000\rC\r");
        let mut channel = Channel::Closed;
        let answers: std::vec::Vec<&[u8]> = cmds
            .iter()
            .map(|c| {
                let (next, answer) = reply(channel, c.as_ref().unwrap());
                channel = next;
                answer
            })
            .collect();
        assert_eq!(answers, [&[BEL][..], b"\r", b"\r", b"z\r", b"\r"]);
        assert_eq!(channel, Channel::Closed);
    }

    #[test]
    fn garbage_is_refused() {
        let mut d = Decoder::default();
        let bad = "t80000\rt6059\rt60520\rt605211\rT2000000000\rS9\rZ2\rsXX00\rQ\rO1\r";
        let out = feed(&mut d, bad);
        assert_eq!(out.len(), 10);
        assert!(out.iter().all(Result::is_err), "{out:?}");
        let long = "t".repeat(40) + "\r";
        assert_eq!(feed(&mut d, &long), [Err(DecodeError::TooLong)]);
        // The decoder recovers at the next line.
        assert_eq!(feed(&mut d, "O\n"), [Ok(Command::Open)]);
        // Frames need an open channel; settings a closed one.
        let f = Command::Transmit(CanFrame::standard(1, &[]).unwrap());
        assert_eq!(reply(Channel::Closed, &f), (Channel::Closed, &[BEL][..]));
        assert_eq!(reply(Channel::ListenOnly, &f), (Channel::ListenOnly, &[BEL][..]));
        assert_eq!(reply(Channel::Open, &Command::Setting), (Channel::Open, &[BEL][..]));
        assert_eq!(reply(Channel::Open, &Command::Open), (Channel::Open, &[BEL][..]));
    }
}
