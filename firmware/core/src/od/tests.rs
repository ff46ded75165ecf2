//! Tests of the runtime dictionary on a small hand-built table, laid out the
//! way od-gen lays out generated ones.

use super::*;
use crate::abort::AbortCode;

const fn e(index: u16, sub: u8, data_type: DataType, attr: Attr, len: u8, offset: u16) -> Entry {
    Entry::new(index, sub, data_type, attr, len, offset)
}

const RO: Attr = Attr::READ;
const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
const CONST: Attr = Attr(Attr::READ.0 | Attr::IN_ROM.0);

static ENTRIES: [Entry; 8] = [
    e(0x1000, 0, DataType::Unsigned32, CONST, 4, 0),
    e(0x1001, 0, DataType::Unsigned8, RO, 1, 0),
    e(0x1008, 0, DataType::VisibleString, CONST, 6, 4),
    e(0x1014, 0, DataType::Unsigned32, Attr(RW.0 | Attr::NODE_ID.0), 4, 1),
    e(0x1017, 0, DataType::Unsigned16, RW, 2, 5),
    e(0x2000, 0, DataType::Integer16, RW, 2, 7),
    e(0x2001, 0, DataType::VisibleString, RW, 4, 9),
    e(0x2002, 0, DataType::Unsigned8, Attr(Attr::WRITE.0), 1, 13),
];
static LIMITS: [Limits; 1] = [Limits { low: -100i64 as u64, high: 100 }];
static ROM: [u8; 10] = [0x92, 0x01, 0x02, 0x00, b'd', b'e', b'v', b'i', b'c', b'e'];
static DEFAULTS: [u8; 14] = [0, 0x80, 0, 0, 0, 0xE8, 0x03, 5, 0, b'a', b'b', 0, 0, 0];
static DICT: Dictionary = Dictionary {
    entries: &ENTRIES,
    limits: &LIMITS,
    limit_rows: &[NO_LIMITS, NO_LIMITS, NO_LIMITS, NO_LIMITS, NO_LIMITS, 0, NO_LIMITS, NO_LIMITS],
    rom: &ROM,
    defaults: crate::od::Defaults::dense(&DEFAULTS),
    comm_len: 7,
    stored_len: 14,
    comm_rest: 0,
    node_id_relative: &[3],
    layout_id: crate::od::layout_id(&ENTRIES),
    device: DeviceInfo {
        baud_rates: 0x1FF,
        lss_supported: true,
        granularity: 8,
        simple_boot_up_slave: true,
        dynamic_channels: false,
        group_messaging: false,
    },
};

fn image(node_id: u8) -> [u8; 14] {
    let mut img = [0xAA; 14];
    DICT.reset_application(&mut img, node_id);
    DICT.reset_communication(&mut img, node_id);
    img
}

#[test]
fn find_tells_missing_object_from_missing_sub_index() {
    assert_eq!(DICT.find(0x1017, 0).map(|e| e.offset), Ok(5));
    assert_eq!(DICT.find(0x1017, 1), Err(AbortCode::NoSubIndex));
    assert_eq!(DICT.find(0x1002, 0), Err(AbortCode::NoObject));
    assert_eq!(DICT.find(0x0000, 0), Err(AbortCode::NoObject));
    assert_eq!(DICT.find(0xFFFF, 0xFF), Err(AbortCode::NoObject));
}

#[test]
fn const_values_come_from_rom_and_node_id_is_resolved() {
    let img = image(0x22);
    assert_eq!(DICT.read(&img, 0x1000, 0), Ok(&[0x92, 0x01, 0x02, 0x00][..]));
    assert_eq!(DICT.read(&img, 0x1008, 0), Ok(&b"device"[..]));
    assert_eq!(DICT.read(&img, 0x1014, 0), Ok(&[0xA2, 0, 0, 0][..]));
    assert_eq!(DICT.read(&img, 0x2001, 0), Ok(&b"ab"[..]));
}

