//! Work areas (0x6400–0x6402) and the EMCY an alarm or warning bit raises
//! (0x6503/0x6505, CiA 406 §6.4–6.5): pure functions of the values.

use super::SensorFault;
use crate::wire::emcy::EmcyCode;

/// 0x6400 bit 0: the position is outside the module's min/max (0x650A:02/03).
pub const OUT_OF_RANGE: u8 = 1 << 0;
/// 0x6400 bit 1: the position is above the work area high limit (0x6402).
pub const RANGE_OVERFLOW: u8 = 1 << 1;
/// 0x6400 bit 2: the position is below the work area low limit (0x6401).
pub const RANGE_UNDERFLOW: u8 = 1 << 2;

/// The state byte of one work-area channel: `position` against its
/// `low`/`high` limits and the module's `min`/`max` (0x650A, compared as
/// signed 32-bit values, docs/devices/sendix.md D20).
pub fn work_area_state(position: u32, low: u32, high: u32, min: i32, max: i32) -> u8 {
    let mut state = 0;
    let signed = position as i32;
    if signed < min || signed > max {
        state |= OUT_OF_RANGE;
    }
    if position > high {
        state |= RANGE_OVERFLOW;
    }
    if position < low {
        state |= RANGE_UNDERFLOW;
    }
    state
}

/// An EMCY a device raises for one of its errors, as its manual prints it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ErrorEmcy {
    /// The EMCY error code.
    pub code: EmcyCode,
    /// Error register (0x1001) bits the error sets while it lasts, beyond
    /// those of its code's class (CiA 301 table 21 gives 0x1000 none; the
    /// Sendix's position error sets bit 5 "device profile", manual §5.5.3).
    pub register: u8,
    /// The manufacturer-specific bytes, unless the raiser gives its own.
    pub info: [u8; 5],
}

/// Warning bits and the EMCY they raise while any of them is set (one
/// entry per error code: the Sendix raises 0x4200 for overspeed and for
/// temperature, so its entry has both bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BitEmcy {
    /// The bits (mask) in 0x6505.
    pub mask: u16,
    /// What they raise.
    pub emcy: ErrorEmcy,
}

/// What a sensor fault sets in 0x6503 and the EMCY it raises while it
/// lasts: the bit says what a master can no longer trust, the code why
/// (two causes may share a bit with different codes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultAlarm {
    /// The fault the sensor reports.
    pub fault: SensorFault,
    /// The bits it sets in 0x6503.
    pub mask: u16,
    /// What it raises.
    pub emcy: ErrorEmcy,
}

/// An EMCY to raise or clear after bits changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmcyChange {
    /// The first bit of this code came on.
    Raise(ErrorEmcy),
    /// The last bit of this code went off.
    Clear(EmcyCode),
}

/// The EMCY changes when the bits go from `old` to `new`: a code is raised
/// by the first of its bits and cleared with the last.
pub fn emcy_changes(table: &[BitEmcy], old: u16, new: u16) -> impl Iterator<Item = EmcyChange> + '_ {
    table.iter().filter_map(move |e| match (old & e.mask != 0, new & e.mask != 0) {
        (false, true) => Some(EmcyChange::Raise(e.emcy)),
        (true, false) => Some(EmcyChange::Clear(e.emcy.code)),
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_area_bits_follow_the_manual_example() {
        // §5.7.2: low 1000, high 35000.
        assert_eq!(work_area_state(500, 1000, 35000, 0, i32::MAX), RANGE_UNDERFLOW);
        assert_eq!(work_area_state(20000, 1000, 35000, 0, i32::MAX), 0);
        assert_eq!(work_area_state(35500, 1000, 35000, 0, i32::MAX), RANGE_OVERFLOW);
        assert_eq!(work_area_state(35500, 1000, 35000, 0, 30000), RANGE_OVERFLOW | OUT_OF_RANGE);
    }

    #[test]
    fn a_shared_code_is_raised_once_and_cleared_with_its_last_bit() {
        let temperature = ErrorEmcy { code: EmcyCode(0x4200), register: 0, info: [1, 0, 0, 0, 0] };
        let memory = ErrorEmcy { code: EmcyCode(0x5200), register: 0, info: [0; 5] };
        let t = [BitEmcy { mask: 0x4001, emcy: temperature }, BitEmcy { mask: 0x8000, emcy: memory }];
        let v: Vec<_> = emcy_changes(&t, 0, 0x4000).collect();
        assert_eq!(v, [EmcyChange::Raise(temperature)]);
        assert_eq!(emcy_changes(&t, 0x4000, 0x4001).count(), 0);
        assert_eq!(emcy_changes(&t, 0x4001, 0x0001).count(), 0);
        let v: Vec<_> = emcy_changes(&t, 0x0001, 0x8000).collect();
        assert_eq!(v, [EmcyChange::Clear(EmcyCode(0x4200)), EmcyChange::Raise(memory)]);
    }
}
