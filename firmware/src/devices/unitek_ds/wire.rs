//! UNITEK register protocol frames: byte formats only (manual §4.1–§4.8,
//! §5.2, English appendix items 1, 3, 7 and 8).
//!
//! Master to drive, on the RX id: `[REGID, value LE]`, DLC 3 = 16 bits,
//! DLC 5 = 32 bits. DLC 4 is read as 16 bits (§5.1 "DLC (3, 4, 5)") and
//! DLC 6–8 as 5 (L231-232: "bis zu 8 Byte … als 5 Byte Daten-Paket
//! ausgewertet"); the upper bytes are ignored (L337). A write to REGID 0x3D
//! is a read request `[3D, REGID, time]`.
//!
//! Drive to master, on the TX id: `[REGID, value LE, stuff]`, DLC 4 for a
//! 16-bit value, DLC 6 for a 32-bit one (L1044); the stuff byte is 0x00
//! (the manual's one concrete reply, L834).

/// REGID 0x3D READ: a write to it asks for a register's value.
pub const READ: u8 = 0x3D;

/// The value of a write frame, as wide as the frame carried it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    /// DLC 3 or 4: 16 bits.
    Bits16(u16),
    /// DLC 5 to 8: 32 bits.
    Bits32(u32),
}

/// When a read request wants its answer (the request's third byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Period {
    /// 0x00: once, at once.
    Once,
    /// 0x01–0xFE: every that many milliseconds.
    EveryMs(u8),
    /// 0xFF: stop the cyclic transmission.
    Stop,
}

impl Period {
    /// The period a time byte asks for.
    pub const fn from_byte(time: u8) -> Period {
        match time {
            0x00 => Period::Once,
            0xFF => Period::Stop,
            ms => Period::EveryMs(ms),
        }
    }
}

/// A frame the master sends to the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request {
    /// Writes `value` to register `regid`.
    Write {
        /// The register.
        regid: u8,
        /// The value, as wide as the frame carried it.
        value: Value,
    },
    /// READ 0x3D: send register `regid`'s value once, cyclically, or stop.
    Read {
        /// The register to send.
        regid: u8,
        /// When.
        period: Period,
    },
}

/// A frame too short to carry a REGID and 16 bits (DLC 0–2): the manual
/// gives it no meaning; it is counted and ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Malformed;

impl Request {
    /// Decodes the data of a frame received on the RX id.
    pub fn parse(data: &[u8]) -> Result<Request, Malformed> {
        let value = match *data {
            [_, b0, b1, b2, b3, ..] => Value::Bits32(u32::from_le_bytes([b0, b1, b2, b3])),
            [_, b0, b1, ..] => Value::Bits16(u16::from_le_bytes([b0, b1])),
            _ => return Err(Malformed),
        };
        let regid = *data.first().ok_or(Malformed)?;
        Ok(match (regid, data) {
            // A 32-bit write to the 16-bit READ register is truncated to its low word too (L1037).
            (READ, [_, target, time, ..]) => Request::Read { regid: *target, period: Period::from_byte(*time) },
            _ => Request::Write { regid, value },
        })
    }
}

/// A frame the drive sends: register `regid`'s value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply {
    /// The register (not 0x3D: the one that was read).
    pub regid: u8,
    /// Its value; only the low 16 bits go out in a 16-bit reply.
    pub value: u32,
    /// DLC 6 (32 bits) instead of DLC 4.
    pub wide: bool,
}

impl Reply {
    /// Decodes a reply (a master's or a trace's view): DLC 4 or 6, the stuff byte ignored.
    pub fn parse(data: &[u8]) -> Result<Reply, Malformed> {
        match *data {
            [regid, b0, b1, _] => Ok(Reply { regid, value: u32::from(u16::from_le_bytes([b0, b1])), wide: false }),
            [regid, b0, b1, b2, b3, _] => Ok(Reply { regid, value: u32::from_le_bytes([b0, b1, b2, b3]), wide: true }),
            _ => Err(Malformed),
        }
    }

