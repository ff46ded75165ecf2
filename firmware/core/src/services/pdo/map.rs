//! PDO mappings resolved against the dictionary. CiA 301 v4.2 §7.5.2.36
//! (RPDO mapping) and §7.5.2.38 (TPDO mapping).
//!
//! A mapping is checked once, when it is configured, and kept as a small
//! array of (RAM or ROM offset, length) slots. Building a TPDO or applying
//! an RPDO then copies bytes and looks nothing up: O(mapped bytes).
//!
//! Rules, each with the abort code a failing SDO download gets:
//! - the object exists: 0x06020000 (no object) or 0x06090011 (no sub-index);
//! - it may be mapped in this direction (`Attr::MAP_RPDO` / `MAP_TPDO`), is
//!   not a DOMAIN, and an RPDO does not map a constant: 0x06040041;
//! - the mapped length equals the object's size in bits: 0x06040043. Bit
//!   mapping is not supported (DeviceInfo `Granularity` = 8), so a length
//!   that is not a whole number of bytes fails the same way;
//! - at most 8 entries and 64 bits in all: 0x06040042;
//! - dummy entries 0x0001–0x0007 (sub 0, length = the type's size) only in
//!   an RPDO, where they skip bytes: 0x06040041 in a TPDO;
//! - the object ends below 32 KiB − 1 of its RAM image or ROM blob (the
//!   marks of the mapping's tables): 0x06040041.

use crate::abort::AbortCode;
use crate::od::{Attr, DataType, Dictionary, Entry, EntryRef, object, sub_entry, value_u32};
use crate::wire::pdo_mapping::MappingEntry;

/// Most entries one mapping can hold: with byte granularity, 8 bytes hold at most 8 objects.
pub const MAX_ENTRIES: usize = 8;
/// Most data bytes of a PDO (a classic CAN frame).
pub const MAX_LEN: usize = 8;

/// A [`Mapping`] byte read from or written to the RAM image: the offset in
/// the bits below it. Without it the entry is a constant in its low 8 bits,
/// so that an all-zero entry (past the mapping's length, or in
/// [`Mapping::EMPTY`]) builds a 0. RAM image offsets stay below it ([`Mapping::check_entry`]).
const RAM: u16 = 0x8000;

/// Which way a PDO carries data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// An RPDO: the network writes the mapped objects.
    Receive,
    /// A TPDO: the mapped objects go to the network.
    Transmit,
}

/// Where the bytes of one mapped object live.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Source {
    /// A dummy entry (RPDO only): the bytes are skipped.
    #[default]
    Dummy,
    /// At this offset of the RAM image.
    Ram(u16),
    /// At this offset of the dictionary's ROM blob (a `const` object, TPDO only).
    Rom(u16),
}

/// One resolved mapping entry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Slot {
    /// Where the value lives.
    pub source: Source,
    /// Its length in bytes (1..=8).
    pub len: u8,
}

impl Slot {
    /// Checks one mapping entry for `direction` and resolves it (one binary
    /// search) into where a [`Mapping`] keeps an entry, with the mapped
    /// entry into `object` (left as it was for a dummy entry): in place,
    /// where a pair returned in a `Result` went through the stack.
    // Offset and length are u16s: their sum fits a u32.
    #[allow(clippy::arithmetic_side_effects)]
    fn resolve_into(
        dict: &Dictionary,
        entry: MappingEntry,
        direction: Direction,
        start: &mut Start,
        object_ref: &mut EntryRef,
    ) -> Result<(), AbortCode> {
        if entry.is_dummy() {
            if direction == Direction::Transmit {
                return Err(AbortCode::NotMappable);
            }
            let size = DataType::from_index(entry.index).and_then(DataType::size).unwrap_or(0);
            return match entry.bytes() {
                Some(len) if usize::from(len) == size => {
                    *start = Start { at: DUMMY, len };
                    Ok(())
                }
                _ => Err(AbortCode::ParameterIncompatible),
            };
        }
        let (found, object) = dict.find_ref(entry.index, entry.sub)?;
        let allowed = match direction {
            Direction::Receive => object.attr.contains(Attr::MAP_RPDO) && !object.in_rom(),
            Direction::Transmit => object.attr.contains(Attr::MAP_TPDO),
        };
        if !allowed || object.data_type == DataType::Domain || object.len == 0 {
            return Err(AbortCode::NotMappable);
        }
        if entry.bytes() != Some(object.len) {
            return Err(AbortCode::ParameterIncompatible);
        }
        if usize::from(object.len) > MAX_LEN {
            return Err(AbortCode::PdoTooLong);
        }
        // An object ending past 32 KiB − 1 would reach the dummy entries'
        // and the RAM marker of a slot's start and of the byte table (a RAM
        // image or a ROM blob that large).
        if u32::from(object.offset) + u32::from(object.len) > u32::from(DUMMY) {
            return Err(AbortCode::NotMappable);
        }
        let at = if object.in_rom() { object.offset } else { RAM | object.offset };
        (*start, *object_ref) = (Start { at, len: object.len }, found);
        Ok(())
    }
}

