//! The BACI's cyclic channel (§4.2, §5.5.1, D55): at most 8 set-points
//! (over all RPDOs) and 8 actual values (over all TPDOs) reach the drive.
//! 0x607A takes two slots (two drive parameters), an object mapped twice in
//! one direction takes one, dummies (index < 0x1000) none, and 0x6041 always
//! holds actual-value slot 1, mapped or not.

use canopen_core::node::Ctx;

/// Slots per direction.
const SLOTS: u32 = 8;
/// Mapping entries in one direction: 4 PDOs of 8, and 0x6041.
const MAX_ENTRIES: usize = 33;

/// True if PDO mapping `index` (0x1600-0x1603 or 0x1A00-0x1A03) with `count`
/// entries would take the direction past its 8 slots.
pub(super) fn exceeded(ctx: &Ctx<'_>, index: u16, count: u8) -> bool {
    let base = index & 0xFF00;
    // Each distinct object as index << 8 | sub (the entry without its length).
    let mut seen = [0u32; MAX_ENTRIES];
    let mut len = 0;
    let mut slots = 0;
    if base == 0x1A00 {
        seen[0] = 0x0060_4100;
        (len, slots) = (1, 1);
    }
    for pdo in base..base + 4 {
        let n = if pdo == index { count } else { ctx.read_u32(pdo, 0).unwrap_or(0) as u8 };
        for sub in 1..=n {
            let object = ctx.read_u32(pdo, sub).unwrap_or(0) >> 8;
            if object >> 8 < 0x1000 || seen.get(..len).is_some_and(|s| s.contains(&object)) {
                continue;
            }
            if let Some(slot) = seen.get_mut(len) {
                *slot = object;
                len += 1;
            }
            slots += if object >> 8 == 0x607A { 2 } else { 1 };
        }
    }
    slots > SLOTS
}
