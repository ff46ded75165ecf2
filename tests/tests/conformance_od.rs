//! CiA CANopen Conformance Test Tool 3.0.3.10, object dictionary cases
//! 4.1–4.9 (`/work/shared/notes/cia-notes.md`, appendix A): every entry of
//! the interop fixture and of the five device dictionaries, read and
//! written through the default SDO server as the CCT does. CiA 301 v4.2
//! §7.4 (object dictionary), §7.2.4.3.17 (abort codes); CiA 306 (access
//! types, limits, defaults).
//!
//! Expected values come from the generated tables (EDS defaults with
//! `$NODEID` added, the constants in flash), not from a node.
//!
//! Cases:
//! - 4.1 every readable entry reads, with its size; 4.7 the same in
//!   Operational (the CCT repeats the access check after 4.6);
//! - 4.2 every readable entry reads as its EDS default after power-on;
//!   4.8 again after the rw entries were changed and the node was reset;
//! - 4.3 every ro/const entry refuses a download with 0x06010002;
//! - 4.4 every wo entry refuses an upload with 0x06010001;
//! - 4.5 sub-index 0xFF (object structure) exists in no dictionary here, so
//!   the CCT skips the comparison: the test checks it is absent everywhere;
//! - 4.6 every writable entry with limits refuses low − 1 (0x06090032) and
//!   high + 1 (0x06090031), and accepts low and high; a communication
//!   object may still refuse an in-range value by its own rules (0x06090030;
//!   a PDO mapping 0x06010000 while valid, or 0x06020000/0x0604004x when its
//!   entries do not resolve), as CiA 301 §7.5.2 gives them;
//! - 4.9 every rw entry can be read and written back, except the commands
//!   0x1010/0x1011, whose read value (the capability bits) is not a signature.
//!
//! No EDS here uses ObjFlags, so 4.8 and 4.9 apply to every entry.
//!
//! Case 1.0 (the CCT's EDS checker, CANchkEDS) is not a test of the node:
//! od-gen validates every EDS it generates a dictionary from (strict for the
//! fixture), and `tests/tests/corpus.rs` runs it over the EDS corpus.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::od::{Attr, DataType, Dictionary, Entry, Kind, ObjectDictionary};
use common::{Bench, ms};
use firmware::devices::{agile, bmaxx4400, ec5000, sendix, unitek_ds};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;

type B<O, const R: usize, const T: usize, const HB: usize> = Bench<O, NoApplication, MemStorage, R, T, HB>;

fn boot<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O) -> B<O, R, T, HB> {
    let mut b = Bench::new(ram, NoApplication, MemStorage::new(16384), ID);
    assert_eq!(b.at(ms(0)), [(0x704, vec![0x00])]);
    b
}

/// Runs `$case::<Ram, R, T, HB>(Ram::new(ID), name)` for the interop
/// fixture and the five devices; the six results, as an array.
macro_rules! on_every_dictionary {
    ($case:ident) => {
        [
            $case::<interop::Ram, { interop::RPDO_COUNT }, { interop::TPDO_COUNT }, { interop::HB_CONSUMER_COUNT }>(
                interop::Ram::new(ID),
                "interop",
            ),
            $case::<ec5000::od::Ram, { ec5000::od::RPDO_COUNT }, { ec5000::od::TPDO_COUNT }, { ec5000::od::HB_CONSUMER_COUNT }>(
                ec5000::od::Ram::new(ID),
                "ec5000",
            ),
            $case::<unitek_ds::od::Ram, { unitek_ds::od::RPDO_COUNT }, { unitek_ds::od::TPDO_COUNT }, { unitek_ds::od::HB_CONSUMER_COUNT }>(
                unitek_ds::od::Ram::new(ID),
                "unitek-ds",
            ),
            $case::<sendix::od::Ram, { sendix::od::RPDO_COUNT }, { sendix::od::TPDO_COUNT }, { sendix::od::HB_CONSUMER_COUNT }>(
                sendix::od::Ram::new(ID),
                "sendix",
            ),
            $case::<bmaxx4400::od::Ram, { bmaxx4400::od::RPDO_COUNT }, { bmaxx4400::od::TPDO_COUNT }, { bmaxx4400::od::HB_CONSUMER_COUNT }>(
                bmaxx4400::od::Ram::new(ID),
                "bmaxx4400",
            ),
            $case::<agile::od::Ram, { agile::od::RPDO_COUNT }, { agile::od::TPDO_COUNT }, { agile::od::HB_CONSUMER_COUNT }>(
                agile::od::Ram::new(ID),
                "agile",
            ),
        ]
    };
}

/// The EDS default of an entry as an SDO upload returns it.
fn default_value(dict: &Dictionary, e: &Entry) -> Vec<u8> {
    let mut v = vec![0; e.range().len()];
    if e.in_rom() {
        v.copy_from_slice(&dict.rom[e.range()]);
    } else {
        dict.defaults.read(e.range().start, &mut v);
    }
    if e.attr.contains(Attr::NODE_ID) {
        // `$NODEID + x`: x is stored, the node-ID added at reset.
        let mut carry = u64::from(ID);
        for b in v.iter_mut() {
            let sum = u64::from(*b) + (carry & 0xFF);
            *b = sum as u8;
            carry = (carry >> 8) + (sum >> 8);
        }
    }
    if e.data_type == DataType::VisibleString
        && let Some(nul) = v.iter().position(|&c| c == 0)
    {
        v.truncate(nul);
    }
    v
}

