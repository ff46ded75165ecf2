//! Runtime object dictionary. CiA 301 v4.2 §7.4.
//!
//! od-gen turns an EDS into three things this module works on:
//! - a sorted `static` table of [`Entry`] metadata (flash), looked up by
//!   binary search, so any lookup is O(log n) with no scan of the dictionary;
//! - a ROM blob holding the values of `const` objects (flash);
//! - one RAM image (`[u8; N]` inside the generated `Ram` struct) holding every
//!   other value. The values a stored parameter set holds come first, as one
//!   prefix ([`Dictionary::stored_len`]), so a set is that prefix alone; the
//!   others follow. Each part is in index order, communication area
//!   (0x1000–0x1FFF) first, so reset communication and reset application are
//!   each two copies from the default image plus the `$NODEID` fix-ups.
//!
//! Nothing here panics on any input: every slice access is checked and a
//! malformed request gets its SDO [`AbortCode`] (CiA 301 §7.2.4.3.17): the
//! dictionary speaks the abort table, so no layer above translates errors.

pub(crate) mod access;
mod defaults;
mod entry;
pub mod index;
mod lookup;
mod types;
mod value;

pub use access::{DictionaryAccess, ObjectAccess};
pub use lookup::le_u32;
pub(crate) use lookup::{checked_entry, object, precheck, sub_entry, u32_exact, value_u32};

use crate::abort::AbortCode;

pub use defaults::Defaults;
pub use entry::{Attr, Entry, EntryRef, Limits, NO_LIMITS};
pub use types::{DataType, Kind};
pub use value::Number;

/// Facts from the EDS `[DeviceInfo]` section that the firmware acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Supported bit rates as a bit set over the CiA 305 bit-timing table
    /// index (bit 0 = 1 Mbit/s, 1 = 800k, 2 = 500k, 3 = 250k, 4 = 125k,
    /// 6 = 50k, 7 = 20k, 8 = 10k).
    pub baud_rates: u16,
    /// `LSS_Supported`.
    pub lss_supported: bool,
    /// `Granularity`: the mapping granularity in bits (0 = no dynamic mapping).
    pub granularity: u8,
    /// `SimpleBootUpSlave`.
    pub simple_boot_up_slave: bool,
    /// `DynamicChannelsSupported`.
    pub dynamic_channels: bool,
    /// `GroupMessaging`.
    pub group_messaging: bool,
}

/// The flash half of a generated dictionary.
#[derive(Debug)]
pub struct Dictionary {
    /// Entries sorted by (index, sub-index).
    pub entries: &'static [Entry],
    /// Limits referenced by [`Dictionary::limit_rows`].
    pub limits: &'static [Limits],
    /// Each entry's row in `limits` ([`NO_LIMITS`] for none), parallel to
    /// `entries`; empty in a dictionary without limits, whose entries then
    /// take no byte for them.
    pub limit_rows: &'static [u8],
    /// Values of `const` entries.
    pub rom: &'static [u8],
    /// The RAM image as the EDS defaults give it, with `$NODEID` not yet added.
    pub defaults: Defaults,
    /// Length of the RAM prefix that holds the stored values of the
    /// communication area 0x1000–0x1FFF.
    pub comm_len: usize,
    /// Length of the RAM prefix a stored parameter set holds: the values a
    /// reset loads from it (writable, in RAM) and those a device stores
    /// itself, communication area first, each part in index order.
    pub stored_len: usize,
    /// Length of the other values of the communication area, which follow
    /// the stored prefix.
    pub comm_rest: usize,
    /// Positions in `entries` of the entries whose default is `$NODEID`-relative.
    pub node_id_relative: &'static [u16],
    /// Device facts from `[DeviceInfo]`.
    pub device: DeviceInfo,
    /// [`layout_id`] of `entries`, evaluated when the static is built: a
    /// stored parameter set carries it, so a set written for another
    /// layout is ignored without hashing the table at every load.
    pub layout_id: u32,
}