#[test]
fn reset_communication_leaves_the_application_area_alone() {
    let mut img = image(1);
    DICT.write(&mut img, 0x1017, 0, &[0x10, 0x00]).unwrap();
    DICT.write(&mut img, 0x2000, 0, &7i16.to_le_bytes()).unwrap();
    DICT.reset_communication(&mut img, 5);
    assert_eq!(DICT.read(&img, 0x1017, 0), Ok(&[0xE8, 0x03][..]));
    assert_eq!(DICT.read(&img, 0x1014, 0), Ok(&[0x85, 0, 0, 0][..]));
    assert_eq!(DICT.read(&img, 0x2000, 0), Ok(&[7, 0][..]));
    DICT.reset_application(&mut img, 5);
    assert_eq!(DICT.read(&img, 0x2000, 0), Ok(&[5, 0][..]));
}

/// Without stored application values (`comm_len == stored_len`) the two
/// communication ranges touch and are restored in one call; the empty
/// application range is skipped. The bytes are those of the ranges alone.
#[test]
fn touching_communication_ranges_restore_as_the_two_would() {
    // Bytes 0..5 stored communication, 5..9 communication not stored, 9..14 application.
    let dict = Dictionary { comm_len: 5, stored_len: 5, comm_rest: 4, ..DICT };
    let mut img = [0xAA; 14];
    dict.reset_communication(&mut img, 0x22);
    assert_eq!(img, [0, 0xA2, 0, 0, 0, 0xE8, 0x03, 5, 0, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA]);
    img = [0xAA; 14];
    dict.reset_application(&mut img, 0x22);
    assert_eq!(img, [0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, b'a', b'b', 0, 0, 0]);
}

#[test]
fn writes_are_checked_before_anything_changes() {
    let mut img = image(1);
    let before = img;
    assert_eq!(DICT.write(&mut img, 0x1000, 0, &[0; 4]), Err(AbortCode::ReadOnly));
    assert_eq!(DICT.write(&mut img, 0x1001, 0, &[0]), Err(AbortCode::ReadOnly));
    assert_eq!(DICT.write(&mut img, 0x1017, 0, &[0]), Err(AbortCode::LengthTooLow));
    assert_eq!(DICT.write(&mut img, 0x1017, 0, &[0, 0, 0]), Err(AbortCode::LengthTooHigh));
    assert_eq!(DICT.write(&mut img, 0x2000, 0, &101i16.to_le_bytes()), Err(AbortCode::ValueTooHigh));
    assert_eq!(DICT.write(&mut img, 0x2000, 0, &(-101i16).to_le_bytes()), Err(AbortCode::ValueTooLow));
    assert_eq!(DICT.write(&mut img, 0x2001, 0, b"abcde"), Err(AbortCode::LengthTooHigh));
    assert_eq!(DICT.write(&mut img, 0x3000, 0, &[0]), Err(AbortCode::NoObject));
    assert_eq!(img, before);
    assert_eq!(DICT.read(&img, 0x2002, 0), Err(AbortCode::WriteOnly));
}

#[test]
fn a_shorter_string_is_nul_filled() {
    let mut img = image(1);
    DICT.write(&mut img, 0x2001, 0, b"wxyz").unwrap();
    DICT.write(&mut img, 0x2001, 0, b"q").unwrap();
    assert_eq!(DICT.read(&img, 0x2001, 0), Ok(&b"q"[..]));
    assert_eq!(load_str(&img, 9, 4), b"q");
    assert_eq!(store_str(&mut img, 9, 4, b"toolong"), 4);
    assert_eq!(load_str(&img, 9, 4), b"tool");
}

#[test]
fn load_and_store_never_panic_out_of_range() {
    let mut img = [1u8; 4];
    assert_eq!(load::<4>(&img, 2), [0; 4]);
    store::<2>(&mut img, 3, [9, 9]);
    assert_eq!(img, [1; 4]);
    store::<2>(&mut img, 2, [9, 9]);
    assert_eq!(load::<2>(&img, 2), [9, 9]);
}

