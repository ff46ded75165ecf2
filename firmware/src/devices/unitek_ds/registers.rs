//! Registers as dictionary objects: REGID `r` is object `0x2000 + r` sub 0
//! (docs/devices/unitek-ds.md D2), 16 or 32 bits wide as its data type
//! says, so the protocol and the dictionary hold one value.
//!
//! Width adaptation (English appendix item 1, L1027-1038): a 16-bit write
//! to a 32-bit register is sign- or zero-extended by the register's type; a
//! 32-bit write to a 16-bit register keeps the low word.

use canopen_core::node::Ctx;
use canopen_core::od::DataType;

use super::wire::Value;

/// 0x30 SPEED_ACTUAL, ±32767 = ±Nmax.
pub const SPEED_ACTUAL: u8 = 0x30;
/// 0x31 SPEED_CMD, ±32767 = ±Nmax.
pub const SPEED_CMD: u8 = 0x31;
/// 0x35 acceleration ramp [ms from 0 to Nmax], low word.
pub const ACC_RAMP: u8 = 0x35;
/// 0x40 STATUS (KERN_STATUS).
pub const STATUS: u8 = 0x40;
/// 0x51 MODE: bit 2 disable, bit 4 event-driven STATUS.
pub const MODE: u8 = 0x51;
/// 0x52 STATUS_MASK: the STATUS bits whose change sends STATUS.
pub const STATUS_MASK: u8 = 0x52;
/// 0x68 CAN_ID_RX.
pub const CAN_ID_RX: u8 = 0x68;
/// 0x69 CAN_ID_TX.
pub const CAN_ID_TX: u8 = 0x69;
/// 0x6D POS_ACTUAL, 65536 per revolution.
pub const POS_ACTUAL: u8 = 0x6D;
/// 0x6E POS_DEST, 65536 per revolution.
pub const POS_DEST: u8 = 0x6E;
/// 0x72 reference zero offset: the position homing sets.
pub const POS_REF_OFFSET: u8 = 0x72;
/// 0x73 CAN_BTR: bit-rate code.
pub const CAN_BTR: u8 = 0x73;
/// 0x78 FUN_REF_START: start homing.
pub const FUN_REF_START: u8 = 0x78;
/// 0x79 POS_WINDOW: tolerance window for Tol.
pub const POS_WINDOW: u8 = 0x79;
/// 0x84 FUN_PARAWRITE: store the parameters.
pub const FUN_PARAWRITE: u8 = 0x84;
/// 0x8E FUN_ERRCANCEL: clear the error list.
pub const FUN_ERRCANCEL: u8 = 0x8E;
/// 0x8F ERR_BITMAP1: errors and warnings.
pub const ERR_BITMAP: u8 = 0x8F;
/// 0x90 TORQUE_SETPOINT, ±32767 = ±150 %.
pub const TORQUE_CMD: u8 = 0x90;
/// 0x97 CAN_COUNTREJ: frames the protocol refused.
pub const CAN_COUNT_REJECT: u8 = 0x97;
/// 0xA0 TORQUE_OUT, ±32767 = ±150 %.
pub const TORQUE_OUT: u8 = 0xA0;
/// 0xC8 SPEED_RPMMAX: Nmax [rpm], what ±32767 means.
pub const SPEED_RPMMAX: u8 = 0xC8;
/// 0xD0 CAN_TIMEOUT [ms], 0 = off.
pub const CAN_TIMEOUT: u8 = 0xD0;
/// 0xDC: upper byte 0x01 = every reply DLC 6.
pub const REPLY_FORMAT: u8 = 0xDC;
/// 0xE2 O_BTB: ready.
pub const BTB: u8 = 0xE2;
/// 0xE4 END1 / 0xE5 END2: limit switch inputs (positive, negative).
pub const END1: u8 = 0xE4;
/// 0xE5 END2.
pub const END2: u8 = 0xE5;
/// 0xE8 I_FRG: hardware enable input RUN.
pub const RUN: u8 = 0xE8;
/// 0xF4: in tolerance.
pub const IN_TOLERANCE: u8 = 0xF4;

/// The object of register `regid`.
pub const fn object(regid: u8) -> u16 {
    0x2000 + regid as u16
}

/// A register's value as the protocol sends it: zero- or sign-extended to
/// 32 bits, and whether the register is 32 bits wide; `None` for a REGID
/// that is not a readable register.
pub fn read(ctx: &Ctx<'_>, regid: u8) -> Option<(u32, bool)> {
    let entry = ctx.dictionary().find(object(regid), 0).ok()?;
    match (ctx.read(object(regid), 0).ok()?, entry.data_type) {
        (&[a, b], DataType::Integer16) => Some((i32::from(i16::from_le_bytes([a, b])) as u32, false)),
        (&[a, b], _) => Some((u32::from(u16::from_le_bytes([a, b])), false)),
        (&[a, b, c, d], _) => Some((u32::from_le_bytes([a, b, c, d]), true)),
        _ => None,
    }
}

/// A register's value as a signed number (0 if there is none).
pub fn read_i32(ctx: &Ctx<'_>, regid: u8) -> i32 {
    read(ctx, regid).map_or(0, |(v, _)| v as i32)
}

/// The bytes a write of `value` puts into register `regid` (extended or
/// truncated to its width); `None` if it is no writable 16/32-bit register.
pub fn encode(ctx: &Ctx<'_>, regid: u8, value: Value) -> Option<([u8; 4], usize)> {
    let entry = ctx.dictionary().find(object(regid), 0).ok().filter(|e| e.writable())?;
    let wide = match value {
        Value::Bits16(v) if entry.data_type == DataType::Integer32 => i32::from(v as i16) as u32,
        Value::Bits16(v) => u32::from(v),
        Value::Bits32(v) => v,
    };
    match entry.len {
        2 | 4 => Some((wide.to_le_bytes(), usize::from(entry.len))),
        _ => None,
    }
}

/// Sets a register the drive maintains (read-only ones included), its
/// value truncated to the register's width.
pub fn set(ctx: &mut Ctx<'_>, regid: u8, value: u32) {
    let Ok(entry) = ctx.dictionary().find(object(regid), 0) else { return };
    let bytes = value.to_le_bytes();
    if let Some(data) = bytes.get(..usize::from(entry.len)) {
        let _ = ctx.set_value(object(regid), 0, data);
    }
}

/// A register's value as an unsigned number (0 if there is none).
pub fn read_u32(ctx: &Ctx<'_>, regid: u8) -> u32 {
    read(ctx, regid).map_or(0, |(v, _)| v)
}
