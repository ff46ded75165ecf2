//! Drive parameters at 0x4000 + P that App. C ties to a CiA 402 object
//! (D52): an SDO upload of such a parameter reads the drive's value, which
//! the profile keeps in the CiA object, converted to the drive's
//! representation. The other parameters of the EDS are plain values.

use canopen_core::abort::AbortCode;
use canopen_core::node::Ctx;

/// How a drive parameter follows a CiA object (App. C, "Umrechnung").
#[derive(Clone, Copy)]
enum Conversion {
    /// y = x (P0300 ↔ 0x6040, P0301 ← 0x6041, P0607 ↔ 0x607A).
    Same,
    /// y = x + 2^31: the drive's unsigned positions, the objects §4.4.7 lists
    /// (P0463 ← 0x6062, P0462 ← 0x6064, P0600 ↔ 0x607A, P1200 ↔ 0x607C,
    /// P1196/P1197 ↔ 0x607D sub 1/2; M-L983-997).
    Offset,
    /// The drive's operation mode for a 0x6060/0x6061 value (P1000 ← 0x6060, P0304 ← 0x6061; M-L5241-5410).
    DriveMode,
}

/// P0830 (0x433E) option-module configuration word.
const CONFIGURATION: u16 = 0x433E;
/// P0830 bit 5: positions without the 2^31 offset.
const NO_OFFSET: u32 = 1 << 5;

/// The parameter table: (P, CiA object, its sub-index, conversion).
const TABLE: [(u16, u16, u8, Conversion); 11] = [
    (300, 0x6040, 0, Conversion::Same),
    (301, 0x6041, 0, Conversion::Same),
    (304, 0x6061, 0, Conversion::DriveMode),
    (462, 0x6064, 0, Conversion::Offset),
    (463, 0x6062, 0, Conversion::Offset),
    (600, 0x607A, 0, Conversion::Offset),
    (607, 0x607A, 0, Conversion::Same),
    (1000, 0x6060, 0, Conversion::DriveMode),
    (1196, 0x607D, 1, Conversion::Offset),
    (1197, 0x607D, 2, Conversion::Offset),
    (1200, 0x607C, 0, Conversion::Offset),
];

/// The drive's P1000/P0304 value for a CANopen mode: pv (3) is the drive's
/// speed control −3, interpolated position (7) its position control −4,
/// jog (−6) its mode 5 and spindle positioning (−106) its −6.
const fn drive_mode(canopen: i8) -> i8 {
    match canopen {
        3 => -3,
        7 => -4,
        -6 => 5,
        -106 => -6,
        m => m,
    }
}

/// An upload of a drive parameter the table backs: its value, in the size
/// of the dictionary's entry for it.
pub(super) fn read(ctx: &Ctx<'_>, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
    let p = index.checked_sub(0x4000)?;
    let &(_, object, object_sub, conversion) = TABLE.iter().find(|(n, ..)| *n == p)?;
    if sub != 0 || offset != 0 {
        return None;
    }
    let len = ctx.read(index, 0).ok()?.len();
    let value = ctx.read(object, object_sub).ok()?;
    let x = match *value {
        [a] => i32::from(a as i8),
        [a, b] => i32::from(u16::from_le_bytes([a, b])),
        [a, b, c, d] => i32::from_le_bytes([a, b, c, d]),
        _ => return None,
    };
    let y = match conversion {
        Conversion::Same => x,
        // P0830 bit 5 (§4.3.6): no offset.
        Conversion::Offset if ctx.read_u32(CONFIGURATION, 0).is_some_and(|c| c & NO_OFFSET != 0) => x,
        Conversion::Offset => x.wrapping_add(i32::MIN),
        Conversion::DriveMode => i32::from(drive_mode(x as i8)),
    };
    let bytes = y.to_le_bytes();
    let out = buf.get_mut(..len)?;
    out.copy_from_slice(bytes.get(..len)?);
    Some(Ok(len))
}