#[test]
fn node_id_addition_wraps_at_the_entry_width() {
    let mut b = [0xFF, 0xFF];
    add_node_id(&mut b, 2, false);
    assert_eq!(b, [1, 0]);
    let mut c = [0xFE, 0x00, 0x00, 0x80];
    add_node_id(&mut c, 0x7F, false);
    assert_eq!(c, [0x7D, 0x01, 0x00, 0x80]);
}

#[test]
fn node_id_subtraction_wraps_at_the_entry_width_and_undoes_the_addition() {
    let mut b = [1, 0];
    add_node_id(&mut b, 2, true);
    assert_eq!(b, [0xFF, 0xFF], "borrows through every byte");
    let mut c = [0x7D, 0x01, 0x00, 0x80];
    add_node_id(&mut c, 0x7F, true);
    assert_eq!(c, [0xFE, 0x00, 0x00, 0x80]);
    let mut one = [0x05];
    add_node_id(&mut one, 0x05, true);
    assert_eq!(one, [0]);
    // Every width, node-id and value: minus then plus gives the value back, as u64 wrapping arithmetic says.
    for id in [0u8, 1, 0x22, 0x7F, 0xFF] {
        for v in [0u64, 1, 0x80, 0xFF, 0x100, 0x4000_0180, u64::MAX] {
            for len in 1..=8usize {
                let mut bytes = v.to_le_bytes();
                add_node_id(&mut bytes[..len], id, true);
                let mask = if len == 8 { u64::MAX } else { (1u64 << (8 * len)) - 1 };
                let expected = (v.wrapping_sub(u64::from(id)) & mask) | (v & !mask);
                assert_eq!(u64::from_le_bytes(bytes), expected, "{v:#x} - {id} in {len} bytes");
                add_node_id(&mut bytes[..len], id, false);
                assert_eq!(u64::from_le_bytes(bytes), v, "{v:#x} back in {len} bytes");
            }
        }
    }
}

#[test]
fn odd_sized_integers_load_and_store() {
    let mut img = [0u8; 8];
    store_uint::<3>(&mut img, 1, (-2i64) as u64);
    assert_eq!(img, [0, 0xFE, 0xFF, 0xFF, 0, 0, 0, 0]);
    assert_eq!(load_int::<3>(&img, 1), -2);
    assert_eq!(load_uint::<3>(&img, 1), 0xFF_FFFE);
    store_uint::<5>(&mut img, 3, 0x12_3456_789A);
    assert_eq!(load_uint::<5>(&img, 3), 0x12_3456_789A);
    // Out of range: reads give zero, writes change nothing.
    assert_eq!(load_uint::<5>(&img, 4), 0);
    let before = img;
    store_uint::<5>(&mut img, 4, 1);
    assert_eq!(img, before);
}

#[test]
fn dictionary_access_reads_in_pieces_and_checks_downloads() {
    let mut img = image(1);
    let mut od = DictionaryAccess { dictionary: &DICT, image: &mut img };
    assert_eq!(od.upload_size(0x1008, 0), Ok(6));
    let mut buf = [0u8; 4];
    assert_eq!(od.read(0x1008, 0, 0, &mut buf), Ok(4));
    assert_eq!(&buf, b"devi");
    assert_eq!(od.read(0x1008, 0, 4, &mut buf), Ok(2));
    assert_eq!(&buf[..2], b"ce");
    assert_eq!(od.read(0x1008, 0, 9, &mut buf), Ok(0));
    assert_eq!(od.upload_size(0x2002, 0), Err(AbortCode::WriteOnly));
    assert_eq!(od.upload_size(0x2003, 0), Err(AbortCode::NoObject));
    assert_eq!(od.upload_size(0x1017, 9), Err(AbortCode::NoSubIndex));
    assert_eq!(od.download_check(0x1000, 0, Some(4)), Err(AbortCode::ReadOnly));
    assert_eq!(od.download_check(0x1017, 0, Some(3)), Err(AbortCode::LengthTooHigh));
    assert_eq!(od.download_check(0x1017, 0, Some(1)), Err(AbortCode::LengthTooLow));
    assert_eq!(od.download_check(0x2001, 0, Some(1)), Ok(()));
    assert_eq!(od.download_check(0x2001, 0, None), Ok(()));
    assert_eq!(od.write(0x2000, 0, &200i16.to_le_bytes()), Err(AbortCode::ValueTooHigh));
    assert_eq!(od.write(0x1017, 0, &[0x64, 0]), Ok(()));
    assert_eq!(od.upload_size(0x1017, 0), Ok(2));
}

