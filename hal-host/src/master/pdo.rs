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
