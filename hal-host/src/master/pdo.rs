//! PDO payloads as the master sees them. CiA 301 v4.2 §7.2.2 (PDO);
//! mapping records §7.5.2.36 (RPDO, 0x1600–0x17FF) and §7.5.2.38 (TPDO,
//! 0x1A00–0x1BFF); default COB-IDs §7.3.5 (pre-defined connection set).
//!
//! The mapped objects follow each other in mapping order, packed bit by
//! bit, least significant bit first: an object of `bits` bits at bit offset
//! `o` holds bits `o..o + bits` of the payload read as a little-endian
//! integer. A PDO has at most 64 bits, so each value fits a `u64`. Entries
//! are the core's [`MappingEntry`]; dummy entries (index 0x0001–0x0007,
//! sub-index 0) take their bits like any other.

pub use canopen_core::wire::pdo_mapping::MappingEntry;

/// Bits in the largest PDO (8 data bytes).
pub const MAX_PDO_BITS: usize = 64;

/// One mapped object's value out of a PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PdoValue {
    /// The mapping entry the value belongs to.
    pub entry: MappingEntry,
    /// The entry's bits, zero-extended.
    pub raw: u64,
}

impl PdoValue {
    /// The value as a signed integer of `entry.bits` bits (INTEGERn), sign-extended.
    pub fn signed(&self) -> i64 {
        let bits = u32::from(self.entry.bits);
        if bits == 0 || bits >= 64 {
            return self.raw as i64;
        }
        let shift = 64 - bits;
        ((self.raw << shift) as i64) >> shift
    }

    /// The value's little-endian bytes, as an SDO transfer of the object
    /// would carry them (one byte per started 8 bits).
    pub fn to_le_bytes(&self) -> Vec<u8> {
        self.raw.to_le_bytes().into_iter().take(usize::from(self.entry.bits).div_ceil(8)).collect()
    }
}

/// Why a payload does not fit a mapping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoError {
    /// The mapping has more than [`MAX_PDO_BITS`] bits (CiA 301 abort 0x06040042 when mapping).
    TooManyBits {
        /// Total bits of the mapping.
        bits: usize,
    },
    /// The payload is shorter than the mapping (a node raises EMCY 0x8210 for this).
    TooShort {
        /// Bytes the mapping needs.
        needed: usize,
        /// Bytes received.
        len: usize,
    },
    /// [`encode`] got a different number of values than the mapping has entries.
    ValueCount {
        /// Entries in the mapping.
        entries: usize,
        /// Values given.
        values: usize,
    },
    /// A value has bits set above its entry's length.
    ValueTooWide {
        /// Position of the value in the mapping.
        position: usize,
    },
}

impl core::fmt::Display for PdoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PdoError::TooManyBits { bits } => write!(f, "mapping of {bits} bits exceeds {MAX_PDO_BITS}"),
            PdoError::TooShort { needed, len } => write!(f, "PDO of {len} bytes, mapping needs {needed}"),
            PdoError::ValueCount { entries, values } => write!(f, "{values} values for {entries} mapping entries"),
            PdoError::ValueTooWide { position } => write!(f, "value {position} does not fit its entry"),
        }
    }
}

impl std::error::Error for PdoError {}

/// Total bits of a mapping.
pub fn mapped_bits(mapping: &[MappingEntry]) -> usize {
    mapping.iter().map(|e| usize::from(e.bits)).sum()
}

/// Bytes a PDO with this mapping carries.
pub fn mapped_len(mapping: &[MappingEntry]) -> usize {
    mapped_bits(mapping).div_ceil(8)
}

/// The mask of the low `bits` bits.
fn mask(bits: u8) -> u64 {
    match bits {
        0 => 0,
        b if b >= 64 => u64::MAX,
        b => (1u64 << b) - 1,
    }
}

fn check_bits(mapping: &[MappingEntry]) -> Result<(), PdoError> {
    let bits = mapped_bits(mapping);
    if bits > MAX_PDO_BITS { Err(PdoError::TooManyBits { bits }) } else { Ok(()) }
}

