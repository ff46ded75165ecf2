//! CiA CANopen Conformance Test Tool 3.0.3.10, SDO cases 2.1–2.30
//! (`/work/shared/notes/cia-notes.md`, appendix A), as exact frames on the
//! interop fixture (`tests/eds/interop.eds`, node 4 as in the CCT log) and,
//! for the guarding objects 0x100C/0x100D, on the b maXX 4400.
//! CiA 301 v4.2 §7.2.4 (SDO protocols), §7.2.4.3.17 (abort codes),
//! §7.5.2.33 (SDO server parameter).
//!
//! Cases:
//! - 2.1–2.3, 2.5–2.13, 2.15–2.19, 2.21–2.23, 2.25–2.27: interop node.
//! - 2.4 (read a write-only object): the interop fixture has none; run on the
//!   Unitek DS, whose 0x2017 is write-only.
//! - 2.14, 2.20, 2.24 (write 0x100C "if guarding is supported"): the b maXX
//!   4400, which has 0x100C/0x100D; for the block writes 2.20 and 2.24 its
//!   dictionary with block transfer, which the device itself does not serve.
//! - 2.28, 2.29: the interop fixture's second SDO server 0x1201.
//! - 2.30 does not apply: it reads the SDO *client* parameters 0x1280 and
//!   following, and no dictionary here has an SDO client (the CCT skips the
//!   case then, as it did on CANopenNode). The save-and-reset-communication
//!   procedure of 2.30 is applied to the server parameter 0x1201 in
//!   `cct_2_29_…` instead.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use common::{Bench, F, abort, ms, ok_write};
use firmware::devices::{bmaxx4400, unitek_ds};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const RX: u16 = 0x604;
const TX: u16 = 0x584;

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

/// The interop node, booted (boot-up frame checked) and Pre-operational.
fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

/// An 8-byte frame: `bytes` then zeros.
fn f(bytes: &[u8]) -> Vec<u8> {
    let mut v = bytes.to_vec();
    v.resize(8, 0);
    v
}

/// The one frame the server sends, on `TX`.
fn on_tx(bytes: &[u8]) -> Vec<F> {
    vec![(TX, f(bytes))]
}

const NAME: &[u8; 23] = b"canopen-rs interop node";

// ---- Expedited transfers and abort codes ---------------------------------------

#[test]
fn cct_2_1_read_device_type_expedited() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x00, 0x10, 0x00])), on_tx(&[0x43, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
}

#[test]
fn cct_2_2_read_and_write_a_rw_communication_entry() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x17, 0x10, 0x00])), on_tx(&[0x4B, 0x17, 0x10, 0x00, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03])), on_tx(&[0x60, 0x17, 0x10, 0x00]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0x40, 0x17, 0x10, 0x00])), on_tx(&[0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03]));
    assert_eq!(b.rx(ms(4), RX, &f(&[0x2B, 0x17, 0x10, 0x00, 0, 0])), on_tx(&[0x60, 0x17, 0x10, 0x00]));
}

#[test]
fn cct_2_3_write_device_type_is_refused() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x23, 0x00, 0x10, 0x00, 0x91, 0x01, 0x0F, 0x00])), vec![(TX, abort(0x1000, 0, 0x0601_0002))]);
}

#[test]
fn cct_2_4_read_a_write_only_object_is_refused() {
    type Ds = Bench<
        unitek_ds::od::Ram,
        NoApplication,
        MemStorage,
        { unitek_ds::od::RPDO_COUNT },
        { unitek_ds::od::TPDO_COUNT },
        { unitek_ds::od::HB_CONSUMER_COUNT },
    >;
    let mut b: Ds = Bench::new(unitek_ds::od::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    b.at(ms(0));
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x17, 0x20, 0x00])), vec![(TX, abort(0x2017, 0, 0x0601_0001))]);
}

#[test]
fn cct_2_5_read_a_missing_sub_index() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x00, 0x10, 0x01])), vec![(TX, abort(0x1000, 1, 0x0609_0011))]);
}