#[test]
fn a_write_tells_whether_the_image_changed() {
    let mut img = image(1);
    let (entry, changed) = DICT.write_entry(&mut img, 0x2000, 0, &7i16.to_le_bytes()).unwrap();
    assert_eq!((entry.index, changed), (0x2000, true));
    assert!(!DICT.write_entry(&mut img, 0x2000, 0, &7i16.to_le_bytes()).unwrap().1, "the same value");
    // A shorter string clears the rest of its slot: a change even where its bytes match.
    assert!(DICT.write_entry(&mut img, 0x2001, 0, b"abcd").unwrap().1);
    assert!(DICT.write_entry(&mut img, 0x2001, 0, b"ab").unwrap().1);
    assert!(!DICT.write_entry(&mut img, 0x2001, 0, b"ab").unwrap().1);
    assert_eq!(DICT.read(&img, 0x2001, 0), Ok(&b"ab"[..]));
}

#[test]
fn an_entry_holds_the_store_scope_of_its_index_and_the_layout_id_ignores_it() {
    // Communication below 0x2000, manufacturer 0x2000-0x5FFF, application above.
    for (index, scope) in [(0x0000, 0), (0x1FFF, 0), (0x2000, 1), (0x5FFF, 1), (0x6000, 2), (0xFFFF, 2)] {
        // Scope bits passed in are replaced by the index's.
        let entry = Entry::new(index, 0, DataType::Unsigned8, Attr(RW.0 | Attr::SCOPE.0), 1, 0);
        assert_eq!(entry.attr, Attr(RW.0 | scope << 6), "{index:#06X}");
        assert_eq!(entry.communication(), scope == 0);
        let bare = Entry { attr: RW, ..entry };
        assert_eq!(layout_id(&[entry]), layout_id(&[bare]));
    }
}

#[test]
fn an_entry_is_eight_bytes_in_flash() {
    // The largest dictionary has about 380 entries (Entry's docs): the
    // limits row is in a table of its own, which a dictionary without
    // limits leaves empty, and the length is one byte.
    assert_eq!(core::mem::size_of::<Entry>(), 8);
}

#[test]
fn the_limits_row_of_an_entry_is_its_place_in_limit_rows() {
    // 0x2000 is the sixth entry, row 0; its neighbours have none.
    assert_eq!(DICT.limits_of(DICT.find(0x2000, 0).unwrap()), Some(&LIMITS[0]));
    assert_eq!(DICT.limits_of(DICT.find(0x1017, 0).unwrap()), None);
    assert_eq!(DICT.limits_of(DICT.find(0x2001, 0).unwrap()), None);
    // A dictionary without limits has no rows: no entry has any.
    let bare = Dictionary { limit_rows: &[], ..DICT };
    assert_eq!(bare.limits_of(bare.find(0x2000, 0).unwrap()), None);
    // An entry that is not in the table has none, and nothing panics.
    let stray = e(0x2000, 0, DataType::Integer16, RW, 2, 7);
    assert_eq!(DICT.limits_of(&stray), None);
}