impl Start {
    /// The [`Slot`] it stands for.
    fn slot(self) -> Slot {
        let source = match self.at.checked_sub(RAM) {
            Some(offset) => Source::Ram(offset),
            None if self.at == DUMMY => Source::Dummy,
            None => Source::Rom(self.at),
        };
        Slot { source, len: self.len }
    }
}

/// A [`Slot`] as a [`Mapping`] keeps it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Start {
    /// [`RAM`] with the image offset of a RAM object, the ROM blob's offset
    /// of a constant (TPDO only), [`DUMMY`] for a dummy entry.
    at: u16,
    /// Its length in bytes.
    len: u8,
}

/// [`Start::at`] of a dummy entry: no RAM object's (at least [`RAM`]) and
/// no ROM object's (every mapped object ends below it, [`Mapping::check_entry`]).
const DUMMY: u16 = RAM - 1;

/// A mapping resolved against the dictionary: at most [`MAX_ENTRIES`]
/// slots and [`MAX_LEN`] bytes.
///
/// Beside the slots, built with them when the mapping changes, where every
/// PDO byte comes from or goes to (`gather`): building a TPDO or applying an
/// RPDO is one load and one store per byte, instead of a walk over the
/// slots with a copy per object.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mapping {
    /// The entries, each where it starts and its length ([`Start`]): a
    /// [`Slot`] in 4 bytes, not 6.
    slots: [Start; MAX_ENTRIES],
    /// PDO byte i: [`RAM`] with the image offset it is read from or written
    /// to, or the byte itself (a ROM object's value, or 0 for a dummy entry,
    /// which an RPDO does not write, and for the bytes past the length).
    gather: [u16; MAX_LEN],
    /// Slot i: the dictionary entry it maps ([`EntryRef::NONE`] for a
    /// dummy), so that the device hears which objects an RPDO wrote
    /// ([`crate::node::Ctx::rpdo_object`]) without a search per object.
    objects: [EntryRef; MAX_ENTRIES],
    count: u8,
    len: u8,
}

impl Mapping {
    /// The mapping of sub-index 0 = 0: nothing mapped (the PDO is disabled).
    pub const EMPTY: Mapping = Mapping {
        slots: [Start { at: 0, len: 0 }; MAX_ENTRIES],
        gather: [0; MAX_LEN],
        objects: [EntryRef::NONE; MAX_ENTRIES],
        count: 0,
        len: 0,
    };

    /// Becomes the mapping record `index` (0x1600+n or 0x1A00+n) read and
    /// resolved as the image holds it, into an empty mapping, as
    /// [`Mapping::resolve`]. `Err(None)` for a record the dictionary
    /// lacks, no error at configuration: one look-up of the record tells it.
    pub(super) fn read_record(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        index: u16,
        direction: Direction,
    ) -> Result<(), Option<AbortCode>> {
        let record = object(dict, index);
        let count = sub_entry(record, 0).ok_or((!record.is_empty()).then_some(AbortCode::NoObject))?;
        Ok(self.resolve(dict, image, record, value_u32(dict, image, count), direction)?)
    }

