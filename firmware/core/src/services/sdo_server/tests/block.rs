//! Block download and upload (CiA 301 §7.2.4.3.9–16).

use super::*;

// ---------------------------------------------------------------------------
// Block download
// ---------------------------------------------------------------------------

/// Sends `data` as segments seqno 1.., c = 1 on the last, checking that
/// nothing comes back before the last one.
#[track_caller]
fn rx_sub_block<const N: usize>(t: &mut Test<N>, at: At, data: &[u8], last: bool) {
    let count = data.chunks(7).count();
    for (i, chunk) in data.chunks(7).enumerate() {
        let c = last && i + 1 == count;
        t.rx_bytes(at, &frame((i as u8 + 1) | if c { 0x80 } else { 0 }, chunk));
        if i + 1 < count {
            t.none();
        }
    }
}

fn end_frame(b0: u8, crc: u16) -> [u8; 8] {
    frame(b0, &crc.to_le_bytes())
}

#[test]
fn block_download_of_120_bytes_with_crc() {
    let mut t = Sdo::new();
    let text = long(b'a');
    let crc = reference_crc(&text);
    assert_eq!(crc, 0xD547); // python: binascii.crc_hqx(text, 0)
    t.x(ms(0), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00"); // cc, s, 120 bytes // sc, blksize 19 = ⌈128 / 7⌉
    rx_sub_block(&mut t, ms(1), &text, true);
    t.tx("A2 12 01 00 00 00 00 00"); // ackseq 18; 2 bytes of room left: blksize 1
    t.rx_bytes(ms(2), &end_frame(0xD9, crc)); // n = 6
    t.tx("A1 00 00 00 00 00 00 00");
    t.done(ms(2));
    assert_eq!(t.value(0x2010, 0), text);
}

#[test]
fn block_download_of_two_bytes_with_and_without_crc() {
    let mut t = Sdo::new();
    // CCT 2.25: with CRC.
    t.x(ms(0), "C6 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(1), "81 D0 07 00 00 00 00 00", "A2 01 12 00 00 00 00 00"); // 121 bytes of room: blksize 18
    t.x(ms(2), "D5 C0 65 00 00 00 00 00", "A1 00 00 00 00 00 00 00"); // n = 5, CRC 0x65C0
    assert_eq!(t.value(0x1017, 0), [0xD0, 0x07]);
    // CCT 2.21: without CRC the CRC field is not checked.
    t.x(ms(3), "C2 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(4), "81 E8 03 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(5), "D5 12 34 00 00 00 00 00", "A1 00 00 00 00 00 00 00");
    t.done(ms(5));
    assert_eq!(t.value(0x1017, 0), [0xE8, 0x03]);
}

#[test]
fn block_download_without_a_size_and_end_requests_out_of_turn() {
    let mut t = Sdo::new();
    // cc = 1, s = 0: no size indicated (bytes 4-7 are not one), CRC on.
    t.x(ms(0), "C4 17 10 00 FF FF FF FF", "A4 17 10 00 13 00 00 00");
    t.x(ms(1), "81 B8 0B 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    // CRC-16 of B8 0B, n = 5.
    let crc = reference_crc(&[0xB8, 0x0B]);
    t.rx_bytes(ms(2), &end_frame(0xD5, crc));
    t.tx("A1 00 00 00 00 00 00 00");
    assert_eq!(t.value(0x1017, 0), [0xB8, 0x0B]);
    // cc = 0, s = 0: no CRC, so the end request's CRC field is not checked.
    t.x(ms(3), "C0 17 10 00 00 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(4), "81 A0 0F 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(5), "D5 00 00 00 00 00 00 00", "A1 00 00 00 00 00 00 00");
    assert_eq!(t.value(0x1017, 0), [0xA0, 0x0F]);
    // An end request with no transfer: abort 0x05040001 for no object.
    t.x(ms(6), "C1 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05");
    // During a sub-block it is a segment (seqno 0x41 > blksize): abort 0x05040003.
    t.x(ms(7), "C4 17 10 00 00 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(8), "C1 00 00 00 00 00 00 00", "80 17 10 00 03 00 04 05");
    t.done(ms(8));
}

#[test]
fn block_download_with_a_lost_segment_is_resent_from_ackseq() {
    let mut t = Sdo::new();
    let text = long(b'a');
    t.x(ms(0), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00");
    // Segment 4 is lost; 5..18 are ignored, and 18 (c = 1) ends the block.
    for (i, chunk) in text.chunks(7).enumerate().filter(|(i, _)| *i != 3) {
        t.rx_bytes(ms(1), &frame((i as u8 + 1) | if i == 17 { 0x80 } else { 0 }, chunk));
    }
    t.tx("A2 03 10 00 00 00 00 00"); // ackseq 3; 107 bytes of room: blksize 16
    t.none();
    // The client starts the next block with the segment after ackseq.
    rx_sub_block(&mut t, ms(2), &text[21..], true);
    t.tx("A2 0F 01 00 00 00 00 00");
    t.rx_bytes(ms(3), &end_frame(0xD9, reference_crc(&text)));
    t.tx("A1 00 00 00 00 00 00 00");
    t.done(ms(3));
    assert_eq!(t.value(0x2010, 0), text);
}

/// After a missing segment nothing of the block is taken, not even the
/// segment that was missing nor a repeat; seqno = blksize still ends the
/// block with the last ackseq in order, and the next block starts clean.
#[test]
fn block_download_ignores_the_rest_of_a_block_after_a_gap() {
    let mut t = Sdo::new();
    let text = long(b'a');
    let seg = |seqno: u8, i: usize| frame(seqno, &text[i * 7..i * 7 + 7]);
    t.x(ms(0), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00"); // blksize 19
    for (seqno, i) in [(1, 0), (2, 1), (4, 3), (3, 2), (2, 1), (5, 4)] {
        t.rx_bytes(ms(1), &seg(seqno, i));
        t.none();
    }
    // Segment 19 = blksize: ackseq 2; 14 bytes taken, 119 of room: blksize 17.
    t.rx_bytes(ms(1), &frame(19, &[0; 7]));
    t.tx("A2 02 11 00 00 00 00 00");
    t.none();
    rx_sub_block(&mut t, ms(2), &text[14..], true);
    t.tx("A2 10 01 00 00 00 00 00"); // 16 segments; 7 bytes of room: blksize 1
    t.rx_bytes(ms(3), &end_frame(0xD9, reference_crc(&text)));
    t.tx("A1 00 00 00 00 00 00 00");
    t.done(ms(3));
    assert_eq!(t.value(0x2010, 0), text);
}

#[test]
fn block_download_block_ending_at_blksize_and_overflowing_at_the_end() {
    let mut t = Test::<14>::new();
    t.x(ms(0), "C0 10 20 00 00 00 00 00", "A4 10 20 00 02 00 00 00"); // no CRC, no size
    t.rx(ms(1), "01 61 62 63 64 65 66 67");
    t.none();
    t.x(ms(1), "02 68 69 6A 6B 6C 6D 6E", "A2 02 01 00 00 00 00 00"); // seqno = blksize ends the block
    t.x(ms(2), "81 6F 00 00 00 00 00 00", "A2 01 01 00 00 00 00 00");
    t.x(ms(3), "D9 00 00 00 00 00 00 00", "80 10 20 00 05 00 04 05"); // 15 bytes > 14
    t.done(ms(3));
}

#[test]
fn block_download_errors() {
    let mut t = Sdo::new();
    // Bad CRC.
    t.x(ms(0), "C6 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(1), "81 D0 07 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(2), "D5 C1 65 00 00 00 00 00", "80 17 10 00 04 00 04 05");
    // More data than indicated (good CRC of 3 bytes).
    t.x(ms(3), "C6 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(4), "81 D0 07 05 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(5), "D1 A6 AC 00 00 00 00 00", "80 17 10 00 12 00 07 06");
    // A full segment beyond the indicated size.
    t.x(ms(6), "C6 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(7), "01 D0 07 05 00 00 00 00", "80 17 10 00 12 00 07 06");
    // Sequence numbers 0 and > blksize.
    for bad in ["00", "14", "7F"] {
        t.x(ms(8), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00");
        t.rx(ms(9), &format!("{bad} 61 62 63 64 65 66 67"));
        t.tx("80 10 20 00 03 00 04 05");
    }
    // The value is refused when it is written.
    t.x(ms(10), "C2 00 20 00 02 00 00 00", "A4 00 20 00 13 00 00 00");
    t.x(ms(11), "81 65 00 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(12), "D5 00 00 00 00 00 00 00", "80 00 20 00 31 00 09 06");
    // Something other than the end request after the last segment.
    t.x(ms(13), "C2 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.x(ms(14), "81 D0 07 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.x(ms(15), "A3 00 00 00 00 00 00 00", "80 17 10 00 01 00 04 05");
    t.done(ms(15));
    assert_eq!(t.image, DEFAULTS);
}

#[test]
fn block_download_abort_from_the_client_ends_it_silently() {
    let mut t = Sdo::new();
    t.x(ms(0), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00");
    t.rx(ms(1), "01 61 62 63 64 65 66 67");
    t.rx(ms(2), "80 10 20 00 00 00 04 05");
    t.done(ms(2));
    // A late segment now finds no transfer.
    t.x(ms(3), "02 68 69 6A 6B 6C 6D 6E", "80 00 00 00 01 00 04 05");
    t.done(ms(3));
    assert_eq!(t.image, DEFAULTS);
}

// ---------------------------------------------------------------------------
// Block upload
// ---------------------------------------------------------------------------

/// Expects `data` as segments seqno 1.., c = 1 on the last if `last`.
#[track_caller]
fn tx_sub_block<const N: usize>(t: &mut Test<N>, data: &[u8], last: bool) {
    let count = data.chunks(7).count();
    for (i, chunk) in data.chunks(7).enumerate() {
        let c = last && i + 1 == count;
        t.tx_bytes(&frame((i as u8 + 1) | if c { 0x80 } else { 0 }, chunk));
    }
    t.none();
}

#[test]
fn block_upload_of_120_bytes_with_crc() {
    // CCT 2.22/2.23.
    let mut t = Sdo::new();
    let crc = reference_crc(&LONG);
    assert_eq!(crc, 0xB4DC); // python: binascii.crc_hqx(LONG, 0)
    t.x(ms(0), "A4 10 20 00 7F 00 00 00", "C6 10 20 00 78 00 00 00"); // cc, blksize 127, pst 0
    t.rx(ms(1), "A3 00 00 00 00 00 00 00");
    t.none();
    assert_eq!(t.poll(ms(1)), Some(ms(1001)));
    tx_sub_block(&mut t, &LONG, true);
    t.rx(ms(2), "A2 12 7F 00 00 00 00 00");
    t.tx_bytes(&end_frame(0xD9, crc)); // n = 6
    t.rx(ms(3), "A1 00 00 00 00 00 00 00");
    t.done(ms(3));
}

#[test]
fn block_upload_of_an_empty_string() {
    // An empty VISIBLE_STRING (size 0): the sub-block is one segment, seqno
    // 1 with c = 1 and no data, and the end says its 7 bytes hold none
    // (n = 7), with the CRC of nothing (0x0000).
    let mut t = Sdo::new();
    t.image[22] = 0;
    t.x(ms(0), "A4 10 20 00 7F 00 00 00", "C6 10 20 00 00 00 00 00"); // cc, s, 0 bytes
    t.rx(ms(1), "A3 00 00 00 00 00 00 00");
    assert_eq!(t.poll(ms(1)), Some(ms(1001)));
    t.tx("81 00 00 00 00 00 00 00");
    t.none();
    t.rx(ms(2), "A2 01 7F 00 00 00 00 00");
    t.tx("DD 00 00 00 00 00 00 00");
    t.rx(ms(3), "A1 00 00 00 00 00 00 00");
    t.done(ms(3));
}

/// A value of a whole number of segments (14 bytes): the end request says
/// n = 0, also when the last block is confirmed in two acks (ackseq 0, then
/// 1) and with and without a CRC.
#[test]
fn block_upload_of_whole_segments_ends_with_n_0() {
    let mut t = Sdo::new();
    t.image[22 + 14] = 0; // 0x2010 is now 14 bytes long
    let crc = reference_crc(&LONG[..14]);
    // blksize 1: one segment a block.
    t.x(ms(0), "A4 10 20 00 01 00 00 00", "C6 10 20 00 0E 00 00 00");
    t.rx(ms(1), "A3 00 00 00 00 00 00 00");
    t.poll(ms(1));
    tx_sub_block(&mut t, &LONG[..7], false);
    t.rx(ms(2), "A2 01 01 00 00 00 00 00");
    t.poll(ms(2));
    tx_sub_block(&mut t, &LONG[7..14], true);
    // ackseq 0: the last segment again, its CRC counted once.
    t.rx(ms(3), "A2 00 01 00 00 00 00 00");
    t.poll(ms(3));
    tx_sub_block(&mut t, &LONG[7..14], true);
    t.x(ms(4), "A2 01 7F 00 00 00 00 00", &format!("C1 {:02X} {:02X} 00 00 00 00 00", crc as u8, crc >> 8));
    t.rx(ms(5), "A1 00 00 00 00 00 00 00");
    t.done(ms(5));
    // Without a CRC: both segments in one block, CRC bytes 0.
    t.x(ms(6), "A0 10 20 00 7F 00 00 00", "C6 10 20 00 0E 00 00 00");
    t.rx(ms(7), "A3 00 00 00 00 00 00 00");
    t.poll(ms(7));
    tx_sub_block(&mut t, &LONG[..14], true);
    t.x(ms(8), "A2 02 7F 00 00 00 00 00", "C1 00 00 00 00 00 00 00");
    t.rx(ms(9), "A1 00 00 00 00 00 00 00");
    t.done(ms(9));
}

#[test]
fn block_upload_resends_from_the_client_ackseq() {
    let mut t = Sdo::new();
    t.x(ms(0), "A4 10 20 00 05 00 00 00", "C6 10 20 00 78 00 00 00"); // blksize 5
    t.rx(ms(1), "A3 00 00 00 00 00 00 00");
    t.poll(ms(1));
    tx_sub_block(&mut t, &LONG[..35], false);
    t.rx(ms(2), "A2 05 05 00 00 00 00 00");
    t.poll(ms(2));
    tx_sub_block(&mut t, &LONG[35..70], false);
    // Segment 4 of the second block was lost: the client confirms 3 and asks for 4 per block.
    t.rx(ms(3), "A2 03 04 00 00 00 00 00");
    t.none();
    t.poll(ms(3));
    tx_sub_block(&mut t, &LONG[56..84], false);
    t.rx(ms(4), "A2 04 7F 00 00 00 00 00");
    t.poll(ms(4));
    tx_sub_block(&mut t, &LONG[84..], true);
    t.rx(ms(5), "A2 06 7F 00 00 00 00 00");
    t.tx_bytes(&end_frame(0xD9, reference_crc(&LONG)));
    t.rx(ms(6), "A1 00 00 00 00 00 00 00");
    t.done(ms(6));
}

#[test]
fn block_upload_without_crc_and_paced_by_the_tx_queue() {
    let mut t = Sdo::new();
    // CCT 2.19: 0x1000 without CRC; the end frame carries CRC 0.
    t.x(ms(0), "A0 00 10 00 7F 00 00 00", "C6 00 10 00 04 00 00 00");
    t.rx(ms(1), "A3 00 00 00 00 00 00 00");
    t.poll(ms(1));
    t.tx("81 92 01 02 00 00 00 00");
    t.x(ms(2), "A2 01 7F 00 00 00 00 00", "CD 00 00 00 00 00 00 00"); // n = 3
    t.rx(ms(3), "A1 00 00 00 00 00 00 00");
    t.done(ms(3));
    // 120 bytes through a queue with room for 3 frames at a time.
    t.x(ms(4), "A0 10 20 00 7F 00 00 00", "C6 10 20 00 78 00 00 00");
    t.rx(ms(5), "A3 00 00 00 00 00 00 00");
    let mut sent = Vec::new();
    for step in 0..5 {
        t.bus.room = 3;
        assert_eq!(t.poll(ms(6 + step)), Some(ms(6 + step)), "segments still waiting");
        sent.extend(t.bus.frames.drain(..));
    }
    t.bus.room = 0;
    assert_eq!(t.poll(ms(11)), Some(ms(11)));
    t.bus.room = usize::MAX;
    assert_eq!(t.poll(ms(11)), Some(ms(1011)), "waiting for the ack, timed from the last segment");
    sent.extend(t.bus.frames.drain(..));
    let want: Vec<[u8; 8]> = LONG.chunks(7).enumerate().map(|(i, c)| frame((i as u8 + 1) | if i == 17 { 0x80 } else { 0 }, c)).collect();
    assert_eq!(sent, want);
    t.x(ms(13), "A2 12 7F 00 00 00 00 00", "D9 00 00 00 00 00 00 00");
    t.rx(ms(14), "A1 00 00 00 00 00 00 00");
    t.done(ms(14));
}

/// At the protocol switch the server reads the small value itself (a plain
/// initiate upload has it from the look-up): a refused read aborts with its
/// code, nothing else is sent and the server is idle.
#[test]
fn a_read_refused_at_the_protocol_switch_aborts_with_its_code() {
    let mut t = Sdo::new();
    t.read_error = Some(AbortCode::Hardware);
    t.x(ms(0), "A4 17 10 00 7F 04 00 00", "80 17 10 00 00 00 06 06"); // 2 bytes <= pst 4
    t.done(ms(1));
}

#[test]
fn block_upload_switches_protocol_at_or_below_pst() {
    let mut t = Sdo::new();
    t.x(ms(0), "A4 17 10 00 7F 04 00 00", "4B 17 10 00 E8 03 00 00"); // 2 bytes <= pst 4: expedited
    t.x(ms(1), "A4 11 20 00 7F 0A 00 00", "41 11 20 00 0A 00 00 00"); // 10 bytes <= pst 10: segmented
    t.x(ms(2), "60 00 00 00 00 00 00 00", "00 00 01 02 03 04 05 06");
    t.x(ms(3), "70 00 00 00 00 00 00 00", "19 07 08 09 00 00 00 00");
    t.x(ms(4), "A4 11 20 00 7F 09 00 00", "C6 11 20 00 0A 00 00 00"); // 10 bytes > pst 9: block
    t.rx(ms(5), "A3 00 00 00 00 00 00 00");
    t.poll(ms(5));
    tx_sub_block(&mut t, &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9], true);
    t.x(ms(6), "A2 02 7F 00 00 00 00 00", "D1 78 23 00 00 00 00 00"); // n = 4, CRC 0x2378
    t.rx(ms(7), "A1 00 00 00 00 00 00 00");
    t.done(ms(7));
    // pst 0 (no switch) and pst 1 (below 2 bytes): a 2-byte value goes by block, not expedited.
    let crc = reference_crc(&[0xE8, 0x03]);
    for pst in ["00", "01"] {
        t.x(ms(8), &format!("A4 17 10 00 7F {pst} 00 00"), "C6 17 10 00 02 00 00 00");
        t.rx(ms(9), "A3 00 00 00 00 00 00 00");
        t.poll(ms(9));
        t.tx("81 E8 03 00 00 00 00 00");
        t.x(ms(10), "A2 01 7F 00 00 00 00 00", &format!("D5 {:02X} {:02X} 00 00 00 00 00", crc as u8, crc >> 8)); // n = 5
        t.rx(ms(11), "A1 00 00 00 00 00 00 00");
        t.done(ms(11));
    }
}

#[test]
fn block_upload_requests_out_of_turn() {
    let mut t = Sdo::new();
    // Start, ack and end with no transfer: abort 0x05040001 for no object.
    for request in ["A3 00 00 00 00 00 00 00", "A2 00 7F 00 00 00 00 00", "A1 00 00 00 00 00 00 00"] {
        t.x(ms(0), request, "80 00 00 00 01 00 04 05");
    }
    // The end response before the end request: abort 0x05040001 for the object.
    t.x(ms(1), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.x(ms(2), "A1 00 00 00 00 00 00 00", "80 08 10 00 01 00 04 05");
    // In turn: start, the segment, its ack, the end request (n = 1), the end response.
    t.x(ms(3), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.rx(ms(4), "A3 00 00 00 00 00 00 00");
    t.poll(ms(4));
    t.tx("81 64 65 76 69 63 65 00");
    t.rx(ms(5), "A2 01 7F 00 00 00 00 00");
    t.tx(&format!("C5 {:02X} {:02X} 00 00 00 00 00", reference_crc(b"device") as u8, reference_crc(b"device") >> 8));
    t.rx(ms(6), "A1 00 00 00 00 00 00 00");
    t.done(ms(6));
}

#[test]
fn block_upload_requests_of_another_phase() {
    let mut t = Sdo::new();
    let abort = "80 08 10 00 01 00 04 05";
    let end = format!("C5 {:02X} {:02X} 00 00 00 00 00", reference_crc(b"device") as u8, reference_crc(b"device") >> 8);
    // Each phase takes one cs (start 3, ack 2, end 1); the other two abort
    // with 0x05040001 for the object and end the transfer.
    for (i, wrong) in ["A2 00 7F 00 00 00 00 00", "A1 00 00 00 00 00 00 00"].into_iter().enumerate() {
        // Waiting for the start.
        t.x(ms(10 * i as u32), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
        t.x(ms(10 * i as u32 + 1), wrong, abort);
    }
    // Initiate and start at `now`: the block's one segment goes out.
    let block_sent = |t: &mut Sdo, now: u32| {
        t.x(ms(now), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
        t.rx(ms(now + 1), "A3 00 00 00 00 00 00 00");
        t.poll(ms(now + 1));
        t.tx("81 64 65 76 69 63 65 00");
    };
    for (i, wrong) in ["A3 00 00 00 00 00 00 00", "A1 00 00 00 00 00 00 00"].into_iter().enumerate() {
        // Waiting for the block's ack.
        let now = 100 + 10 * i as u32;
        block_sent(&mut t, now);
        t.x(ms(now + 2), wrong, abort);
    }
    for (i, wrong) in ["A3 00 00 00 00 00 00 00", "A2 01 7F 00 00 00 00 00"].into_iter().enumerate() {
        // Waiting for the end response.
        let now = 200 + 10 * i as u32;
        block_sent(&mut t, now);
        t.x(ms(now + 2), "A2 01 7F 00 00 00 00 00", &end);
        t.x(ms(now + 3), wrong, abort);
    }
    // Ended: an end response now belongs to no transfer.
    t.x(ms(300), "A1 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05");
    t.done(ms(300));
}

#[test]
fn block_upload_errors() {
    let mut t = Sdo::new();
    // CCT 2.26: blksize 128, and 0.
    t.x(ms(0), "A4 00 10 00 80 00 00 00", "80 00 10 00 02 00 04 05");
    t.x(ms(0), "A4 00 10 00 00 00 00 00", "80 00 10 00 02 00 04 05");
    t.x(ms(0), "A4 04 10 00 7F 00 00 00", "80 04 10 00 00 00 02 06");
    // CCT 2.27: sequence number 128 in the ack.
    t.x(ms(1), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.rx(ms(2), "A3 00 00 00 00 00 00 00");
    t.poll(ms(2));
    t.tx("81 64 65 76 69 63 65 00");
    t.x(ms(3), "A2 80 7F 00 00 00 00 00", "80 08 10 00 03 00 04 05");
    // A bad blksize for the next block.
    t.x(ms(4), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.rx(ms(5), "A3 00 00 00 00 00 00 00");
    t.poll(ms(5));
    t.tx("81 64 65 76 69 63 65 00");
    t.x(ms(6), "A2 01 00 00 00 00 00 00", "80 08 10 00 02 00 04 05");
    // An ack before the start command, and a start during the transfer.
    t.x(ms(7), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.x(ms(8), "A2 00 7F 00 00 00 00 00", "80 08 10 00 01 00 04 05");
    t.x(ms(9), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.rx(ms(10), "A3 00 00 00 00 00 00 00");
    t.x(ms(10), "A3 00 00 00 00 00 00 00", "80 08 10 00 01 00 04 05");
    // The application fails a read in the middle of a block.
    t.x(ms(11), "A4 10 20 00 7F 00 00 00", "C6 10 20 00 78 00 00 00");
    t.rx(ms(12), "A3 00 00 00 00 00 00 00");
    t.read_error = Some(AbortCode::Hardware);
    assert_eq!(t.poll(ms(12)), None);
    t.tx("80 10 20 00 00 00 06 06");
    t.done(ms(12));
}
