//! SDO block transfers on the virtual bus at 1 Mbit/s: the hal-host master
//! against the interop node, exact frames at exact times, and the two ways
//! the bus loses a frame: a segment nobody receives (the SDO protocol
//! recovers through ackseq) and a corrupted segment (the CAN controller
//! retransmits it; SDO never notices). CiA 301 v4.2 §7.2.4.3.9–16.
//!
//! The times are EOF ends in µs (one bit = 1 µs). Every frame starts right
//! after the 3-bit intermission of the frame before it (a node answers at
//! the instant it receives), so each time is the previous one plus 3 plus
//! the frame's length up to EOF, stuff bits included; the gaps are idle bus
//! or a dropped frame. The CRCs are CRC-16-CCITT (XModem) of the value:
//! 0x800F for the text of 0x2005, 0x15A1 for the bytes 0..=199.

mod common;

use canopen_core::node::NoApplication;
use common::net::{Net, NodeHandle, bits, us};
use embedded_can::Frame;
use hal_host::bus::{BitRate, CRC_ERROR_DETECT_BITS, ERROR_FRAME_BITS, INTERMISSION_BITS, PortId, frame_bits};
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::master::{DownloadMode, UploadMode};
use hal_host::storage::MemStorage;

type Interop = Node<NoApplication, MemStorage>;

const NODE: u8 = 5;
const TEXT: &[u8] =
    b"The quick brown fox jumps over the lazy dog; the five boxing wizards jump quickly. Pack my box with five dozen liquor jugs.";
const BLOCK_127_CRC: UploadMode = UploadMode::Block { blksize: 127, pst: 0, crc: true };

/// The master and node 5 on a 1 Mbit/s bus, after the boot-up (t = 1 ms).
fn network(name: &str) -> (Net, PortId, NodeHandle) {
    let mut net = Net::new(name, BitRate::MBIT_1);
    let master = net.add_master();
    let node = net.add_node(Interop::new(Ram::new(NODE), NoApplication, MemStorage::new(4096), NODE, us(0)));
    net.run_until(us(1000));
    assert_eq!(net.candump_since(us(0)), "(0000000000.000055) vcan0 705#00\n");
    (net, master, node)
}

fn blob() -> Vec<u8> {
    (0..=199u8).collect()
}

/// Drops the first frame from `port` whose byte 0 is `b0`.
fn drop_first(net: &mut Net, port: PortId, b0: u8) {
    let mut done = false;
    net.bus().drop_where(move |p, f| {
        let hit = !done && p == port && f.data().first() == Some(&b0);
        done |= hit;
        hit
    });
}

// ---- Block upload ------------------------------------------------------------

#[test]
fn block_upload_with_crc_exact_frames() {
    let (mut net, m, _) = network("block_upload_with_crc_exact_frames");
    assert_eq!(net.sdo_upload(m, NODE, 0x2005, 0, BLOCK_127_CRC).as_deref(), Ok(TEXT));
    // Initiate (blksize 127, CRC) and the answer (CRC, 123 bytes); start;
    // 18 segments, the last (c = 1) with "ugs."; ack 18; end with n = 3
    // unused bytes and the CRC; the client's end.
    let expected = "\
(0000000000.001117) vcan0 605#A40520007F000000
(0000000000.001236) vcan0 585#C60520007B000000
(0000000000.001359) vcan0 605#A300000000000000
(0000000000.001473) vcan0 585#0154686520717569
(0000000000.001586) vcan0 585#02636B2062726F77
(0000000000.001702) vcan0 585#036E20666F78206A
(0000000000.001816) vcan0 585#04756D7073206F76
(0000000000.001930) vcan0 585#0565722074686520
(0000000000.002044) vcan0 585#066C617A7920646F
(0000000000.002160) vcan0 585#07673B2074686520
(0000000000.002273) vcan0 585#086669766520626F
(0000000000.002387) vcan0 585#0978696E67207769
(0000000000.002502) vcan0 585#0A7A61726473206A
(0000000000.002617) vcan0 585#0B756D7020717569
(0000000000.002730) vcan0 585#0C636B6C792E2050
(0000000000.002845) vcan0 585#0D61636B206D7920
(0000000000.002960) vcan0 585#0E626F7820776974
(0000000000.003076) vcan0 585#0F68206669766520
(0000000000.003191) vcan0 585#10646F7A656E206C
(0000000000.003304) vcan0 585#116971756F72206A
(0000000000.003422) vcan0 585#927567732E000000
(0000000000.003543) vcan0 605#A2127F0000000000
(0000000000.003665) vcan0 585#CD0F800000000000
(0000000000.003790) vcan0 605#A100000000000000
";
    assert_eq!(net.candump_since(us(1000)), expected);
    // The request left at 1000 µs: 117 bits to its EOF.
    assert_eq!(bits(0x605, &[0xA4, 0x05, 0x20, 0x00, 0x7F, 0, 0, 0]).0, 117);
    // Nothing else happens afterwards.
    net.run_until(us(10_000));
    assert_eq!(net.frames_since(us(3791)), []);
}

