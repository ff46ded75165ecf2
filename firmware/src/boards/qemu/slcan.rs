//! The QEMU board's SLCAN adapter: what it answers to each host command
//! (the codec, and the channel-state rules, are [`crate::slcan`]). The
//! board plays a serial CAN adapter whose bus holds the node, so
//! python-can's `slcan` interface can drive it over the emulated UART.
//!
//! No timestamps are ever added, and the status flags are always clear.
//! Bit-rate, timestamp and filter settings are accepted and ignored: the
//! emulated bus has no bit rate, and the board filters received frames by
//! the node's own identifier list instead.

use crate::slcan::{BEL, ChannelState, Command};
use embedded_can::Frame;

/// What the adapter does with a command: the new channel state and the
/// answer to send (without the frame itself, which the caller forwards when
/// the answer is `z`/`Z`).
pub fn reply(channel: ChannelState, command: &Command) -> (ChannelState, &'static [u8]) {
    let Some(next) = channel.after(command) else { return (channel, &[BEL]) };
    let answer: &'static [u8] = match command {
        Command::Transmit(f) if f.is_extended() => b"Z\r",
        Command::Transmit(_) => b"z\r",
        Command::Version => b"V1013\r",
        Command::DetailedVersion => b"v1013\r",
        Command::SerialNumber => b"NQEMU\r",
        Command::StatusFlags => b"F00\r",
        _ => b"\r",
    };
    (next, answer)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::slcan::Decoder;
    use canopen_core::frame::CanFrame;

    #[test]
    fn python_can_start_up_and_shut_down() {
        // What python-can's slcan interface sends for bitrate=500000.
        let mut d = Decoder::default();
        let cmds: std::vec::Vec<_> = b"C\rS6\r\rO\rt60580001000000000000\rC\r".iter().filter_map(|&b| d.push(b)).collect();
        let mut channel = ChannelState::Closed;
        let answers: std::vec::Vec<&[u8]> = cmds
            .iter()
            .map(|c| {
                let (next, answer) = reply(channel, c.as_ref().unwrap());
                channel = next;
                answer
            })
            .collect();
        assert_eq!(answers, [&[BEL][..], b"\r", b"\r", b"z\r", b"\r"]);
        assert_eq!(channel, ChannelState::Closed);
    }

    #[test]
    fn answers_follow_the_channel_state() {
        use ChannelState::{Closed, ListenOnly, Open};
        // Frames need an open channel; settings a closed one.
        let f = Command::Transmit(CanFrame::standard(1, &[]).unwrap());
        let ext = Command::Transmit(CanFrame::extended(1, &[]).unwrap());
        assert_eq!(reply(Closed, &f), (Closed, &[BEL][..]));
        assert_eq!(reply(ListenOnly, &f), (ListenOnly, &[BEL][..]));
        assert_eq!(reply(Open, &ext), (Open, &b"Z\r"[..]));
        assert_eq!(reply(Open, &Command::SetBitRate(6)), (Open, &[BEL][..]));
        assert_eq!(reply(Closed, &Command::Timestamps(true)), (Closed, &b"\r"[..]));
        assert_eq!(reply(Open, &Command::Open), (Open, &[BEL][..]));
        assert_eq!(reply(Closed, &Command::StatusFlags), (Closed, &[BEL][..]));
        assert_eq!(reply(ListenOnly, &Command::StatusFlags), (ListenOnly, &b"F00\r"[..]));
        assert_eq!(reply(Closed, &Command::SerialNumber), (Closed, &b"NQEMU\r"[..]));
        assert_eq!(reply(ListenOnly, &Command::Close), (Closed, &b"\r"[..]));
    }
}
