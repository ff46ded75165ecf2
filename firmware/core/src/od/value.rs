//! Numeric view of little-endian value bytes, used for limit checks.

use super::entry::Limits;
use super::types::{DataType, Kind};
use crate::abort::AbortCode;

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

/// The bits of the f64 equal to the f32 with bits `b` (as `f64::from`, NaN
/// payload kept). In integer arithmetic: a Cortex-M3 has no FPU, and the
/// soft-float conversion and comparison would be the only float code in an image.
// A subnormal's mantissa (1..2^23) has 41..=63 leading zeros, so `shift` is
// 1..=23; an exponent below 0xFF plus 896 stays below 2^11.
#[allow(clippy::arithmetic_side_effects)]
fn widen_f32(b: u32) -> u64 {
    let sign = u64::from(b >> 31) << 63;
    let exponent = u64::from((b >> 23) & 0xFF);
    let mantissa = u64::from(b & 0x7F_FFFF);
    match exponent {
        0 if mantissa == 0 => sign,
        0 => {
            // Subnormal (mantissa × 2^-149): normal in f64, with the top bit
            // of the mantissa shifted to the implicit-one position (bit 23).
            let shift = mantissa.leading_zeros() - 40;
            sign | ((1023 - 126 - u64::from(shift)) << 52) | (((mantissa << shift) & 0x7F_FFFF) << 29)
        }
        0xFF => sign | (0x7FF << 52) | (mantissa << 29),
        _ => sign | ((exponent + 1023 - 127) << 52) | (mantissa << 29),
    }
}

/// A key that orders f64 bit patterns as `<` orders the numbers, in
/// integer arithmetic: -0 and +0 are equal, and NaN (`None`) compares with nothing.
// The magnitude is at most infinity's bits (below 2^63): its negation fits.
#[allow(clippy::arithmetic_side_effects)]
fn order_key(bits: u64) -> Option<i64> {
    let magnitude = bits & !(1 << 63);
    if magnitude > f64::INFINITY.to_bits() {
        return None;
    }
    let magnitude = magnitude as i64;
    Some(if bits >> 63 == 0 { magnitude } else { -magnitude })
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
                // size ≤ 8: checked above.
                #[allow(clippy::arithmetic_side_effects)]
                let shift = 64 - 8 * size as u32;
                Number::Signed(((unsigned << shift) as i64) >> shift)
            }
            Kind::Real if size == 4 => Number::Real(f64::from_bits(widen_f32(unsigned as u32))),
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
            (Number::Real(a), Number::Real(b)) => match (order_key(a.to_bits()), order_key(b.to_bits())) {
                (Some(a), Some(b)) => a < b,
                _ => false,
            },
            _ => false,
        }
    }
}

impl Limits {
    /// Checks little-endian `bytes` of type `data_type` against the limits:
    /// [`AbortCode::ValueTooLow`] or [`AbortCode::ValueTooHigh`] outside.
    /// Values of non-numeric types always pass.
    pub fn check(&self, data_type: DataType, bytes: &[u8]) -> Result<(), AbortCode> {
        let kind = data_type.kind();
        let (Some(value), Some(low), Some(high)) =
            (Number::decode(data_type, bytes), Number::from_limit(kind, self.low), Number::from_limit(kind, self.high))
        else {
            return Ok(());
        };
        if value.less_than(low) {
            Err(AbortCode::ValueTooLow)
        } else if high.less_than(value) {
            Err(AbortCode::ValueTooHigh)
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
        assert_eq!(l.check(DataType::Integer16, &(-11i16).to_le_bytes()), Err(AbortCode::ValueTooLow));
        assert_eq!(l.check(DataType::Integer16, &11i16.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        assert_eq!(l.check(DataType::Integer16, &(-10i16).to_le_bytes()), Ok(()));
        let r = Limits { low: Number::Real(-1.5).to_limit(), high: Number::Real(2.5).to_limit() };
        assert_eq!(r.check(DataType::Real32, &3.0f32.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        assert_eq!(r.check(DataType::Real32, &2.5f32.to_le_bytes()), Ok(()));
        let u = Limits { low: 1, high: 0xFFFF_FFFF };
        assert_eq!(u.check(DataType::Unsigned32, &0u32.to_le_bytes()), Err(AbortCode::ValueTooLow));
        assert_eq!(u.check(DataType::Unsigned32, &u32::MAX.to_le_bytes()), Ok(()));
    }

    #[test]
    fn widens_every_kind_of_f32_exactly() {
        let values = [
            0.0f32,
            -0.0,
            1.0,
            -1.5,
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            f32::EPSILON,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            f32::from_bits(0x0040_0000),
            f32::from_bits(0x007F_FFFF),
            f32::from_bits(0x0000_0F00),
            3.0e-40,
        ];
        for v in values {
            assert_eq!(widen_f32(v.to_bits()), f64::from(v).to_bits(), "{v:e}");
        }
        assert!(f64::from_bits(widen_f32(f32::NAN.to_bits())).is_nan());
    }

    #[test]
    fn compares_reals_as_numbers() {
        let r = Limits { low: Number::Real(0.0).to_limit(), high: Number::Real(f64::INFINITY).to_limit() };
        // -0 equals the low limit 0; NaN is neither too low nor too high (as `<` says).
        assert_eq!(r.check(DataType::Real32, &(-0.0f32).to_le_bytes()), Ok(()));
        assert_eq!(r.check(DataType::Real64, &f64::NAN.to_le_bytes()), Ok(()));
        assert_eq!(r.check(DataType::Real32, &f32::INFINITY.to_le_bytes()), Ok(()));
        assert_eq!(r.check(DataType::Real32, &(-1.0e-45f32).to_le_bytes()), Err(AbortCode::ValueTooLow));
        let n = Limits { low: Number::Real(-2.0).to_limit(), high: Number::Real(-1.0).to_limit() };
        assert_eq!(n.check(DataType::Real64, &(-2.5f64).to_le_bytes()), Err(AbortCode::ValueTooLow));
        assert_eq!(n.check(DataType::Real64, &(-0.5f64).to_le_bytes()), Err(AbortCode::ValueTooHigh));
        assert_eq!(n.check(DataType::Real32, &(-1.0f32).to_le_bytes()), Ok(()));
        assert_eq!(n.check(DataType::Real32, &f32::NEG_INFINITY.to_le_bytes()), Err(AbortCode::ValueTooLow));
    }
}
