//! Expensive single frames: candidates for the longest `on_frame` +
//! `process` the CANopen task runs for one received frame. Each [`Case`]
//! prepares a node (not measured), names the one frame to measure, and
//! checks the node's answer and effect afterwards, so a case that stopped
//! doing its work fails instead of looking cheap.

use canopen_core::frame::CanFrame;
use canopen_core::services::store::{LOAD, SAVE};
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use canopen_core::wire::sdo_block::crc16;
use embedded_can::Frame;

use crate::{Answer, Dut, HEARTBEAT, Kind, Mismatch, NODE_ID, Pdo, SDO_TX, frame, map_pdo, new_node, read, sdo, sdo_write, start};

/// One expensive frame.
pub struct Case {
    /// Short name, for reports.
    pub name: &'static str,
    /// What the frame makes the node do.
    pub what: &'static str,
    prepare: fn(Instant) -> Result<(Dut, CanFrame), Mismatch>,
    check: fn(&mut Dut, Instant, Answer) -> Result<(), Mismatch>,
}

impl Case {
    /// A node ready for the measured frame at `now`, and that frame.
    pub fn prepare(&self, now: Instant) -> Result<(Dut, CanFrame), Mismatch> {
        (self.prepare)(now)
    }

    /// Checks what the node sent for the frame (all of it) and what it did;
    /// `now` is when it got the frame, for a case that needs the node to run on.
    pub fn check(&self, node: &mut Dut, now: Instant, answer: Answer) -> Result<(), Mismatch> {
        (self.check)(node, now, answer)
    }
}