/// FNV-1a over the entry table (index, sub-index, type, attributes, length
/// and offset of each entry): the dictionary layout a stored set belongs to.
/// A `const fn` so that a generated dictionary holds the result, not the loop.
pub const fn layout_id(entries: &[Entry]) -> u32 {
    const fn mix(mut h: u32, mut bytes: &[u8]) -> u32 {
        while let [b, rest @ ..] = bytes {
            h = (h ^ *b as u32).wrapping_mul(0x0100_0193);
            bytes = rest;
        }
        h
    }
    let mut h: u32 = 0x811C_9DC5;
    let mut entries = entries;
    while let [e, rest @ ..] = entries {
        h = mix(h, &e.index.to_le_bytes());
        // The attributes without the scope bits, which follow from the
        // index: a set stored before they were added keeps its layout.
        h = mix(h, &[e.sub, e.data_type as u8, e.attr.0 & !Attr::SCOPE.0]);
        // The length as the 16 bits it had when the entry held it so: a
        // stored set keeps its layout across the change of width.
        h = mix(h, &(e.len as u16).to_le_bytes());
        h = mix(h, &e.offset.to_le_bytes());
        entries = rest;
    }
    h
}

/// The optional services a node on a dictionary links, chosen at compile
/// time from its EDS (od-gen's `SERVICES`). A service that is off is never
/// reached, so the compiler leaves its code out of the image; the node
/// behaves as if the dictionary lacked its objects (a frame for it is
/// ignored, an SDO request of a block transfer is refused).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Services {
    /// LSS slave (`LSS_Supported=1`).
    pub lss: bool,
    /// SDO block transfer (a value too long for segmented transfer to be quick).
    pub block_sdo: bool,
    /// Node and life guarding (0x100C and 0x100D).
    pub guarding: bool,
    /// TIME consumer (0x1012).
    pub time: bool,
    /// Store and restore parameters (0x1010 or 0x1011), and LSS store.
    pub storage: bool,
    /// The acceptance list ([`crate::node::Node::acceptance`]): the
    /// identifiers the node consumes, kept for a board that programs its
    /// CAN controller's hardware filter from them. Not a CiA 301/305
    /// service: a board that receives every frame never reads it, and
    /// without it the node never builds the list and `acceptance()` answers
    /// one that is not complete (a filter built from it passes every frame).
    pub acceptance: bool,
}

impl Services {
    /// Every service: what a dictionary written by hand gets.
    pub const ALL: Services = Services { lss: true, block_sdo: true, guarding: true, time: true, storage: true, acceptance: true };
}

/// A dictionary with its RAM image: implemented by each generated `Ram` struct.
pub trait ObjectDictionary {
    /// The optional services a node on this dictionary links.
    const SERVICES: Services = Services::ALL;
    /// Whether any entry has a LowLimit/HighLimit (od-gen: a limits table
    /// that is not empty). Without, the downloads' check of the value
    /// against its limits ([`Limits::check`]) is left out of the image.
    const HAS_LIMITS: bool = true;
    /// The flash tables of this dictionary.
    fn dictionary(&self) -> &'static Dictionary;
    /// The RAM image.
    fn image(&self) -> &[u8];
    /// The RAM image, for writing.
    fn image_mut(&mut self) -> &mut [u8];
}

impl Dictionary {
    /// A unit test's dictionary of communication objects alone: no limits,
    /// no ROM, every value in RAM, stored and in the communication range.
    #[cfg(test)]
    pub(crate) const fn comm_only(entries: &'static [Entry], defaults: &'static [u8]) -> Self {
        Self {
            entries,
            limits: &[],
            limit_rows: &[],
            rom: &[],
            defaults: Defaults::dense(defaults),
            comm_len: defaults.len(),
            stored_len: defaults.len(),
            comm_rest: 0,
            node_id_relative: &[],
            layout_id: layout_id(entries),
            device: DeviceInfo {
                baud_rates: 0,
                lss_supported: false,
                granularity: 8,
                simple_boot_up_slave: true,
                dynamic_channels: false,
                group_messaging: false,
            },
        }
    }