#[test]
fn cct_2_6_read_a_missing_object() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x04, 0x10, 0x00])), vec![(TX, abort(0x1004, 0, 0x0602_0000))]);
}

#[test]
fn cct_2_7_wrong_command_specifier() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xE0, 0x00, 0x10, 0x00])), vec![(TX, abort(0x1000, 0, 0x0504_0001))]);
}

#[test]
fn cct_2_8_write_u32_to_an_u8_object() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x03, 0x10, 0x00])), on_tx(&[0x4F, 0x03, 0x10, 0x00, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x23, 0x03, 0x10, 0x00, 0, 0, 0, 0])), vec![(TX, abort(0x1003, 0, 0x0607_0012))]);
    // And a u32 to the u16 0x1017.
    assert_eq!(b.rx(ms(3), RX, &f(&[0x23, 0x17, 0x10, 0x00, 0, 0, 0, 0])), vec![(TX, abort(0x1017, 0, 0x0607_0012))]);
}

#[test]
fn cct_2_9_write_u8_to_an_u32_object() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x05, 0x10, 0x00])), on_tx(&[0x43, 0x05, 0x10, 0x00, 0x80, 0, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x2F, 0x05, 0x10, 0x00, 0x80])), vec![(TX, abort(0x1005, 0, 0x0607_0013))]);
    assert_eq!(b.sdo_upload(ID, 0x1005, 0), Ok(vec![0x80, 0, 0, 0]), "unchanged");
}

#[test]
fn cct_2_10_write_a_value_too_high() {
    let mut b = interop();
    // 0x1003 sub 0 accepts only 0 (CiA 301 §7.5.2.4).
    assert_eq!(b.rx(ms(1), RX, &f(&[0x2F, 0x03, 0x10, 0x00, 0xFF])), vec![(TX, abort(0x1003, 0, 0x0609_0030))]);
    // 0x2004 HighLimit = 1 000 000.
    let [a, c, d, e] = 1_000_001i32.to_le_bytes();
    assert_eq!(b.rx(ms(2), RX, &f(&[0x23, 0x04, 0x20, 0x00, a, c, d, e])), vec![(TX, abort(0x2004, 0, 0x0609_0031))]);
    let [a, c, d, e] = 1_000_000i32.to_le_bytes();
    assert_eq!(b.rx(ms(3), RX, &f(&[0x23, 0x04, 0x20, 0x00, a, c, d, e])), on_tx(&[0x60, 0x04, 0x20, 0x00]));
}

#[test]
fn cct_2_11_write_a_value_too_low() {
    let mut b = interop();
    let [a, c, d, e] = (-1_000_001i32).to_le_bytes();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x23, 0x04, 0x20, 0x00, a, c, d, e])), vec![(TX, abort(0x2004, 0, 0x0609_0032))]);
    assert_eq!(b.sdo_upload(ID, 0x2004, 0), Ok((-5i32).to_le_bytes().to_vec()), "unchanged");
}

#[test]
fn cct_2_12_default_sdo_server_cob_ids() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x00, 0x12, 0x01])), on_tx(&[0x43, 0x00, 0x12, 0x01, 0x04, 0x06, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x40, 0x00, 0x12, 0x02])), on_tx(&[0x43, 0x00, 0x12, 0x02, 0x84, 0x05, 0, 0]));
}

// ---- Segmented transfers --------------------------------------------------------

