//! CANopen basic data types. CiA 301 v4.2 §7.1.6, table 44 (indices 0x0001–0x001B).

/// A basic CANopen data type, numbered as in the object dictionary (index 0x0001–0x001B).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum DataType {
    /// BOOLEAN (0x0001), one byte in the dictionary.
    Boolean = 0x01,
    /// INTEGER8 (0x0002).
    Integer8 = 0x02,
    /// INTEGER16 (0x0003).
    Integer16 = 0x03,
    /// INTEGER32 (0x0004).
    Integer32 = 0x04,
    /// UNSIGNED8 (0x0005).
    Unsigned8 = 0x05,
    /// UNSIGNED16 (0x0006).
    Unsigned16 = 0x06,
    /// UNSIGNED32 (0x0007).
    Unsigned32 = 0x07,
    /// REAL32 (0x0008), IEEE 754 single precision.
    Real32 = 0x08,
    /// VISIBLE_STRING (0x0009).
    VisibleString = 0x09,
    /// OCTET_STRING (0x000A).
    OctetString = 0x0A,
    /// UNICODE_STRING (0x000B), UTF-16LE code units.
    UnicodeString = 0x0B,
    /// TIME_OF_DAY (0x000C): 28-bit milliseconds after midnight, 16-bit days since 1984-01-01.
    TimeOfDay = 0x0C,
    /// TIME_DIFFERENCE (0x000D): same layout as TIME_OF_DAY.
    TimeDifference = 0x0D,
    /// DOMAIN (0x000F): an application-defined block of bytes.
    Domain = 0x0F,
    /// INTEGER24 (0x0010).
    Integer24 = 0x10,
    /// REAL64 (0x0011), IEEE 754 double precision.
    Real64 = 0x11,
    /// INTEGER40 (0x0012).
    Integer40 = 0x12,
    /// INTEGER48 (0x0013).
    Integer48 = 0x13,
    /// INTEGER56 (0x0014).
    Integer56 = 0x14,
    /// INTEGER64 (0x0015).
    Integer64 = 0x15,
    /// UNSIGNED24 (0x0016).
    Unsigned24 = 0x16,
    /// UNSIGNED40 (0x0018).
    Unsigned40 = 0x18,
    /// UNSIGNED48 (0x0019).
    Unsigned48 = 0x19,
    /// UNSIGNED56 (0x001A).
    Unsigned56 = 0x1A,
    /// UNSIGNED64 (0x001B).
    Unsigned64 = 0x1B,
}

/// How the bytes of a value are interpreted when they are compared with limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Two's-complement integer (BOOLEAN counts as unsigned).
    Signed,
    /// Unsigned integer.
    Unsigned,
    /// IEEE 754 floating point.
    Real,
    /// Strings, TIME types and DOMAIN: a sequence of bytes without an order.
    Bytes,
}

impl DataType {
    /// Every basic type, in index order.
    pub const ALL: [DataType; 25] = [
        DataType::Boolean,
        DataType::Integer8,
        DataType::Integer16,
        DataType::Integer32,
        DataType::Unsigned8,
        DataType::Unsigned16,
        DataType::Unsigned32,
        DataType::Real32,
        DataType::VisibleString,
        DataType::OctetString,
        DataType::UnicodeString,
        DataType::TimeOfDay,
        DataType::TimeDifference,
        DataType::Domain,
        DataType::Integer24,
        DataType::Real64,
        DataType::Integer40,
        DataType::Integer48,
        DataType::Integer56,
        DataType::Integer64,
        DataType::Unsigned24,
        DataType::Unsigned40,
        DataType::Unsigned48,
        DataType::Unsigned56,
        DataType::Unsigned64,
    ];

    /// The type with dictionary index `index`, if it is a basic type.
    pub const fn from_index(index: u16) -> Option<DataType> {
        Some(match index {
            0x01 => DataType::Boolean,
            0x02 => DataType::Integer8,
            0x03 => DataType::Integer16,
            0x04 => DataType::Integer32,
            0x05 => DataType::Unsigned8,
            0x06 => DataType::Unsigned16,
            0x07 => DataType::Unsigned32,
            0x08 => DataType::Real32,
            0x09 => DataType::VisibleString,
            0x0A => DataType::OctetString,
            0x0B => DataType::UnicodeString,
            0x0C => DataType::TimeOfDay,
            0x0D => DataType::TimeDifference,
            0x0F => DataType::Domain,
            0x10 => DataType::Integer24,
            0x11 => DataType::Real64,
            0x12 => DataType::Integer40,
            0x13 => DataType::Integer48,
            0x14 => DataType::Integer56,
            0x15 => DataType::Integer64,
            0x16 => DataType::Unsigned24,
            0x18 => DataType::Unsigned40,
            0x19 => DataType::Unsigned48,
            0x1A => DataType::Unsigned56,
            0x1B => DataType::Unsigned64,
            _ => return None,
        })
    }

    /// The dictionary index of this type.
    pub const fn index(self) -> u16 {
        self as u16
    }

