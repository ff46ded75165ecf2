//! SDO abort codes. CiA 301 v4.2 §7.2.4.3.17, table 22.

/// Why an SDO transfer was aborted; [`AbortCode::code`] gives the CiA 301 value.
///
/// One byte rather than the 32-bit value as discriminant: every `Err` the
/// core builds then loads a small constant instead of a 32-bit one, and a
/// `Result<(), AbortCode>` is one byte (464 bytes less flash in the `core`
/// image of `cargo xtask size`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AbortCode {
    /// 0x05030000 Toggle bit not alternated.
    ToggleBit,
    /// 0x05040000 SDO protocol timed out.
    Timeout,
    /// 0x05040001 Client/server command specifier not valid or unknown.
    InvalidCommand,
    /// 0x05040002 Invalid block size (block mode only).
    InvalidBlockSize,
    /// 0x05040003 Invalid sequence number (block mode only).
    InvalidSequence,
    /// 0x05040004 CRC error (block mode only).
    CrcError,
    /// 0x05040005 Out of memory.
    OutOfMemory,
    /// 0x06010000 Unsupported access to an object.
    UnsupportedAccess,
    /// 0x06010001 Attempt to read a write only object.
    WriteOnly,
    /// 0x06010002 Attempt to write a read only object.
    ReadOnly,
    /// 0x06020000 Object does not exist in the object dictionary.
    NoObject,
    /// 0x06040041 Object cannot be mapped to the PDO.
    NotMappable,
    /// 0x06040042 The number and length of the objects to be mapped would exceed PDO length.
    PdoTooLong,
    /// 0x06040043 General parameter incompatibility reason.
    ParameterIncompatible,
    /// 0x06040047 General internal incompatibility in the device.
    InternalIncompatible,
    /// 0x06060000 Access failed due to a hardware error.
    Hardware,
    /// 0x06070010 Data type does not match, length of service parameter does not match.
    LengthMismatch,
    /// 0x06070012 Data type does not match, length of service parameter too high.
    LengthTooHigh,
    /// 0x06070013 Data type does not match, length of service parameter too low.
    LengthTooLow,
    /// 0x06090011 Sub-index does not exist.
    NoSubIndex,
    /// 0x06090030 Invalid value for parameter (download only).
    InvalidValue,
    /// 0x06090031 Value of parameter written too high (download only).
    ValueTooHigh,
    /// 0x06090032 Value of parameter written too low (download only).
    ValueTooLow,
    /// 0x06090036 Maximum value is less than minimum value.
    MaxBelowMin,
    /// 0x060A0023 Resource not available: SDO connection.
    NoResource,
    /// 0x08000000 General error.
    General,
    /// 0x08000020 Data cannot be transferred or stored to the application.
    CannotStore,
    /// 0x08000021 Data cannot be transferred or stored because of local control.
    LocalControl,
    /// 0x08000022 Data cannot be transferred or stored because of the present device state.
    DeviceState,
    /// 0x08000023 Object dictionary dynamic generation fails or no object dictionary is present.
    NoDictionary,
    /// 0x08000024 No data available.
    NoData,
}

impl AbortCode {
    /// The 32-bit value sent in the abort frame.
    // Every CiA 301 code is 0x0HMM00LL with H and MM below 16: packed as
    // 0xHMLL, 2 bytes a code where a jump table of the values takes 4.
    #[allow(clippy::indexing_slicing)] // one entry per variant, in their order
    pub const fn code(self) -> u32 {
        const PACKED: [u16; 31] = [
            0x5300, 0x5400, 0x5401, 0x5402, 0x5403, 0x5404, 0x5405, 0x6100, 0x6101, 0x6102, 0x6200, 0x6441, 0x6442, 0x6443, 0x6447, 0x6600,
            0x6710, 0x6712, 0x6713, 0x6911, 0x6930, 0x6931, 0x6932, 0x6936, 0x6A23, 0x8000, 0x8020, 0x8021, 0x8022, 0x8023, 0x8024,
        ];
        let p = PACKED[self as usize] as u32;
        ((p & 0xF000) << 12) | ((p & 0x0F00) << 8) | (p & 0xFF)
    }

