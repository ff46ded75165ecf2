//! Number forms and typed values of CiA 306 §4.6.3: decimal, `0x` hex,
//! leading-zero octal, negative numbers and `$NODEID` arithmetic in any
//! spelling and order (`$NODEID+0x180`, `0x180 + $NodeID`).

use canopen_core::od::{DataType, Kind, Number};

/// An integer that may be relative to the node-id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntExpr {
    /// The constant part.
    pub value: i128,
    /// Whether `$NODEID` is added at run time.
    pub node_id: bool,
    /// Whether the constant was written in hex (two's-complement hex is then accepted).
    pub hex: bool,
}

/// Parses an integer expression: terms joined by `+`/`-`, each a number or
/// `$NODEID` (at most once, added).
pub fn parse_int(text: &str) -> Result<IntExpr, String> {
    let s: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    if s.is_empty() {
        return Err("empty number".into());
    }
    let mut value: i128 = 0;
    let mut node_id = false;
    let mut hex = false;
    let mut rest = s.as_str();
    let mut first = true;
    while !rest.is_empty() {
        let mut negative = false;
        if let Some(r) = rest.strip_prefix('+') {
            rest = r;
        } else if let Some(r) = rest.strip_prefix('-') {
            negative = true;
            rest = r;
        } else if !first {
            return Err(format!("`{text}` is not a number"));
        }
        first = false;
        let end = rest.find(['+', '-']).unwrap_or(rest.len());
        let term = &rest[..end];
        rest = &rest[end..];
        if term.eq_ignore_ascii_case("$NODEID") {
            if negative || node_id {
                return Err(format!("`{text}`: $NODEID may only be added, and only once"));
            }
            node_id = true;
            continue;
        }
        let (n, is_hex) = parse_unsigned(term).ok_or_else(|| {
            // `08`, `0900`: decimal digits, but CiA 306 reads a leading 0 as octal.
            let octal = term.len() > 1 && term.starts_with('0') && term.chars().all(|c| c.is_ascii_digit());
            if octal {
                format!("`{text}` is not a number: a leading 0 makes it octal (CiA 306)")
            } else {
                format!("`{text}` is not a number")
            }
        })?;
        hex |= is_hex;
        let n = if negative { -n } else { n };
        value = value.checked_add(n).ok_or_else(|| format!("`{text}` is out of range"))?;
    }
    Ok(IntExpr { value, node_id, hex })
}

/// Whether whitespace separates two characters of one term (`1 2`), not a
/// term from a `+`/`-` (`$NODEID + 0x600`).
fn space_within_number(text: &str) -> bool {
    let chars: Vec<char> = text.trim().chars().collect();
    chars.iter().enumerate().any(|(i, c)| {
        c.is_whitespace()
            && chars[..i].iter().rev().find(|c| !c.is_whitespace()).is_some_and(|c| !matches!(c, '+' | '-'))
            && chars[i..].iter().find(|c| !c.is_whitespace()).is_some_and(|c| !matches!(c, '+' | '-'))
    })
}

fn parse_unsigned(term: &str) -> Option<(i128, bool)> {
    let (digits, radix) = if let Some(h) = term.strip_prefix("0x").or_else(|| term.strip_prefix("0X")) {
        (h, 16)
    } else if term.len() > 1 && term.starts_with('0') {
        (&term[1..], 8)
    } else {
        (term, 10)
    };
    if digits.is_empty() || digits.len() > 40 || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    u128::from_str_radix(digits, radix).ok().and_then(|v| i128::try_from(v).ok()).map(|v| (v, radix == 16))
}

/// A value ready for the dictionary.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    /// Little-endian bytes (for `$NODEID` values: the constant part).
    pub bytes: Vec<u8>,
    /// Whether `$NODEID` is added at run time.
    pub node_id: bool,
    /// Something to warn about while the value was still accepted.
    pub note: Option<String>,
}

impl Encoded {
    fn plain(bytes: Vec<u8>) -> Self {
        Encoded { bytes, node_id: false, note: None }
    }
}

