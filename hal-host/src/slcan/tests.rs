//! The host adapter's tests: its answers and state (the codec's own are in
//! `firmware::slcan`, the TCP server's in `server_tests.rs`).

use super::*;

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

/// Runs `input` through an adapter; returns its replies as a string.
fn run(adapter: &mut SlcanAdapter, input: &str, frames: &mut Vec<CanFrame>) -> String {
    let mut reply = Vec::new();
    adapter.receive(input.as_bytes(), &mut reply, frames);
    String::from_utf8(reply).unwrap()
}

#[test]
fn adapter_follows_the_channel_state() {
    let mut a = SlcanAdapter::new();
    let mut frames = Vec::new();
    // python-can's start-up: C, S6, an empty line, O.
    assert_eq!(run(&mut a, "C\rS6\r\rO\r", &mut frames), "\x07\r\r");
    assert_eq!((a.state(), a.bitrate()), (ChannelState::Open, Some(BitRate::KBIT_500)));
    assert_eq!(run(&mut a, "O\rL\rS4\rs031C\rZ1\rX1\rM00000000\rm00000000\r", &mut frames), "\x07".repeat(8));
    assert_eq!(a.bitrate(), Some(BitRate::KBIT_500), "S refused while open");
    assert_eq!(run(&mut a, "t6011AA\rT000000010\rr7010\rR000000020\r", &mut frames), "z\rZ\rz\rZ\r");
    assert_eq!(frames.len(), 4);
    assert_eq!(frames.first(), Some(&std(0x601, &[0xAA])));
    assert_eq!(run(&mut a, "t6011A\rV\rv\rN\rF\r", &mut frames), "\x07V1013\rv1013\rNHOST\rF00\r");
    a.raise_status(0x08);
    a.raise_status(0x80);
    assert_eq!(run(&mut a, "F\rF\r", &mut frames), "F88\rF00\r");
    assert_eq!(a.encode_rx(&std(0x181, &[1]), 5), Some(b"t181101\r".to_vec()));
    assert_eq!(run(&mut a, "C\rC\rF\rt0010\r", &mut frames), "\r\x07\x07\x07");
    assert_eq!(a.encode_rx(&std(0x181, &[1]), 5), None, "a closed channel shows nothing");
    assert_eq!(run(&mut a, "Z1\rs031C\rX0\rM00000000\rm00000000\rL\r", &mut frames), "\r\r\r\r\r\r");
    assert_eq!((a.timestamps(), a.btr(), a.state()), (true, Some((0x03, 0x1C)), ChannelState::ListenOnly));
    assert_eq!(run(&mut a, "t0010\r", &mut frames), "\x07", "listen-only sends nothing");
    assert_eq!(a.encode_rx(&std(0x181, &[1]), 60_005), Some(b"t1811010005\r".to_vec()));
    assert_eq!(frames.len(), 4);
    assert_eq!(a.errors(), 1 + 8 + 1 + 3 + 1);
}

#[test]
fn adapter_answers_every_garbage_line_exactly_once() {
    // A deterministic pseudo-random byte soup: one answer per non-empty line,
    // each a CR-terminated line or a single BEL, and no panic.
    let mut state: u32 = 0x1234_5678;
    let mut input = Vec::new();
    for _ in 0..20_000 {
        state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        let b = (state >> 16) as u8;
        input.push(match b % 8 {
            0 => CR,
            1 => b"tTrRSsOCLZXMmFVvN"[usize::from(b) % 17],
            2 | 3 => b"0123456789abcdefABCDEF"[usize::from(b) % 22],
            _ => b,
        });
    }
    input.push(CR);
    let lines = input.split(|&b| b == CR || b == b'\n').filter(|l| !l.is_empty()).count();
    let mut a = SlcanAdapter::new();
    let (mut reply, mut frames) = (Vec::new(), Vec::new());
    for chunk in input.chunks(7) {
        a.receive(chunk, &mut reply, &mut frames);
    }
    let answers = reply.iter().filter(|&&b| b == CR || b == BEL).count();
    assert_eq!(answers, lines);
}