    /// Makes an empty mapping ([`Mapping::EMPTY`], which each caller's
    /// is: no second clearing here) the first `count` entries (sub
    /// 1..=count) of a mapping record resolved as the image holds them:
    /// the configured mapping, or the one an SDO download of sub 0 =
    /// `count` asks for. At most one binary search per entry. Built in
    /// place (a caller's mapping, not a value returned and copied: 66
    /// bytes each time). After an error it is still empty (no entry, no
    /// byte: a PDO with it is silent); the entries it got to may stay in
    /// slots past its count, which nothing reads.
    // `total` is at most MAX_ENTRIES × 255; od-gen lays out each value
    // inside its u16-addressed table, so `offset + i` fits a u16.
    #[allow(clippy::arithmetic_side_effects)]
    pub(super) fn resolve(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        record: &'static [Entry],
        count: u32,
        direction: Direction,
    ) -> Result<(), AbortCode> {
        let count = usize::try_from(count).unwrap_or(usize::MAX);
        if count > MAX_ENTRIES {
            return Err(AbortCode::PdoTooLong);
        }
        let mut raw = [0u32; MAX_ENTRIES];
        for (value, sub) in raw.iter_mut().take(count).zip(1u8..) {
            // A count beyond the record's sub-indices maps more than the record can hold.
            let entry = sub_entry(record, sub).ok_or(AbortCode::PdoTooLong)?;
            *value = value_u32(dict, image, entry);
        }
        let mapping = self;
        let mut total = 0usize;
        for ((start, object), &raw) in mapping.slots.iter_mut().zip(&mut mapping.objects).zip(raw.iter().take(count)) {
            // An empty mapping's objects are `EntryRef::NONE`, as a dummy entry's stays.
            Slot::resolve_into(dict, MappingEntry::from_u32(raw), direction, start, object)?;
            total += usize::from(start.len);
            if total > MAX_LEN {
                return Err(AbortCode::PdoTooLong);
            }
        }
        mapping.count = count as u8;
        mapping.len = total as u8;
        let mut bytes = mapping.gather.iter_mut();
        for start in mapping.slots.iter().take(count) {
            for i in 0..u16::from(start.len) {
                let Some(g) = bytes.next() else { break };
                // A dummy entry (RPDO only) reads as whatever byte: below
                // `RAM`, it is no image byte, and an RPDO writes none for it.
                let at = start.at + i;
                *g = if start.at >= RAM { at } else { u16::from(dict.rom.get(usize::from(at)).copied().unwrap_or(0)) };
            }
        }
        Ok(())
    }

    /// Checks one mapping entry for `direction` (an SDO download of sub
    /// 1..=8), resolved into the first slot of this scratch mapping (the
    /// download's, which only sub 0 fills): no slot of its own on the stack.
    pub(super) fn check_entry(&mut self, dict: &Dictionary, entry: MappingEntry, direction: Direction) -> Result<(), AbortCode> {
        let ([start, ..], [object, ..]) = (&mut self.slots, &mut self.objects);
        Slot::resolve_into(dict, entry, direction, start, object)
    }

    /// Entry `i` (in mapping order): the dictionary entry it maps
    /// ([`EntryRef::NONE`] for a dummy entry) and its slot.
    pub fn object(&self, i: usize) -> Option<(EntryRef, Slot)> {
        if i >= usize::from(self.count) {
            return None;
        }
        Some((*self.objects.get(i)?, self.slots.get(i)?.slot()))
    }