    /// Finds an entry by index and sub-index. O(log n): a binary search for
    /// the object on the 16-bit index alone, then along the object's
    /// entries (at most 256), which also tell a missing sub-index
    /// (0x06090011) from a missing object (0x06020000).
    // In line: a wrapper of `search`, whose two scalars come back in
    // registers where a `Result` of an entry and a code comes back through
    // a stack slot (a store in the search, loads at each call site).
    #[inline(always)]
    pub fn find(&self, index: u16, sub: u8) -> Result<&'static Entry, AbortCode> {
        found(self.search(index, sub))
    }

    /// [`Dictionary::find`] as two scalars: the entry, or `None` and the
    /// abort code for its absence.
    // The walk alone, without a first look at the sub-index's own place
    // (sub-indices mostly run 0, 1, 2, ...): 28 bytes less in every image,
    // a few instructions more for a sub-index past the first.
    #[inline(never)]
    fn search(&self, index: u16, sub: u8) -> Found {
        let record = self.object_onwards(index);
        let mut missing = AbortCode::NoObject;
        for e in record.iter().take_while(|e| e.index == index) {
            if e.sub == sub {
                return (Some(e), missing);
            }
            missing = AbortCode::NoSubIndex;
        }
        (None, missing)
    }

    /// The entries from the first of object `index` (or from where it would
    /// be) to the end of the table: a binary search on the index alone.
    // Out of line: `find` and `object` share it.
    #[inline(never)]
    pub(crate) fn object_onwards(&self, index: u16) -> &'static [Entry] {
        let entries: &'static [Entry] = self.entries;
        entries.get(entries.partition_point(|e| e.index < index)..).unwrap_or(&[])
    }

    /// An entry found once, for a caller that reads or writes it often
    /// ([`Dictionary::entry`] gets it back without a search); [`EntryRef::NONE`]
    /// if the dictionary lacks it.
    pub fn locate(&self, index: u16, sub: u8) -> EntryRef {
        self.find_ref(index, sub).map_or(EntryRef::NONE, |(r, _)| r)
    }

    /// [`Dictionary::find`], with the entry's [`EntryRef`].
    pub fn find_ref(&self, index: u16, sub: u8) -> Result<(EntryRef, &'static Entry), AbortCode> {
        let entry = self.find(index, sub)?;
        match self.position(entry).checked_add(1).and_then(|r| u16::try_from(r).ok()) {
            Some(r) => Ok((EntryRef(r), entry)),
            None => Err(AbortCode::NoObject),
        }
    }

    /// The position in `entries` of an entry of the table, from its address:
    /// no second search. (An entry from elsewhere gets a position that
    /// names no entry or another one; never a panic.)
    fn position(&self, entry: &Entry) -> usize {
        (entry as *const Entry as usize)
            .wrapping_sub(self.entries.as_ptr() as usize)
            .checked_div(core::mem::size_of::<Entry>())
            .unwrap_or(usize::MAX)
    }

    /// The entry [`Dictionary::locate`] found (`None` for [`EntryRef::NONE`],
    /// or a reference into another dictionary's table that does not fit this one).
    pub fn entry(&self, r: EntryRef) -> Option<&'static Entry> {
        let entries: &'static [Entry] = self.entries;
        usize::from(r.0).checked_sub(1).and_then(|pos| entries.get(pos))
    }

    /// The limits of an entry, if it has any.
    pub fn limits_of(&self, entry: &Entry) -> Option<&'static Limits> {
        let row = self.limit_rows.get(self.position(entry))?;
        self.limits.get(usize::from(*row))
    }

    /// The value bytes of `entry` (its whole capacity for strings).
    // Out of line: a dozen callers each had a copy (198 bytes more).
    #[inline(never)]
    pub fn value<'a>(&self, image: &'a [u8], entry: &Entry) -> &'a [u8] {
        let src: &'a [u8] = if entry.in_rom() { self.rom } else { image };
        src.get(entry.range()).unwrap_or(&[])
    }

    /// Reads a value as an SDO upload would: access checked, a VISIBLE_STRING
    /// ends at its first NUL (CiA 301 lets it be shorter than its capacity).
    pub fn read<'a>(&self, image: &'a [u8], index: u16, sub: u8) -> Result<&'a [u8], AbortCode> {
        self.read_entry(image, self.find(index, sub)?)
    }

    /// [`Dictionary::read`] of an entry already found.
    // In line: a wrapper of `upload_value`, so that a device's read of a
    // located entry on every frame (`Ctx::read_at`) is one call deep.
    #[inline(always)]
    pub fn read_entry<'a>(&self, image: &'a [u8], entry: &Entry) -> Result<&'a [u8], AbortCode> {
        // An SDO upload's reading (one copy of it in an image), but for a
        // readable DOMAIN, which has no bytes here to read (0x08000020
        // where an upload answers "no data", 0x08000024), and for 0x1003's
        // entries above its count, which the node and its device read as the
        // zeros they are (only an upload answers them "no data").
        match access::upload_value(self, image, entry) {
            Err(AbortCode::NoData) if entry.data_type == DataType::Domain => Err(AbortCode::CannotStore),
            Err(AbortCode::NoData) => Ok(self.value(image, entry)),
            read => read,
        }
    }

    /// Reads an integer entry of at most 32 bits as a `u32` (the
    /// communication parameters: COB-IDs, times, counts).
    pub fn read_u32(&self, image: &[u8], index: u16, sub: u8) -> Option<u32> {
        self.read(image, index, sub).ok().map(le_u32)
    }

    /// Writes a value as an SDO download would: access, length and limits are
    /// checked before any byte changes.
    pub fn write(&self, image: &mut [u8], index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.write_entry(image, index, sub, data).map(|_| ())
    }

    /// [`Dictionary::write`], returning the entry written, and whether a
    /// byte of the image changed (a TPDO mapping it cannot have new data otherwise).
    pub fn write_entry(&self, image: &mut [u8], index: u16, sub: u8, data: &[u8]) -> Result<(&'static Entry, bool), AbortCode> {
        let entry = self.find(index, sub)?;
        self.check_write(entry, data)?;
        Ok((entry, store_checked(image, entry, data)?))
    }

    /// The checks of [`Dictionary::write`] before any byte changes: access,
    /// length and limits. The node's SDO router runs them first on every
    /// communication object.
    pub(crate) fn check_write(&self, entry: &Entry, data: &[u8]) -> Result<(), AbortCode> {
        self.check_size(entry, Some(data.len()))?;
        if let Some(limits) = self.limits_of(entry) {
            limits.check(entry.data_type, data)?;
        }
        Ok(())
    }

    /// [`Dictionary::check_write`] but the limits: access and length
    /// (`size`: the value's, if known; an SDO download's initiate may not
    /// tell it).
    pub(crate) fn check_size(&self, entry: &Entry, size: Option<usize>) -> Result<(), AbortCode> {
        if !entry.writable() {
            return Err(AbortCode::ReadOnly);
        }
        if entry.data_type == DataType::Domain {
            return Err(AbortCode::CannotStore);
        }
        let len = usize::from(entry.len);
        match size {
            Some(n) if n > len => Err(AbortCode::LengthTooHigh),
            // A string or domain may be shorter than its capacity.
            Some(n) if n < len && !entry.data_type.is_variable_length() => Err(AbortCode::LengthTooLow),
            _ => Ok(()),
        }
    }

    /// Writes a value the node itself maintains (the error register, the
    /// error history, a statusword), without the SDO access check: read-only
    /// means read-only for the bus, not for the device. Length must fit;
    /// a shorter value is zero-filled.
    pub fn write_unchecked(&self, image: &mut [u8], index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.write_unchecked_entry(image, self.find(index, sub)?, data).map(|_| ())
    }

    /// [`Dictionary::write_unchecked`] of an entry already found; true if a
    /// byte of the image changed (a TPDO mapping it has no new data otherwise).
    pub fn write_unchecked_entry(&self, image: &mut [u8], entry: &Entry, data: &[u8]) -> Result<bool, AbortCode> {
        if entry.in_rom() || entry.data_type == DataType::Domain {
            return Err(AbortCode::CannotStore);
        }
        if data.len() > usize::from(entry.len) {
            return Err(AbortCode::LengthTooHigh);
        }
        // A shorter value's bytes past `data` are zeroed, as a string's.
        store_checked(image, entry, data)
    }

    /// Restores the communication area (0x1000–0x1FFF) to its defaults and
    /// resolves `$NODEID` there. CiA 301 §7.3.2.2.2 "reset communication".
    pub fn reset_communication(&self, image: &mut [u8], node_id: u8) {
        let rest = self.stored_len.saturating_add(self.comm_rest);
        // Without stored application values the two ranges touch: one call
        // (a node's dictionary is a constant, so the test folds away).
        if self.comm_len == self.stored_len {
            self.restore(image, 0..rest, node_id);
        } else {
            self.restore(image, 0..self.comm_len, node_id);
            self.restore(image, self.stored_len..rest, node_id);
        }
    }

    /// Restores the application area (0x2000 and up) to its defaults.
    /// CiA 301 "reset application"; the node follows it with reset communication.
    pub fn reset_application(&self, image: &mut [u8], node_id: u8) {
        // An empty range restores nothing: no call (a dictionary without
        // application objects, where the bounds are constants).
        let rest = self.stored_len.saturating_add(self.comm_rest);
        if self.comm_len < self.stored_len {
            self.restore(image, self.comm_len..self.stored_len, node_id);
        }
        if rest < self.defaults.len {
            self.restore(image, rest..self.defaults.len, node_id);
        }
    }

    fn restore(&self, image: &mut [u8], range: core::ops::Range<usize>, node_id: u8) {
        if range.end <= self.defaults.len
            && let Some(dst) = image.get_mut(range.clone())
        {
            self.defaults.read(range.start, dst);
        }
        for &pos in self.node_id_relative {
            let Some(entry) = self.entries.get(usize::from(pos)) else { continue };
            if !entry.in_rom()
                && range.contains(&usize::from(entry.offset))
                && let Some(slot) = image.get_mut(entry.range())
            {
                add_node_id(slot, node_id, false);
            }
        }
    }
}

