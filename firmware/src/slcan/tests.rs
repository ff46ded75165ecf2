//! The codec's tests: exact strings both ways, every malformed case, the
//! line splitter under any chunking and the channel-state rules. The
//! adapters' answers are tested where they are made (the QEMU board's
//! `boards::qemu::slcan`, hal-host's `slcan`).

extern crate std;

use super::*;
use std::string::String;
use std::vec::Vec;
use std::{format, vec};

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn dec(line: &str) -> Result<Command, DecodeError> {
    decode(line.as_bytes())
}

fn tx(f: CanFrame) -> Result<Command, DecodeError> {
    Ok(Command::Transmit(f))
}

fn len(expected: usize, got: usize) -> Result<Command, DecodeError> {
    Err(DecodeError::BadLength { expected, got })
}

fn push_all(d: &mut Decoder, bytes: &[u8]) -> Vec<Result<Command, DecodeError>> {
    bytes.iter().filter_map(|&b| d.push(b)).collect()
}

fn line(frame: &CanFrame, timestamp_ms: Option<u16>) -> String {
    let mut out = [0u8; FRAME_LINE];
    let n = encode(frame, timestamp_ms, &mut out);
    String::from_utf8(out[..n].to_vec()).unwrap()
}

#[test]
fn decodes_frames() {
    assert_eq!(dec("t60184000100000000000"), tx(std(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0])));
    assert_eq!(dec("t0000"), tx(std(0, &[])));
    assert_eq!(dec("t7ff2abCD"), tx(std(0x7FF, &[0xAB, 0xCD])), "either case");
    assert_eq!(dec("T1ABCDEF02AABB"), tx(CanFrame::extended(0x1ABC_DEF0, &[0xAA, 0xBB]).unwrap()));
    assert_eq!(dec("T1FFFFFFF0"), tx(CanFrame::extended(0x1FFF_FFFF, &[]).unwrap()));
    assert_eq!(dec("r7011"), tx(CanFrame::remote(0x701, 1).unwrap()));
    let ext_rtr = Frame::new_remote(ExtendedId::new(0x1234_5678).unwrap(), 8).unwrap();
    assert_eq!(dec("R123456788"), tx(ext_rtr));
}

#[test]
fn frames_round_trip() {
    let frames = [
        std(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]),
        std(0x000, &[0x01, 0x7F]),
        std(0x7FF, &[]),
        CanFrame::remote(0x77F, 1).unwrap(),
        CanFrame::extended(0x1FFF_FFFF, &[b'E', b'X', b'I', b'T', 0]).unwrap(),
        CanFrame::new_remote(ExtendedId::new(0x1ABC_DEF0).unwrap(), 8).unwrap(),
    ];
    let expected = ["t60584000100000000000\r", "t0002017F\r", "t7FF0\r", "r77F1\r", "T1FFFFFFF54558495400\r", "R1ABCDEF08\r"];
    let mut d = Decoder::default();
    for (f, text) in frames.iter().zip(expected) {
        assert_eq!(line(f, None), text);
        assert_eq!(push_all(&mut d, text.as_bytes()), [Ok(Command::Transmit(*f))]);
    }
}

#[test]
fn rejects_every_malformed_frame() {
    assert_eq!(dec(""), Err(DecodeError::Empty));
    assert_eq!(dec("t"), len(5, 1));
    assert_eq!(dec("t60"), len(5, 3));
    assert_eq!(dec("t601"), len(5, 4));
    assert_eq!(dec("tG010"), Err(DecodeError::BadHex { pos: 1 }));
    assert_eq!(dec("t6 10"), Err(DecodeError::BadHex { pos: 2 }));
    assert_eq!(dec("t800000"), Err(DecodeError::BadLength { expected: 5, got: 7 }));
    assert_eq!(dec("t8000"), Err(DecodeError::IdOutOfRange(0x800)));
    assert_eq!(dec("tFFF0"), Err(DecodeError::IdOutOfRange(0xFFF)));
    assert_eq!(dec("t6019"), Err(DecodeError::BadDlc(b'9')));
    assert_eq!(dec("t601A"), Err(DecodeError::BadDlc(b'A')), "no CAN FD lengths");
    assert_eq!(dec("t601-"), Err(DecodeError::BadDlc(b'-')));
    assert_eq!(dec("t6012AA"), len(9, 7));
    assert_eq!(dec("t6011AAB"), len(7, 8));
    assert_eq!(dec("t6011AG"), Err(DecodeError::BadHex { pos: 6 }));
    assert_eq!(dec("t6011+1"), Err(DecodeError::BadHex { pos: 5 }));
    assert_eq!(dec("t60520"), len(9, 6));
    assert_eq!(dec("t605211"), len(9, 7));
    assert_eq!(dec("T200000000"), Err(DecodeError::IdOutOfRange(0x2000_0000)));
    assert_eq!(dec("TFFFFFFFF0"), Err(DecodeError::IdOutOfRange(0xFFFF_FFFF)));
    assert_eq!(dec("T1234567"), len(10, 8));
    assert_eq!(dec("T1234567x0"), Err(DecodeError::BadHex { pos: 8 }));
    assert_eq!(dec("T0000000082"), len(26, 11));
    assert_eq!(dec("r7011AA"), len(5, 7), "a remote frame carries no data");
    assert_eq!(dec("r70190"), Err(DecodeError::BadDlc(b'9')));
    assert_eq!(dec("R1234"), len(10, 5));
    assert_eq!(dec("R200000001"), Err(DecodeError::IdOutOfRange(0x2000_0000)));
    assert_eq!(decode(b"t\xff\xfe\x800"), Err(DecodeError::BadHex { pos: 1 }));
}

