//! Tests of the master. SDO transfers run against a scripted server with
//! the exact frames of CiA 301 §7.2.4.3 (values from the CCT cases where
//! they apply), then against the core's SDO server over the virtual bus.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use super::nmt::{self, NmtCommand};
use super::*;
use crate::bus::BitRate;
use canopen_core::abort::AbortCode;

mod driver;

const NODE: u8 = 5;

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

/// One step of a scripted exchange: a frame the client must send (`C`) or
/// one the scripted server sends (`S`).
enum Step {
    C([u8; 8]),
    S([u8; 8]),
}
use Step::{C, S};

/// Plays `steps` against `t`: the client must send exactly the `C` frames,
/// in order, before each `S` frame arrives (1 ms after the previous one),
/// and nothing after the last step.
fn play(t: &mut SdoTransfer, steps: &[Step]) {
    let mut now = Instant::ZERO;
    for (i, step) in steps.iter().enumerate() {
        match step {
            C(want) => assert_eq!(t.pop_tx().map(|f| format!("{f:02X?}")), Some(format!("{want:02X?}")), "step {i}"),
            S(frame) => {
                assert_eq!(t.pop_tx(), None, "step {i}: the client sent more than the script expects");
                now += Duration::from_millis(1);
                t.on_frame(now, frame);
            }
        }
    }
    assert_eq!(t.pop_tx(), None, "the client sent more than the script expects");
}

fn upload(mode: UploadMode, index: u16, sub: u8) -> SdoTransfer {
    SdoClient::new(NODE).upload(Instant::ZERO, index, sub, mode)
}

fn download(mode: DownloadMode, index: u16, sub: u8, data: &[u8]) -> SdoTransfer {
    SdoClient::new(NODE).download(Instant::ZERO, index, sub, data, mode)
}

/// Segment `k` of `data` (7 bytes, zero-padded) behind byte 0 `b0`.
fn seg(b0: u8, data: &[u8], k: usize) -> [u8; 8] {
    let mut f = [b0, 0, 0, 0, 0, 0, 0, 0];
    for (i, b) in data.iter().skip(7 * k).take(7).enumerate() {
        f[1 + i] = *b;
    }
    f
}

fn abort(index: u16, sub: u8, code: u32) -> [u8; 8] {
    let [i0, i1] = index.to_le_bytes();
    let [c0, c1, c2, c3] = code.to_le_bytes();
    [0x80, i0, i1, sub, c0, c1, c2, c3]
}

const BLOCK_UP: UploadMode = UploadMode::Block { blksize: 4, pst: 0, crc: true };

fn cmd(b0: u8) -> [u8; 8] {
    [b0, 0, 0, 0, 0, 0, 0, 0]
}

// === NMT ===

#[test]
fn nmt_command_frames() {
    // CiA 301 §7.2.8.3.1: "01 05" starts node 5, "82 00" resets communication of all.
    assert_eq!(nmt::command(NmtCommand::Start, 5), [0x01, 0x05]);
    assert_eq!(nmt::broadcast(NmtCommand::ResetCommunication), [0x82, 0x00]);
    assert_eq!(nmt::command(NmtCommand::Stop, 0x7F), [0x02, 0x7F]);
    assert_eq!(nmt::broadcast(NmtCommand::EnterPreOperational), [0x80, 0]);
    assert_eq!(nmt::command(NmtCommand::ResetNode, 1), [0x81, 1]);
    let mut bus = Bus::new(BitRate::KBIT_500);
    let (master, node) = (bus.attach(), bus.attach());
    nmt::send(&mut bus, master, NmtCommand::Start, nmt::ALL_NODES).unwrap();
    bus.run_until(ms(1));
    let (_, f) = bus.recv(node).unwrap();
    assert_eq!((f.cob_id(), f.data()), (Some(0x000), &[0x01, 0x00][..]));
    assert!(matches!(send(&mut bus, master, 0x800, &[]), Err(SendError::InvalidFrame { cob_id: 0x800, len: 0 })));
}

// === SDO: expedited and segmented ===

