//! The option codes as App. C has them (6007h, 605Ah-605Eh, M-L4550-4570, M-L5040-5240; D63 in
//! docs/devices/bmaxx4400.md): each object takes the values its table
//! gives a meaning ("unbenutzt"/"reserved" ones abort 0x06090030), and the
//! shutdown and disable operation codes have the manufacturer's −1 (quick
//! stop ramp, drive value 2) and −2 (current limit, drive value 3), which
//! the profile knows as CiA 402's 2 and 3 of the other option codes.

use canopen_core::node::Ctx;

/// 0x605B shutdown option code.
const SHUTDOWN: u16 = 0x605B;
/// 0x605C disable operation option code.
const DISABLE_OPERATION: u16 = 0x605C;

/// Whether `value` is one App. C gives `index` (an option code) a meaning;
/// true for any other object.
pub(super) fn valid(index: u16, value: i16) -> bool {
    match index {
        // Abort connection: 0-3 ("reserved" 4.., manufacturer-specific negative ones unused).
        0x6007 => (0..=3).contains(&value),
        // Quick stop: 0-8 (negative and 9.. "unbenutzt").
        0x605A => (0..=8).contains(&value),
        // Shutdown, disable operation: 0, 1 and the manufacturer's −1, −2.
        SHUTDOWN | DISABLE_OPERATION => (-2..=1).contains(&value),
        // Halt, fault reaction: 0-3 (4, the voltage limit, has no drive value).
        0x605D | 0x605E => (0..=3).contains(&value),
        _ => true,
    }
}

/// Runs `f` (the profile) with 0x605B and 0x605C holding the CiA codes for
/// the manufacturer's −1 and −2 (2 quick stop ramp, 3 current limit), then
/// puts the master's values back.
pub(super) fn as_cia<R>(ctx: &mut Ctx<'_>, f: impl FnOnce(&mut Ctx<'_>) -> R) -> R {
    let codes = [SHUTDOWN, DISABLE_OPERATION].map(|index| (index, ctx.read_u32(index, 0).map_or(0, |v| v as i16)));
    for (index, code) in codes {
        if code < 0 {
            let _ = ctx.set_value(index, 0, &(1 - code).to_le_bytes());
        }
    }
    let result = f(ctx);
    for (index, code) in codes {
        if code < 0 {
            let _ = ctx.set_value(index, 0, &code.to_le_bytes());
        }
    }
    result
}
