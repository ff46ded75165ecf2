//! The Lawicel SLCAN ASCII protocol (CAN232/CANUSB manuals), adapter side,
//! on the host: what this adapter answers its host. The codec (lines to
//! [`Command`]s and frames to lines) and the channel-state rules are the
//! firmware's `no_std` one, [`firmware::slcan`], re-exported here; the QEMU
//! board's adapter uses the same.
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

pub use firmware::slcan::{BEL, CR, ChannelState, Command, DecodeError, Decoder, FRAME_LINE, MAX_LINE, decode, encode, lawicel_bit_rate};

use crate::bus::BitRate;
use canopen_core::frame::CanFrame;
use embedded_can::Frame;

/// The protocol state of one adapter: decodes host bytes, keeps the channel
/// state and produces the answers.
#[derive(Clone, Debug, Default)]
pub struct SlcanAdapter {
    decoder: Decoder,
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
        let Some((command, next)) = decoded.ok().and_then(|c| Some((c, self.state.after(&c)?))) else {
            self.errors += 1;
            reply.push(BEL);
            return None;
        };
        self.state = next;
        match command {
            Command::Transmit(frame) => {
                reply.extend_from_slice(if frame.is_extended() { b"Z\r" } else { b"z\r" });
                return Some(frame);
            }
            Command::SetBitRate(code) => self.bitrate = lawicel_bit_rate(code).and_then(BitRate::new),
            Command::SetBtr { btr0, btr1 } => self.btr = Some((btr0, btr1)),
            Command::Timestamps(on) => self.timestamps = on,
            Command::Version => reply.extend_from_slice(b"V1013"),
            Command::DetailedVersion => reply.extend_from_slice(b"v1013"),
            Command::SerialNumber => reply.extend_from_slice(b"NHOST"),
            Command::StatusFlags => {
                let flags = std::mem::take(&mut self.status_flags);
                reply.push(b'F');
                reply.extend(format!("{flags:02X}").bytes());
            }
            Command::Open | Command::ListenOnly | Command::Close => {}
            Command::AutoPoll(_) | Command::AcceptanceCode(_) | Command::AcceptanceMask(_) => {}
        }
        reply.push(CR);
        None
    }

    /// The line announcing a received frame to the host, or `None` while the
    /// channel is closed. `now_ms` is used only when timestamps are on.
    pub fn encode_rx(&self, frame: &CanFrame, now_ms: u64) -> Option<Vec<u8>> {
        if self.state == ChannelState::Closed {
            return None;
        }
        let mut line = [0u8; FRAME_LINE];
        let n = encode(frame, self.timestamps.then_some((now_ms % 60_000) as u16), &mut line);
        Some(line.get(..n).unwrap_or(&[]).to_vec())
    }
}
