//! The option module's positioning rules and errors (§4.4.3 M-L856-875, §4.4.8
//! M-L1002-1016; EMCY 8600h "Positioning Controller" with the drive error
//! number, §5.6.2 M-L3699-3707), D61:
//! - a new pp target outside the software limits 0x607D: no motion, drive
//!   error 00C4h (below limit 1, sub 1) or 00C5h (beyond limit 2, sub 2),
//!   the drive reacts as 0x605A says and a fault reset acknowledges it;
//! - running onto a hardware limit switch (§4.4.4 M-L876-880) outside
//!   homing: drive error 00C6h (negative) or 00C7h (positive), the drive
//!   reacting as for the software limits (D65);
//! - P0601 = 4 takes every target as relative; the card's start sets P0601
//!   to 9 unless P1190 bit 9 says otherwise (§4.4.9, D67);
//! - positioning without homing: while P0601 is 9 (the CANopen mode, which
//!   requires homing, M-L1020), pp enabled before a homing since power-on
//!   raises drive error 00C8h; the drive holds its position and takes no
//!   set-point, and a fault reset acknowledges the error once homed.

use canopen_core::node::Ctx;
use canopen_core::wire::emcy::EmcyCode;

/// EMCY 8600h positioning controller.
pub(super) const CODE: EmcyCode = EmcyCode(0x8600);
/// Drive error 00C4h software limit switch 1 (196).
const LIMIT_1: u8 = 0xC4;
/// Drive error 00C5h software limit switch 2 (197).
const LIMIT_2: u8 = 0xC5;
/// Drive error 00C6h negative hardware limit switch (198); 00C7h the positive one.
const HARDWARE_LIMIT_1: u8 = 0xC6;
/// Drive error 00C8h positioning started without homing (200).
const NOT_HOMED: u8 = 0xC8;
/// P0601 (0x4259) positioning mode: 9 is the CANopen mode.
const POSITIONING_MODE: u16 = 0x4259;
/// P1190 (0x44A6) positioning mode word.
const POSITIONING_MODE_WORD: u16 = 0x44A6;

/// EMCY bytes 3-7 for drive error `number` (most significant byte first, D54).
const fn info(number: u8) -> [u8; 5] {
    [0, number, 0, 0, 0]
}

/// Positioning waits for a homing (P0601 = 9).
pub(super) fn homing_required(ctx: &Ctx<'_>) -> bool {
    ctx.read_u32(POSITIONING_MODE, 0) == Some(9)
}

/// P0601 = 4 "Relativ, positiv und negativ": every target is relative,
/// whatever controlword bit 6 says (§4.4.9 M-L1081-1085, D67).
pub(super) fn always_relative(ctx: &Ctx<'_>) -> bool {
    ctx.read_u32(POSITIONING_MODE, 0) == Some(4)
}

/// The card's start (reset communication): P0601 becomes 9, "Absolut/Relativ
/// CANopen", unless P1190 (0x44A6) bit 9 switches that off (§4.4.9 M-L1060-1065, D67).
pub(super) fn init_mode(ctx: &mut Ctx<'_>) {
    if ctx.read_u32(POSITIONING_MODE_WORD, 0).is_some_and(|word| word & 1 << 9 == 0) {
        let _ = ctx.set_value(POSITIONING_MODE, 0, &9i16.to_le_bytes());
    }
}

/// The error of positioning before homing.
pub(super) const fn not_homed() -> [u8; 5] {
    info(NOT_HOMED)
}

/// The error of running onto a hardware limit switch, the positive one if `positive`.
pub(super) const fn hardware_limit(positive: bool) -> [u8; 5] {
    info(HARDWARE_LIMIT_1 + positive as u8)
}

/// The error of a target the profile limited (statusword bit 11) with
/// controlword `cw`: limit 1 for a target below 0x607D sub 1 (relative:
/// a negative distance), else limit 2.
pub(super) fn limit(ctx: &Ctx<'_>, cw: u32) -> [u8; 5] {
    let read = |index, sub| ctx.read_u32(index, sub).unwrap_or(0) as i32;
    let target = read(0x607A, 0);
    let below = if cw & 0x40 != 0 { target < 0 } else { target < read(0x607D, 1) };
    info(if below { LIMIT_1 } else { LIMIT_2 })
}