#[test]
fn decodes_and_rejects_commands() {
    assert_eq!(dec("O"), Ok(Command::Open));
    assert_eq!(dec("L"), Ok(Command::ListenOnly));
    assert_eq!(dec("C"), Ok(Command::Close));
    assert_eq!(dec("V"), Ok(Command::Version));
    assert_eq!(dec("v"), Ok(Command::DetailedVersion));
    assert_eq!(dec("N"), Ok(Command::SerialNumber));
    assert_eq!(dec("F"), Ok(Command::StatusFlags));
    assert_eq!(dec("O1"), len(1, 2));
    assert_eq!(dec("Vx"), len(1, 2));
    let rates: Vec<u32> = (0..=8)
        .map(|n| match dec(&format!("S{n}")) {
            Ok(Command::SetBitRate(code)) => lawicel_bit_rate(code).unwrap_or(0),
            _ => 0,
        })
        .collect();
    assert_eq!(rates, [10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000]);
    assert_eq!(dec("S9"), Err(DecodeError::BadBitRate(b'9')));
    assert_eq!(dec("Sx"), Err(DecodeError::BadBitRate(b'x')));
    assert_eq!(dec("S"), len(2, 1));
    assert_eq!(dec("S10"), len(2, 3));
    assert_eq!(dec("s031C"), Ok(Command::SetBtr { btr0: 0x03, btr1: 0x1C }));
    assert_eq!(dec("s03"), len(5, 3));
    assert_eq!(dec("s031G"), Err(DecodeError::BadHex { pos: 4 }));
    assert_eq!(dec("sXX00"), Err(DecodeError::BadHex { pos: 1 }));
    assert_eq!(dec("Z1"), Ok(Command::Timestamps(true)));
    assert_eq!(dec("Z0"), Ok(Command::Timestamps(false)));
    assert_eq!(dec("Z2"), Err(DecodeError::BadFlag(b'2')));
    assert_eq!(dec("Z"), len(2, 1));
    assert_eq!(dec("X1"), Ok(Command::AutoPoll(true)));
    assert_eq!(dec("X"), len(2, 1));
    assert_eq!(dec("M00000000"), Ok(Command::AcceptanceCode(0)));
    assert_eq!(dec("mFFFFFFFF"), Ok(Command::AcceptanceMask(0xFFFF_FFFF)));
    assert_eq!(dec("M0"), len(9, 2));
    assert_eq!(dec("m0000000Z"), Err(DecodeError::BadHex { pos: 8 }));
    assert_eq!(dec("Q"), Err(DecodeError::UnknownCommand(b'Q')));
    assert_eq!(dec("Y2"), Err(DecodeError::UnknownCommand(b'Y')), "no CAN FD");
    assert_eq!(decode(&[0xFF]), Err(DecodeError::UnknownCommand(0xFF)));
    assert_eq!(format!("{}", DecodeError::BadLength { expected: 5, got: 1 }), "1 characters, expected 5");
}