    /// The frame's data in `buf`: DLC 4 or 6, the stuff byte 0x00.
    pub fn emit(self, buf: &mut [u8; 6]) -> &[u8] {
        let [b0, b1, b2, b3] = self.value.to_le_bytes();
        *buf = if self.wide { [self.regid, b0, b1, b2, b3, 0] } else { [self.regid, b0, b1, 0, 0, 0] };
        let len = if self.wide { 6 } else { 4 };
        buf.get(..len).unwrap_or(buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dlc_3_and_4_write_16_bits() {
        // Ex. 3 (M-L512-524): speed 10 %.
        assert_eq!(Request::parse(&[0x31, 0xCD, 0x0C]), Ok(Request::Write { regid: 0x31, value: Value::Bits16(0x0CCD) }));
        // §5.1 "DLC (3, 4, 5)": the fourth byte is registered, not considered.
        assert_eq!(Request::parse(&[0x31, 0xCD, 0x0C, 0x77]), Ok(Request::Write { regid: 0x31, value: Value::Bits16(0x0CCD) }));
    }

    #[test]
    fn dlc_5_to_8_write_32_bits() {
        // §4.8 (M-L355-387): POS_DEST 300010000.
        let write = Request::Write { regid: 0x6E, value: Value::Bits32(300_010_000) };
        assert_eq!(Request::parse(&[0x6E, 0x10, 0xCA, 0xE1, 0x11]), Ok(write));
        for extra in 1..=3 {
            let data = [0x6E, 0x10, 0xCA, 0xE1, 0x11, 0xAA, 0xBB, 0xCC];
            assert_eq!(Request::parse(&data[..5 + extra]), Ok(write), "DLC {}", 5 + extra);
        }
    }

    #[test]
    fn dlc_0_to_2_are_malformed() {
        for data in [&[][..], &[0x31], &[0x31, 0xCD]] {
            assert_eq!(Request::parse(data), Err(Malformed));
        }
    }

    #[test]
    fn read_requests() {
        // Ex. 8 (M-L599-609), Ex. 9 (M-L641-660), stop (M-L442).
        assert_eq!(Request::parse(&[0x3D, 0x40, 0x00]), Ok(Request::Read { regid: 0x40, period: Period::Once }));
        assert_eq!(Request::parse(&[0x3D, 0x30, 0x64]), Ok(Request::Read { regid: 0x30, period: Period::EveryMs(100) }));
        assert_eq!(Request::parse(&[0x3D, 0x30, 0xFF]), Ok(Request::Read { regid: 0x30, period: Period::Stop }));
        assert_eq!(Request::parse(&[0x3D, 0x30, 0x01, 0, 0]), Ok(Request::Read { regid: 0x30, period: Period::EveryMs(1) }));
    }

    #[test]
    fn replies_are_dlc_4_or_6_with_a_zero_stuff_byte() {
        let mut buf = [0xEE; 6];
        // Ex. 11 (M-L834): BTB = 1.
        assert_eq!(Reply { regid: 0xE2, value: 1, wide: false }.emit(&mut buf), [0xE2, 0x01, 0x00, 0x00]);
        // Ex. 10 (M-L727): STATUS 0x3181.
        assert_eq!(Reply { regid: 0x40, value: 0x3181, wide: true }.emit(&mut buf), [0x40, 0x81, 0x31, 0x00, 0x00, 0x00]);
        assert_eq!(Reply { regid: 0x30, value: 0xFFFF_7FFF, wide: false }.emit(&mut buf), [0x30, 0xFF, 0x7F, 0x00]);
    }

    #[test]
    fn replies_parse_back() {
        assert_eq!(Reply::parse(&[0xE2, 0x01, 0x00, 0x00]), Ok(Reply { regid: 0xE2, value: 1, wide: false }));
        assert_eq!(Reply::parse(&[0x40, 0x85, 0x31, 0x00, 0x00, 0x00]), Ok(Reply { regid: 0x40, value: 0x3185, wide: true }));
        for len in [0, 1, 2, 3, 5, 7, 8] {
            assert_eq!(Reply::parse(&[0x30; 8][..len]), Err(Malformed), "DLC {len}");
        }
    }
}
