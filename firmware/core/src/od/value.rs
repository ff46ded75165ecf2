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

/// A key whose `u64` order is the order of the numbers of `kind` whose
/// raw 64-bit patterns (as [`Number::to_limit`] makes them) are `raw`: an
/// unsigned value as it is, a signed one with its sign bit flipped, an f64
/// by its magnitude up or down from the middle, so -0 and +0 are equal.
/// NaN (`None`) compares with nothing; so does a non-numeric kind. One
/// integer compare then decides a limit, whatever the type.
// The magnitude is at most infinity's bits (below 2^63): 2^63 ± it fits.
// Out of line: the value and both limits each had a copy.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
fn order_key(kind: Kind, raw: u64) -> Option<u64> {
    const MIDDLE: u64 = 1 << 63;
    match kind {
        Kind::Unsigned => Some(raw),
        Kind::Signed => Some(raw ^ MIDDLE),
        Kind::Real => {
            let magnitude = raw & !MIDDLE;
            if magnitude > f64::INFINITY.to_bits() {
                return None;
            }
            Some(if raw & MIDDLE == 0 { MIDDLE + magnitude } else { MIDDLE - magnitude })
        }
        Kind::Bytes => None,
    }
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
}

impl Limits {
    /// Checks little-endian `bytes` of type `data_type` against the limits:
    /// [`AbortCode::ValueTooLow`] or [`AbortCode::ValueTooHigh`] outside.
    /// Values of non-numeric types always pass.
    pub fn check(&self, data_type: DataType, bytes: &[u8]) -> Result<(), AbortCode> {
        let kind = data_type.kind();
        if data_type.size() != Some(bytes.len()) {
            return Ok(());
        }
        // The value as the limits store theirs: sign-extended, a REAL32 widened.
        let mut raw = [0u8; 8];
        for (dst, src) in raw.iter_mut().zip(bytes) {
            *dst = *src;
        }
        let mut value = u64::from_le_bytes(raw);
        match kind {
            // 1 ≤ size ≤ 8 (a numeric type's).
            #[allow(clippy::arithmetic_side_effects)]
            Kind::Signed => {
                let shift = 64 - 8 * bytes.len() as u32;
                value = (((value << shift) as i64) >> shift) as u64;
            }
            Kind::Real if bytes.len() == 4 => value = widen_f32(value as u32),
            _ => {}
        }
        let Some(value) = order_key(kind, value) else { return Ok(()) };
        if order_key(kind, self.low).is_some_and(|low| value < low) {
            Err(AbortCode::ValueTooLow)
        } else if order_key(kind, self.high).is_some_and(|high| high < value) {
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
    fn limits_order_as_the_numbers_do() {
        // Each pair (a, b) with a < b as numbers: `a` is below a low limit of
        // `b`, `b` above a high limit of `a`, and each is within limits of itself.
        let cases: [(DataType, Number, Number); 7] = [
            (DataType::Integer64, Number::Signed(i64::MIN), Number::Signed(-1)),
            (DataType::Integer64, Number::Signed(-1), Number::Signed(i64::MAX)),
            (DataType::Unsigned64, Number::Unsigned(0x7FFF_FFFF_FFFF_FFFF), Number::Unsigned(u64::MAX)),
            (DataType::Real64, Number::Real(f64::NEG_INFINITY), Number::Real(-1.0e300)),
            (DataType::Real64, Number::Real(-5e-324), Number::Real(5e-324)),
            (DataType::Real64, Number::Real(1.0), Number::Real(f64::INFINITY)),
            (DataType::Integer8, Number::Signed(-128), Number::Signed(127)),
        ];
        for (t, a, b) in cases {
            let bytes = |n: Number| {
                let size = t.size().unwrap_or(0);
                n.to_limit().to_le_bytes()[..size].to_vec()
            };
            let (la, lb) = (a.to_limit(), b.to_limit());
            assert_eq!(Limits { low: lb, high: lb }.check(t, &bytes(a)), Err(AbortCode::ValueTooLow), "{a:?} < {b:?}");
            assert_eq!(Limits { low: la, high: la }.check(t, &bytes(b)), Err(AbortCode::ValueTooHigh), "{b:?} > {a:?}");
            assert_eq!(Limits { low: la, high: la }.check(t, &bytes(a)), Ok(()));
            assert_eq!(Limits { low: lb, high: lb }.check(t, &bytes(b)), Ok(()));
        }
        // A NaN limit bounds nothing; the other limit still holds.
        let nan = f64::NAN.to_bits();
        assert_eq!(
            Limits { low: nan, high: 0.0f64.to_bits() }.check(DataType::Real64, &1.0f64.to_le_bytes()),
            Err(AbortCode::ValueTooHigh)
        );
        assert_eq!(Limits { low: nan, high: nan }.check(DataType::Real64, &1.0f64.to_le_bytes()), Ok(()));
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