/// The integer range of a numeric type, as (min, max).
pub fn int_range(t: DataType) -> Option<(i128, i128)> {
    let bits = 8 * t.size()? as u32;
    match t.kind() {
        Kind::Unsigned if t == DataType::Boolean => Some((0, 1)),
        Kind::Unsigned => Some((0, (1i128 << bits) - 1)),
        Kind::Signed => Some((-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)),
        _ => None,
    }
}

/// The lowest and highest value of a numeric type.
pub fn type_bounds(t: DataType) -> (Number, Number) {
    match (t.kind(), int_range(t)) {
        (Kind::Signed, Some((lo, hi))) => (Number::Signed(lo as i64), Number::Signed(hi as i64)),
        (Kind::Unsigned, Some((lo, hi))) => (Number::Unsigned(lo as u64), Number::Unsigned(hi as u64)),
        _ => (Number::Real(f64::NEG_INFINITY), Number::Real(f64::INFINITY)),
    }
}

/// Parses a number of a numeric type into its [`Number`], for values and limits.
/// Returns the number, whether it is `$NODEID`-relative, and a note.
pub fn parse_number(t: DataType, text: &str) -> Result<(Number, bool, Option<String>), String> {
    match t.kind() {
        Kind::Real => {
            let (v, note) = parse_real(t, text)?;
            // A REAL32 number is the nearest f32, so a limit `0.1` equals a value `0.1`.
            let v = if t == DataType::Real32 { f64::from(v as f32) } else { v };
            Ok((Number::Real(v), false, note))
        }
        Kind::Signed | Kind::Unsigned => {
            let e = parse_int(text)?;
            let (min, max) = int_range(t).ok_or("not an integer type")?;
            let mut v = e.value;
            let mut note = None;
            if v > max && t.kind() == Kind::Signed && e.hex && !e.node_id {
                let bits = 8 * t.size().unwrap_or(8) as u32;
                if v < (1i128 << bits) {
                    v -= 1i128 << bits;
                    note = Some(format!("`{text}` is read as the two's-complement pattern of {v}"));
                }
            }
            let limit_max = if e.node_id { max - 127 } else { max };
            if v < min || v > limit_max {
                return Err(format!("`{text}` does not fit {} ({min}..={max})", t.name()));
            }
            let n = if t.kind() == Kind::Signed { Number::Signed(v as i64) } else { Number::Unsigned(v as u64) };
            // Spaces around `+`/`-` are how `$NODEID + 0x600` is written;
            // within a number they are dropped, which a reader should see.
            let note = note.or_else(|| space_within_number(text).then(|| format!("the spaces within `{text}` are dropped: read as {v}")));
            Ok((n, e.node_id, note))
        }
        Kind::Bytes => Err(format!("{} has no numeric value", t.name())),
    }
}

fn parse_real(t: DataType, text: &str) -> Result<(f64, Option<String>), String> {
    let s = text.trim();
    if s.starts_with("0x") || s.starts_with("0X") {
        let e = parse_int(s)?;
        let note = Some(format!("`{s}` for a {} is read as its IEEE 754 bit pattern", t.name()));
        return match t {
            DataType::Real32 => {
                u32::try_from(e.value).map(|b| (f64::from(f32::from_bits(b)), note)).map_err(|_| format!("`{s}` is wider than 32 bits"))
            }
            _ => u64::try_from(e.value).map(|b| (f64::from_bits(b), note)).map_err(|_| format!("`{s}` is wider than 64 bits")),
        };
    }
    let valid = !s.is_empty()
        && s.chars().all(|c| c.is_ascii_digit() || matches!(c, '+' | '-' | '.' | 'e' | 'E'))
        && s.chars().any(|c| c.is_ascii_digit());
    let v: f64 = if valid {
        s.parse().map_err(|_| format!("`{s}` is not a {} number", t.name()))?
    } else {
        return Err(format!("`{s}` is not a {} number", t.name()));
    };
    if t == DataType::Real32 && v.is_finite() && (v as f32).is_infinite() {
        return Err(format!("`{s}` does not fit REAL32"));
    }
    Ok((v, None))
}