/// An entry, or `None` and the abort code for its absence (the code beside
/// an entry means nothing): the result of a look-up as two scalars, which
/// thumbv7m returns in two registers.
pub(crate) type Found = (Option<&'static Entry>, AbortCode);

/// A [`Found`] as the `Result` its callers take.
#[inline(always)]
pub(crate) fn found(f: Found) -> Result<&'static Entry, AbortCode> {
    match f {
        (Some(entry), _) => Ok(entry),
        (None, code) => Err(code),
    }
}

/// Stores `data` into `entry`'s bytes of the RAM image, zero-filling the
/// rest of a shorter string; returns whether a byte changed. For an entry
/// that passed [`Dictionary::check_write`] (or a writable DOMAIN, which the
/// plain tables cannot store), or [`Dictionary::write_unchecked_entry`]'s
/// checks (a RAM entry, `data` no longer than it).
pub(crate) fn store_checked(image: &mut [u8], entry: &Entry, data: &[u8]) -> Result<bool, AbortCode> {
    if entry.data_type == DataType::Domain {
        return Err(AbortCode::CannotStore);
    }
    let slot = image.get_mut(entry.range()).ok_or(AbortCode::CannotStore)?;
    // A 32-bit value, the commonest, and a 16-bit one (a statusword or
    // controlword a profile sets on every frame): one word compared and
    // stored, without a `memcmp` or `memcpy` call.
    if let (Ok(d), Ok(s)) = (<&mut [u8; 4]>::try_from(&mut *slot), <&[u8; 4]>::try_from(data)) {
        let changed = *d != *s;
        *d = *s;
        return Ok(changed);
    }
    if let (Ok(d), Ok(s)) = (<&mut [u8; 2]>::try_from(&mut *slot), <&[u8; 2]>::try_from(data)) {
        let changed = *d != *s;
        *d = *s;
        return Ok(changed);
    }
    // Other lengths: the library's compare and copy (a byte loop for every
    // length took a 200-byte block download end from 2,147 to 4,112 thumbv7m
    // instructions; one for up to 8 bytes cost 52 bytes of flash).
    let (head, tail) = slot.split_at_mut(data.len().min(slot.len()));
    let data = data.get(..head.len()).unwrap_or(&[]);
    let changed = *head != *data || tail.iter().any(|&b| b != 0);
    head.copy_from_slice(data);
    tail.fill(0);
    Ok(changed)
}

