//! Numeric view of little-endian value bytes, used for limit checks.

use super::entry::Limits;
use super::types::{DataType, Kind};

/// A number decoded from a value of a numeric type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Number {
    /// From a signed integer type.
    Signed(i64),
    /// From an unsigned integer type or BOOLEAN.
    Unsigned(u64),
    /// From REAL32 or REAL64.
    Real(f64),
}

/// Why a value was refused against its limits. CiA 301 abort codes 0x06090031/0x06090032.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangeError {
    /// Above the high limit (abort 0x06090031).
    TooHigh,
    /// Below the low limit (abort 0x06090032).
    TooLow,
}

impl Number {
    /// Decodes `bytes` (little-endian, exactly the type's size) as `data_type`.
    /// `None` for non-numeric types or a wrong length.
    pub fn decode(data_type: DataType, bytes: &[u8]) -> Option<Number> {
        let size = data_type.size()?;
        if bytes.len() != size || size > 8 {
            return None;
        }
        let mut raw = [0u8; 8];
        raw.get_mut(..size)?.copy_from_slice(bytes);
        let unsigned = u64::from_le_bytes(raw);
        Some(match data_type.kind() {
            Kind::Unsigned => Number::Unsigned(unsigned),
            Kind::Signed => {
                let shift = 64 - 8 * size as u32;
                Number::Signed(((unsigned << shift) as i64) >> shift)
            }
            Kind::Real if size == 4 => Number::Real(f64::from(f32::from_bits(unsigned as u32))),
            Kind::Real => Number::Real(f64::from_bits(unsigned)),
            Kind::Bytes => return None,
        })
    }

    /// Decodes a raw limit pattern as stored in [`Limits`] for a type of `kind`.
    pub fn from_limit(kind: Kind, raw: u64) -> Option<Number> {
        match kind {
            Kind::Signed => Some(Number::Signed(raw as i64)),
            Kind::Unsigned => Some(Number::Unsigned(raw)),
            Kind::Real => Some(Number::Real(f64::from_bits(raw))),
            Kind::Bytes => None,
        }
    }

    /// The raw 64-bit pattern a [`Limits`] table stores for this number.
    pub fn to_limit(self) -> u64 {
        match self {
            Number::Signed(v) => v as u64,
            Number::Unsigned(v) => v,
            Number::Real(v) => v.to_bits(),
        }
    }

    fn less_than(self, other: Number) -> bool {
        match (self, other) {
            (Number::Signed(a), Number::Signed(b)) => a < b,
            (Number::Unsigned(a), Number::Unsigned(b)) => a < b,
            (Number::Real(a), Number::Real(b)) => a < b,
            _ => false,
        }
    }
}

impl Limits {
    /// Checks little-endian `bytes` of type `data_type` against the limits.
    /// Values of non-numeric types always pass.
    pub fn check(&self, data_type: DataType, bytes: &[u8]) -> Result<(), RangeError> {
        let kind = data_type.kind();
        let (Some(value), Some(low), Some(high)) =
            (Number::decode(data_type, bytes), Number::from_limit(kind, self.low), Number::from_limit(kind, self.high))
        else {
            return Ok(());
        };
        if value.less_than(low) {
            Err(RangeError::TooLow)
        } else if high.less_than(value) {
            Err(RangeError::TooHigh)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_odd_sized_signed_integers() {
        assert_eq!(Number::decode(DataType::Integer24, &[0xFF, 0xFF, 0xFF]), Some(Number::Signed(-1)));
        assert_eq!(Number::decode(DataType::Integer40, &[0, 0, 0, 0, 0x80]), Some(Number::Signed(-(1 << 39))));
        assert_eq!(Number::decode(DataType::Unsigned24, &[0xFF, 0xFF, 0xFF]), Some(Number::Unsigned(0xFF_FFFF)));
        assert_eq!(Number::decode(DataType::Unsigned16, &[1]), None);
        assert_eq!(Number::decode(DataType::VisibleString, b"ab"), None);
    }

    #[test]
    fn checks_limits_by_kind() {
        let l = Limits { low: Number::Signed(-10).to_limit(), high: Number::Signed(10).to_limit() };
        assert_eq!(l.check(DataType::Integer16, &(-11i16).to_le_bytes()), Err(RangeError::TooLow));
        assert_eq!(l.check(DataType::Integer16, &11i16.to_le_bytes()), Err(RangeError::TooHigh));
        assert_eq!(l.check(DataType::Integer16, &(-10i16).to_le_bytes()), Ok(()));
        let r = Limits { low: Number::Real(-1.5).to_limit(), high: Number::Real(2.5).to_limit() };
        assert_eq!(r.check(DataType::Real32, &3.0f32.to_le_bytes()), Err(RangeError::TooHigh));
        assert_eq!(r.check(DataType::Real32, &2.5f32.to_le_bytes()), Ok(()));
        let u = Limits { low: 1, high: 0xFFFF_FFFF };
        assert_eq!(u.check(DataType::Unsigned32, &0u32.to_le_bytes()), Err(RangeError::TooLow));
        assert_eq!(u.check(DataType::Unsigned32, &u32::MAX.to_le_bytes()), Ok(()));
    }
}
