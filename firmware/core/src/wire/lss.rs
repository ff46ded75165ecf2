//! LSS frame formats. CiA 305 v3.0 §4: master → slave on COB-ID 0x7E5,
//! slave → master on 0x7E4, always 8 bytes, byte 0 the command specifier.

/// COB-ID of requests from the LSS master.
pub const MASTER_COB_ID: u16 = 0x7E5;
/// COB-ID of answers from LSS slaves.
pub const SLAVE_COB_ID: u16 = 0x7E4;

/// Which part of the LSS address (0x1018 sub 1..4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AddressPart {
    /// Vendor-ID (0x1018 sub 1).
    Vendor = 0,
    /// Product code (sub 2).
    Product = 1,
    /// Revision number (sub 3).
    Revision = 2,
    /// Serial number (sub 4).
    Serial = 3,
}

/// A request from the LSS master.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LssRequest {
    /// 0x04: switch state global, to configuration (`true`) or waiting.
    SwitchGlobal(bool),
    /// 0x40–0x43: switch state selective, one part of the address.
    SwitchSelective(AddressPart, u32),
    /// 0x11: configure node-id.
    ConfigureNodeId(u8),
    /// 0x13: configure bit timing (table selector, table index).
    ConfigureBitTiming(u8, u8),
    /// 0x15: activate bit timing after `delay` ms.
    ActivateBitTiming(u16),
    /// 0x17: store configuration.
    StoreConfiguration,
    /// 0x5A–0x5D: inquire one part of the address.
    Inquire(AddressPart),
    /// 0x5E: inquire node-id.
    InquireNodeId,
    /// 0x46–0x4B: identify remote slave, one bound of the address range:
    /// vendor, product, revision low/high, serial low/high.
    IdentifyRemote(u8, u32),
    /// 0x4C: identify non-configured remote slave.
    IdentifyNonConfigured,
    /// 0x51: fastscan.
    Fastscan {
        /// The bits of the part under test.
        id: u32,
        /// Lowest bit compared; 0x80 resets the scan.
        bit_checked: u8,
        /// Part under test (0..=3).
        sub: u8,
        /// Part to test next.
        next: u8,
    },
}

/// Why a frame on 0x7E5 was not understood.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LssError {
    /// Not 8 bytes.
    Length,
    /// A command specifier CiA 305 does not define (or a reserved mode).
    Unknown(u8),
}

/// Bytes 1–4 of a frame, little-endian (an address part, an identify
/// bound, a fastscan ID).
pub(crate) fn u32_at(d: &[u8; 8]) -> u32 {
    u32::from_le_bytes([d[1], d[2], d[3], d[4]])
}

fn part(n: u8) -> AddressPart {
    match n & 3 {
        0 => AddressPart::Vendor,
        1 => AddressPart::Product,
        2 => AddressPart::Revision,
        _ => AddressPart::Serial,
    }
}

