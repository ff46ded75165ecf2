//! The look-ups the services share, one of each: an object's entries, a
//! sub-index among them, an integer value, and the checks every download
//! passes before the object's owner applies its rules. The SDO router, the
//! PDO and SYNC services and the profiles all use these.

use super::{DataType, Dictionary, Entry};
use crate::abort::AbortCode;

/// The entries of object `index`: a binary search for the first, then the
/// object's few entries in a row (one search and a short walk are less
/// code than a second search for the end).
pub(crate) fn object(dict: &Dictionary, index: u16) -> &'static [Entry] {
    let rest = dict.object_onwards(index);
    let len = rest.iter().position(|e| e.index != index).unwrap_or(rest.len());
    rest.get(..len).unwrap_or(&[])
}

/// Sub-index `sub` within the entries of one object (at most 255 of them).
// Out of line, as `value_u32`: a dozen callers each had a copy (536 bytes for both).
#[inline(never)]
pub(crate) fn sub_entry(record: &'static [Entry], sub: u8) -> Option<&'static Entry> {
    record.iter().find(|e| e.sub == sub)
}

/// The value of an integer entry of up to 4 bytes, little-endian.
// Out of line: see `sub_entry`.
#[inline(never)]
pub(crate) fn value_u32(dict: &Dictionary, image: &[u8], entry: &Entry) -> u32 {
    le_u32(dict.value(image, entry))
}

/// Up to 4 little-endian bytes as a `u32` (missing bytes read as 0): the
/// value of an integer entry of at most 32 bits.
// Out of line: it had a copy in each of its callers (66 bytes more).
#[inline(never)]
pub fn le_u32(bytes: &[u8]) -> u32 {
    // Four bytes or more (a 32-bit value, the commonest): one load, no
    // copy call (2 B less flash than without this arm).
    if let [a, b, c, d, ..] = *bytes {
        return u32::from_le_bytes([a, b, c, d]);
    }
    let mut b = [0u8; 4];
    for (dst, src) in b.iter_mut().zip(bytes) {
        *dst = *src;
    }
    u32::from_le_bytes(b)
}

/// Exactly 4 little-endian bytes as a `u32` (a COB-ID or a signature in a
/// download), or the abort code for the wrong length.
pub(crate) fn u32_exact(data: &[u8]) -> Result<u32, AbortCode> {
    match *data {
        [a, b, c, d] => Ok(u32::from_le_bytes([a, b, c, d])),
        [_, _, _, _, _, ..] => Err(AbortCode::LengthTooHigh),
        _ => Err(AbortCode::LengthTooLow),
    }
}

/// The checks every download passes before the object's own rules: the
/// entry exists and is writable, the length fits, and the value is within
/// the EDS limits; a writable DOMAIN has no length or limits to check here.
/// So an access or range error gets its own abort code (0x06010002,
/// 0x0607001x, 0x06090031/32) whatever the object's owner would say about
/// the value. `LIMITS`: whether the dictionary has any
/// ([`super::ObjectDictionary::HAS_LIMITS`]): a dictionary without links no
/// limit check.
pub(crate) fn precheck<const LIMITS: bool>(dict: &Dictionary, index: u16, sub: u8, data: &[u8]) -> Result<&'static Entry, AbortCode> {
    if !LIMITS {
        return checked_entry(dict, index, sub, Some(data.len()), true);
    }
    let entry = dict.find(index, sub)?;
    if entry.data_type == DataType::Domain && entry.writable() {
        return Ok(entry);
    }
    dict.check_write(entry, data)?;
    Ok(entry)
}

/// [`precheck`] without limits, for a value of `size` bytes (`None`: not
/// known yet, as an SDO download's initiate may leave it); a writable
/// DOMAIN is taken if `domain`, else refused (0x08000020: a download
/// cannot store one). One copy for the writes of a dictionary without
/// limits and the SDO download checks of every dictionary (0x1010/0x1011 apart).
pub(crate) fn checked_entry(
    dict: &Dictionary,
    index: u16,
    sub: u8,
    size: Option<usize>,
    domain: bool,
) -> Result<&'static Entry, AbortCode> {
    let entry = dict.find(index, sub)?;
    if entry.data_type == DataType::Domain && entry.writable() {
        return if domain { Ok(entry) } else { Err(AbortCode::CannotStore) };
    }
    dict.check_size(entry, size)?;
    Ok(entry)
}
