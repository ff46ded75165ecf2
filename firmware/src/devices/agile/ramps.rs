//! The vl objects written into the inverter's parameters (§9.5.8-§9.5.11,
//! M-L2773-2884; D54 in docs/devices/agile.md): 0x6046 sub 1/2 into p.418
//! and p.419 (minimum and maximum frequency), 0x6048 into p.420 and p.422
//! (acceleration clockwise and anticlockwise), 0x6049 into p.421 and p.423
//! (deceleration), 0x604A into p.424 and p.425 (emergency stop), each "im
//! Datensatz 5, alle Datensätze nur im RAM", converted to 0.01 Hz (per
//! second) with the pole pairs of p.373 in data set 1: f = n · p / 60.

use canopen_core::node::Ctx;

/// p.373 pole pairs (0x2175, data set 1 at sub 1).
pub(super) const POLE_PAIRS: u16 = 0x2175;

/// The parameters (0x2000 + number) an object's write sets, and whether the
/// object is a ramp (delta speed sub 1 over delta time sub 2) rather than a speed.
fn targets(index: u16, sub: u8) -> Option<([u16; 2], bool)> {
    Some(match (index, sub) {
        (0x6046, 1) => ([0x21A2, 0x21A2], false),
        (0x6046, 2) => ([0x21A3, 0x21A3], false),
        (0x6048, _) => ([0x21A4, 0x21A6], true),
        (0x6049, _) => ([0x21A5, 0x21A7], true),
        (0x604A, _) => ([0x21A8, 0x21A9], true),
        _ => return None,
    })
}

/// (index, sub) was written: the parameters it drives take its value in RAM.
pub(super) fn written(ctx: &mut Ctx<'_>, index: u16, sub: u8) {
    let Some((parameters, ramp)) = targets(index, sub) else { return };
    let pole_pairs = ctx.read_u32(POLE_PAIRS, 1).unwrap_or(2);
    let speed = ctx.read_u32(index, if ramp { 1 } else { sub }).unwrap_or(0);
    let per_second = if ramp { ctx.read_u32(index, 2).unwrap_or(1).max(1) } else { 1 };
    // min⁻¹ (per s) to 0.01 Hz (per s): · p · 100 / 60, in 32 bits (no 64-bit division
    // on the MCU): 32767 · 24 · 100 fits; larger values saturate.
    let hundredths = (speed.saturating_mul(pole_pairs).saturating_mul(100) / 60 / per_second).min(i32::MAX as u32) as i32;
    for parameter in parameters {
        for set in 1..=4 {
            let _ = ctx.set_value(parameter, set, &hundredths.to_le_bytes());
        }
    }
}

/// Reset application (power-on): objects a 0x1010 "save" stored overwrite the
/// parameters ("Nach dem nächsten Einschalten … überschreiben die Einstellungen
/// der Parameter", M-L2788, M-L2820).
pub(super) fn at_power_on(ctx: &mut Ctx<'_>) {
    for (index, sub) in [(0x6046, 1), (0x6046, 2), (0x6048, 1), (0x6049, 1), (0x604A, 1)] {
        if ctx.stored(index, sub, &mut [0; 4]).is_some() {
            written(ctx, index, sub);
        }
    }
}

/// p.549 "max. Regelabweichung", "Sollwert erreicht: Schalthysterese"
/// (0x2225, 0.01 %).
pub(super) const MAX_CONTROL_DEVIATION: u16 = 0x2225;
/// p.418 minimum frequency (0x21A2, 0.01 Hz).
pub(super) const MINIMUM_FREQUENCY: u16 = 0x21A2;
/// p.419 maximum frequency (0x21A3, 0.01 Hz).
pub(super) const MAXIMUM_FREQUENCY: u16 = 0x21A3;

/// The hysteresis of statusword bit 10 [inc/s at 4096 per revolution] in
/// data set `set` (D62): p.549 of the range p.419 − p.418 ("a percentage
/// of the adjustable range (Max − Min)", the operating instructions of the
/// series), in min⁻¹ with the pole pairs: n = f · 60 / p.
pub(super) fn target_window(ctx: &Ctx<'_>, set: u8) -> u32 {
    let read = |index| ctx.read_u32(index, set).unwrap_or(0);
    // In 0.01 Hz, at most the inverter's 999.99 Hz; p.549 at most 20.00 % and p.373 24
    // (their limits): 32 bits hold each step.
    let range = (read(MAXIMUM_FREQUENCY) as i32).saturating_sub(read(MINIMUM_FREQUENCY) as i32).clamp(0, 99_999) as u32;
    let hundredths_hz = read(MAX_CONTROL_DEVIATION).min(2000) * range / 10_000;
    // 0.01 Hz → inc/s: n · 4096 / 60 with n = f · 60 / p.
    hundredths_hz * 4096 / (100 * read(POLE_PAIRS).clamp(1, 24))
}
