//! Speeds in min⁻¹ (App. C: 0x60FF, 0x606B, 0x606C; 0.1 min⁻¹ with P0830
//! bit 2, §4.3.3), D57, times the gear factor 0x604C (§4.4.6, D60: motor
//! speed = object · numerator / denominator). The profile works in user
//! units per second (the factor group of 0x6092); the device converts at
//! the objects: 0x60FF before the profile reads it, 0x606B/0x606C after it
//! wrote them.

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
/// 0x604C gear factor ("vl dimension factor"): numerator (sub 1), denominator (sub 2).
pub(super) const GEAR_FACTOR: u16 = 0x604C;
/// P0830 (0x433E) option-module configuration word.
pub(super) const CONFIGURATION: u16 = 0x433E;
/// P0830 bit 2: speeds in 0.1 min⁻¹.
const TENTH: u32 = 1 << 2;

/// Whether P0830 has any of the bits of `mask` set.
pub(super) fn configured(ctx: &Ctx<'_>, mask: u32) -> bool {
    ctx.read_u32(CONFIGURATION, 0).is_some_and(|c| c & mask != 0)
}

/// Speed units to BE/s as (numerator, denominator, negative): feed ·
/// gear numerator / (60 or 600 · revolutions · gear denominator).
fn scales(ctx: &Ctx<'_>) -> (u64, u64, bool) {
    let per_minute = if configured(ctx, TENTH) { 600 } else { 60 };
    let feed = u64::from(ctx.read_u32(FEED_CONSTANT, 1).filter(|f| *f != 0).unwrap_or(65536));
    let revs = u64::from(ctx.read_u32(FEED_CONSTANT, 2).filter(|r| *r != 0).unwrap_or(1));
    // A zero factor (check_write refuses a zero denominator) counts as 1.
    let gear = |sub| ctx.read_u32(GEAR_FACTOR, sub).map(|g| g as i32).filter(|g| *g != 0).unwrap_or(1);
    let (num, den) = (gear(1), gear(2));
    (feed * u64::from(num.unsigned_abs()), per_minute * revs * u64::from(den.unsigned_abs()), (num < 0) != (den < 0))
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

/// The speed unit (of 0x606C and 0x606F) in BE/s, for the profile's
/// standstill window (docs/devices/bmaxx4400.md D68).
pub(super) fn unit(ctx: &Ctx<'_>) -> Factor {
    let (num, den, _) = scales(ctx);
    Factor::ratio(num, den)
}

/// 0x60FF in user units per second for the profile.
pub(super) fn target_for_profile(ctx: &Ctx<'_>) -> Option<i32> {
    let (num, den, negative) = scales(ctx);
    let user = Factor::ratio(num, den).apply(i64::from(read_i32(ctx, TARGET_VELOCITY)?));
    Some(clamp(if negative { -user } else { user }))
}

/// 0x606B and 0x606C in speed units. `shown` holds what this wrote last:
/// a value that differs is the profile's (in user units per second) and is
/// converted; one that equals it was not rewritten since (the profile
/// writes its actual values only while the axis moves or is sampled).
pub(super) fn actuals(ctx: &mut Ctx<'_>, shown: &mut [i32; 2]) {
    let (num, den, negative) = scales(ctx);
    let factor = Factor::ratio(den, num);
    for (index, shown) in [VELOCITY_DEMAND, VELOCITY_ACTUAL].into_iter().zip(shown.iter_mut()) {
        match read_i32(ctx, index) {
            Some(user) if user != *shown => {
                let speed = factor.apply(i64::from(user));
                *shown = clamp(if negative { -speed } else { speed });
                let _ = ctx.set_value(index, 0, &shown.to_le_bytes());
            }
            _ => {}
        }
    }
}