/// Adds `node_id` to the little-endian integer in `bytes` (a `$NODEID`
/// value), or with `minus` subtracts it, wrapping at the integer's width.
/// Subtracting adds 2^(8·len) − `node_id`: 0x100 − `node_id` to the first
/// byte and 0xFF to every other. In 32 bits, where a 64-bit carry (the
/// negated node-id as a `u64`) took 12 bytes more in each copy of the loop
/// on thumbv7m.
// A byte plus 0x100 plus a carry of 1 is at most 0x200.
#[allow(clippy::arithmetic_side_effects)]
pub(crate) fn add_node_id(bytes: &mut [u8], node_id: u8, minus: bool) {
    let (mut add, rest) = if minus { (0x100 - u32::from(node_id), 0xFF) } else { (u32::from(node_id), 0) };
    for b in bytes.iter_mut() {
        let sum = u32::from(*b) + add;
        *b = sum as u8;
        add = rest + (sum >> 8);
    }
}

/// Copies `N` bytes at `offset` out of an image. Generated accessors call
/// this with constant offsets, so the bounds check folds away; an offset out
/// of range (impossible for generated code) yields zeros rather than a panic.
/// Here and below, an end that wraps lies below `offset`, so `get` refuses
/// the range as it refuses one past the image.
#[inline(always)]
pub fn load<const N: usize>(image: &[u8], offset: usize) -> [u8; N] {
    image.get(offset..offset.wrapping_add(N)).and_then(|s| s.try_into().ok()).unwrap_or([0; N])
}

