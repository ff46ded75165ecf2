//! The download rules of the communication objects, one row per rule, on
//! the interop fixture (node 4): each COB-ID's reserved bits, restricted
//! CAN-IDs and "changes only while not in use" (CiA 301 §7.5.2.5 SYNC,
//! §7.5.2.13 TIME, §7.5.2.15 EMCY), 0x1019's range, 0x1029's values and
//! 0x1003's "only 0", with the exact abort code of each refusal and the
//! value left behind. The PDO records, 0x1016 and the SDO server
//! parameters have their own cases (`conformance_pdo.rs`,
//! `conformance_error_control.rs`, `conformance_sdo.rs`).

mod common;

use canopen_core::node::NoApplication;
use common::{Bench, ms};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const INVALID: Result<(), u32> = Err(0x0609_0030);

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

/// Downloads each (value, expected answer) into (index, sub) in turn, then
/// checks the value the object holds.
fn rows(index: u16, sub: u8, rows: &[(u32, Result<(), u32>, &str)], last: u32) {
    let mut b = interop();
    for &(value, expected, why) in rows {
        assert_eq!(b.sdo_download(ID, index, sub, &value.to_le_bytes()), expected, "{index:#06X}:{sub} <- {value:#010X}: {why}");
    }
    assert_eq!(b.sdo_upload(ID, index, sub), Ok(last.to_le_bytes().to_vec()), "{index:#06X}:{sub} holds the last value accepted");
}

#[test]
fn cob_id_emcy_rules() {
    rows(
        0x1014,
        0,
        &[
            (0x0000_0085, INVALID, "the CAN-ID changes only while EMCY is off"),
            (0x4000_0084, INVALID, "bit 30 is reserved"),
            (0x2000_0084, INVALID, "29-bit CAN-ID"),
            (0x0000_0884, INVALID, "bits 11..28 with a 29-bit CAN-ID only"),
            (0x0000_0084, Ok(()), "the same value again"),
            (0x8000_0084, Ok(()), "off"),
            (0x8000_0000, INVALID, "CAN-ID 0, even while off"),
            (0x8000_0701, Ok(()), "a restricted CAN-ID while off"),
            (0x0000_0701, INVALID, "a restricted CAN-ID on"),
            (0x0000_0090, Ok(()), "a new CAN-ID, coming on"),
            (0x8000_0091, Ok(()), "a new CAN-ID, going off"),
        ],
        0x8000_0091,
    );
}

#[test]
fn cob_id_time_rules() {
    rows(
        0x1012,
        0,
        &[
            (0x2000_0100, INVALID, "29-bit CAN-ID"),
            (0x0000_0900, INVALID, "bits 11..28"),
            (0x0000_0701, Ok(()), "a restricted CAN-ID, neither consumed nor produced"),
            (0x8000_0701, INVALID, "a restricted CAN-ID consumed"),
            (0x4000_0701, INVALID, "a restricted CAN-ID produced"),
            (0xC000_0000, INVALID, "CAN-ID 0 consumed and produced"),
            (0x8000_0290, Ok(()), "consumed"),
            (0xC000_0291, Ok(()), "the CAN-ID may change while in use"),
        ],
        0xC000_0291,
    );
}

#[test]
fn cob_id_sync_rules() {
    rows(
        0x1005,
        0,
        &[
            (0x2000_0080, INVALID, "29-bit CAN-ID"),
            (0x0000_0880, INVALID, "bits 11..28"),
            (0x0000_0701, INVALID, "a restricted CAN-ID, even for a consumer"),
            (0x8000_0701, INVALID, "bit 31 is 'do not care': still restricted"),
            (0x0000_0081, Ok(()), "a consumer's CAN-ID changes freely"),
            (0x4000_0081, Ok(()), "producer"),
            (0x4000_0082, INVALID, "a producer's CAN-ID changes only while it does not produce"),
            (0xC000_0081, Ok(()), "bit 31 ignored: the same producer"),
            (0x0000_0082, Ok(()), "a consumer again, on a new CAN-ID"),
        ],
        0x0000_0082,
    );
}

#[test]
fn sync_counter_overflow_and_error_behaviour_ranges() {
    let mut b = interop();
    for (v, expected) in [(1u8, INVALID), (241, INVALID), (255, INVALID), (0, Ok(())), (2, Ok(())), (240, Ok(()))] {
        assert_eq!(b.sdo_download(ID, 0x1019, 0, &[v]), expected, "0x1019 <- {v}");
    }
    assert_eq!(b.sdo_upload(ID, 0x1019, 0), Ok(vec![240]));
    for sub in 1..=2 {
        if b.sdo_upload(ID, 0x1029, sub).is_err() {
            continue;
        }
        assert_eq!(b.sdo_download(ID, 0x1029, sub, &[3]), INVALID, "0x1029:{sub} <- 3");
        assert_eq!(b.sdo_download(ID, 0x1029, sub, &[0xFF]), INVALID, "0x1029:{sub} <- 255");
        assert_eq!(b.sdo_download(ID, 0x1029, sub, &[2]), Ok(()), "0x1029:{sub} <- 2");
        assert_eq!(b.sdo_upload(ID, 0x1029, sub), Ok(vec![2]));
    }
    assert_eq!(b.sdo_download(ID, 0x1029, 0, &[2]), Err(0x0601_0002), "0x1029:0 is read-only");
}

#[test]
fn error_history_takes_only_zero_on_sub_0() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1003, 0, &[1]), INVALID);
    assert_eq!(b.sdo_download(ID, 0x1003, 0, &[0, 0]), Err(0x0607_0012));
    assert_eq!(b.sdo_download(ID, 0x1003, 1, &[0; 4]), Err(0x0601_0002), "the entries are read-only");
    assert_eq!(b.sdo_download(ID, 0x1003, 0, &[0]), Ok(()));
}

#[test]
fn cob_ids_have_four_bytes() {
    let mut b = interop();
    for index in [0x1005, 0x1012, 0x1014] {
        assert_eq!(b.sdo_download(ID, index, 0, &[0x80, 0, 0]), Err(0x0607_0013), "{index:#06X}");
        assert_eq!(b.sdo_download(ID, index, 0, &[0x80, 0, 0, 0, 0]), Err(0x0607_0012), "{index:#06X}");
    }
}