/// Splits a PDO payload (a TPDO the node sent) into one value per entry.
/// Bytes beyond the mapping are ignored, as CiA 301 lets a receiver do.
pub fn decode(mapping: &[MappingEntry], payload: &[u8]) -> Result<Vec<PdoValue>, PdoError> {
    check_bits(mapping)?;
    let needed = mapped_len(mapping);
    if payload.len() < needed {
        return Err(PdoError::TooShort { needed, len: payload.len() });
    }
    let mut word = [0u8; 8];
    for (w, b) in word.iter_mut().zip(payload) {
        *w = *b;
    }
    let word = u64::from_le_bytes(word);
    let mut offset = 0u32;
    let mut values = Vec::with_capacity(mapping.len());
    for &entry in mapping {
        let raw = word.checked_shr(offset).unwrap_or(0) & mask(entry.bits);
        values.push(PdoValue { entry, raw });
        offset = offset.saturating_add(u32::from(entry.bits));
    }
    Ok(values)
}

/// Packs one value per entry into a PDO payload (an RPDO for the node), of
/// [`mapped_len`] bytes. Give dummy entries a value too (normally 0).
pub fn encode(mapping: &[MappingEntry], values: &[u64]) -> Result<Vec<u8>, PdoError> {
    check_bits(mapping)?;
    if mapping.len() != values.len() {
        return Err(PdoError::ValueCount { entries: mapping.len(), values: values.len() });
    }
    let mut word = 0u64;
    let mut offset = 0u32;
    for (position, (entry, &value)) in mapping.iter().zip(values).enumerate() {
        if value & !mask(entry.bits) != 0 {
            return Err(PdoError::ValueTooWide { position });
        }
        word |= value.checked_shl(offset).unwrap_or(0);
        offset = offset.saturating_add(u32::from(entry.bits));
    }
    Ok(word.to_le_bytes().into_iter().take(mapped_len(mapping)).collect())
}

/// Default COB-ID of TPDO `pdo` (1..=4) of node `node_id` (1..=127): 0x180,
/// 0x280, 0x380, 0x480 + node-ID (CiA 301 table 72).
pub fn tpdo_cob_id(pdo: u8, node_id: u8) -> Option<u16> {
    default_cob_id(0x180, pdo, node_id)
}

/// Default COB-ID of RPDO `pdo` (1..=4) of node `node_id` (1..=127): 0x200,
/// 0x300, 0x400, 0x500 + node-ID (CiA 301 table 72).
pub fn rpdo_cob_id(pdo: u8, node_id: u8) -> Option<u16> {
    default_cob_id(0x200, pdo, node_id)
}