/// `read_entry` as it was before it shared the SDO upload's reading
/// (`access::upload_value`), and that reading as it was before its checks
/// were reordered: every data type, every access, in RAM and in flash,
/// must read the same bytes or fail with the same abort code.
#[test]
fn read_entry_and_the_upload_reading_read_what_they_read_before() {
    fn before<'a>(dict: &Dictionary, image: &'a [u8], entry: &Entry) -> Result<&'a [u8], AbortCode> {
        if !entry.readable() {
            return Err(AbortCode::WriteOnly);
        }
        if entry.data_type == DataType::Domain {
            return Err(AbortCode::CannotStore);
        }
        let value = dict.value(image, entry);
        Ok(if entry.data_type == DataType::VisibleString { until_nul(value) } else { value })
    }
    // `access::upload_value` before its checks were put in read order.
    fn upload_before<'a>(dict: &Dictionary, image: &'a [u8], entry: &Entry) -> Result<&'a [u8], AbortCode> {
        if entry.data_type == DataType::Domain {
            return if entry.readable() { Err(AbortCode::NoData) } else { Err(AbortCode::WriteOnly) };
        }
        if !entry.readable() {
            return Err(AbortCode::WriteOnly);
        }
        let value = dict.value(image, entry);
        Ok(if entry.data_type == DataType::VisibleString { until_nul(value) } else { value })
    }
    // A string ending early (NUL at 2) in both the image and flash.
    let image = [b'a', b'b', 0, b'd', 5, 6];
    let mut checked = 0;
    for data_type in DataType::ALL {
        for attr in [0, Attr::READ.0, Attr::WRITE.0, Attr::READ.0 | Attr::WRITE.0] {
            for rom in [0, Attr::IN_ROM.0] {
                for (len, offset) in [(4, 0), (1, 4), (0, 6), (3, 5)] {
                    let entry = e(0x2000, 0, data_type, Attr(attr | rom), len, offset);
                    assert_eq!(DICT.read_entry(&image, &entry), before(&DICT, &image, &entry), "{entry:?}");
                    assert_eq!(access::upload_value(&DICT, &image, &entry), upload_before(&DICT, &image, &entry), "{entry:?}");
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 25 * 4 * 2 * 4);
}

/// A writable and a read-only DOMAIN beside a fixed-size value, in a table without limits.
static DOMAINS: [Entry; 3] =
    [e(0x1017, 0, DataType::Unsigned16, RW, 2, 0), e(0x2100, 0, DataType::Domain, RW, 0, 2), e(0x2101, 0, DataType::Domain, RO, 0, 2)];
static DOMAIN_DICT: Dictionary =
    Dictionary { entries: &DOMAINS, limits: &[], limit_rows: &[NO_LIMITS; 3], comm_len: 2, stored_len: 2, ..DICT };

#[test]
fn the_checks_without_limits_take_a_writable_domain_for_a_write_not_for_a_download() {
    let checked = |index, size, domain| checked_entry(&DOMAIN_DICT, index, 0, size, domain).map(|e| e.index);
    // A write (`precheck`): a writable DOMAIN has no length to check.
    assert_eq!(precheck::<false>(&DOMAIN_DICT, 0x2100, 0, &[1, 2, 3]).map(|e| e.index), Ok(0x2100));
    assert_eq!(precheck::<false>(&DOMAIN_DICT, 0x2101, 0, &[1]), Err(AbortCode::ReadOnly));
    assert_eq!(precheck::<false>(&DOMAIN_DICT, 0x1017, 0, &[1, 2, 3]), Err(AbortCode::LengthTooHigh));
    // An SDO download's initiate: a DOMAIN cannot be stored (0x08000020), read-only first.
    assert_eq!(checked(0x2100, Some(3), false), Err(AbortCode::CannotStore));
    assert_eq!(checked(0x2100, None, false), Err(AbortCode::CannotStore));
    assert_eq!(checked(0x2101, None, false), Err(AbortCode::ReadOnly));
    // The length, when the initiate tells it; none told passes.
    assert_eq!(checked(0x1017, Some(3), false), Err(AbortCode::LengthTooHigh));
    assert_eq!(checked(0x1017, Some(1), false), Err(AbortCode::LengthTooLow));
    assert_eq!(checked(0x1017, Some(2), false), Ok(0x1017));
    assert_eq!(checked(0x1017, None, false), Ok(0x1017));
    assert_eq!(checked(0x1018, None, false), Err(AbortCode::NoObject));
    assert_eq!(checked(0x1017, None, true), Ok(0x1017));
}