/// Stores `N` bytes at `offset` of an image; the counterpart of [`load`].
#[inline(always)]
pub fn store<const N: usize>(image: &mut [u8], offset: usize, value: [u8; N]) {
    if let Some(slot) = image.get_mut(offset..offset.wrapping_add(N)) {
        slot.copy_from_slice(&value);
    }
}

/// Reads an `N`-byte little-endian unsigned integer (for the 24- to 56-bit types).
#[inline(always)]
pub fn load_uint<const N: usize>(image: &[u8], offset: usize) -> u64 {
    let mut b = [0u8; 8];
    if let (Some(dst), Some(src)) = (b.get_mut(..N), image.get(offset..offset.wrapping_add(N))) {
        dst.copy_from_slice(src);
    }
    u64::from_le_bytes(b)
}

/// Reads an `N`-byte little-endian two's-complement integer, sign-extended.
#[inline(always)]
pub fn load_int<const N: usize>(image: &[u8], offset: usize) -> i64 {
    // 8 to 64 bits: the shift is 0..=56.
    #[allow(clippy::arithmetic_side_effects)]
    let shift = 64 - 8 * N.clamp(1, 8) as u32;
    ((load_uint::<N>(image, offset) << shift) as i64) >> shift
}

/// Stores the low `N` bytes of `value`, little-endian.
#[inline(always)]
pub fn store_uint<const N: usize>(image: &mut [u8], offset: usize, value: u64) {
    if let (Some(dst), Some(src)) = (image.get_mut(offset..offset.wrapping_add(N)), value.to_le_bytes().get(..N)) {
        dst.copy_from_slice(src);
    }
}

/// The `len` bytes of an OCTET_STRING or UNICODE_STRING entry.
#[inline]
pub fn load_bytes(image: &[u8], offset: usize, len: usize) -> &[u8] {
    image.get(offset..offset.wrapping_add(len)).unwrap_or(&[])
}

/// The bytes of a string entry up to its first NUL.
#[inline]
pub fn load_str(image: &[u8], offset: usize, len: usize) -> &[u8] {
    until_nul(image.get(offset..offset.wrapping_add(len)).unwrap_or(&[]))
}

pub(crate) fn until_nul(s: &[u8]) -> &[u8] {
    let used = s.iter().position(|&b| b == 0).unwrap_or(s.len());
    s.get(..used).unwrap_or(s)
}

/// Stores a string entry, cut to its capacity and NUL-filled. Returns the
/// number of bytes stored.
#[inline]
pub fn store_str(image: &mut [u8], offset: usize, len: usize, value: &[u8]) -> usize {
    let Some(slot) = image.get_mut(offset..offset.wrapping_add(len)) else { return 0 };
    let n = value.len().min(slot.len());
    let (head, tail) = slot.split_at_mut(n);
    head.copy_from_slice(value.get(..n).unwrap_or(&[]));
    tail.fill(0);
    n
}

#[cfg(test)]
mod tests;