fn default_cob_id(base: u16, pdo: u8, node_id: u8) -> Option<u16> {
    if !(1..=4).contains(&pdo) || !(1..=127).contains(&node_id) {
        return None;
    }
    // The four PDOs of the pre-defined connection set are 0x100 apart.
    Some(base + 0x100 * u16::from(pdo - 1) + u16::from(node_id))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    const STATUSWORD: MappingEntry = MappingEntry { index: 0x6041, sub: 0, bits: 16 };
    const POSITION: MappingEntry = MappingEntry { index: 0x6064, sub: 0, bits: 32 };

    #[test]
    fn decodes_byte_aligned_objects_in_mapping_order() {
        // CiA 402-3 TPDO2 style: statusword 0x0237, position actual 0x12345678.
        let v = decode(&[STATUSWORD, POSITION], &[0x37, 0x02, 0x78, 0x56, 0x34, 0x12]).unwrap();
        assert_eq!((v[0].entry, v[0].raw, v[1].raw), (STATUSWORD, 0x0237, 0x1234_5678));
        assert_eq!(v[1].to_le_bytes(), [0x78, 0x56, 0x34, 0x12]);
        // Extra bytes are ignored; missing ones are an error.
        assert_eq!(decode(&[STATUSWORD], &[1, 2, 3]).unwrap()[0].raw, 0x0201);
        assert_eq!(decode(&[STATUSWORD, POSITION], &[0; 5]), Err(PdoError::TooShort { needed: 6, len: 5 }));
        assert_eq!(decode(&[], &[]), Ok(vec![]));
    }

    #[test]
    fn packs_bits_least_significant_first() {
        let m = [
            MappingEntry { index: 0x2000, sub: 1, bits: 1 },
            MappingEntry { index: 0x0005, sub: 0, bits: 3 }, // dummy
            MappingEntry { index: 0x2000, sub: 2, bits: 12 },
            MappingEntry { index: 0x2000, sub: 3, bits: 8 },
        ];
        // 1 | 5 << 1 | 0xABC << 4 | 0x7F << 16 = 0x7F_ABCB; 0xABC as INTEGER12 is 2748 - 4096.
        let payload = encode(&m, &[1, 5, 0xABC, 0x7F]).unwrap();
        assert_eq!(payload, [0xCB, 0xAB, 0x7F]);
        let v = decode(&m, &payload).unwrap();
        assert_eq!(v.iter().map(|v| v.raw).collect::<Vec<_>>(), [1, 5, 0xABC, 0x7F]);
        assert!(v[1].entry.is_dummy());
        assert_eq!((v[2].signed(), v[2].to_le_bytes()), (-1348, vec![0xBC, 0x0A]));
        assert_eq!(mapped_len(&m), 3);
    }

    #[test]
    fn signed_values_and_full_width() {
        let e = |bits| MappingEntry { index: 0x2001, sub: 0, bits };
        assert_eq!(PdoValue { entry: e(16), raw: 0x8000 }.signed(), -32768);
        assert_eq!(PdoValue { entry: e(16), raw: 0x7FFF }.signed(), 32767);
        assert_eq!(PdoValue { entry: e(64), raw: u64::MAX }.signed(), -1);
        assert_eq!(PdoValue { entry: e(0), raw: 0 }.signed(), 0);
        let full = encode(&[e(64)], &[0x0102_0304_0506_0708]).unwrap();
        assert_eq!(full, [8, 7, 6, 5, 4, 3, 2, 1]);
        assert_eq!(decode(&[e(64)], &full).unwrap()[0].raw, 0x0102_0304_0506_0708);
        // A zero-length entry after 64 bits takes nothing and shifts nothing.
        assert_eq!(decode(&[e(64), e(0)], &full).unwrap()[1].raw, 0);
    }

    #[test]
    fn encode_and_decode_errors() {
        let m = [POSITION, POSITION, MappingEntry { index: 0x2000, sub: 0, bits: 1 }];
        assert_eq!(decode(&m, &[0; 8]), Err(PdoError::TooManyBits { bits: 65 }));
        assert_eq!(encode(&m, &[0, 0, 0]), Err(PdoError::TooManyBits { bits: 65 }));
        assert_eq!(encode(&[STATUSWORD], &[]), Err(PdoError::ValueCount { entries: 1, values: 0 }));
        assert_eq!(encode(&[STATUSWORD, STATUSWORD], &[1, 0x1_0000]), Err(PdoError::ValueTooWide { position: 1 }));
    }

    #[test]
    fn default_cob_ids() {
        assert_eq!(tpdo_cob_id(1, 5), Some(0x185));
        assert_eq!(tpdo_cob_id(4, 127), Some(0x4FF));
        assert_eq!(rpdo_cob_id(1, 1), Some(0x201));
        assert_eq!(rpdo_cob_id(4, 0x7F), Some(0x57F));
        assert_eq!(rpdo_cob_id(0, 5), None);
        assert_eq!(tpdo_cob_id(5, 5), None);
        assert_eq!(tpdo_cob_id(1, 0), None);
        assert_eq!(tpdo_cob_id(1, 128), None);
    }
}