#[test]
fn expedited_upload() {
    // CCT 2.1: read the device type 0x1000 = 0x00020192.
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1000, 0);
    play(&mut t, &[C([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), S([0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])]);
    assert_eq!(t.into_result(), Some(Ok(vec![0x92, 0x01, 0x02, 0x00])));
    // n = 2: two bytes; s = 0: all four, size unspecified.
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1017, 0);
    play(&mut t, &[C([0x40, 0x17, 0x10, 0, 0, 0, 0, 0]), S([0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0xAA, 0xAA])]);
    assert_eq!(t.into_result(), Some(Ok(vec![0xE8, 0x03])));
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1017, 0);
    play(&mut t, &[C([0x40, 0x17, 0x10, 0, 0, 0, 0, 0]), S([0x42, 0x17, 0x10, 0x00, 1, 2, 3, 4])]);
    assert_eq!(t.into_result(), Some(Ok(vec![1, 2, 3, 4])));
}

#[test]
fn expedited_download() {
    // CCT 2.15: heartbeat 0x1017 = 1000 ms.
    let mut t = download(DownloadMode::Auto, 0x1017, 0, &1000u16.to_le_bytes());
    play(&mut t, &[C([0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0]), S([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0])]);
    assert_eq!(t.into_result(), Some(Ok(vec![])));
    let mut t = download(DownloadMode::Expedited, 0x2000, 1, &[9]);
    play(&mut t, &[C([0x2F, 0x00, 0x20, 0x01, 9, 0, 0, 0]), S([0x60, 0x00, 0x20, 0x01, 0, 0, 0, 0])]);
    assert!(t.is_done());
}

