//! Emergency message format. CiA 301 v4.2 §7.2.7.3.1: error code (2 bytes),
//! error register (1 byte), manufacturer-specific error field (5 bytes).

/// One emergency message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// Error code (CiA 301 table 21, e.g. 0x8130 life guard or heartbeat error; 0x0000 error reset).
    pub code: u16,
    /// Error register 0x1001 at the time of the message.
    pub register: u8,
    /// Manufacturer-specific error field.
    pub info: [u8; 5],
}

/// Error codes the communication services raise (CiA 301 table 21).
pub mod code {
    /// Error reset or no error.
    pub const NO_ERROR: u16 = 0x0000;
    /// Generic error.
    pub const GENERIC: u16 = 0x1000;
    /// CAN overrun (objects lost).
    pub const CAN_OVERRUN: u16 = 0x8110;
    /// CAN in error passive mode.
    pub const CAN_PASSIVE: u16 = 0x8120;
    /// Life guard error or heartbeat error.
    pub const HEARTBEAT: u16 = 0x8130;
    /// Recovered from bus off.
    pub const BUS_OFF_RECOVERED: u16 = 0x8140;
    /// PDO not processed due to length error.
    pub const PDO_LENGTH: u16 = 0x8210;
    /// PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: u16 = 0x8220;
    /// RPDO timeout.
    pub const RPDO_TIMEOUT: u16 = 0x8250;
    /// Unexpected SYNC data length.
    pub const SYNC_LENGTH: u16 = 0x8240;
}

impl Emcy {
    /// The 8 data bytes.
    pub fn emit(&self) -> [u8; 8] {
        let [c0, c1] = self.code.to_le_bytes();
        let [i0, i1, i2, i3, i4] = self.info;
        [c0, c1, self.register, i0, i1, i2, i3, i4]
    }

    /// Parses 8 data bytes; `None` for any other length.
    pub fn parse(data: &[u8]) -> Option<Self> {
        let [c0, c1, register, i0, i1, i2, i3, i4] = *data else { return None };
        Some(Emcy { code: u16::from_le_bytes([c0, c1]), register, info: [i0, i1, i2, i3, i4] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_length() {
        let e = Emcy { code: code::HEARTBEAT, register: 0x11, info: [3, 0, 0, 0, 0] };
        assert_eq!(e.emit(), [0x30, 0x81, 0x11, 3, 0, 0, 0, 0]);
        assert_eq!(Emcy::parse(&e.emit()), Some(e));
        for n in 0..8 {
            assert_eq!(Emcy::parse(&[0; 8][..n]), None);
        }
    }
}