impl LssRequest {
    /// Parses a frame from the master.
    // Each subtraction takes a command specifier within its arm's range.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn parse(data: &[u8]) -> Result<Self, LssError> {
        let d: &[u8; 8] = data.try_into().map_err(|_| LssError::Length)?;
        Ok(match d[0] {
            0x04 => match d[1] {
                0 => LssRequest::SwitchGlobal(false),
                1 => LssRequest::SwitchGlobal(true),
                _ => return Err(LssError::Unknown(0x04)),
            },
            cs @ 0x40..=0x43 => LssRequest::SwitchSelective(part(cs - 0x40), u32_at(d)),
            0x11 => LssRequest::ConfigureNodeId(d[1]),
            0x13 => LssRequest::ConfigureBitTiming(d[1], d[2]),
            0x15 => LssRequest::ActivateBitTiming(u16::from_le_bytes([d[1], d[2]])),
            0x17 => LssRequest::StoreConfiguration,
            cs @ 0x5A..=0x5D => LssRequest::Inquire(part(cs - 0x5A)),
            0x5E => LssRequest::InquireNodeId,
            cs @ 0x46..=0x4B => LssRequest::IdentifyRemote(cs - 0x46, u32_at(d)),
            0x4C => LssRequest::IdentifyNonConfigured,
            0x51 => LssRequest::Fastscan { id: u32_at(d), bit_checked: d[5], sub: d[6], next: d[7] },
            other => return Err(LssError::Unknown(other)),
        })
    }

    /// The 8 data bytes (the master side, for tests and tools).
    // An address part is 0..=3 and `k % 6` 0..=5: each sum stays below 0x60.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn emit(&self) -> [u8; 8] {
        let with_u32 = |cs: u8, v: u32| {
            let [a, b, c, d] = v.to_le_bytes();
            [cs, a, b, c, d, 0, 0, 0]
        };
        match *self {
            LssRequest::SwitchGlobal(cfg) => [0x04, u8::from(cfg), 0, 0, 0, 0, 0, 0],
            LssRequest::SwitchSelective(p, v) => with_u32(0x40 + p as u8, v),
            LssRequest::ConfigureNodeId(id) => [0x11, id, 0, 0, 0, 0, 0, 0],
            LssRequest::ConfigureBitTiming(t, i) => [0x13, t, i, 0, 0, 0, 0, 0],
            LssRequest::ActivateBitTiming(ms) => {
                let [a, b] = ms.to_le_bytes();
                [0x15, a, b, 0, 0, 0, 0, 0]
            }
            LssRequest::StoreConfiguration => [0x17, 0, 0, 0, 0, 0, 0, 0],
            LssRequest::Inquire(p) => [0x5A + p as u8, 0, 0, 0, 0, 0, 0, 0],
            LssRequest::InquireNodeId => [0x5E, 0, 0, 0, 0, 0, 0, 0],
            LssRequest::IdentifyRemote(k, v) => with_u32(0x46 + (k % 6), v),
            LssRequest::IdentifyNonConfigured => [0x4C, 0, 0, 0, 0, 0, 0, 0],
            LssRequest::Fastscan { id, bit_checked, sub, next } => {
                let [a, b, c, d] = id.to_le_bytes();
                [0x51, a, b, c, d, bit_checked, sub, next]
            }
        }
    }
}

/// An answer with a command specifier and an error code (0x11, 0x13, 0x17).
pub fn answer(cs: u8, error: u8, spec: u8) -> [u8; 8] {
    answer_u32(cs, u32::from(u16::from_le_bytes([error, spec])))
}

/// An answer carrying a 32-bit value (0x5A–0x5D).
pub fn answer_u32(cs: u8, value: u32) -> [u8; 8] {
    // As one 64-bit value: two word stores, not four of bytes and halves.
    (u64::from(cs) | u64::from(value) << 8).to_le_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_request_round_trips() {
        let all = [
            LssRequest::SwitchGlobal(true),
            LssRequest::SwitchGlobal(false),
            LssRequest::SwitchSelective(AddressPart::Serial, 0x1234_5678),
            LssRequest::ConfigureNodeId(0x7F),
            LssRequest::ConfigureBitTiming(0, 3),
            LssRequest::ActivateBitTiming(500),
            LssRequest::StoreConfiguration,
            LssRequest::Inquire(AddressPart::Product),
            LssRequest::InquireNodeId,
            LssRequest::IdentifyRemote(5, 0xFFFF_FFFF),
            LssRequest::IdentifyNonConfigured,
            LssRequest::Fastscan { id: 0x8000_0000, bit_checked: 31, sub: 3, next: 0 },
        ];
        for r in all {
            assert_eq!(LssRequest::parse(&r.emit()), Ok(r));
        }
        // CiA 305: switch state global to configuration is "04 01 00 00 00 00 00 00".
        assert_eq!(LssRequest::SwitchGlobal(true).emit(), [0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn bad_frames_are_errors() {
        assert_eq!(LssRequest::parse(&[0x04, 1]), Err(LssError::Length));
        assert_eq!(LssRequest::parse(&[0x04, 2, 0, 0, 0, 0, 0, 0]), Err(LssError::Unknown(0x04)));
        assert_eq!(LssRequest::parse(&[0x99, 0, 0, 0, 0, 0, 0, 0]), Err(LssError::Unknown(0x99)));
        assert_eq!(answer(0x11, 1, 0), [0x11, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(answer_u32(0x5D, 7), [0x5D, 7, 0, 0, 0, 0, 0, 0]);
    }
}