#[test]
fn cct_2_13_read_device_type_when_asking_for_any_transfer() {
    // The client cannot ask for a segmented upload: a server sends 1..=4
    // bytes expedited (CiA 301 §7.2.4.3.6), as CANopenNode does in the CCT log.
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x00, 0x10, 0x00])), on_tx(&[0x43, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
}

type Bmaxx = Bench<bmaxx4400::od::Ram, NoApplication, MemStorage, 4, 4, 0>;

fn bmaxx() -> Bmaxx {
    let mut b: Bmaxx = Bench::new(bmaxx4400::od::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

common::with_services! {
    /// The b maXX 4400's dictionary with block transfer on: the device has no
    /// block transfer (docs/devices/bmaxx4400.md), and the CCT's block writes of
    /// 0x100C need a dictionary with 0x100C and a server that has it.
    BlockBmaxx(bmaxx4400::od::Ram) { block_sdo: true }
}

fn block_bmaxx() -> Bench<BlockBmaxx, NoApplication, MemStorage, 4, 4, 0> {
    let mut b = Bench::new(BlockBmaxx(bmaxx4400::od::Ram::new(ID)), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

#[test]
fn a_device_without_block_transfer_refuses_it_as_an_unknown_command() {
    let mut b = bmaxx();
    const { assert!(!<bmaxx4400::od::Ram as ObjectDictionary>::SERVICES.block_sdo) };
    // Block download and block upload initiate: abort 0x05040001 for the object named.
    assert_eq!(b.rx(ms(1), RX, &f(&[0xC2, 0x0C, 0x10, 0x00, 0x02, 0, 0, 0])), vec![(TX, abort(0x100C, 0, 0x0504_0001))]);
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA0, 0x08, 0x10, 0x00, 0x14])), vec![(TX, abort(0x1008, 0, 0x0504_0001))]);
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![0, 0]), "nothing written");
    assert_eq!(b.run_until(ms(2000)), [], "no transfer in progress: no timeout abort");
}

#[test]
fn cct_2_14_write_guard_time_segmented() {
    let mut b = bmaxx();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x21, 0x0C, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0x60, 0x0C, 0x10, 0x00]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x0B, 0xF4, 0x01])), on_tx(&[0x20]));
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![0xF4, 0x01]));
}

#[test]
fn cct_2_15_write_heartbeat_time_segmented() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x21, 0x17, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0x60, 0x17, 0x10, 0x00]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x0B, 0x00, 0x00])), on_tx(&[0x20]));
    // A non-zero value takes effect: the first heartbeat comes one period later.
    assert_eq!(b.rx(ms(3), RX, &f(&[0x21, 0x17, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0x60, 0x17, 0x10, 0x00]));
    assert_eq!(b.rx(ms(4), RX, &f(&[0x0B, 0x64, 0x00])), on_tx(&[0x20]));
    assert_eq!(b.run_until(ms(104)), [(ms(104), (0x704, vec![0x7F]))]);
}

/// The segmented upload of 0x1008 (23 bytes) as the CCT runs it in 2.16 and 2.18.
fn upload_device_name(b: &mut Interop, t: u64) {
    assert_eq!(b.rx(ms(t), RX, &f(&[0x40, 0x08, 0x10, 0x00])), on_tx(&[0x41, 0x08, 0x10, 0x00, 23, 0, 0, 0]));
    let segments: [(u8, u8, &[u8]); 4] =
        [(0x60, 0x00, &NAME[0..7]), (0x70, 0x10, &NAME[7..14]), (0x60, 0x00, &NAME[14..21]), (0x70, 0x1B, &NAME[21..])];
    for (k, (req, cmd, data)) in segments.into_iter().enumerate() {
        let mut expect = vec![cmd];
        expect.extend_from_slice(data);
        assert_eq!(b.rx(ms(t + 1 + k as u64), RX, &f(&[req])), on_tx(&expect), "segment {k}");
    }
}

#[test]
fn cct_2_16_read_a_segmented_object_longer_than_4_bytes() {
    let mut b = interop();
    upload_device_name(&mut b, 1);
    assert_eq!(b.at(ms(10)), [], "nothing more");
}

#[test]
fn cct_2_17_segmented_upload_wrong_toggle() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x08, 0x10, 0x00])), on_tx(&[0x41, 0x08, 0x10, 0x00, 23, 0, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x70])), vec![(TX, abort(0x1008, 0, 0x0503_0000))]);
    // The transfer is over: the next segment request is not part of any transfer.
    assert_eq!(b.rx(ms(3), RX, &f(&[0x60])), vec![(TX, abort(0, 0, 0x0504_0001))]);
    // A toggle error in the middle of a longer transfer too.
    assert_eq!(b.rx(ms(4), RX, &f(&[0x40, 0x08, 0x10, 0x00])), on_tx(&[0x41, 0x08, 0x10, 0x00, 23, 0, 0, 0]));
    let mut first = vec![0x00];
    first.extend_from_slice(&NAME[..7]);
    assert_eq!(b.rx(ms(5), RX, &f(&[0x60])), on_tx(&first));
    assert_eq!(b.rx(ms(6), RX, &f(&[0x60])), vec![(TX, abort(0x1008, 0, 0x0503_0000))]);
}