    /// Size in bytes of a fixed-size type; `None` for strings and DOMAIN.
    // A byte table indexed by the type's number (0 where it has no fixed
    // size): one load, where the match took a 76-byte function in every image.
    // Indexing below its checked length: it cannot panic (a `const fn` has no `get`).
    #[allow(clippy::indexing_slicing)]
    pub const fn size(self) -> Option<usize> {
        const SIZES: [u8; 0x1C] = [
            0, 1, 1, 2, 4, 1, 2, 4, 4, // 0x00, BOOLEAN .. REAL32
            0, 0, 0, 6, 6, 0, 0, // strings, TIME_OF_DAY, TIME_DIFFERENCE, 0x0E, DOMAIN
            3, 8, 5, 6, 7, 8, // INTEGER24, REAL64, INTEGER40 .. INTEGER64
            3, 0, 5, 6, 7, 8, // UNSIGNED24, 0x17, UNSIGNED40 .. UNSIGNED64
        ];
        let i = self as usize;
        match if i < SIZES.len() { SIZES[i] } else { 0 } {
            0 => None,
            n => Some(n as usize),
        }
    }

    /// How values of this type compare.
    pub const fn kind(self) -> Kind {
        match self {
            DataType::Integer8
            | DataType::Integer16
            | DataType::Integer24
            | DataType::Integer32
            | DataType::Integer40
            | DataType::Integer48
            | DataType::Integer56
            | DataType::Integer64 => Kind::Signed,
            DataType::Boolean
            | DataType::Unsigned8
            | DataType::Unsigned16
            | DataType::Unsigned24
            | DataType::Unsigned32
            | DataType::Unsigned40
            | DataType::Unsigned48
            | DataType::Unsigned56
            | DataType::Unsigned64 => Kind::Unsigned,
            DataType::Real32 | DataType::Real64 => Kind::Real,
            DataType::VisibleString
            | DataType::OctetString
            | DataType::UnicodeString
            | DataType::TimeOfDay
            | DataType::TimeDifference
            | DataType::Domain => Kind::Bytes,
        }
    }

    /// Whether an SDO may transfer fewer bytes than the entry holds
    /// (strings and DOMAIN have no fixed length).
    pub const fn is_variable_length(self) -> bool {
        self.size().is_none()
    }

    /// The CiA 306 spelling, as in `UNSIGNED16`.
    pub const fn name(self) -> &'static str {
        match self {
            DataType::Boolean => "BOOLEAN",
            DataType::Integer8 => "INTEGER8",
            DataType::Integer16 => "INTEGER16",
            DataType::Integer32 => "INTEGER32",
            DataType::Unsigned8 => "UNSIGNED8",
            DataType::Unsigned16 => "UNSIGNED16",
            DataType::Unsigned32 => "UNSIGNED32",
            DataType::Real32 => "REAL32",
            DataType::VisibleString => "VISIBLE_STRING",
            DataType::OctetString => "OCTET_STRING",
            DataType::UnicodeString => "UNICODE_STRING",
            DataType::TimeOfDay => "TIME_OF_DAY",
            DataType::TimeDifference => "TIME_DIFFERENCE",
            DataType::Domain => "DOMAIN",
            DataType::Integer24 => "INTEGER24",
            DataType::Real64 => "REAL64",
            DataType::Integer40 => "INTEGER40",
            DataType::Integer48 => "INTEGER48",
            DataType::Integer56 => "INTEGER56",
            DataType::Integer64 => "INTEGER64",
            DataType::Unsigned24 => "UNSIGNED24",
            DataType::Unsigned40 => "UNSIGNED40",
            DataType::Unsigned48 => "UNSIGNED48",
            DataType::Unsigned56 => "UNSIGNED56",
            DataType::Unsigned64 => "UNSIGNED64",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_round_trips_for_every_basic_type() {
        for t in DataType::ALL {
            assert_eq!(DataType::from_index(t.index()), Some(t));
        }
        // 0x000E and 0x0017 are reserved, 0x0000 and 0x001C+ are not basic types.
        for i in [0x00, 0x0E, 0x17, 0x1C, 0x20, 0x40, 0xFFFF] {
            assert_eq!(DataType::from_index(i), None);
        }
    }

    #[test]
    fn every_type_has_its_table_44_size() {
        let expected = |t: DataType| match t {
            DataType::Boolean | DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer24 | DataType::Unsigned24 => Some(3),
            DataType::Integer32 | DataType::Unsigned32 | DataType::Real32 => Some(4),
            DataType::Integer40 | DataType::Unsigned40 => Some(5),
            DataType::Integer48 | DataType::Unsigned48 | DataType::TimeOfDay | DataType::TimeDifference => Some(6),
            DataType::Integer56 | DataType::Unsigned56 => Some(7),
            DataType::Integer64 | DataType::Unsigned64 | DataType::Real64 => Some(8),
            DataType::VisibleString | DataType::OctetString | DataType::UnicodeString | DataType::Domain => None,
        };
        for t in DataType::ALL {
            assert_eq!(t.size(), expected(t), "{}", t.name());
        }
    }

    #[test]
    fn sizes_follow_cia301_table_44() {
        assert_eq!(DataType::Integer24.size(), Some(3));
        assert_eq!(DataType::Unsigned56.size(), Some(7));
        assert_eq!(DataType::TimeOfDay.size(), Some(6));
        assert_eq!(DataType::Real64.size(), Some(8));
        assert_eq!(DataType::Domain.size(), None);
        assert!(DataType::VisibleString.is_variable_length());
    }
}