#[test]
fn block_upload_recovers_a_dropped_segment() {
    let (mut net, m, node) = network("block_upload_recovers_a_dropped_segment");
    drop_first(&mut net, node.port, 0x05);
    assert_eq!(net.sdo_upload(m, NODE, 0x2005, 0, BLOCK_127_CRC).as_deref(), Ok(TEXT));
    // Segment 5 went over the wire (1816..1930) but nobody received it. The
    // client acks 4; the server sends the rest again from byte 28 as a new
    // sub-block of 14 segments; the CRC is that of the whole value.
    let expected = "\
(0000000000.001117) vcan0 605#A40520007F000000
(0000000000.001236) vcan0 585#C60520007B000000
(0000000000.001359) vcan0 605#A300000000000000
(0000000000.001473) vcan0 585#0154686520717569
(0000000000.001586) vcan0 585#02636B2062726F77
(0000000000.001702) vcan0 585#036E20666F78206A
(0000000000.001816) vcan0 585#04756D7073206F76
(0000000000.002044) vcan0 585#066C617A7920646F
(0000000000.002160) vcan0 585#07673B2074686520
(0000000000.002273) vcan0 585#086669766520626F
(0000000000.002387) vcan0 585#0978696E67207769
(0000000000.002502) vcan0 585#0A7A61726473206A
(0000000000.002617) vcan0 585#0B756D7020717569
(0000000000.002730) vcan0 585#0C636B6C792E2050
(0000000000.002845) vcan0 585#0D61636B206D7920
(0000000000.002960) vcan0 585#0E626F7820776974
(0000000000.003076) vcan0 585#0F68206669766520
(0000000000.003191) vcan0 585#10646F7A656E206C
(0000000000.003304) vcan0 585#116971756F72206A
(0000000000.003422) vcan0 585#927567732E000000
(0000000000.003544) vcan0 605#A2047F0000000000
(0000000000.003660) vcan0 585#0165722074686520
(0000000000.003774) vcan0 585#026C617A7920646F
(0000000000.003888) vcan0 585#03673B2074686520
(0000000000.004002) vcan0 585#046669766520626F
(0000000000.004116) vcan0 585#0578696E67207769
(0000000000.004229) vcan0 585#067A61726473206A
(0000000000.004343) vcan0 585#07756D7020717569
(0000000000.004456) vcan0 585#08636B6C792E2050
(0000000000.004570) vcan0 585#0961636B206D7920
(0000000000.004684) vcan0 585#0A626F7820776974
(0000000000.004800) vcan0 585#0B68206669766520
(0000000000.004914) vcan0 585#0C646F7A656E206C
(0000000000.005028) vcan0 585#0D6971756F72206A
(0000000000.005144) vcan0 585#8E7567732E000000
(0000000000.005266) vcan0 605#A20E7F0000000000
(0000000000.005388) vcan0 585#CD0F800000000000
(0000000000.005513) vcan0 605#A100000000000000
";
    assert_eq!(net.candump_since(us(1000)), expected);
    // The gap is exactly the dropped frame: 3 + 111 bits.
    let (eof, total) = bits(0x585, &[0x05, 0x65, 0x72, 0x20, 0x74, 0x68, 0x65, 0x20]);
    assert_eq!((eof, total), (111, 114));
    assert_eq!(2044 - 1816, total + 3 + bits(0x585, &[0x06, 0x6C, 0x61, 0x7A, 0x79, 0x20, 0x64, 0x6F]).0);
    assert_eq!(net.bus().stats().dropped, 1);
}