#[test]
fn cct_2_18_read_object_segmented() {
    let mut b = interop();
    upload_device_name(&mut b, 1);
    // And the 123-character 0x2005, 18 segments.
    let text = b.sdo_upload(ID, 0x2005, 0).unwrap();
    assert_eq!(text.len(), 123);
    assert!(text.starts_with(b"The quick brown fox") && text.ends_with(b"liquor jugs."));
}

// ---- Block transfers --------------------------------------------------------------

#[test]
fn cct_2_19_block_read_of_device_type_without_crc() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xA0, 0x00, 0x10, 0x00, 0x14])), on_tx(&[0xC6, 0x00, 0x10, 0x00, 0x04, 0, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA3])), on_tx(&[0x81, 0, 0, 0, 0]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0xA2, 0x01, 0x14])), on_tx(&[0xCD, 0x00, 0x00]));
    assert_eq!(b.rx(ms(4), RX, &f(&[0xA1])), []);
    assert_eq!(b.run_until(ms(2000)), [], "the transfer ended: no timeout abort");
}

#[test]
fn cct_2_20_block_write_guard_time_without_crc() {
    let mut b = block_bmaxx();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xC2, 0x0C, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0xA4, 0x0C, 0x10, 0x00, 0x7F]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x81, 0xF4, 0x01])), on_tx(&[0xA2, 0x01, 0x7F]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0xD5, 0x00, 0x00])), on_tx(&[0xA1]));
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![0xF4, 0x01]));
}

#[test]
fn cct_2_21_block_write_heartbeat_time_without_crc() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xC2, 0x17, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0xA4, 0x17, 0x10, 0x00, 0x7F]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x81, 0xE8, 0x03])), on_tx(&[0xA2, 0x01, 0x7F]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0xD5, 0x00, 0x00])), on_tx(&[0xA1]));
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0xE8, 0x03]));
}

#[test]
fn block_upload_initiate_of_a_value_of_up_to_4_bytes() {
    // A block upload initiate of a 2-byte value: pst at or above the size
    // answers as an expedited upload, below it or 0 starts a block upload;
    // the blksize is checked before the object.
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03])), on_tx(&[0x60, 0x17, 0x10, 0x00]));
    // pst 2, the size: an expedited upload answers.
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA4, 0x17, 0x10, 0x00, 0x7F, 0x02])), on_tx(&[0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03]));
    // pst 1 (below the size), then pst 0 (no switch): a block upload, its one segment with n = 5.
    for (at, pst) in [(10, 1), (20, 0)] {
        assert_eq!(b.rx(ms(at), RX, &f(&[0xA4, 0x17, 0x10, 0x00, 0x7F, pst])), on_tx(&[0xC6, 0x17, 0x10, 0x00, 0x02]));
        assert_eq!(b.rx(ms(at + 1), RX, &f(&[0xA3])), on_tx(&[0x81, 0xE8, 0x03]));
        // CRC of E8 03 = 0xA978.
        assert_eq!(b.rx(ms(at + 2), RX, &f(&[0xA2, 0x01, 0x7F])), on_tx(&[0xD5, 0x78, 0xA9]));
        assert_eq!(b.rx(ms(at + 3), RX, &f(&[0xA1])), []);
    }
    // The blksize is checked before the object: 0x05040002 for a missing
    // one too; a valid blksize then finds no object: 0x06020000.
    assert_eq!(b.rx(ms(30), RX, &f(&[0xA4, 0x34, 0x12, 0x00, 0x00, 0x02])), vec![(TX, abort(0x1234, 0, 0x0504_0002))]);
    assert_eq!(b.rx(ms(31), RX, &f(&[0xA4, 0x34, 0x12, 0x00, 0x7F, 0x02])), vec![(TX, abort(0x1234, 0, 0x0602_0000))]);
    // Heartbeats (0x1017 is 1000 ms now) but no timeout abort: every transfer ended.
    assert!(b.run_until(ms(2000)).iter().all(|(_, (id, _))| *id != TX));
}

