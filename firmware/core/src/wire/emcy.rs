//! Emergency message format. CiA 301 v4.2 §7.2.7.3.1: error code (2 bytes),
//! error register (1 byte), manufacturer-specific error field (5 bytes).

/// An emergency error code (CiA 301 §7.2.7.3.1, table 21). An open set:
/// CiA 301, the device profiles (CiA 402, CiA 406) and the vendors each
/// define codes, so a newtype with named constants rather than an enum.
/// The high byte's upper nibble is the error class, which decides the error
/// register bit it sets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct EmcyCode(pub u16);

impl EmcyCode {
    /// 0x0000 Error reset or no error.
    pub const NO_ERROR: EmcyCode = EmcyCode(0x0000);
    /// 0x1000 Generic error.
    pub const GENERIC: EmcyCode = EmcyCode(0x1000);
    /// 0x5000 Device hardware.
    pub const DEVICE_HARDWARE: EmcyCode = EmcyCode(0x5000);
    /// 0x6100 Internal software.
    pub const INTERNAL_SOFTWARE: EmcyCode = EmcyCode(0x6100);
    /// 0x8100 Communication (generic).
    pub const COMMUNICATION: EmcyCode = EmcyCode(0x8100);
    /// 0x8110 CAN overrun (objects lost).
    pub const CAN_OVERRUN: EmcyCode = EmcyCode(0x8110);
    /// 0x8120 CAN in error passive mode.
    pub const CAN_ERROR_PASSIVE: EmcyCode = EmcyCode(0x8120);
    /// 0x8130 Life guard error or heartbeat error.
    pub const LIFE_GUARD_OR_HEARTBEAT: EmcyCode = EmcyCode(0x8130);
    /// 0x8140 Recovered from bus off.
    pub const RECOVERED_FROM_BUS_OFF: EmcyCode = EmcyCode(0x8140);
    /// 0x8210 PDO not processed due to length error.
    pub const PDO_LENGTH: EmcyCode = EmcyCode(0x8210);
    /// 0x8220 PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: EmcyCode = EmcyCode(0x8220);
    /// 0x8240 Unexpected SYNC data length.
    pub const UNEXPECTED_SYNC_LENGTH: EmcyCode = EmcyCode(0x8240);
    /// 0x8250 RPDO timeout.
    pub const RPDO_TIMEOUT: EmcyCode = EmcyCode(0x8250);

    /// The 16-bit value sent in the message.
    pub const fn value(self) -> u16 {
        self.0
    }
}

impl From<EmcyCode> for u16 {
    fn from(code: EmcyCode) -> u16 {
        code.0
    }
}

impl From<u16> for EmcyCode {
    fn from(value: u16) -> EmcyCode {
        EmcyCode(value)
    }
}

/// One emergency message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// Error code ([`EmcyCode::NO_ERROR`]: error reset).
    pub code: EmcyCode,
    /// Error register 0x1001 at the time of the message.
    pub register: u8,
    /// Manufacturer-specific error field.
    pub info: [u8; 5],
}

impl Emcy {
    /// The 8 data bytes.
    pub fn emit(&self) -> [u8; 8] {
        let [c0, c1] = self.code.0.to_le_bytes();
        let [i0, i1, i2, i3, i4] = self.info;
        [c0, c1, self.register, i0, i1, i2, i3, i4]
    }

    /// Parses 8 data bytes; `None` for any other length.
    pub fn parse(data: &[u8]) -> Option<Self> {
        let [c0, c1, register, i0, i1, i2, i3, i4] = *data else { return None };
        Some(Emcy { code: EmcyCode(u16::from_le_bytes([c0, c1])), register, info: [i0, i1, i2, i3, i4] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_length() {
        let e = Emcy { code: EmcyCode::LIFE_GUARD_OR_HEARTBEAT, register: 0x11, info: [3, 0, 0, 0, 0] };
        assert_eq!(e.emit(), [0x30, 0x81, 0x11, 3, 0, 0, 0, 0]);
        assert_eq!(Emcy::parse(&e.emit()), Some(e));
        for n in 0..8 {
            assert_eq!(Emcy::parse(&[0; 8][..n]), None);
        }
    }

    #[test]
    fn named_codes_have_their_cia_301_values() {
        // CiA 301 v4.2 table 21.
        let table = [
            (EmcyCode::NO_ERROR, 0x0000),
            (EmcyCode::GENERIC, 0x1000),
            (EmcyCode::DEVICE_HARDWARE, 0x5000),
            (EmcyCode::INTERNAL_SOFTWARE, 0x6100),
            (EmcyCode::COMMUNICATION, 0x8100),
            (EmcyCode::CAN_OVERRUN, 0x8110),
            (EmcyCode::CAN_ERROR_PASSIVE, 0x8120),
            (EmcyCode::LIFE_GUARD_OR_HEARTBEAT, 0x8130),
            (EmcyCode::RECOVERED_FROM_BUS_OFF, 0x8140),
            (EmcyCode::PDO_LENGTH, 0x8210),
            (EmcyCode::PDO_LENGTH_EXCEEDED, 0x8220),
            (EmcyCode::UNEXPECTED_SYNC_LENGTH, 0x8240),
            (EmcyCode::RPDO_TIMEOUT, 0x8250),
        ];
        for (code, value) in table {
            assert_eq!((u16::from(code), EmcyCode::from(value)), (value, code));
        }
    }
}
