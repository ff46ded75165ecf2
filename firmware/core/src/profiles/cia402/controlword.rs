//! Controlword 0x6040: the device control commands of CiA 402-2 §6.2
//! (bits 0-3 and 7) and the operation-mode-specific bits (4-6, 8, 9).

/// Bit 0 switch on.
pub const SWITCH_ON: u16 = 1 << 0;
/// Bit 1 enable voltage.
pub const ENABLE_VOLTAGE: u16 = 1 << 1;
/// Bit 2 quick stop (0 = quick stop).
pub const QUICK_STOP: u16 = 1 << 2;
/// Bit 3 enable operation.
pub const ENABLE_OPERATION: u16 = 1 << 3;
/// Bit 4: pp new set-point, hm homing operation start.
pub const NEW_SET_POINT: u16 = 1 << 4;
/// Bit 5 (pp): change set immediately.
pub const CHANGE_IMMEDIATELY: u16 = 1 << 5;
/// Bit 6 (pp): target position is relative.
pub const RELATIVE: u16 = 1 << 6;
/// Bit 7 fault reset (on its rising edge).
pub const FAULT_RESET: u16 = 1 << 7;
/// Bit 8 halt.
pub const HALT: u16 = 1 << 8;
/// Bit 9 (pp): change on set-point (the buffered set-point follows without a stop).
pub const CHANGE_OF_SET_POINT: u16 = 1 << 9;

/// A device control command (CiA 402-2 table "Command coding").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// x110: transitions 2, 6, 8.
    Shutdown,
    /// 0111: transition 3; from Operation enabled "disable operation", 5.
    SwitchOn,
    /// 1111: transitions 4 and 16; from Ready to switch on 3 then 4.
    EnableOperation,
    /// xx0x: transitions 7, 9, 10, 12.
    DisableVoltage,
    /// x01x: transitions 7, 10, 11.
    QuickStop,
    /// Rising edge of bit 7: transition 15.
    FaultReset,
}

/// The command `cw` gives after `previous`: a fault reset on the rising
/// edge of bit 7; while bit 7 stays set, no command (the table codes every
/// other command with bit 7 = 0).
pub fn decode(cw: u16, previous: u16) -> Option<Command> {
    if cw & FAULT_RESET != 0 {
        return if previous & FAULT_RESET == 0 { Some(Command::FaultReset) } else { None };
    }
    // Bits 0-3 index the table (one load, not up to four tests); the mask keeps the index in it.
    BY_BITS_0_TO_3.get(usize::from(cw & 0x0F)).copied()
}

/// The command of each value of bits 0-3 (bit 7 clear), CiA 402-2's
/// coding: xx0x disable voltage, x01x quick stop, x110 shutdown, 0111
/// switch on, 1111 enable operation.
const BY_BITS_0_TO_3: [Command; 16] = {
    use Command::{DisableVoltage as Dv, EnableOperation as Eo, QuickStop as Qs, Shutdown as Sd, SwitchOn as So};
    [Dv, Dv, Qs, Qs, Dv, Dv, Sd, So, Dv, Dv, Qs, Qs, Dv, Dv, Sd, Eo]
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_coding_of_cia_402_2() {
        assert_eq!(decode(0x0006, 0), Some(Command::Shutdown));
        assert_eq!(decode(0x000E, 0), Some(Command::Shutdown), "bit 3 is don't care");
        assert_eq!(decode(0x0007, 0), Some(Command::SwitchOn));
        assert_eq!(decode(0x000F, 0), Some(Command::EnableOperation));
        assert_eq!(decode(0x0000, 0), Some(Command::DisableVoltage));
        assert_eq!(decode(0x000D, 0), Some(Command::DisableVoltage));
        assert_eq!(decode(0x0002, 0), Some(Command::QuickStop));
        assert_eq!(decode(0x000B, 0), Some(Command::QuickStop));
        assert_eq!(decode(0x0080, 0), Some(Command::FaultReset));
        assert_eq!(decode(0x0080, 0x0080), None, "only the rising edge");
        assert_eq!(decode(0x008F, 0x0080), None, "bit 7 held: no command");
        assert_eq!(decode(0x011F, 0), Some(Command::EnableOperation), "mode bits do not change the command");
    }

    #[test]
    fn every_value_of_bits_0_to_3_decodes_as_the_coding_table_says() {
        for bits in 0..16u16 {
            let want = if bits & ENABLE_VOLTAGE == 0 {
                Command::DisableVoltage
            } else if bits & QUICK_STOP == 0 {
                Command::QuickStop
            } else if bits & SWITCH_ON == 0 {
                Command::Shutdown
            } else if bits & ENABLE_OPERATION == 0 {
                Command::SwitchOn
            } else {
                Command::EnableOperation
            };
            assert_eq!(decode(bits | 0x0370, 0), Some(want), "controlword {:#06x}", bits | 0x0370);
        }
    }
}