    /// The abort code with this value, if it is one CiA 301 defines.
    pub const fn from_code(code: u32) -> Option<AbortCode> {
        use AbortCode::*;
        Some(match code {
            0x0503_0000 => ToggleBit,
            0x0504_0000 => Timeout,
            0x0504_0001 => InvalidCommand,
            0x0504_0002 => InvalidBlockSize,
            0x0504_0003 => InvalidSequence,
            0x0504_0004 => CrcError,
            0x0504_0005 => OutOfMemory,
            0x0601_0000 => UnsupportedAccess,
            0x0601_0001 => WriteOnly,
            0x0601_0002 => ReadOnly,
            0x0602_0000 => NoObject,
            0x0604_0041 => NotMappable,
            0x0604_0042 => PdoTooLong,
            0x0604_0043 => ParameterIncompatible,
            0x0604_0047 => InternalIncompatible,
            0x0606_0000 => Hardware,
            0x0607_0010 => LengthMismatch,
            0x0607_0012 => LengthTooHigh,
            0x0607_0013 => LengthTooLow,
            0x0609_0011 => NoSubIndex,
            0x0609_0030 => InvalidValue,
            0x0609_0031 => ValueTooHigh,
            0x0609_0032 => ValueTooLow,
            0x0609_0036 => MaxBelowMin,
            0x060A_0023 => NoResource,
            0x0800_0000 => General,
            0x0800_0020 => CannotStore,
            0x0800_0021 => LocalControl,
            0x0800_0022 => DeviceState,
            0x0800_0023 => NoDictionary,
            0x0800_0024 => NoData,
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip() {
        for c in [AbortCode::ToggleBit, AbortCode::CrcError, AbortCode::NoSubIndex, AbortCode::NoData, AbortCode::MaxBelowMin] {
            assert_eq!(AbortCode::from_code(c.code()), Some(c));
        }
        assert_eq!(AbortCode::from_code(0x1234_5678), None);
    }

    #[test]
    fn every_code_has_its_cia_301_value() {
        use AbortCode::*;
        // Table 22 of CiA 301 v4.2, one line per variant.
        let table = [
            (ToggleBit, 0x0503_0000),
            (Timeout, 0x0504_0000),
            (InvalidCommand, 0x0504_0001),
            (InvalidBlockSize, 0x0504_0002),
            (InvalidSequence, 0x0504_0003),
            (CrcError, 0x0504_0004),
            (OutOfMemory, 0x0504_0005),
            (UnsupportedAccess, 0x0601_0000),
            (WriteOnly, 0x0601_0001),
            (ReadOnly, 0x0601_0002),
            (NoObject, 0x0602_0000),
            (NotMappable, 0x0604_0041),
            (PdoTooLong, 0x0604_0042),
            (ParameterIncompatible, 0x0604_0043),
            (InternalIncompatible, 0x0604_0047),
            (Hardware, 0x0606_0000),
            (LengthMismatch, 0x0607_0010),
            (LengthTooHigh, 0x0607_0012),
            (LengthTooLow, 0x0607_0013),
            (NoSubIndex, 0x0609_0011),
            (InvalidValue, 0x0609_0030),
            (ValueTooHigh, 0x0609_0031),
            (ValueTooLow, 0x0609_0032),
            (MaxBelowMin, 0x0609_0036),
            (NoResource, 0x060A_0023),
            (General, 0x0800_0000),
            (CannotStore, 0x0800_0020),
            (LocalControl, 0x0800_0021),
            (DeviceState, 0x0800_0022),
            (NoDictionary, 0x0800_0023),
            (NoData, 0x0800_0024),
        ];
        for (code, value) in table {
            assert_eq!(code.code(), value, "{code:?}");
            assert_eq!(AbortCode::from_code(value), Some(code));
        }
    }
}