fn dictionary<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(b: &B<O, R, T, HB>) -> &'static Dictionary {
    b.node.od().dictionary()
}

/// Entries an SDO can move: every one but DOMAINs, whose bytes belong to the application.
fn entries(dict: &'static Dictionary) -> impl Iterator<Item = &'static Entry> {
    dict.entries.iter().filter(|e| e.data_type != DataType::Domain)
}

/// Commands, not values: writing back what they read is not a signature.
fn is_command(e: &Entry) -> bool {
    matches!(e.index, 0x1010 | 0x1011) && e.sub > 0
}

/// 0x1003 sub 1..: with no error recorded (as in these tests) each is above
/// sub 0's count and holds no error: uploads abort with 0x08000024.
fn empty_history_entry(e: &Entry) -> bool {
    e.index == 0x1003 && e.sub > 0
}

/// What an upload of `e` answers on a node without errors: its default.
fn default_upload(dict: &'static Dictionary, e: &Entry) -> Result<Vec<u8>, u32> {
    if empty_history_entry(e) { Err(0x0800_0024) } else { Ok(default_value(dict, e)) }
}

// ---- 4.1, 4.7: access by access type ----------------------------------------------

fn reads_by_access_type<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(b: &mut B<O, R, T, HB>, name: &str) {
    let dict = dictionary(b);
    for e in entries(dict) {
        let got = b.sdo_upload(ID, e.index, e.sub);
        if e.readable() && empty_history_entry(e) {
            assert_eq!(got, Err(0x0800_0024), "{name} {:04X}:{}", { e.index }, { e.sub });
        } else if e.readable() {
            let v = got.unwrap_or_else(|code| panic!("{name} {:04X}:{}: abort {code:08X}", { e.index }, { e.sub }));
            if e.data_type.size().is_some() {
                assert_eq!(v.len(), usize::from(e.len), "{name} {:04X}:{}", { e.index }, { e.sub });
            } else {
                assert!(v.len() <= usize::from(e.len), "{name} {:04X}:{}", { e.index }, { e.sub });
            }
        } else {
            assert_eq!(got, Err(0x0601_0001), "{name} {:04X}:{}", { e.index }, { e.sub });
        }
    }
}

fn access_by_access_type<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    reads_by_access_type(&mut b, name);
}

#[test]
fn cct_4_1_access_by_access_type() {
    on_every_dictionary!(access_by_access_type);
}

fn access_in_operational<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    b.rx(ms(1), 0x000, &[0x01, ID]);
    b.at(ms(1));
    reads_by_access_type(&mut b, name);
}

#[test]
fn cct_4_7_access_by_access_type_in_operational() {
    on_every_dictionary!(access_in_operational);
}

// ---- 4.2, 4.8: defaults -------------------------------------------------------------

fn check_defaults<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(b: &mut B<O, R, T, HB>, name: &str) {
    let dict = dictionary(b);
    for e in entries(dict).filter(|e| e.readable()) {
        assert_eq!(b.sdo_upload(ID, e.index, e.sub), default_upload(dict, e), "{name} {:04X}:{}", { e.index }, { e.sub });
    }
}

fn defaults_after_power_on<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    check_defaults(&mut b, name);
}

#[test]
fn cct_4_2_values_are_the_eds_defaults() {
    on_every_dictionary!(defaults_after_power_on);
}

fn defaults_after_reset_node<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    // Change whatever the node accepts: every integer rw entry + 1.
    let mut changed = 0;
    for e in entries(dict).filter(|e| e.readable() && e.writable() && !is_command(e) && e.data_type.kind() != Kind::Bytes) {
        let Ok(mut v) = b.sdo_upload(ID, e.index, e.sub) else { continue };
        v[0] = v[0].wrapping_add(1);
        if b.sdo_download(ID, e.index, e.sub, &v).is_ok() {
            changed += 1;
        }
        // A heartbeat or SYNC producer may have started; time stands still, so nothing is sent.
    }
    assert!(changed > 0, "{name}");
    assert_eq!(b.nmt(0x81, ID), [(0x704, vec![0x00])], "{name}");
    check_defaults(&mut b, name);
}

#[test]
fn cct_4_8_values_are_the_eds_defaults_after_reset_node() {
    on_every_dictionary!(defaults_after_reset_node);
}

// ---- 4.3, 4.4: refused accesses -------------------------------------------------------

fn read_only_refuses_writes<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    for e in entries(dict).filter(|e| !e.writable()) {
        let mut value = default_value(dict, e);
        if value.is_empty() {
            value.push(0);
        }
        assert_eq!(b.sdo_download(ID, e.index, e.sub, &value), Err(0x0601_0002), "{name} {:04X}:{}", { e.index }, { e.sub });
        assert_eq!(b.sdo_upload(ID, e.index, e.sub), default_upload(dict, e), "{name} {:04X}:{} unchanged", { e.index }, { e.sub });
    }
}