#[test]
fn corrupted_segment_is_retransmitted_by_the_controller() {
    // The same upload twice: clean, and with segment 3 destroyed by a CRC
    // error once. The frames are the same; from segment 3 on everything is
    // later by the destroyed attempt (SOF..CRC, then the 3 bits up to the
    // error flag), the error frame and its intermission.
    let (mut clean, m, _) = network("corrupted_segment_clean_run");
    assert_eq!(clean.sdo_upload(m, NODE, 0x2005, 0, BLOCK_127_CRC).as_deref(), Ok(TEXT));
    let (mut net, m, node) = network("corrupted_segment_is_retransmitted_by_the_controller");
    let port = node.port;
    let mut done = false;
    net.bus().corrupt_where(move |p, f| {
        let hit = !done && p == port && f.data().first() == Some(&0x03);
        done |= hit;
        hit
    });
    assert_eq!(net.sdo_upload(m, NODE, 0x2005, 0, BLOCK_127_CRC).as_deref(), Ok(TEXT));

    let segment3 = canopen_core::frame::CanFrame::standard(0x585, &[0x03, 0x6E, 0x20, 0x66, 0x6F, 0x78, 0x20, 0x6A]).unwrap();
    let lost = u64::from(frame_bits(&segment3).stuffed() + CRC_ERROR_DETECT_BITS + ERROR_FRAME_BITS + INTERMISSION_BITS);
    assert_eq!(lost, 103 + 3 + 14 + 3);
    let (a, b) = (clean.frames_since(us(1000)), net.frames_since(us(1000)));
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert_eq!((x.2, &x.3), (y.2, &y.3), "frame {i}");
        let shift = if i < 5 { 0 } else { lost };
        assert_eq!(y.0.as_micros(), x.0.as_micros() + shift, "frame {i}: {:02X?}", y.3);
    }
    let stats = net.bus().stats();
    assert_eq!((stats.error_frames, stats.dropped), (1, 0));
    let ps = net.bus().port_stats(port).unwrap();
    assert_eq!((ps.tx_errors, ps.tx_frames), (1, 21), "boot-up, initiate response, 18 segments, end");
    // TEC: +8 for the error, -1 for each of the 17 frames sent since.
    assert_eq!(net.bus().error_counters(port), Some((0, 0)));
}

// ---- Block download ----------------------------------------------------------