/// Little-endian bytes of a number of type `t` (the type's exact size).
pub fn number_bytes(t: DataType, n: Number) -> Vec<u8> {
    let size = t.size().unwrap_or(0);
    match n {
        Number::Signed(v) => v.to_le_bytes()[..size].to_vec(),
        Number::Unsigned(v) => v.to_le_bytes()[..size].to_vec(),
        Number::Real(v) if t == DataType::Real32 => (v as f32).to_le_bytes().to_vec(),
        Number::Real(v) => v.to_le_bytes().to_vec(),
    }
}

/// Encodes an EDS value text as the bytes of type `t`.
pub fn encode(t: DataType, text: &str) -> Result<Encoded, String> {
    match t {
        DataType::VisibleString => {
            let s = unquote(text);
            let note = (!s.chars().all(|c| c.is_ascii() && (' '..='~').contains(&c)))
                .then(|| "VISIBLE_STRING holds characters outside printable ASCII; kept as UTF-8".to_owned());
            Ok(Encoded { bytes: s.as_bytes().to_vec(), node_id: false, note })
        }
        DataType::UnicodeString => Ok(Encoded::plain(unquote(text).encode_utf16().flat_map(u16::to_le_bytes).collect())),
        DataType::OctetString => hex_bytes(text).map(Encoded::plain),
        DataType::Domain => match hex_bytes(text) {
            Ok(b) => Ok(Encoded::plain(b)),
            Err(_) => Ok(Encoded {
                bytes: Vec::new(),
                node_id: false,
                note: Some(format!("DOMAIN default `{}` is not hex bytes; dropped", crate::lexer::clip(text))),
            }),
        },
        DataType::TimeOfDay | DataType::TimeDifference => {
            let parts: Vec<&str> = text.split_whitespace().collect();
            let (days, ms) = match parts.as_slice() {
                [ms] => (0, parse_int(ms)?.value),
                [days, ms] => (parse_int(days)?.value, parse_int(ms)?.value),
                _ => return Err(format!("`{text}` is not `days ms` for {}", t.name())),
            };
            if !(0..=0xFFFF).contains(&days) || !(0..1 << 28).contains(&ms) {
                return Err(format!("`{text}` is out of range for {} (days 0..=65535, ms < 2^28)", t.name()));
            }
            let mut b = (ms as u32).to_le_bytes().to_vec();
            b.extend((days as u16).to_le_bytes());
            Ok(Encoded::plain(b))
        }
        _ => {
            let (n, node_id, note) = parse_number(t, text)?;
            Ok(Encoded { bytes: number_bytes(t, n), node_id, note })
        }
    }
}

/// Quoted strings (lely writes `"Hello, World!"`) lose their quotes.
fn unquote(text: &str) -> &str {
    text.strip_prefix('"').and_then(|s| s.strip_suffix('"')).unwrap_or(text)
}