/// A block upload of 0x1008 in one block of 20 segments; `crc` asks for a CRC.
fn block_upload_device_name(b: &mut Interop, crc: bool) -> Vec<F> {
    let cc = if crc { 0x04 } else { 0 };
    assert_eq!(b.rx(ms(1), RX, &f(&[0xA0 | cc, 0x08, 0x10, 0x00, 0x14])), on_tx(&[0xC6, 0x08, 0x10, 0x00, 23, 0, 0, 0]));
    let mut segments = Vec::new();
    for (seqno, chunk) in (1u8..).zip(NAME.chunks(7)) {
        let mut s = vec![seqno | if seqno == 4 { 0x80 } else { 0 }];
        s.extend_from_slice(chunk);
        segments.push((TX, f(&s)));
    }
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA3])), segments);
    let end = b.rx(ms(3), RX, &f(&[0xA2, 0x04, 0x14]));
    assert_eq!(b.rx(ms(4), RX, &f(&[0xA1])), []);
    end
}

#[test]
fn cct_2_22_block_read_of_a_segmented_object() {
    let mut b = interop();
    // n = 5 unused bytes in the last segment; no CRC asked, so 0.
    assert_eq!(block_upload_device_name(&mut b, false), on_tx(&[0xD5, 0x00, 0x00]));
}

#[test]
fn cct_2_23_block_read_with_crc() {
    let mut b = interop();
    // CRC-16-CCITT (XMODEM) of "canopen-rs interop node" = 0xB521.
    assert_eq!(block_upload_device_name(&mut b, true), on_tx(&[0xD5, 0x21, 0xB5]));
}

#[test]
fn cct_2_24_block_write_guard_time_with_crc() {
    let mut b = block_bmaxx();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xC6, 0x0C, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0xA4, 0x0C, 0x10, 0x00, 0x7F]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x81, 0xE8, 0x03])), on_tx(&[0xA2, 0x01, 0x7F]));
    // CRC of E8 03 = 0xA978. A wrong CRC is refused first.
    assert_eq!(b.rx(ms(3), RX, &f(&[0xD5, 0x79, 0xA9])), vec![(TX, abort(0x100C, 0, 0x0504_0004))]);
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![0, 0]), "nothing written");
    assert_eq!(b.rx(ms(4), RX, &f(&[0xC6, 0x0C, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0xA4, 0x0C, 0x10, 0x00, 0x7F]));
    assert_eq!(b.rx(ms(5), RX, &f(&[0x81, 0xE8, 0x03])), on_tx(&[0xA2, 0x01, 0x7F]));
    assert_eq!(b.rx(ms(6), RX, &f(&[0xD5, 0x78, 0xA9])), on_tx(&[0xA1]));
    assert_eq!(b.sdo_upload(ID, 0x100C, 0), Ok(vec![0xE8, 0x03]));
}

#[test]
fn cct_2_25_block_write_heartbeat_time_with_crc() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xC6, 0x17, 0x10, 0x00, 0x02, 0, 0, 0])), on_tx(&[0xA4, 0x17, 0x10, 0x00, 0x7F]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x81, 0xE8, 0x03])), on_tx(&[0xA2, 0x01, 0x7F]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0xD5, 0x78, 0xA9])), on_tx(&[0xA1]));
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0xE8, 0x03]));
}

#[test]
fn cct_2_26_block_read_with_blksize_128() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xA0, 0x00, 0x10, 0x00, 0x80])), vec![(TX, abort(0x1000, 0, 0x0504_0002))]);
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA0, 0x00, 0x10, 0x00, 0x00])), vec![(TX, abort(0x1000, 0, 0x0504_0002))], "0 too");
}