/// The cases: per-frame work that grows with a mapping or an object, then the storage and reset paths.
pub const CASES: [Case; 15] = [
    Case {
        name: "rpdo-5-entries",
        what: "RPDO1 remapped to 8 bytes: 0x2000, 0x2001, 0x2100 sub 1 and 2, an 8-bit dummy",
        prepare: |now| rpdo_case(now, &[0x2000_0008, 0x2001_0010, 0x2100_0110, 0x2100_0210, 0x0005_0008]),
        check: |node, _, answer| {
            expect_tpdo1(answer, &[1, 2, 3])?;
            let want: [(u16, u8, &[u8]); 4] = [(0x2000, 0, &[1]), (0x2001, 0, &[2, 3]), (0x2100, 1, &[4, 5]), (0x2100, 2, &[6, 7])];
            expect_values(node, "RPDO, 5 entries: values", &want)
        },
    },
    Case {
        name: "rpdo-8-entries",
        what: "RPDO1 remapped to the most entries, 8: 0x2000 and seven 8-bit dummies",
        prepare: |now| rpdo_case(now, &EIGHT_ENTRIES),
        check: |node, _, answer| {
            expect_tpdo1(answer, &[1])?;
            expect_values(node, "RPDO, 8 entries: value", &[(0x2000, 0, &[1])])
        },
    },
    Case {
        name: "sdo-segmented-upload-segment",
        what: "segmented SDO upload of 0x2006 (200 bytes): the first segment",
        prepare: |now| {
            let mut node = new_node(now)?;
            let answer = crate::exchange(&mut node, now, &sdo([0x40, 0x06, 0x20, 0x00, 0, 0, 0, 0]));
            answer.expect("segmented upload initiate", 1, Some((SDO_TX, &[0x41, 0x06, 0x20, 0x00, BLOB_LEN as u8, 0, 0, 0])))?;
            Ok((node, sdo([0x60, 0, 0, 0, 0, 0, 0, 0])))
        },
        // Toggle 0, more to come, then the first 7 bytes of the default blob (zeros).
        check: |_, _, answer| answer.expect("segmented upload segment", 1, Some((SDO_TX, &[0x00, 0, 0, 0, 0, 0, 0, 0]))),
    },
    Case {
        name: "sync-4-tpdos",
        what: "SYNC with all four TPDOs synchronous (7 + 8 + 8 + 8 bytes)",
        prepare: |now| Ok((Kind::Sync.setup(now)?, crate::frame(0x080, &[]))),
        check: |_, _, answer| answer.expect("SYNC", 4, None),
    },
    Case {
        name: "sdo-block-download-last-segment",
        what: "SDO block download of 0x2006 (200 bytes, CRC): the last segment, answered by the block acknowledge",
        prepare: |now| {
            let (node, segment) = block_download(now)?;
            Ok((node, segment))
        },
        check: |_, _, answer| expect_block_ack(answer),
    },
    Case {
        name: "sdo-block-download-end",
        what: "SDO block download of 0x2006 (200 bytes): the end request (CRC over the buffer, write into the dictionary)",
        prepare: |now| {
            let (mut node, segment) = block_download(now)?;
            expect_block_ack(crate::exchange(&mut node, now, &segment))?;
            let [lo, hi] = crc16(&blob()).to_le_bytes();
            // ccs 6, cs 1; n = bytes of the last segment without data.
            let unused = (7 * BLOB_SEGMENTS as usize - BLOB_LEN) as u8;
            Ok((node, sdo([0xC1 | (unused << 2), lo, hi, 0, 0, 0, 0, 0])))
        },
        check: |node, _, answer| {
            answer.expect("block download end", 1, Some((SDO_TX, &[0xA1, 0, 0, 0, 0, 0, 0, 0])))?;
            expect_values(node, "block download: 0x2006", &[(0x2006, 0, &blob())])
        },
    },
    Case {
        name: "sdo-block-upload-sub-block",
        what: "SDO block upload of 0x2006 (200 bytes): the start request, after which the node queues the whole sub-block (29 segments)",
        prepare: |now| {
            let mut node = new_node(now)?;
            // ccs 5, client CRC support, initiate; blksize 127, no protocol switch.
            let answer = crate::exchange(&mut node, now, &sdo([0xA4, 0x06, 0x20, 0x00, 127, 0, 0, 0]));
            answer.expect("block upload initiate", 1, Some((SDO_TX, &[0xC6, 0x06, 0x20, 0x00, BLOB_LEN as u8, 0, 0, 0])))?;
            Ok((node, sdo([0xA3, 0, 0, 0, 0, 0, 0, 0])))
        },
        // The transmit queue takes all but the last segments at once; that one
        // follows at the next `process`.
        check: |node, now, answer| {
            let queued = usize::from(BLOB_SEGMENTS) - 1;
            answer.expect("block upload sub-block", queued, Some((SDO_TX, &[0x01, 0, 0, 0, 0, 0, 0, 0])))?;
            node.process(now);
            let last = Answer::drain(node);
            last.expect("block upload last segment", 1, Some((SDO_TX, &[0x80 | BLOB_SEGMENTS, 0, 0, 0, 0, 0, 0, 0])))
        },
    },
    Case {
        name: "restore-0x1011",
        what: "0x1011 sub 1 \"load\" over a stored set (defaults from the next reset on: a new header)",
        prepare: |now| {
            let mut node = new_node(now)?;
            sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
            Ok((node, sdo_download(0x1011, 1, LOAD)))
        },
        check: |_, _, answer| answer.expect("restore", 1, Some((SDO_TX, &[0x60, 0x11, 0x10, 0x01, 0, 0, 0, 0]))),
    },
    Case {
        name: "nmt-reset-communication",
        what: "NMT reset communication with a stored set (communication parameters reloaded, CRC checked, COB-ID table rebuilt)",
        prepare: |now| {
            let mut node = new_node(now)?;
            sdo_write(&mut node, now, 0x1017, 0, STORED_HEARTBEAT_MS, 2)?;
            sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
            sdo_write(&mut node, now, 0x1017, 0, 0, 2)?;
            Ok((node, frame(0x000, &[0x82, NODE_ID])))
        },
        check: |node, _, answer| {
            answer.expect("reset communication: boot-up", 1, Some((HEARTBEAT, &[0x00])))?;
            expect_values(node, "reset communication: stored 0x1017", &[(0x1017, 0, &STORED_HEARTBEAT_MS.to_le_bytes()[..2])])
        },
    },
    Case {
        name: "store-0x1010",
        what: "0x1010 sub 1 \"save\" over a stored set (erase, the whole image, CRC-32, header)",
        prepare: |now| {
            let mut node = new_node(now)?;
            sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
            sdo_write(&mut node, now, 0x2003, 0, STORED_VALUE, 4)?;
            Ok((node, sdo_download(0x1010, 1, SAVE)))
        },
        check: |_, _, answer| answer.expect("store", 1, Some((SDO_TX, &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]))),
    },
    Case {
        name: "nmt-reset-node",
        what: "NMT reset node with a stored set (whole image from defaults, then from storage, CRC checked, COB-ID table rebuilt)",
        prepare: |now| {
            let mut node = new_node(now)?;
            sdo_write(&mut node, now, 0x2003, 0, STORED_VALUE, 4)?;
            sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
            sdo_write(&mut node, now, 0x2003, 0, 0, 4)?;
            Ok((node, frame(0x000, &[0x81, NODE_ID])))
        },
        check: |node, _, answer| {
            answer.expect("reset node: boot-up", 1, Some((HEARTBEAT, &[0x00])))?;
            expect_values(node, "reset node: stored 0x2003", &[(0x2003, 0, &STORED_VALUE.to_le_bytes())])
        },
    },
    Case {
        name: "store-0x1010-newer-broken",
        what: "0x1010 sub 1 \"save\" with two stored sets, the newer one's CRC broken (both sets checked)",
        prepare: |now| {
            let mut node = two_sets_newer_broken(now)?;
            sdo_write(&mut node, now, 0x2003, 0, STORED_VALUE, 4)?;
            Ok((node, sdo_download(0x1010, 1, SAVE)))
        },
        check: |_, _, answer| answer.expect("store over a broken set", 1, Some((SDO_TX, &[0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]))),
    },
    Case {
        name: "nmt-reset-node-newer-broken",
        what: "NMT reset node with two stored sets, the newer one's CRC broken (both sets checked, the older one loaded)",
        prepare: |now| Ok((two_sets_newer_broken(now)?, frame(0x000, &[0x81, NODE_ID]))),
        check: |node, _, answer| {
            answer.expect("reset node over a broken set: boot-up", 1, Some((HEARTBEAT, &[0x00])))?;
            expect_values(node, "reset node: the older set's 0x2003", &[(0x2003, 0, &STORED_VALUE.to_le_bytes())])
        },
    },
    Case {
        name: "nmt-reset-communication-newer-broken",
        what: "NMT reset communication with two stored sets, the newer one's CRC broken (both sets checked, the older one loaded)",
        prepare: |now| Ok((two_sets_newer_broken(now)?, frame(0x000, &[0x82, NODE_ID]))),
        check: |node, _, answer| {
            answer.expect("reset communication over a broken set: boot-up", 1, Some((HEARTBEAT, &[0x00])))?;
            expect_values(node, "reset communication: the older set's 0x1017", &[(0x1017, 0, &STORED_HEARTBEAT_MS.to_le_bytes()[..2])])
        },
    },
    Case {
        name: "sdo-download-pdo-mapping",
        what: "expedited SDO download of 0x1600 sub 0 = 8 (validates the eight entries of `rpdo-8-entries`)",
        prepare: |now| {
            let mut node = new_node(now)?;
            sdo_write(&mut node, now, 0x1400, 1, 0x8000_0000 | 0x200 | u32::from(NODE_ID), 4)?;
            sdo_write(&mut node, now, 0x1600, 0, 0, 1)?;
            for (sub, entry) in (1..).zip(EIGHT_ENTRIES) {
                sdo_write(&mut node, now, 0x1600, sub, entry, 4)?;
            }
            Ok((node, sdo([0x2F, 0x00, 0x16, 0x00, 8, 0, 0, 0])))
        },
        check: |node, _, answer| {
            answer.expect("mapping count", 1, Some((SDO_TX, &[0x60, 0x00, 0x16, 0x00, 0, 0, 0, 0])))?;
            expect_values(node, "mapping count", &[(0x1600, 0, &[8])])
        },
    },
];