fn hex_bytes(text: &str) -> Result<Vec<u8>, String> {
    let digits: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let digits = digits.strip_prefix("0x").unwrap_or(&digits);
    if !digits.len().is_multiple_of(2) || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(format!("`{}` is not a sequence of hex byte pairs", crate::lexer::clip(text)));
    }
    (0..digits.len()).step_by(2).map(|i| u8::from_str_radix(&digits[i..i + 2], 16).map_err(|e| e.to_string())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn int(s: &str) -> (i128, bool) {
        let e = parse_int(s).unwrap();
        (e.value, e.node_id)
    }

    #[test]
    fn number_forms() {
        assert_eq!(int("42"), (42, false));
        assert_eq!(int("0x2A"), (42, false));
        assert_eq!(int("0X2a"), (42, false));
        assert_eq!(int("052"), (42, false));
        assert_eq!(int("0"), (0, false));
        assert_eq!(int("-5"), (-5, false));
        assert_eq!(int("-0x7f"), (-127, false));
        assert!(parse_int("08").is_err());
        assert!(parse_int("0x").is_err());
        assert!(parse_int("12a").is_err());
        assert!(parse_int("").is_err());
        assert!(parse_int("1 2").is_ok()); // whitespace is dropped: "12" (parse_number notes it)
    }

    #[test]
    fn node_id_in_any_spelling_and_order() {
        assert_eq!(int("$NODEID+0x180"), (0x180, true));
        assert_eq!(int("0x180 + $NodeID"), (0x180, true));
        assert_eq!(int("$nodeid"), (0, true));
        assert_eq!(int("1280+$NODEID"), (1280, true));
        assert_eq!(int("$NODEID + 0x80000300"), (0x8000_0300, true));
        assert_eq!(int("0x40000180+$NODEID"), (0x4000_0180, true));
        assert!(parse_int("-$NODEID").is_err());
        assert!(parse_int("$NODEID+$NODEID").is_err());
        assert!(parse_int("$NODE").is_err());
    }

    #[test]
    fn every_numeric_type_encodes_to_its_size() {
        for t in DataType::ALL {
            if let Some(size) = t.size() {
                let text = if t == DataType::TimeOfDay || t == DataType::TimeDifference { "1 2" } else { "1" };
                assert_eq!(encode(t, text).unwrap().bytes.len(), size, "{t:?}");
            }
        }
    }

    #[test]
    fn integer_ranges_are_enforced() {
        assert_eq!(encode(DataType::Integer24, "-8388608").unwrap().bytes, [0, 0, 0x80]);
        assert!(encode(DataType::Integer24, "8388608").is_err());
        assert_eq!(encode(DataType::Unsigned40, "0xFFFFFFFFFF").unwrap().bytes, [0xFF; 5]);
        assert!(encode(DataType::Unsigned8, "256").is_err());
        assert!(encode(DataType::Unsigned8, "-1").is_err());
        assert!(encode(DataType::Boolean, "2").is_err());
        assert_eq!(encode(DataType::Integer64, "-1234567890123456789").unwrap().bytes, (-1234567890123456789i64).to_le_bytes());
        let e = encode(DataType::Integer64, "0xFFFFFFFFFFFFFFF6").unwrap();
        assert_eq!(e.bytes, (-10i64).to_le_bytes());
        assert!(e.note.unwrap().contains("two's-complement"));
        assert!(encode(DataType::Unsigned32, "$NODEID+0xFFFFFFFF").is_err());
    }

    #[test]
    fn reals_take_decimals_and_bit_patterns() {
        assert_eq!(encode(DataType::Real32, "1.5").unwrap().bytes, 1.5f32.to_le_bytes());
        assert_eq!(encode(DataType::Real64, "-2e3").unwrap().bytes, (-2000f64).to_le_bytes());
        let pi = encode(DataType::Real32, "0x40490FDB").unwrap();
        assert_eq!(pi.bytes, 0x4049_0FDBu32.to_le_bytes());
        assert!(pi.note.is_some());
        assert_eq!(encode(DataType::Real64, "0x400921FB54442D18").unwrap().bytes, std::f64::consts::PI.to_le_bytes());
        assert!(encode(DataType::Real32, "0.0f").is_err());
        assert!(encode(DataType::Real32, "1e39").is_err());
        assert!(encode(DataType::Real32, "nan").is_err());
    }

    #[test]
    fn strings_and_times() {
        assert_eq!(encode(DataType::VisibleString, "\"Hello, World!\"").unwrap().bytes, b"Hello, World!");
        assert!(encode(DataType::VisibleString, "among us ඞ").unwrap().note.is_some());
        assert_eq!(encode(DataType::OctetString, "ABCD").unwrap().bytes, [0xAB, 0xCD]);
        assert_eq!(encode(DataType::OctetString, "01 02 0a").unwrap().bytes, [1, 2, 10]);
        assert_eq!(encode(DataType::OctetString, "0123456789abcdef").unwrap().bytes.len(), 8);
        assert!(encode(DataType::OctetString, "ABC").is_err());
        assert_eq!(encode(DataType::UnicodeString, "a✓").unwrap().bytes, [b'a', 0, 0x13, 0x27]);
        assert_eq!(encode(DataType::TimeOfDay, "365 43200000").unwrap().bytes, [0x00, 0x2E, 0x93, 0x02, 0x6D, 0x01]);
        assert!(encode(DataType::TimeDifference, "1 2 3").is_err());
        let d = encode(DataType::Domain, "@ABCD").unwrap();
        assert!(d.bytes.is_empty() && d.note.is_some());
    }
}