#[test]
fn block_download_with_crc_exact_frames() {
    let (mut net, m, node) = network("block_download_with_crc_exact_frames");
    assert_ne!(net.node::<Interop>(node).od().blob(), &blob()[..]);
    assert_eq!(net.sdo_download(m, NODE, 0x2006, 0, &blob(), DownloadMode::Block { crc: true }), Ok(()));
    assert_eq!(net.node::<Interop>(node).od().blob(), &blob()[..]);
    // Initiate (CRC, 200 bytes) and the answer (blksize 127: the node's
    // 896-byte buffer); 29 segments, the last (c = 1) with 4 bytes; ack 29
    // with the next blksize, 99 (the room left: (896 - 203) / 7); end with
    // n = 3 and the CRC; the server's end.
    let expected = "\
(0000000000.001117) vcan0 605#C6062000C8000000
(0000000000.001238) vcan0 585#A40620007F000000
(0000000000.001360) vcan0 605#0100010203040506
(0000000000.001477) vcan0 605#020708090A0B0C0D
(0000000000.001593) vcan0 605#030E0F1011121314
(0000000000.001708) vcan0 605#0415161718191A1B
(0000000000.001824) vcan0 605#051C1D1E1F202122
(0000000000.001938) vcan0 605#0623242526272829
(0000000000.002052) vcan0 605#072A2B2C2D2E2F30
(0000000000.002166) vcan0 605#0831323334353637
(0000000000.002282) vcan0 605#0938393A3B3C3D3E
(0000000000.002400) vcan0 605#0A3F404142434445
(0000000000.002513) vcan0 605#0B464748494A4B4C
(0000000000.002629) vcan0 605#0C4D4E4F50515253
(0000000000.002742) vcan0 605#0D5455565758595A
(0000000000.002858) vcan0 605#0E5B5C5D5E5F6061
(0000000000.002972) vcan0 605#0F62636465666768
(0000000000.003088) vcan0 605#10696A6B6C6D6E6F
(0000000000.003202) vcan0 605#1170717273747576
(0000000000.003318) vcan0 605#127778797A7B7C7D
(0000000000.003438) vcan0 605#137E7F8081828384
(0000000000.003554) vcan0 605#1485868788898A8B
(0000000000.003668) vcan0 605#158C8D8E8F909192
(0000000000.003781) vcan0 605#1693949596979899
(0000000000.003897) vcan0 605#179A9B9C9D9E9FA0
(0000000000.004012) vcan0 605#18A1A2A3A4A5A6A7
(0000000000.004125) vcan0 605#19A8A9AAABACADAE
(0000000000.004239) vcan0 605#1AAFB0B1B2B3B4B5
(0000000000.004353) vcan0 605#1BB6B7B8B9BABBBC
(0000000000.004472) vcan0 605#1CBDBEBFC0C1C2C3
(0000000000.004590) vcan0 605#9DC4C5C6C7000000
(0000000000.004709) vcan0 585#A21D630000000000
(0000000000.004829) vcan0 605#CDA1150000000000
(0000000000.004951) vcan0 585#A100000000000000
";
    assert_eq!(net.candump_since(us(1000)), expected);
}

#[test]
fn block_download_recovers_a_dropped_segment() {
    let (mut net, m, node) = network("block_download_recovers_a_dropped_segment");
    drop_first(&mut net, m, 0x03);
    assert_eq!(net.sdo_download(m, NODE, 0x2006, 0, &blob(), DownloadMode::Block { crc: true }), Ok(()));
    assert_eq!(net.node::<Interop>(node).od().blob(), &blob()[..]);
    let frames = net.frames_since(us(1000));
    let server: Vec<_> = frames.iter().filter(|f| f.1 == node.port).map(|f| (f.0.as_micros(), f.3.clone())).collect();
    // The server ignores segments 4..=29 after the gap, acks 2 and offers
    // blksize 126 ((896 - 14) / 7); the client sends bytes 14.. again as
    // segments 1..=27, and the server acks them all with blksize 99.
    assert_eq!(
        server,
        [
            (1238, vec![0xA4, 0x06, 0x20, 0x00, 0x7F, 0, 0, 0]),
            (4712, vec![0xA2, 0x02, 0x7E, 0, 0, 0, 0, 0]),
            (7937, vec![0xA2, 0x1B, 0x63, 0, 0, 0, 0, 0]),
            (8179, vec![0xA1, 0, 0, 0, 0, 0, 0, 0]),
        ]
    );
    let resent: Vec<_> = frames.iter().filter(|f| f.1 == m && f.0.as_micros() > 4712 && f.3[0] & 0x7F != 0x4D).collect();
    assert_eq!(resent.len(), 27);
    assert_eq!((resent[0].0.as_micros(), &resent[0].3[..]), (4829, &[0x01, 14, 15, 16, 17, 18, 19, 20][..]));
    assert_eq!(&resent[26].3[..], &[0x9B, 196, 197, 198, 199, 0, 0, 0]);
    assert_eq!(net.bus().stats().dropped, 1);
}
