//! SLCAN tests: exact strings both ways and every malformed case (the TCP
//! server's are in `server_tests.rs`).

use super::*;

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn dec(line: &str) -> Result<Command, DecodeError> {
    decode_command(line.as_bytes())
}

fn tx(f: CanFrame) -> Result<Command, DecodeError> {
    Ok(Command::Transmit(f))
}

fn len(expected: usize, got: usize) -> Result<Command, DecodeError> {
    Err(DecodeError::BadLength { expected, got })
}

#[test]
fn decodes_frames() {
    assert_eq!(dec("t60184000100000000000"), tx(std(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0])));
    assert_eq!(dec("t0000"), tx(std(0, &[])));
    assert_eq!(dec("t7ff2abCD"), tx(std(0x7FF, &[0xAB, 0xCD])), "either case");
    assert_eq!(dec("T1ABCDEF02AABB"), tx(CanFrame::extended(0x1ABC_DEF0, &[0xAA, 0xBB]).unwrap()));
    assert_eq!(dec("T1FFFFFFF0"), tx(CanFrame::extended(0x1FFF_FFFF, &[]).unwrap()));
    assert_eq!(dec("r7011"), tx(CanFrame::remote(0x701, 1).unwrap()));
    let ext_rtr = embedded_can::Frame::new_remote(ExtendedId::new(0x1234_5678).unwrap(), 8).unwrap();
    assert_eq!(dec("R123456788"), tx(ext_rtr));
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
    assert_eq!(dec("T200000000"), Err(DecodeError::IdOutOfRange(0x2000_0000)));
    assert_eq!(dec("TFFFFFFFF0"), Err(DecodeError::IdOutOfRange(0xFFFF_FFFF)));
    assert_eq!(dec("T1234567"), len(10, 8));
    assert_eq!(dec("T1234567x0"), Err(DecodeError::BadHex { pos: 8 }));
    assert_eq!(dec("T0000000082"), len(26, 11));
    assert_eq!(dec("r7011AA"), len(5, 7), "a remote frame carries no data");
    assert_eq!(dec("r70190"), Err(DecodeError::BadDlc(b'9')));
    assert_eq!(dec("R1234"), len(10, 5));
    assert_eq!(dec("R200000001"), Err(DecodeError::IdOutOfRange(0x2000_0000)));
    assert_eq!(decode_command(b"t\xff\xfe\x800"), Err(DecodeError::BadHex { pos: 1 }));
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
            Ok(Command::SetBitRate(r)) => r.bps(),
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
    assert_eq!(decode_command(&[0xFF]), Err(DecodeError::UnknownCommand(0xFF)));
    assert_eq!(DecodeError::BadLength { expected: 5, got: 1 }.to_string(), "1 characters, expected 5");
}

#[test]
fn stream_decoder_takes_any_chunking() {
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
    // Byte by byte, in one piece, and in odd chunks: the same lines.
    let mut one = StreamDecoder::new();
    assert_eq!(one.push_all(input), expected);
    let mut bytewise = StreamDecoder::new();
    let got: Vec<_> = input.iter().filter_map(|&b| bytewise.push(b)).collect();
    assert_eq!(got, expected);
    let mut chunked = StreamDecoder::new();
    let got: Vec<_> = input.chunks(3).flat_map(|c| chunked.push_all(c)).collect();
    assert_eq!(got, expected);
    let mut frames = StreamDecoder::new();
    let got: Vec<_> = [&b"t60"[..], b"18400010", b"0000000000\r"].iter().flat_map(|c| frames.push_all(c)).collect();
    assert_eq!(got, [tx(std(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]))]);
}

#[test]
fn stream_decoder_survives_overlong_lines() {
    let mut d = StreamDecoder::new();
    let mut input = vec![b'a'; 1_000];
    input.extend_from_slice(b"\rO\r");
    assert_eq!(d.push_all(&input), [Err(DecodeError::TooLong), Ok(Command::Open)]);
    // Exactly MAX_LINE characters still fit.
    let mut line = vec![b'Q'; MAX_LINE];
    line.push(CR);
    assert_eq!(d.push_all(&line), [Err(DecodeError::UnknownCommand(b'Q'))]);
}

#[test]
fn encodes_received_frames() {
    let enc = |f: &CanFrame, ts: Option<u64>| {
        let mut v = Vec::new();
        encode_frame(f, ts, &mut v);
        String::from_utf8(v).unwrap()
    };
    assert_eq!(enc(&std(0x581, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]), None), "t58184300100092010200\r");
    assert_eq!(enc(&std(0x080, &[]), None), "t0800\r");
    assert_eq!(enc(&CanFrame::extended(0x1ABC_DEF0, &[0xAA, 0xBB]).unwrap(), None), "T1ABCDEF02AABB\r");
    assert_eq!(enc(&CanFrame::remote(0x701, 1).unwrap(), None), "r7011\r");
    let ext_rtr = embedded_can::Frame::new_remote(ExtendedId::MAX, 8).unwrap();
    assert_eq!(enc(&ext_rtr, None), "R1FFFFFFF8\r");
    assert_eq!(enc(&std(0x001, &[0xFF]), Some(61_234)), "t0011FF04D2\r", "1234 ms after the wrap at 60000");
    assert_eq!(enc(&std(0x001, &[]), Some(59_999)), "t0010EA5F\r");
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
