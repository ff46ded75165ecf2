//! Interpolated position mode as the b maXX option module runs it (App. C
//! 60C0h-60C4h, M-L6237-6450; D58): linear interpolation only, one
//! record, taken on every SYNC. 0x60C1 sub 1 goes to the drive's position
//! set-point P0369 as it is (y = x): its upper 16 bits are revolutions and
//! its lower 16 bits the angle in increments, so it is increments at 65536
//! per revolution, whatever 0x6092 says and without the 2^31 offset. The
//! interpolation time period 0x60C2 may only be 2000, 4000 or 8000 µs and
//! is taken when sub 2 is written.

use canopen_core::node::Ctx;

/// 0x60C1 interpolation data record.
const DATA_RECORD: u16 = 0x60C1;
/// 0x60C2 interpolation time period: units (sub 1) × 10^index (sub 2) s.
pub(super) const TIME_PERIOD: u16 = 0x60C2;

/// The period of (ip time units, ip time index) as a power of two of 1 ms
/// ticks: 2, 4 or 8 ms ("Zulässig sind nur Einträge, die 2000, 4000 und
/// 8000 µs entsprechen"); `None` for any other period.
pub(super) fn period_log2(units: u32, index: i8) -> Option<u8> {
    // units · 10^index s in µs: index −6..=−3 multiplies by 1..1000.
    let exponent = i32::from(index) + 6;
    if !(0..=3).contains(&exponent) {
        return None;
    }
    let us = (0..exponent).fold(units, |u, _| u * 10);
    [2000, 4000, 8000].iter().position(|p| *p == us).map(|i| i as u8 + 1)
}

/// The period 0x60C2 holds now (at reset application: the stored or default one).
pub(super) fn period(ctx: &Ctx<'_>, index: Option<i8>) -> Option<u8> {
    let units = ctx.read_u32(TIME_PERIOD, 1)?;
    let index = match index {
        Some(i) => i,
        None => ctx.read_u32(TIME_PERIOD, 2)? as u8 as i8,
    };
    period_log2(units, index)
}

/// The record a SYNC takes: 0x60C1 sub 1 [inc].
pub(super) fn set_point(ctx: &Ctx<'_>) -> i64 {
    i64::from(ctx.read_u32(DATA_RECORD, 1).unwrap_or(0) as i32)
}