#[test]
fn segmented_upload_with_toggle() {
    let name = b"CANopen Device";
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1008, 0);
    play(
        &mut t,
        &[
            C([0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
            S([0x41, 0x08, 0x10, 0x00, 14, 0, 0, 0]),
            C(cmd(0x60)),
            S(seg(0x00, name, 0)),
            C(cmd(0x70)),
            // t = 1, n = 0, c = 1.
            S(seg(0x11, name, 1)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(name.to_vec())));
}

#[test]
fn segmented_download_with_toggle() {
    let mut t = download(DownloadMode::Auto, 0x2000, 0, b"123456789");
    play(
        &mut t,
        &[
            C([0x21, 0x00, 0x20, 0x00, 9, 0, 0, 0]),
            S([0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
            C(seg(0x00, b"1234567", 0)),
            S(cmd(0x20)),
            // t = 1, n = 5, c = 1.
            C(seg(0x1B, b"89", 0)),
            S(cmd(0x30)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(vec![])));
    // An empty value is one empty last segment.
    let mut t = download(DownloadMode::Segmented, 0x2000, 0, &[]);
    play(&mut t, &[C([0x21, 0x00, 0x20, 0x00, 0, 0, 0, 0]), S([0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]), C(cmd(0x0F)), S(cmd(0x20))]);
    assert_eq!(t.into_result(), Some(Ok(vec![])));
}

/// Plays `steps`, then feeds `bad`: the client must answer with `abort`
/// and end with `error`.
fn expect_abort(mut t: SdoTransfer, steps: &[Step], bad: &[u8], abort: [u8; 8], error: SdoClientError) {
    play(&mut t, steps);
    t.on_frame(ms(100), bad);
    assert_eq!(t.pop_tx(), Some(abort));
    assert_eq!(t.pop_tx(), None);
    assert_eq!(t.into_result(), Some(Err(error)));
}

const READ_1008: [u8; 8] = [0x40, 0x08, 0x10, 0, 0, 0, 0, 0];

#[test]
fn wrong_toggle_size_or_multiplexer_is_aborted() {
    let segmented = || upload(UploadMode::ExpeditedOrSegmented, 0x1008, 0);
    let p = |e| SdoClientError::Protocol(e);
    let start = [C(READ_1008), S([0x41, 0x08, 0x10, 0, 14, 0, 0, 0]), C(cmd(0x60))];
    expect_abort(segmented(), &start, &seg(0x10, b"CANopen", 0), abort(0x1008, 0, 0x0503_0000), p(ProtocolError::Toggle));
    let start = [C(READ_1008), S([0x41, 0x08, 0x10, 0, 8, 0, 0, 0]), C(cmd(0x60))];
    let mismatch = ProtocolError::SizeMismatch { indicated: 8, received: 7 };
    expect_abort(segmented(), &start, &seg(0x01, b"CANopen", 0), abort(0x1008, 0, 0x0607_0010), p(mismatch));
    let wrong = ProtocolError::WrongMultiplexer { index: 0x1009, sub: 0 };
    expect_abort(segmented(), &[C(READ_1008)], &[0x4F, 0x09, 0x10, 0, 1, 0, 0, 0], abort(0x1008, 0, 0x0604_0043), p(wrong));
    // A download confirmation where an upload response belongs; a short frame.
    let unexpected = ProtocolError::UnexpectedCommand(0x60);
    expect_abort(segmented(), &[C(READ_1008)], &[0x60, 0x08, 0x10, 0, 0, 0, 0, 0], abort(0x1008, 0, 0x0504_0001), p(unexpected));
    expect_abort(segmented(), &[C(READ_1008)], &[0x43, 0x08, 0x10, 0], abort(0x1008, 0, 0x0504_0001), p(ProtocolError::Malformed(4)));
    // A segmented download confirmed with the wrong toggle.
    let t = download(DownloadMode::Segmented, 0x2000, 0, b"12345678");
    let start = [C([0x21, 0x00, 0x20, 0x00, 8, 0, 0, 0]), S([0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]), C(seg(0x00, b"1234567", 0))];
    expect_abort(t, &start, &cmd(0x30), abort(0x2000, 0, 0x0503_0000), p(ProtocolError::Toggle));
}

#[test]
fn server_abort_is_reported_with_its_code() {
    // CCT 2.3-style: 0x1000 written, the server answers 0x06010002 (read only).
    let mut t = download(DownloadMode::Auto, 0x1000, 0, &[1, 2, 3, 4]);
    play(&mut t, &[C([0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4]), S([0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06])]);
    let e = t.into_result().unwrap().unwrap_err();
    assert_eq!(e, SdoClientError::ServerAbort { index: 0x1000, sub: 0, code: 0x0601_0002 });
    assert_eq!(e.abort_code(), Some(AbortCode::ReadOnly));
    // A code CiA 301 does not define is kept raw.
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1008, 0);
    play(&mut t, &[C(READ_1008), S(abort(0x1008, 0, 0x1234_5678))]);
    let e = t.into_result().unwrap().unwrap_err();
    assert_eq!((e, e.abort_code()), (SdoClientError::ServerAbort { index: 0x1008, sub: 0, code: 0x1234_5678 }, None));
}

#[test]
fn timeout_sends_abort_at_the_deadline() {
    let mut t = upload(UploadMode::ExpeditedOrSegmented, 0x1000, 0);
    assert_eq!(t.pop_tx(), Some([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!(t.process(ms(999)), Some(ms(1000)));
    assert_eq!(t.pop_tx(), None);
    // A tx-complete note restarts the wait.
    t.on_sent(ms(500));
    assert_eq!(t.process(ms(1000)), Some(ms(1500)));
    assert_eq!(t.process(ms(1500)), None);
    assert_eq!(t.pop_tx(), Some(abort(0x1000, 0, 0x0504_0000)));
    assert_eq!(t.process(ms(5000)), None);
    // Late frames change nothing.
    t.on_frame(ms(1600), &[0x43, 0x00, 0x10, 0x00, 1, 2, 3, 4]);
    assert_eq!(t.pop_tx(), None);
    let e = t.into_result().unwrap().unwrap_err();
    assert_eq!((e, e.abort_code()), (SdoClientError::Timeout, Some(AbortCode::Timeout)));
}

#[test]
fn invalid_requests_send_nothing() {
    for (t, e) in [
        (download(DownloadMode::Expedited, 0x2000, 0, &[1, 2, 3, 4, 5]), RequestError::ExpeditedLength(5)),
        (download(DownloadMode::Expedited, 0x2000, 0, &[]), RequestError::ExpeditedLength(0)),
        (upload(UploadMode::Block { blksize: 0, pst: 0, crc: true }, 0x2000, 0), RequestError::BlockSize(0)),
        (upload(UploadMode::Block { blksize: 128, pst: 0, crc: true }, 0x2000, 0), RequestError::BlockSize(128)),
    ] {
        let mut t = t;
        assert!(t.is_done());
        assert_eq!((t.pop_tx(), t.process(ms(0))), (None, None));
        assert_eq!(t.into_result(), Some(Err(SdoClientError::InvalidRequest(e))));
    }
}

// === SDO block upload ===

/// 30 bytes: five segments, the last with 5 unused bytes; CRC 0x1F11
/// (python: `binascii.crc_hqx(bytes(range(30)), 0)`).
fn value30() -> Vec<u8> {
    (0..30).collect()
}

const INIT_UP: [u8; 8] = [0xA4, 0x00, 0x20, 0x00, 4, 0, 0, 0];
const INIT_UP_ANSWER: [u8; 8] = [0xC6, 0x00, 0x20, 0x00, 30, 0, 0, 0];
const END_UP_30: [u8; 8] = [0xD5, 0x11, 0x1F, 0, 0, 0, 0, 0];

#[test]
fn block_upload_two_sub_blocks_with_crc() {
    let v = value30();
    let mut t = upload(BLOCK_UP, 0x2000, 0);
    play(
        &mut t,
        &[
            C(INIT_UP),
            S(INIT_UP_ANSWER),
            C(cmd(0xA3)),
            S(seg(0x01, &v, 0)),
            S(seg(0x02, &v, 1)),
            S(seg(0x03, &v, 2)),
            S(seg(0x04, &v, 3)),
            C([0xA2, 4, 4, 0, 0, 0, 0, 0]),
            S(seg(0x81, &v, 4)),
            C([0xA2, 1, 4, 0, 0, 0, 0, 0]),
            S(END_UP_30),
            C(cmd(0xA1)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(v)));
}

#[test]
fn block_upload_lost_segment_is_acknowledged_short_and_sent_again() {
    let v = value30();
    let mut t = upload(BLOCK_UP, 0x2000, 0);
    play(
        &mut t,
        &[
            C(INIT_UP),
            S(INIT_UP_ANSWER),
            C(cmd(0xA3)),
            S(seg(0x01, &v, 0)),
            S(seg(0x02, &v, 1)),
            // Segment 3 is lost: segment 4 ends the sub-block, ackseq 2.
            S(seg(0x04, &v, 3)),
            C([0xA2, 2, 4, 0, 0, 0, 0, 0]),
            S(seg(0x01, &v, 2)),
            S(seg(0x02, &v, 3)),
            S(seg(0x83, &v, 4)),
            C([0xA2, 3, 4, 0, 0, 0, 0, 0]),
            S(END_UP_30),
            C(cmd(0xA1)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(v)));
}

#[test]
fn block_upload_crc_mismatch_is_aborted() {
    let v = value30();
    let steps = [
        C(INIT_UP),
        S(INIT_UP_ANSWER),
        C(cmd(0xA3)),
        S(seg(0x01, &v, 0)),
        S(seg(0x02, &v, 1)),
        S(seg(0x03, &v, 2)),
        S(seg(0x04, &v, 3)),
        C([0xA2, 4, 4, 0, 0, 0, 0, 0]),
        S(seg(0x81, &v, 4)),
        C([0xA2, 1, 4, 0, 0, 0, 0, 0]),
    ];
    let crc = ProtocolError::Crc { received: 0x1F12, computed: 0x1F11 };
    let p = SdoClientError::Protocol;
    expect_abort(upload(BLOCK_UP, 0x2000, 0), &steps, &[0xD5, 0x12, 0x1F, 0, 0, 0, 0, 0], abort(0x2000, 0, 0x0504_0004), p(crc));
    // Without CRC on both sides the field is not checked, but the size is.
    let no_crc = UploadMode::Block { blksize: 4, pst: 0, crc: false };
    let mut steps = steps;
    steps[0] = C([0xA0, 0x00, 0x20, 0x00, 4, 0, 0, 0]);
    let mut t = upload(no_crc, 0x2000, 0);
    play(&mut t, &steps);
    t.on_frame(ms(50), &[0xD5, 0xFF, 0xFF, 0, 0, 0, 0, 0]);
    assert_eq!(t.pop_tx(), Some(cmd(0xA1)));
    assert_eq!(t.into_result(), Some(Ok(v)));
    let mismatch = ProtocolError::SizeMismatch { indicated: 30, received: 29 };
    expect_abort(upload(no_crc, 0x2000, 0), &steps, &[0xD9, 0, 0, 0, 0, 0, 0, 0], abort(0x2000, 0, 0x0607_0010), p(mismatch));
}

#[test]
fn block_upload_bad_sequence_and_server_abort() {
    let v = value30();
    let start = [C(INIT_UP), S(INIT_UP_ANSWER), C(cmd(0xA3))];
    let p = SdoClientError::Protocol;
    expect_abort(upload(BLOCK_UP, 0x2000, 0), &start, &seg(0x05, &v, 0), abort(0x2000, 0, 0x0504_0003), p(ProtocolError::Sequence(5)));
    expect_abort(upload(BLOCK_UP, 0x2000, 0), &start, &seg(0x00, &v, 0), abort(0x2000, 0, 0x0504_0003), p(ProtocolError::Sequence(0)));
    // 0x80 in the sub-block phase is the server's abort, not a segment.
    let mut t = upload(BLOCK_UP, 0x2000, 0);
    play(&mut t, &[C(INIT_UP), S(INIT_UP_ANSWER), C(cmd(0xA3)), S(seg(0x01, &v, 0)), S(abort(0x2000, 0, 0x0800_0000))]);
    assert_eq!(t.into_result(), Some(Err(SdoClientError::ServerAbort { index: 0x2000, sub: 0, code: 0x0800_0000 })));
}

#[test]
fn block_upload_protocol_switch_below_pst() {
    // pst 10: the server may answer a 3-byte value with an expedited upload.
    let mode = UploadMode::Block { blksize: 127, pst: 10, crc: true };
    let mut t = upload(mode, 0x1018, 1);
    play(&mut t, &[C([0xA4, 0x18, 0x10, 0x01, 127, 10, 0, 0]), S([0x47, 0x18, 0x10, 0x01, 1, 2, 3, 0])]);
    assert_eq!(t.into_result(), Some(Ok(vec![1, 2, 3])));
    // ... or a segmented one.
    let mut t = upload(mode, 0x1008, 0);
    let switch = [C([0xA4, 0x08, 0x10, 0x00, 127, 10, 0, 0]), S([0x41, 0x08, 0x10, 0, 9, 0, 0, 0]), C(cmd(0x60))];
    play(&mut t, &switch);
    play(&mut t, &[S(seg(0x00, b"123456789", 0)), C(cmd(0x70)), S(seg(0x1B, b"89", 0))]);
    assert_eq!(t.into_result(), Some(Ok(b"123456789".to_vec())));
}

// === SDO block download ===

/// 20 bytes: three segments, the last with 1 unused byte; CRC 0xACCC
/// (python: `binascii.crc_hqx(bytes(range(20)), 0)`).
fn value20() -> Vec<u8> {
    (0..20).collect()
}

const INIT_DOWN: [u8; 8] = [0xC6, 0x00, 0x20, 0x00, 20, 0, 0, 0];
const END_DOWN_20: [u8; 8] = [0xC5, 0xCC, 0xAC, 0, 0, 0, 0, 0];

#[test]
fn block_download_with_crc() {
    let v = value20();
    let mut t = download(DownloadMode::Block { crc: true }, 0x2000, 0, &v);
    play(
        &mut t,
        &[
            C(INIT_DOWN),
            S([0xA4, 0x00, 0x20, 0x00, 127, 0, 0, 0]),
            C(seg(0x01, &v, 0)),
            C(seg(0x02, &v, 1)),
            C(seg(0x83, &v, 2)),
            S([0xA2, 3, 127, 0, 0, 0, 0, 0]),
            C(END_DOWN_20),
            S(cmd(0xA1)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(vec![])));
    // An empty value: one segment of 7 unused bytes, CRC 0; no CRC when the server has none.
    let mut t = download(DownloadMode::Block { crc: true }, 0x2000, 0, &[]);
    play(
        &mut t,
        &[
            C([0xC6, 0x00, 0x20, 0x00, 0, 0, 0, 0]),
            S([0xA0, 0x00, 0x20, 0x00, 127, 0, 0, 0]),
            C(cmd(0x81)),
            S([0xA2, 1, 127, 0, 0, 0, 0, 0]),
            C(cmd(0xDD)),
            S(cmd(0xA1)),
        ],
    );
    assert!(t.into_result().unwrap().is_ok());
}

#[test]
fn block_download_lost_segment_is_sent_again() {
    let v = value20();
    let mut t = download(DownloadMode::Block { crc: true }, 0x2000, 0, &v);
    play(
        &mut t,
        &[
            C(INIT_DOWN),
            S([0xA4, 0x00, 0x20, 0x00, 2, 0, 0, 0]),
            C(seg(0x01, &v, 0)),
            C(seg(0x02, &v, 1)),
            // Segment 2 never arrived: the rest goes again, renumbered from 1.
            S([0xA2, 1, 2, 0, 0, 0, 0, 0]),
            C(seg(0x01, &v, 1)),
            C(seg(0x82, &v, 2)),
            S([0xA2, 2, 2, 0, 0, 0, 0, 0]),
            C(END_DOWN_20),
            S(cmd(0xA1)),
        ],
    );
    assert_eq!(t.into_result(), Some(Ok(vec![])));
}

#[test]
fn block_download_crc_abort_and_bad_block_sizes() {
    let v = value20();
    let mode = DownloadMode::Block { crc: true };
    let sub_block =
        [C(INIT_DOWN), S([0xA4, 0x00, 0x20, 0x00, 127, 0, 0, 0]), C(seg(0x01, &v, 0)), C(seg(0x02, &v, 1)), C(seg(0x83, &v, 2))];
    // The server finds a CRC error and aborts.
    let mut t = download(mode, 0x2000, 0, &v);
    play(&mut t, &sub_block);
    t.on_frame(ms(10), &[0xA2, 3, 127, 0, 0, 0, 0, 0]);
    assert_eq!(t.pop_tx(), Some(END_DOWN_20));
    t.on_frame(ms(11), &abort(0x2000, 0, 0x0504_0004));
    let e = t.into_result().unwrap().unwrap_err();
    assert_eq!(e.abort_code(), Some(AbortCode::CrcError));
    // blksize 0 from the server; ackseq beyond the sub-block; blksize 128 for the next one.
    let p = SdoClientError::Protocol;
    let bad_blksize = [0xA4, 0x00, 0x20, 0x00, 0, 0, 0, 0];
    expect_abort(
        download(mode, 0x2000, 0, &v),
        &[C(INIT_DOWN)],
        &bad_blksize,
        abort(0x2000, 0, 0x0504_0002),
        p(ProtocolError::BlockSize(0)),
    );
    let ack4 = [0xA2, 4, 127, 0, 0, 0, 0, 0];
    expect_abort(download(mode, 0x2000, 0, &v), &sub_block, &ack4, abort(0x2000, 0, 0x0504_0003), p(ProtocolError::Sequence(4)));
    let ack1 = [0xA2, 1, 128, 0, 0, 0, 0, 0];
    expect_abort(download(mode, 0x2000, 0, &v), &sub_block, &ack1, abort(0x2000, 0, 0x0504_0002), p(ProtocolError::BlockSize(128)));
}

// === Robustness ===

#[test]
fn random_frames_in_every_state_never_panic() {
    let mut seed = 0x1234_5678_9ABC_DEF0u64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    // Byte 0 values that move the transfers on, so that later states are reached too.
    const COMMANDS: [u8; 14] = [0x43, 0x41, 0x60, 0x20, 0x30, 0x00, 0x11, 0xC6, 0xA4, 0xA2, 0xA1, 0x81, 0x01, 0x80];
    for round in 0..3000u64 {
        let mut t = match round % 6 {
            0 => upload(UploadMode::ExpeditedOrSegmented, 0x2000, 0),
            1 => upload(BLOCK_UP, 0x2000, 0),
            2 => download(DownloadMode::Auto, 0x2000, 0, &[1, 2]),
            3 => download(DownloadMode::Segmented, 0x2000, 0, &value20()),
            4 => download(DownloadMode::Block { crc: true }, 0x2000, 0, &value30()),
            _ => upload(UploadMode::Block { blksize: 1, pst: 4, crc: false }, 0x2000, 0),
        };
        for step in 0..40 {
            let r = rand();
            let mut f = rand().to_le_bytes().to_vec();
            f.truncate(if r & 0x7 == 0 { (r >> 3) as usize % 9 } else { 8 });
            if f.len() == 8 && r & 0x100 != 0 {
                f[0] = COMMANDS[(r >> 16) as usize % COMMANDS.len()];
                f[1..4].copy_from_slice(&[0x00, 0x20, 0x00]);
            }
            t.on_frame(ms(step), &f);
            while t.pop_tx().is_some() {}
            assert_eq!(t.process(ms(step)).is_none(), t.is_done());
        }
        assert_eq!(t.result().is_some(), t.is_done());
        assert_eq!(t.process(ms(10_000)), None);
        assert!(t.into_result().is_some());
    }
}
