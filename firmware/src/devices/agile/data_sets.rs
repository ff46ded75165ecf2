//! Inverter parameters at 0x2000 + number with the data set as sub-index
//! (§9.3.1, M-L2155-2192; D25, D26 and D49 in docs/devices/agile.md).
//!
//! A parameter has one value (a VAR: data set 0) or four (an ARRAY whose
//! sub 0 is 9: data sets 1-4 at sub 1-4). Sub 0-4 address data sets 0-4 and
//! go "automatically into the EEPROM": a write is stored at once. Sub 5-9
//! address the same data sets in RAM only: the value changes, the stored one
//! stays, and a power cycle brings the stored one back. Data set 0 of a
//! four-data-set parameter is all four: a write sets each, a read answers
//! only while the four are equal, else 0x06040047 ("Datensätze
//! unterschiedlich", M-L795). The ARRAY's own sub 5-9 entries are not used.

use canopen_core::abort::AbortCode;
use canopen_core::node::Ctx;

/// Which data sets an access means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Target {
    /// The sub-index holding the value: 0 for a one-value parameter, 1-4 for
    /// a data set, `None` for data set 0 of a four-data-set parameter (all four).
    set: Option<u8>,
    /// Written to RAM only (sub 5-9).
    ram: bool,
    /// The value's length.
    pub(super) len: usize,
    /// Writable (a setting, not an actual value).
    pub(super) writable: bool,
}

impl Target {
    /// A write to it is stored (EEPROM, sub 0-4), not RAM only.
    pub(super) fn stored(self) -> bool {
        !self.ram
    }
}

/// The data sets (index, sub) addresses, if `index` is an inverter
/// parameter of the dictionary and `sub` a data set it has; `None` leaves
/// the access to the dictionary (other objects, or a data set the parameter
/// lacks: 0x06090011, "nicht vorhandener Datensatz").
pub(super) fn target(ctx: &Ctx<'_>, index: u16, sub: u8) -> Option<Target> {
    if !(0x2000..0x3000).contains(&index) {
        return None;
    }
    let dict = ctx.dictionary();
    let ram = sub >= 5;
    let set = sub.checked_sub(if ram { 5 } else { 0 })?;
    // Four data sets: an ARRAY whose sub 0 is the highest sub-index, 9.
    let four = dict.find(index, 9).is_ok();
    // Data sets 0-4 (sub 0-9); a one-value parameter has data set 0 alone.
    if set > 4 || !four && set != 0 {
        return None;
    }
    let entry = dict.find(index, if four { set.max(1) } else { 0 }).ok()?;
    let set = (!four || set != 0).then_some(set);
    Some(Target { set, ram, len: usize::from(entry.len), writable: entry.writable() })
}

/// The value of a read: the data set's, or for data set 0 the value all four share.
pub(super) fn read<'a>(ctx: &'a Ctx<'_>, index: u16, target: Target) -> Result<&'a [u8], AbortCode> {
    match target.set {
        Some(set) => ctx.read(index, set),
        None => {
            let first = ctx.read(index, 1)?;
            for set in 2..=4 {
                if ctx.read(index, set)? != first {
                    return Err(AbortCode::InternalIncompatible);
                }
            }
            Ok(first)
        }
    }
}

/// A write: the data set (or all four), then, unless to RAM only, stored.
pub(super) fn write(ctx: &mut Ctx<'_>, index: u16, target: Target, data: &[u8]) -> Result<(), AbortCode> {
    if !target.writable {
        return Err(AbortCode::UnsupportedAccess);
    }
    // A 0x1010 store in stages is writing the parameters: nothing may change under it.
    if !target.ram && ctx.storing() {
        return Err(AbortCode::DeviceState);
    }
    match target.set {
        Some(set) => ctx.write_object(index, set, data)?,
        // The four data sets share type and limits: the first write checks them for all.
        None => (1..=4).try_for_each(|set| ctx.write_object(index, set, data))?,
    }
    match target.set {
        _ if target.ram => Ok(()),
        Some(set @ 1..=4) => store_one(ctx, index, set, target.len),
        _ => ctx.save_objects(index, index),
    }
}

/// Stores data set `set` of a four-data-set parameter alone: the other
/// three keep their stored values (a RAM-only value of theirs is not made
/// permanent). A store takes a whole object, so they hold their stored
/// values (or the factory ones) while it runs, then their RAM values again.
fn store_one(ctx: &mut Ctx<'_>, index: u16, set: u8, len: usize) -> Result<(), AbortCode> {
    let dict = ctx.dictionary();
    // Data sets 1-4 as they are now, 4 bytes each.
    let mut active = [0u8; 16];
    for (other, slot) in (1..=4u8).zip(active.chunks_exact_mut(4)) {
        slot.iter_mut().zip(ctx.read(index, other)?).for_each(|(d, s)| *d = *s);
        let mut stored = [0u8; 4];
        if other != set {
            let value = match ctx.stored(index, other, &mut stored) {
                Some(n) => stored.get(..n).unwrap_or(&[]),
                None => {
                    let e = dict.find(index, other)?;
                    let value = stored.get_mut(..e.range().len()).unwrap_or(&mut []);
                    dict.defaults.read(e.range().start, value);
                    value
                }
            };
            ctx.set_value(index, other, value)?;
        }
    }
    let result = ctx.save_objects(index, index);
    for (other, slot) in (1..=4u8).zip(active.chunks_exact(4)) {
        ctx.set_value(index, other, slot.get(..len).unwrap_or(&[]))?;
    }
    result
}