#[test]
fn cct_4_3_read_only_entries_refuse_writes() {
    on_every_dictionary!(read_only_refuses_writes);
}

fn write_only_refuses_reads<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) -> usize {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    let mut n = 0;
    for e in dict.entries.iter().filter(|e| !e.readable()) {
        assert_eq!(b.sdo_upload(ID, e.index, e.sub), Err(0x0601_0001), "{name} {:04X}:{}", { e.index }, { e.sub });
        // A block upload too, where the device serves block transfer (else
        // its command specifier is unknown: 0x05040001).
        let [lo, hi] = e.index.to_le_bytes();
        let out = b.rx(ms(1), 0x604, &[0xA4, lo, hi, e.sub, 0x10, 0, 0, 0]);
        let code = if O::SERVICES.block_sdo { 0x0601_0001 } else { 0x0504_0001 };
        assert_eq!(out, [(0x584, common::abort(e.index, e.sub, code))], "{name}");
        n += 1;
    }
    n
}

#[test]
fn cct_4_4_write_only_entries_refuse_reads() {
    let n: usize = on_every_dictionary!(write_only_refuses_reads).iter().sum();
    assert!(n >= 10, "the devices have write-only entries ({n})");
}

// ---- 4.5: sub-index 0xFF -----------------------------------------------------------------

fn no_structure_sub_index<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    let mut last = None;
    for e in dict.entries {
        if last == Some(e.index) {
            continue;
        }
        last = Some(e.index);
        assert_eq!(b.sdo_upload(ID, e.index, 0xFF), Err(0x0609_0011), "{name} {:04X}", { e.index });
    }
}

#[test]
fn cct_4_5_sub_index_255_is_absent_so_the_case_is_skipped() {
    on_every_dictionary!(no_structure_sub_index);
}

// ---- 4.6: limits ---------------------------------------------------------------------------

/// The little-endian bytes of `v` in an entry of `len` bytes.
fn le(v: i128, len: usize) -> Vec<u8> {
    v.to_le_bytes()[..len].to_vec()
}

fn limits_respected<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) -> usize {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    let mut checked = 0;
    for e in entries(dict).filter(|e| e.writable() && e.readable()) {
        let Some(limits) = dict.limits_of(e) else { continue };
        let len = usize::from(e.len);
        let bits = 8 * len as u32;
        let (low, high, min, max) = match e.data_type.kind() {
            Kind::Signed => (limits.low as i64 as i128, limits.high as i64 as i128, -(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1),
            Kind::Unsigned => (i128::from(limits.low), i128::from(limits.high), 0, (1i128 << bits) - 1),
            _ => continue,
        };
        let at = format!("{name} {:04X}:{}", { e.index }, { e.sub });
        let original = b.sdo_upload(ID, e.index, e.sub).unwrap();
        if low > min {
            assert_eq!(b.sdo_download(ID, e.index, e.sub, &le(low - 1, len)), Err(0x0609_0032), "{at} low − 1");
        }
        if high < max {
            assert_eq!(b.sdo_download(ID, e.index, e.sub, &le(high + 1, len)), Err(0x0609_0031), "{at} high + 1");
        }
        for v in [low, high] {
            match b.sdo_download(ID, e.index, e.sub, &le(v, len)) {
                Ok(()) => {}
                Err(code) if e.index < 0x2000 && matches!(code, 0x0609_0030 | 0x0601_0000 | 0x0602_0000 | 0x0604_0041..=0x0604_0043) => {}
                Err(code) => panic!("{at} {v} in range, refused {code:08X}"),
            }
        }
        assert_eq!(b.sdo_download(ID, e.index, e.sub, &original), Ok(()), "{at} back to the original value");
        checked += 1;
    }
    checked
}

#[test]
fn cct_4_6_limits_are_respected() {
    let n: usize = on_every_dictionary!(limits_respected).iter().sum();
    assert!(n > 100, "entries with limits checked: {n}");
}

// ---- 4.9: read and write back ------------------------------------------------------------------

fn read_and_write_back<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(ram: O, name: &str) {
    let mut b = boot::<O, R, T, HB>(ram);
    let dict = dictionary(&b);
    for e in entries(dict).filter(|e| e.readable() && e.writable() && !is_command(e)) {
        let at = format!("{name} {:04X}:{}", { e.index }, { e.sub });
        let value = b.sdo_upload(ID, e.index, e.sub).unwrap_or_else(|code| panic!("{at}: abort {code:08X}"));
        assert_eq!(b.sdo_download(ID, e.index, e.sub, &value), Ok(()), "{at}");
        assert_eq!(b.sdo_upload(ID, e.index, e.sub), Ok(value), "{at}");
    }
}

#[test]
fn cct_4_9_rw_entries_read_and_write_back() {
    on_every_dictionary!(read_and_write_back);
}
