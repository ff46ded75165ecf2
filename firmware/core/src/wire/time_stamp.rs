//! TIME frame format: TIME_OF_DAY. CiA 301 v4.2 §7.2.6.3: milliseconds after
//! midnight in bits 0..27 (bits 28..31 reserved, 0), days since 1984-01-01 in
//! the next 16 bits.

/// A TIME_OF_DAY value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeOfDay {
    /// Milliseconds after midnight (< 86 400 000).
    pub ms: u32,
    /// Days since 1984-01-01.
    pub days: u16,
}

impl TimeOfDay {
    /// Parses the 6 data bytes of a TIME frame. The reserved bits are ignored.
    pub fn parse(data: &[u8]) -> Option<Self> {
        let [a, b, c, d, e, f] = *data else { return None };
        Some(TimeOfDay { ms: u32::from_le_bytes([a, b, c, d]) & 0x0FFF_FFFF, days: u16::from_le_bytes([e, f]) })
    }

    /// The 6 data bytes.
    pub fn emit(&self) -> [u8; 6] {
        let [a, b, c, d] = (self.ms & 0x0FFF_FFFF).to_le_bytes();
        let [e, f] = self.days.to_le_bytes();
        [a, b, c, d, e, f]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_reserved_bits() {
        let t = TimeOfDay { ms: 43_200_000, days: 365 };
        assert_eq!(t.emit(), [0x00, 0x2E, 0x93, 0x02, 0x6D, 0x01]);
        assert_eq!(TimeOfDay::parse(&t.emit()), Some(t));
        assert_eq!(TimeOfDay::parse(&[0xFF, 0xFF, 0xFF, 0xFF, 0, 0]).map(|t| t.ms), Some(0x0FFF_FFFF));
        assert_eq!(TimeOfDay::parse(&[0; 5]), None);
        assert_eq!(TimeOfDay::parse(&[0; 7]), None);
    }
}