/// The most entries an 8-byte PDO holds: 0x2000 (8 bits) and seven 8-bit
/// dummies (0x0005, UNSIGNED8).
const EIGHT_ENTRIES: [u32; 8] = [0x2000_0008, 0x0005_0008, 0x0005_0008, 0x0005_0008, 0x0005_0008, 0x0005_0008, 0x0005_0008, 0x0005_0008];
/// 0x2006 "Blob" of the interop dictionary: an OCTET_STRING of 200 bytes.
const BLOB_LEN: usize = 200;
/// Its segments of 7 bytes.
const BLOB_SEGMENTS: u8 = BLOB_LEN.div_ceil(7) as u8;
/// A value the reset cases store and expect back.
const STORED_VALUE: u32 = 0x1234_5678;
/// A heartbeat time the reset communication case stores and expects back.
const STORED_HEARTBEAT_MS: u32 = 250;

/// The bytes the block download writes into 0x2006.
fn blob() -> [u8; BLOB_LEN] {
    let mut data = [0u8; BLOB_LEN];
    for (i, byte) in data.iter_mut().enumerate() {
        *byte = (i * 7 + 3) as u8;
    }
    data
}

/// A node with two stored sets whose newer one (region 1) has a broken CRC:
/// the older one holds 0x2003 = [`STORED_VALUE`] and 0x1017 =
/// [`STORED_HEARTBEAT_MS`], the newer other values; the image holds neither.
fn two_sets_newer_broken(now: Instant) -> Result<Dut, Mismatch> {
    let mut node = new_node(now)?;
    sdo_write(&mut node, now, 0x2003, 0, STORED_VALUE, 4)?;
    sdo_write(&mut node, now, 0x1017, 0, STORED_HEARTBEAT_MS, 2)?;
    sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
    sdo_write(&mut node, now, 0x2003, 0, 1, 4)?;
    sdo_write(&mut node, now, 0x1017, 0, 1, 2)?;
    sdo_write(&mut node, now, 0x1010, 1, SAVE, 4)?;
    // The CRC word of the header (bytes 20..24); programming can only clear bits, as in flash.
    node.storage_mut().write(1, 20, &[0; 4]).map_err(|_| Mismatch { step: "breaking the newer set", answer: Answer::default() })?;
    sdo_write(&mut node, now, 0x2003, 0, 0, 4)?;
    sdo_write(&mut node, now, 0x1017, 0, 0, 2)?;
    Ok(node)
}

