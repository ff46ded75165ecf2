//! Speeds in min⁻¹ at the motor (App. C: 0x60FF, 0x606B, 0x606C; 0.1 min⁻¹
//! with P0830 bit 2, §4.3.3), D57. The profile works in user units per
//! second (the factor group of 0x6092); the device converts at the objects:
//! 0x60FF before the profile reads it, 0x606B/0x606C after it wrote them.

use canopen_core::node::Ctx;
use canopen_core::profiles::cia402::units::Factor;

/// 0x60FF target velocity.
pub(super) const TARGET_VELOCITY: u16 = 0x60FF;
/// 0x606B velocity demand value.
const VELOCITY_DEMAND: u16 = 0x606B;
/// 0x606C velocity actual value.
const VELOCITY_ACTUAL: u16 = 0x606C;
/// 0x6092 feed constant: feed [BE] (sub 1) per revolutions (sub 2).
const FEED_CONSTANT: u16 = 0x6092;
/// P0830 (0x433E) option-module configuration word.
const CONFIGURATION: u16 = 0x433E;
/// P0830 bit 2: speeds in 0.1 min⁻¹.
const TENTH: u32 = 1 << 2;

/// (speed units per revolution per second, BE per revolution): 60 or 600, and 0x6092's feed per revolution.
fn scales(ctx: &Ctx<'_>) -> (u64, u64, u64) {
    let per_minute = if ctx.read_u32(CONFIGURATION, 0).is_some_and(|c| c & TENTH != 0) { 600 } else { 60 };
    let feed = u64::from(ctx.read_u32(FEED_CONSTANT, 1).filter(|f| *f != 0).unwrap_or(65536));
    let revs = u64::from(ctx.read_u32(FEED_CONSTANT, 2).filter(|r| *r != 0).unwrap_or(1));
    (per_minute, feed, revs)
}

fn read_i32(ctx: &Ctx<'_>, index: u16) -> Option<i32> {
    match *ctx.read(index, 0).ok()? {
        [a, b, c, d] => Some(i32::from_le_bytes([a, b, c, d])),
        _ => None,
    }
}

fn clamp(value: i64) -> i32 {
    value.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// 0x60FF in user units per second for the profile: speed · feed / (60 · revolutions).
pub(super) fn target_for_profile(ctx: &Ctx<'_>) -> Option<i32> {
    let (per_minute, feed, revs) = scales(ctx);
    Some(clamp(Factor::ratio(feed, per_minute * revs).apply(i64::from(read_i32(ctx, TARGET_VELOCITY)?))))
}

/// 0x606B and 0x606C in speed units. `shown` holds what this wrote last:
/// a value that differs is the profile's (in user units per second) and is
/// converted; one that equals it was not rewritten since (the profile
/// writes its actual values only while the axis moves or is sampled).
pub(super) fn actuals(ctx: &mut Ctx<'_>, shown: &mut [i32; 2]) {
    let (per_minute, feed, revs) = scales(ctx);
    let factor = Factor::ratio(per_minute * revs, feed);
    for (index, shown) in [VELOCITY_DEMAND, VELOCITY_ACTUAL].into_iter().zip(shown.iter_mut()) {
        match read_i32(ctx, index) {
            Some(user) if user != *shown => {
                *shown = clamp(factor.apply(i64::from(user)));
                let _ = ctx.set_value(index, 0, &shown.to_le_bytes());
            }
            _ => {}
        }
    }
}
