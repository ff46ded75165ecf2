//! PDO mapping entry format. CiA 301 v4.2 §7.5.2.36 (RPDO mapping,
//! 0x1600–0x17FF) and §7.5.2.38 (TPDO mapping, 0x1A00–0x1BFF).
//!
//! Each of sub-indices 1..=64 of a mapping record is an UNSIGNED32:
//!
//! ```text
//! bits 31..16  index of the mapped object
//! bits 15..8   sub-index of the mapped object
//! bits  7..0   length of the mapped object in bits
//! ```
//!
//! Indices 0x0001–0x0007 (the basic data types BOOLEAN … UNSIGNED32) with
//! sub-index 0 are *dummy entries*: in an RPDO they skip that many bits of
//! the received data (CiA 301 "dummy mapping"; a TPDO cannot use them).

/// One PDO mapping entry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct MappingEntry {
    /// Index of the mapped object.
    pub index: u16,
    /// Sub-index of the mapped object.
    pub sub: u8,
    /// Length of the mapped object in bits.
    pub bits: u8,
}

/// The data is not the 4 bytes of an UNSIGNED32.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LengthError;

/// Highest data type index usable as a dummy entry (0x0007 UNSIGNED32).
pub const DUMMY_MAX: u16 = 0x0007;

impl MappingEntry {
    /// From the UNSIGNED32 value of a mapping sub-index.
    pub const fn from_u32(value: u32) -> Self {
        MappingEntry { index: (value >> 16) as u16, sub: (value >> 8) as u8, bits: value as u8 }
    }

    /// The UNSIGNED32 value of a mapping sub-index.
    pub const fn to_u32(self) -> u32 {
        ((self.index as u32) << 16) | ((self.sub as u32) << 8) | self.bits as u32
    }

    /// Parses the 4 little-endian bytes of an SDO download or of the dictionary image.
    pub fn parse(data: &[u8]) -> Result<Self, LengthError> {
        let [a, b, c, d] = *data else { return Err(LengthError) };
        Ok(Self::from_u32(u32::from_le_bytes([a, b, c, d])))
    }

    /// The 4 little-endian bytes.
    pub const fn emit(self) -> [u8; 4] {
        self.to_u32().to_le_bytes()
    }

    /// Whether this is a dummy entry (index 0x0001–0x0007, sub-index 0).
    pub const fn is_dummy(self) -> bool {
        self.index >= 0x0001 && self.index <= DUMMY_MAX && self.sub == 0
    }

    /// The length in whole bytes, or `None` if it is not a multiple of 8 bits.
    pub const fn bytes(self) -> Option<u8> {
        if self.bits.is_multiple_of(8) { Some(self.bits / 8) } else { None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_emits_the_cia402_default_mappings() {
        // 0x60400010: controlword 0x6040 sub 0, 16 bits (CiA 402-3 RPDO1; ec5000.eds 0x1600 sub1).
        let cw = MappingEntry { index: 0x6040, sub: 0, bits: 16 };
        assert_eq!(MappingEntry::parse(&[0x10, 0x00, 0x40, 0x60]), Ok(cw));
        assert_eq!(cw.emit(), [0x10, 0x00, 0x40, 0x60]);
        assert_eq!(cw.to_u32(), 0x6040_0010);
        // 0x22000610: 0x2200 sub 6, 16 bits (ec5000.eds 0x1A00 sub4).
        let e = MappingEntry::from_u32(0x2200_0610);
        assert_eq!((e.index, e.sub, e.bits, e.bytes()), (0x2200, 6, 16, Some(2)));
        assert_eq!(MappingEntry::from_u32(e.to_u32()), e);
    }

    #[test]
    fn every_other_length_is_refused() {
        for n in [0, 1, 2, 3, 5, 8] {
            assert_eq!(MappingEntry::parse(&[0; 8][..n]), Err(LengthError), "{n} bytes");
        }
    }

    #[test]
    fn dummy_entries_and_bit_lengths() {
        assert!(MappingEntry::from_u32(0x0005_0008).is_dummy());
        assert!(MappingEntry::from_u32(0x0001_0008).is_dummy());
        assert!(MappingEntry::from_u32(0x0007_0020).is_dummy());
        assert!(!MappingEntry::from_u32(0x0008_0020).is_dummy(), "REAL32 is not a dummy type");
        assert!(!MappingEntry::from_u32(0x0005_0108).is_dummy(), "a dummy has sub-index 0");
        assert!(!MappingEntry::from_u32(0x0000_0008).is_dummy());
        assert_eq!(MappingEntry::from_u32(0x6000_0101).bytes(), None);
        assert_eq!(MappingEntry::from_u32(0x6000_0140).bytes(), Some(8));
    }
}