/// An expedited 4-byte SDO download request.
fn sdo_download(index: u16, sub: u8, value: u32) -> CanFrame {
    let [lo, hi] = index.to_le_bytes();
    let [a, b, c, d] = value.to_le_bytes();
    sdo([0x23, lo, hi, sub, a, b, c, d])
}

/// A started node with RPDO1 mapped to `objects`, and an RPDO1 frame with data 1..=8.
fn rpdo_case(now: Instant, objects: &[u32]) -> Result<(Dut, CanFrame), Mismatch> {
    let mut node = new_node(now)?;
    map_pdo(&mut node, now, Pdo::Receive(0), objects, 0xFF)?;
    start(&mut node, now)?;
    Ok((node, frame(0x200 + u16::from(NODE_ID), &[1, 2, 3, 4, 5, 6, 7, 8])))
}

/// A node inside a block download of [`blob`] into 0x2006 with every
/// segment but the last delivered, and that last segment.
fn block_download(now: Instant) -> Result<(Dut, CanFrame), Mismatch> {
    let mut node = new_node(now)?;
    let [a, b, c, d] = (BLOB_LEN as u32).to_le_bytes();
    // ccs 6, client CRC support, size indicated, initiate.
    let answer = crate::exchange(&mut node, now, &sdo([0xC6, 0x06, 0x20, 0x00, a, b, c, d]));
    if answer.count != 1 || answer.first.is_none_or(|f| f.data().first() != Some(&0xA4) || f.data().get(4) < Some(&BLOB_SEGMENTS)) {
        return Err(Mismatch { step: "block download initiate (one sub-block of 29 segments)", answer });
    }
    let data = blob();
    let mut segments = (1u8..).zip(data.chunks(7)).map(|(seq, chunk)| {
        let mut bytes = [0u8; 8];
        bytes[0] = if usize::from(seq) == usize::from(BLOB_SEGMENTS) { 0x80 | seq } else { seq };
        bytes[1..=chunk.len()].copy_from_slice(chunk);
        sdo(bytes)
    });
    for segment in segments.by_ref().take(usize::from(BLOB_SEGMENTS) - 1) {
        crate::exchange(&mut node, now, &segment).expect("block download segment", 0, None)?;
    }
    let last = segments.next().ok_or(Mismatch { step: "block download: no last segment", answer: Answer::default() })?;
    Ok((node, last))
}

/// Requires one frame, TPDO1 starting with `data`: the RPDO changed 0x2000
/// (and 0x2001), which TPDO1 maps and sends on a change (type 0xFF).
fn expect_tpdo1(answer: Answer, data: &[u8]) -> Result<(), Mismatch> {
    let tpdo1 = 0x180 + u16::from(NODE_ID);
    let sent = answer.first.is_some_and(|f| f.cob_id() == Some(tpdo1) && f.data().starts_with(data));
    if answer.count == 1 && sent { Ok(()) } else { Err(Mismatch { step: "RPDO: TPDO1 on the change", answer }) }
}

/// Requires the block acknowledge of all [`BLOB_SEGMENTS`] segments
/// (whatever block size the server asks for next).
fn expect_block_ack(answer: Answer) -> Result<(), Mismatch> {
    let acked = answer.first.is_some_and(|f| f.cob_id() == Some(SDO_TX) && f.data().get(..2) == Some(&[0xA2, BLOB_SEGMENTS][..]));
    if answer.count == 1 && acked { Ok(()) } else { Err(Mismatch { step: "block acknowledge", answer }) }
}

/// Requires each (index, sub-index) to read `value`.
fn expect_values(node: &Dut, step: &'static str, want: &[(u16, u8, &[u8])]) -> Result<(), Mismatch> {
    if want.iter().all(|&(index, sub, value)| read(node, index, sub) == Some(value)) {
        Ok(())
    } else {
        Err(Mismatch { step, answer: Answer::default() })
    }
}