    /// Number of mapped bytes.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether nothing is mapped.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The image offsets the PDO's bytes come from or go to, in order
    /// (constants, dummy bytes and the bytes past the length have none).
    pub(super) fn ram_bytes(&self) -> impl Iterator<Item = u16> + '_ {
        self.gather.iter().filter_map(|&g| g.checked_sub(RAM))
    }

    /// Whether a PDO byte comes from or goes to an image byte in
    /// `start..end` (`start < end`): one compare per byte of the gather
    /// table, whose constants and unused bytes lie below [`RAM`] and so
    /// wrap past any range.
    pub(super) fn maps_any(&self, start: u32, end: u32) -> bool {
        let span = end.wrapping_sub(start);
        self.gather.iter().any(|&g| u32::from(g).wrapping_sub(u32::from(RAM)).wrapping_sub(start) < span)
    }

    /// Copies the mapped values into all 8 bytes of `out`, zeros past the
    /// PDO length, which it returns. Dummy slots (never in a valid TPDO)
    /// read as zeros. Eight straight byte copies, without a loop or a
    /// branch on the length: six thumbv7m instructions per byte.
    // Out of line: one copy of the 8 steps for every TPDO path.
    #[inline(never)]
    pub fn build(&self, image: &[u8], out: &mut [u8; MAX_LEN]) -> usize {
        // A constant's "offset" wraps past any image: one compare tells an
        // image byte from a constant, which is the entry's low byte.
        let byte = |g: u16| match image.get(usize::from(g).wrapping_sub(usize::from(RAM))) {
            Some(&b) => b,
            None => g as u8,
        };
        let [g0, g1, g2, g3, g4, g5, g6, g7] = self.gather;
        *out = [byte(g0), byte(g1), byte(g2), byte(g3), byte(g4), byte(g5), byte(g6), byte(g7)];
        usize::from(self.len)
    }

    /// Writes the mapped objects from received PDO data, which the caller
    /// has checked holds at least [`Mapping::len`] bytes. Dummy slots are skipped.
    // Out of line: the general RPDO frame and the SYNC each had a copy
    // (the usual frame takes `apply_in_line`).
    #[inline(never)]
    pub fn apply(&self, image: &mut [u8], data: &[u8]) {
        let len = usize::from(self.len);
        // Two slices of the same length: one count for the loop, not two.
        let (Some(gather), Some(data)) = (self.gather.get(..len), data.get(..len)) else { return };
        for (&g, &b) in gather.iter().zip(data) {
            if let Some(d) = image.get_mut(usize::from(g).wrapping_sub(usize::from(RAM))) {
                *d = b;
            }
        }
    }

    /// [`Mapping::apply`] for the plain RPDO frame's path, an object at a
    /// time from its slot: a value of 2 or 4 bytes is one load and one store
    /// (thumbv7m takes them unaligned), not a loop over its bytes through
    /// the gather table (9 thumbv7m instructions a byte). Larger code than
    /// `apply`'s loop, so only that path has it.
    #[inline(always)]
    pub(super) fn apply_in_line(&self, image: &mut [u8], data: &[u8]) {
        let mut rest = data;
        for start in self.slots.get(..usize::from(self.count)).unwrap_or(&[]) {
            let Some((value, tail)) = rest.split_at_checked(usize::from(start.len)) else { return };
            rest = tail;
            // An RPDO maps no constant: a RAM object or a dummy entry.
            if start.at & RAM != 0 {
                let start = usize::from(start.at & !RAM);
                // `resolve` keeps a RAM slot inside the image it was resolved against.
                if let Some(dst) = image.get_mut(start..start.wrapping_add(value.len())) {
                    copy_value(dst, value);
                }
            }
        }
    }
}

/// `src` into `dst` (of the same length, 1 to 8 bytes): one load and one
/// store for 2 and 4 bytes (the usual objects: tested first), a byte; the
/// other lengths byte by byte.
#[inline(always)]
fn copy_value(dst: &mut [u8], src: &[u8]) {
    if let (Ok(d), Ok(s)) = (<&mut [u8; 2]>::try_from(&mut *dst), <&[u8; 2]>::try_from(src)) {
        *d = *s;
    } else if let (Ok(d), Ok(s)) = (<&mut [u8; 4]>::try_from(&mut *dst), <&[u8; 4]>::try_from(src)) {
        *d = *s;
    } else {
        for (d, s) in dst.iter_mut().zip(src) {
            *d = *s;
        }
    }
}