#[test]
fn decoder_takes_any_chunking() {
    // LF ends a line too, so the frame is cut short; its rest is a line of
    // its own; empty lines are skipped.
    let input = b"O\rt601840001000000\n00000\r\r\nC\rQQ\r";
    let expected = vec![
        Ok(Command::Open),
        len(21, 16),
        Err(DecodeError::UnknownCommand(b'0')),
        Ok(Command::Close),
        Err(DecodeError::UnknownCommand(b'Q')),
    ];
    // In one piece and in odd chunks: the same lines.
    let mut one = Decoder::new();
    assert_eq!(push_all(&mut one, input), expected);
    let mut chunked = Decoder::new();
    let got: Vec<_> = input.chunks(3).flat_map(|c| push_all(&mut chunked, c)).collect();
    assert_eq!(got, expected);
    let mut frames = Decoder::new();
    let got: Vec<_> = [&b"t60"[..], b"18400010", b"0000000000\r"].iter().flat_map(|c| push_all(&mut frames, c)).collect();
    assert_eq!(got, [tx(std(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]))]);
}

#[test]
fn decoder_survives_overlong_lines() {
    let mut d = Decoder::new();
    let mut input = vec![b'a'; 1_000];
    input.extend_from_slice(b"\rO\r");
    assert_eq!(push_all(&mut d, &input), [Err(DecodeError::TooLong), Ok(Command::Open)]);
    // Exactly MAX_LINE characters still fit.
    let mut line = vec![b'Q'; MAX_LINE];
    line.push(CR);
    assert_eq!(push_all(&mut d, &line), [Err(DecodeError::UnknownCommand(b'Q'))]);
    // One more does not; the decoder recovers at the next line.
    let long = "t".repeat(MAX_LINE + 1) + "\r";
    assert_eq!(push_all(&mut d, long.as_bytes()), [Err(DecodeError::TooLong)]);
    assert_eq!(push_all(&mut d, b"O\n"), [Ok(Command::Open)]);
}

#[test]
fn encodes_received_frames() {
    assert_eq!(line(&std(0x581, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]), None), "t58184300100092010200\r");
    assert_eq!(line(&std(0x080, &[]), None), "t0800\r");
    assert_eq!(line(&CanFrame::extended(0x1ABC_DEF0, &[0xAA, 0xBB]).unwrap(), None), "T1ABCDEF02AABB\r");
    assert_eq!(line(&CanFrame::remote(0x701, 1).unwrap(), None), "r7011\r");
    let ext_rtr = Frame::new_remote(ExtendedId::MAX, 8).unwrap();
    assert_eq!(line(&ext_rtr, None), "R1FFFFFFF8\r");
    assert_eq!(line(&std(0x001, &[0xFF]), Some(61_234)), "t0011FF04D2\r", "1234 ms after the wrap at 60000");
    assert_eq!(line(&std(0x001, &[]), Some(59_999)), "t0010EA5F\r");
    // The longest line fills the buffer exactly.
    let longest = line(&CanFrame::extended(0x1FFF_FFFF, &[0xFF; 8]).unwrap(), Some(0));
    assert_eq!((longest.as_str(), longest.len()), ("T1FFFFFFF8FFFFFFFFFFFFFFFF0000\r", FRAME_LINE));
}

#[test]
fn the_channel_state_allows_each_command_where_lawicel_does() {
    use ChannelState::{Closed, ListenOnly, Open};
    let frame = Command::Transmit(std(1, &[]));
    let settings = [
        Command::SetBitRate(6),
        Command::SetBtr { btr0: 3, btr1: 0x1C },
        Command::Timestamps(true),
        Command::AutoPoll(false),
        Command::AcceptanceCode(0),
        Command::AcceptanceMask(0),
    ];
    // Frames need an open channel.
    assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&frame)), [None, Some(Open), None]);
    // Opening needs a closed one, closing an open one.
    assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&Command::Open)), [Some(Open), None, None]);
    assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&Command::ListenOnly)), [Some(ListenOnly), None, None]);
    assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&Command::Close)), [None, Some(Closed), Some(Closed)]);
    // Settings need a closed channel; the flags an open one.
    for s in &settings {
        assert_eq!([Closed, Open, ListenOnly].map(|c| c.after(s)), [Some(Closed), None, None], "{s:?}");
    }
    assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&Command::StatusFlags)), [None, Some(Open), Some(ListenOnly)]);
    // Version and serial number always.
    for c in [Command::Version, Command::DetailedVersion, Command::SerialNumber] {
        assert_eq!([Closed, Open, ListenOnly].map(|s| s.after(&c)), [Some(Closed), Some(Open), Some(ListenOnly)]);
    }
}
