//! 0x6007 abort connection option code and parameter 388 "CAN
//! Störverhalten" are one setting (§7.3, §9.5.1, M-L683, M-L2585-2600; D50
//! in docs/devices/agile.md): "Das Schreiben des Parameters … 388 und das
//! Schreiben des Objektes 0x6007 haben die gleiche Wirkung", with p.388's
//! 4 and 5 being 0x6007's −1 and −2. A write of either sets the other; at
//! power-on a 0x6007 stored by 0x1010 "überschreibt die Einstellung des
//! Parameters 388", else 0x6007 follows p.388 (which is stored when written).

use canopen_core::abort::AbortCode;
use canopen_core::node::Ctx;

/// 0x6007 abort connection option code (INTEGER16, −2..3).
pub(super) const ABORT_CONNECTION: u16 = 0x6007;
/// p.388 CAN fault behaviour (0x2184, UNSIGNED16, 0..5).
pub(super) const CAN_FAULT_BEHAVIOUR: u16 = 0x2184;

/// p.388 written: 0x6007 takes its value (4 → −1, 5 → −2); with `store`
/// (p.388 went into the EEPROM) 0x6007 is stored with it, so that an older
/// 0x6007 a 0x1010 "save" stored does not win at the next power-on.
pub(super) fn from_p388(ctx: &mut Ctx<'_>, store: bool) -> Result<(), AbortCode> {
    let p388 = ctx.read_u32(CAN_FAULT_BEHAVIOUR, 0).unwrap_or(1) as i16;
    let option = if p388 > 3 { 3 - p388 } else { p388 };
    ctx.set_value(ABORT_CONNECTION, 0, &option.to_le_bytes())?;
    if store { ctx.save_objects(ABORT_CONNECTION, ABORT_CONNECTION) } else { Ok(()) }
}

/// 0x6007 written: p.388 takes its value (−1 → 4, −2 → 5), in RAM: 0x1010
/// stores both.
pub(super) fn to_p388(ctx: &mut Ctx<'_>) {
    let option = ctx.read_u32(ABORT_CONNECTION, 0).unwrap_or(1) as i16;
    let p388 = if option < 0 { 3 - option } else { option };
    let _ = ctx.set_value(CAN_FAULT_BEHAVIOUR, 0, &p388.to_le_bytes());
}

/// Reset application (power-on): a stored 0x6007 wins, else p.388 sets it.
pub(super) fn at_power_on(ctx: &mut Ctx<'_>) {
    if ctx.stored(ABORT_CONNECTION, 0, &mut [0; 2]).is_some() {
        to_p388(ctx);
    } else {
        let _ = from_p388(ctx, false);
    }
}