#[test]
fn cct_2_27_block_read_with_sequence_number_128() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0xA0, 0x00, 0x10, 0x00, 0x14])), on_tx(&[0xC6, 0x00, 0x10, 0x00, 0x04, 0, 0, 0]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0xA3])), on_tx(&[0x81, 0, 0, 0, 0]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0xA2, 0x80, 0x14])), vec![(TX, abort(0x1000, 0, 0x0504_0003))]);
}

// ---- Further SDO servers -----------------------------------------------------------

/// The second server's COB-IDs in these tests: 0x680–0x6DF is free of
/// restricted CAN-IDs (CiA 301 §7.3.5).
const RX2: u16 = 0x6A4;
const TX2: u16 = 0x6B4;

/// Enables server 0x1201 on (`RX2`, `TX2`) for client node 0x7F.
fn enable_second_server(b: &mut Interop) {
    assert_eq!(b.sdo_download(ID, 0x1201, 1, &u32::from(RX2).to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1201, 2, &u32::from(TX2).to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1201, 3, &[0x7F]), Ok(()));
    assert_eq!(b.node.sdo_cob_ids(1), Some((RX2, TX2)));
}

#[test]
fn cct_2_28_read_0x1201_and_following() {
    let mut b = interop();
    assert_eq!(b.rx(ms(1), RX, &f(&[0x40, 0x01, 0x12, 0x00])), on_tx(&[0x4F, 0x01, 0x12, 0x00, 3]));
    assert_eq!(b.rx(ms(2), RX, &f(&[0x40, 0x01, 0x12, 0x01])), on_tx(&[0x43, 0x01, 0x12, 0x01, 0, 0, 0, 0x80]));
    assert_eq!(b.rx(ms(3), RX, &f(&[0x40, 0x01, 0x12, 0x02])), on_tx(&[0x43, 0x01, 0x12, 0x02, 0, 0, 0, 0x80]));
    assert_eq!(b.rx(ms(4), RX, &f(&[0x40, 0x01, 0x12, 0x03])), on_tx(&[0x4F, 0x01, 0x12, 0x03, 0]));
    for index in 0x1202..=0x127Fu16 {
        let [lo, hi] = index.to_le_bytes();
        assert_eq!(b.rx(ms(5), RX, &f(&[0x40, lo, hi, 0x01])), vec![(TX, abort(index, 1, 0x0602_0000))]);
    }
    // Off by default (COB-IDs not valid): its CAN-IDs mean nothing.
    assert_eq!(b.node.sdo_cob_ids(1), None);
    assert_eq!(b.rx(ms(6), RX2, &f(&[0x40, 0x00, 0x10, 0x00])), []);

    // The COB-ID rules of CiA 301 §7.5.2.33, each answered 0x06090030.
    let w = |b: &mut Interop, sub: u8, v: u32| b.sdo_download(ID, 0x1201, sub, &v.to_le_bytes());
    assert_eq!(w(&mut b, 1, 0x0000_0605), Err(0x0609_0030), "restricted CAN-ID (default SDO of node 5)");
    assert_eq!(w(&mut b, 1, 0x0000_0604), Err(0x0609_0030), "this node's own default SDO is restricted for 0x1201");
    assert_eq!(w(&mut b, 1, 0x2000_06A4), Err(0x0609_0030), "29-bit CAN-ID");
    assert_eq!(w(&mut b, 1, 0x8000_0605), Ok(()), "a restricted CAN-ID is harmless while not valid");
    assert_eq!(w(&mut b, 1, u32::from(RX2)), Ok(()));
    assert_eq!(w(&mut b, 1, u32::from(RX2) + 1), Err(0x0609_0030), "the CAN-ID changes only while not valid");
    assert_eq!(w(&mut b, 1, u32::from(RX2)), Ok(()), "rewriting the same value is fine");
    assert_eq!(b.sdo_download(ID, 0x1201, 3, &[0x80]), Err(0x0609_0030), "client node-ID 1..=127");
    assert_eq!(b.node.sdo_cob_ids(1), None, "sub 2 is still not valid");
    enable_second_server(&mut b);

    // Both servers answer, each on its own COB-IDs.
    assert_eq!(b.rx(ms(7), RX2, &f(&[0x40, 0x00, 0x10, 0x00])), vec![(TX2, f(&[0x43, 0x00, 0x10, 0x00, 0, 0, 0, 0]))]);
    assert_eq!(b.sdo_upload_via(RX2, TX2, 0x1008, 0), Ok(NAME.to_vec()));
    assert_eq!(b.sdo_upload_via(RX2, TX2, 0x1201, 1), Ok(vec![0xA4, 0x06, 0, 0]));
    assert_eq!(b.sdo_download_via(RX2, TX2, 0x2003, 0, &[1, 2, 3, 4]), Ok(()));
    assert_eq!(b.sdo_upload(ID, 0x2003, 0), Ok(vec![1, 2, 3, 4]));

    // They share one download buffer: while the default server collects a
    // segmented download, a segmented or block download on the second one
    // is refused with 0x060A0023; its uploads and expedited downloads run.
    assert_eq!(b.rx(ms(8), RX, &f(&[0x21, 0x06, 0x20, 0x00, 10, 0, 0, 0])), on_tx(&[0x60, 0x06, 0x20, 0x00]));
    assert_eq!(b.rx(ms(9), RX2, &f(&[0x21, 0x05, 0x20, 0x00, 10, 0, 0, 0])), vec![(TX2, abort(0x2005, 0, 0x060A_0023))]);
    assert_eq!(b.rx(ms(10), RX2, &f(&[0xC6, 0x05, 0x20, 0x00, 10, 0, 0, 0])), vec![(TX2, abort(0x2005, 0, 0x060A_0023))]);
    assert_eq!(b.sdo_download_via(RX2, TX2, 0x2000, 0, &[0x5A]), Ok(()));
    assert_eq!(b.sdo_upload_via(RX2, TX2, 0x2000, 0), Ok(vec![0x5A]));
    assert_eq!(b.rx(ms(11), RX, &f(&[0x00, 1, 2, 3, 4, 5, 6, 7])), on_tx(&[0x20]));
    assert_eq!(b.rx(ms(12), RX, &f(&[0x19, 8, 9, 10])), on_tx(&[0x30]));
    let mut blob = b.sdo_upload(ID, 0x2006, 0).unwrap();
    blob.truncate(10);
    assert_eq!(blob, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
    // The buffer is free again.
    assert_eq!(b.sdo_download_via(RX2, TX2, 0x2005, 0, b"second server"), Ok(()));
    assert_eq!(b.sdo_upload(ID, 0x2005, 0), Ok(b"second server".to_vec()));

    // Invalidating a COB-ID turns the server off.
    assert_eq!(w(&mut b, 2, 0x8000_0000 | u32::from(TX2)), Ok(()));
    assert_eq!(b.node.sdo_cob_ids(1), None);
    assert_eq!(b.rx(ms(13), RX2, &f(&[0x40, 0x00, 0x10, 0x00])), []);
}

#[test]
fn cct_2_29_read_0x1201_after_reset_communication() {
    let mut b = interop();
    enable_second_server(&mut b);
    assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1201, 1), Ok(vec![0, 0, 0, 0x80]));
    assert_eq!(b.sdo_upload(ID, 0x1201, 2), Ok(vec![0, 0, 0, 0x80]));
    assert_eq!(b.sdo_upload(ID, 0x1201, 3), Ok(vec![0]));
    assert_eq!(b.rx(ms(1), RX2, &f(&[0x40, 0x00, 0x10, 0x00])), [], "off again");

    // The procedure of 2.30 on the server parameters: saved ones survive reset communication.
    enable_second_server(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1201, 1), Ok(u32::from(RX2).to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x1201, 3), Ok(vec![0x7F]));
    assert_eq!(b.sdo_upload_via(RX2, TX2, 0x1000, 0), Ok(vec![0, 0, 0, 0]));
    // And "load" brings the defaults back at the next reset.
    assert_eq!(b.sdo_write(ID, 0x1011, 2, b"load"), ok_write(0x1011, 2));
    assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
    assert_eq!(b.node.sdo_cob_ids(1), None);
}
