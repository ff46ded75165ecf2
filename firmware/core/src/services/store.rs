//! Store and restore parameters: 0x1010 / 0x1011. CiA 301 v4.2 §7.5.2.13–14.
//!
//! A parameter set is the stored prefix of the RAM image
//! ([`Dictionary::stored_len`]: the writable values and those a device
//! stores itself; od-gen lays them out first), written to the [`Storage`] region not
//! holding the newest valid set: erase, payload, then the header last. The
//! header carries a sequence number, the dictionary layout it belongs to
//! ([`Dictionary::layout_id`], a constant of the generated dictionary) and a
//! CRC-32 of the payload, so a power cut at any step leaves either the old
//! set or the new one valid, never a mix. A reset checks the sets once
//! ([`newest`]) and loads each part from the set found ([`StoredSet::load`]).
//!
//! Scopes follow the sub-indices of 0x1010/0x1011: 1 all, 2 communication
//! (0x1000–0x1FFF), 3 application (0x6000–0x9FFF), 4 manufacturer
//! (0x2000–0x5FFF); each value is taken from the scope of its index.
//! "Restore defaults" writes a set that marks its scopes as default.
//! Only writable entries are taken from a stored set; `$NODEID` entries are
//! stored relative to the node-id, so they follow a node-id change.

use crate::od::{Attr, Dictionary, Entry};
use crate::storage::{Storage, StorageError};

/// 0x1010 signature "save" (ASCII, little-endian).
pub const SAVE: u32 = 0x6576_6173;
/// 0x1011 signature "load".
pub const LOAD: u32 = 0x6461_6F6C;

/// The first word of a stored set's header ("COPS"), for boards that log what they find.
pub const MAGIC: u32 = 0x5350_4F43;
const VERSION: u16 = 1;
const HEADER: usize = 24;

/// Which parameters a command covers (the 0x1010/0x1011 sub-index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// Sub 1: all parameters.
    All,
    /// Sub 2: communication parameters 0x1000–0x1FFF.
    Communication,
    /// Sub 3: application (profile) parameters 0x6000–0x9FFF.
    Application,
    /// Sub 4: manufacturer parameters 0x2000–0x5FFF.
    Manufacturer,
}

impl Scope {
    /// The scope of 0x1010/0x1011 sub-index `sub`.
    pub const fn from_sub(sub: u8) -> Option<Scope> {
        Some(match sub {
            1 => Scope::All,
            2 => Scope::Communication,
            3 => Scope::Application,
            4 => Scope::Manufacturer,
            _ => return None,
        })
    }

    const fn mask(self) -> u8 {
        match self {
            Scope::All => 0b111,
            Scope::Communication => 0b001,
            Scope::Manufacturer => 0b010,
            Scope::Application => 0b100,
        }
    }
}

/// Why a store or restore failed (abort 0x06060000 or 0x08000020 in the node).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreError {
    /// The storage failed.
    Storage(StorageError),
    /// The image does not fit a region.
    TooLarge,
    /// Another store is in progress (abort 0x08000022 in the node).
    Busy,
    /// The objects asked for have no value a stored set holds (read-only
    /// values the device's build does not name as kept: od-gen's stored
    /// prefix); abort 0x08000020 in the node.
    NotStored,
}

impl From<StorageError> for StoreError {
    fn from(e: StorageError) -> Self {
        StoreError::Storage(e)
    }
}

/// The scope bit (see [`Scope::mask`]) of the object at `index`.
const fn scope_bit(index: u16) -> u8 {
    bit_of(Attr::scope_of(index))
}

/// The scope bit of an entry, from its attributes' scope bits (none: 1,
/// manufacturer: 2, application: 4), which it loads anyway.
const fn entry_scope(entry: &Entry) -> u8 {
    bit_of(entry.attr)
}

/// The [`Scope::mask`] bit of the scope bits of `attr` (0, 1 or 2 after the shift).
const fn bit_of(attr: Attr) -> u8 {
    1 << (attr.0 >> 6)
}

/// CRC-32 (reflected, polynomial 0xEDB88320) of each value of a nibble.
/// Chosen by measurement on thumbv7m (`cargo xtask icount`, `cargo xtask
/// size`): against the bitwise loop it saves about 52 instructions per byte
/// (45,000 per check of an 866-byte image) for 66 bytes of flash; a
/// 256-entry table would save 3 more per byte for 946 bytes more.
const CRC32_NIBBLE: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n: u32 = 0;
    let mut slots: &mut [u32] = &mut table;
    while let [slot, rest @ ..] = slots {
        let mut crc = n;
        let mut bit = 0;
        while bit < 4 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            bit += 1;
        }
        *slot = crc;
        n += 1;
        slots = rest;
    }
    table
};

// Out of line: one copy for the checks and the writes (ds301 -12 B, every image with storage smaller;
// a call per piece of 128 bytes).
#[inline(never)]
fn crc32_update(mut crc: u32, data: &[u8]) -> u32 {
    // The index is masked to 4 bits, so the look-up is always in the table.
    let step = |crc: u32| (crc >> 4) ^ CRC32_NIBBLE.get((crc & 0xF) as usize).copied().unwrap_or(0);
    for &b in data {
        crc = step(step(crc ^ u32::from(b)));
    }
    crc
}

/// Payload bytes a store's step writes at most ([`STAGE`]), and a check reads at a time.
const PIECE: usize = 128;

/// The CRC-32 of the payload bytes `0..len` of the set in `region`, read a
/// piece at a time.
// `pos` ≤ `len`, a payload offset.
#[allow(clippy::arithmetic_side_effects)]
fn payload_crc(storage: &mut dyn Storage, region: u8, len: usize) -> Result<u32, StorageError> {
    let mut buf = [0u8; PIECE];
    let (mut pos, mut crc) = (0, u32::MAX);
    while let Some(chunk) = buf.get_mut(..len.wrapping_sub(pos).min(PIECE)).filter(|_| pos < len) {
        // An offset in the image: the header's length added cannot wrap.
        storage.read(region, pos.wrapping_add(HEADER), chunk)?;
        crc = crc32_update(crc, chunk);
        pos += chunk.len();
    }
    Ok(!crc)
}

/// The newest valid parameter set in a [`Storage`]: found once by
/// [`newest`], then read by each part of a reset without checking it again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoredSet {
    region: u8,
    /// The scopes the set marks as default ([`Scope`] bits).
    defaults: u8,
    /// LSS configuration stored with the set: node-id, bit-rate table index
    /// (0xFF, 0xFF = none; an erased header reads that way).
    lss: [u8; 2],
    seq: u32,
}

/// The set header of `region` if it belongs to this dictionary, with the
/// CRC its payload should have (not checked yet). Little-endian words:
/// magic, version and LSS, layout id, sequence number, length and default
/// scopes, CRC.
fn read_header(storage: &mut dyn Storage, region: u8, dict: &Dictionary) -> Option<(StoredSet, u32)> {
    let mut h = [0u8; HEADER];
    storage.read(region, 0, &mut h).ok()?;
    let [m0, m1, m2, m3, v0, v1, id, rate, l0, l1, l2, l3, s0, s1, s2, s3, n0, n1, defaults, _, c0, c1, c2, c3] = h;
    // A set of another prefix is refused even where the entries' offsets agree.
    (u32::from_le_bytes([m0, m1, m2, m3]) == MAGIC
        && u16::from_le_bytes([v0, v1]) == VERSION
        && u32::from_le_bytes([l0, l1, l2, l3]) == dict.layout_id
        && usize::from(u16::from_le_bytes([n0, n1])) == dict.stored_len)
        .then_some((
            StoredSet { region, defaults, lss: [id, rate], seq: u32::from_le_bytes([s0, s1, s2, s3]) },
            u32::from_le_bytes([c0, c1, c2, c3]),
        ))
}

impl StoredSet {
    /// The LSS configuration stored with the set (node-id, bit-rate table index), if any.
    pub fn lss(&self) -> Option<(u8, u8)> {
        let [id, rate] = self.lss;
        (id != 0xFF || rate != 0xFF).then_some((id, rate))
    }

    /// Resets `part` of the image from this set: see [`reset_part`].
    pub fn load(&self, dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
        reset_part(dict, image, node_id, storage, Some(self), part)
    }
}

/// Resets `part` of the image (CiA 301 reset communication or application):
/// its defaults, then, with a set, the values the set holds for a reset,
/// and the node-id on the `$NODEID` values (a set keeps them relative, as
/// the defaults are). Returns whether a value was taken from the set; if
/// the storage fails, the part keeps its defaults.
///
/// The part's stored payload is one read into the image; the values the
/// set does not hold for a reset (read-only ones, scopes it marks as
/// default) then get their defaults back, in the one walk over the part's
/// entries that adds the node-id.
// In line: the node's reset calls it with its dictionary, a static, whose
// lengths and tables then are constants (ds301 -40 B, every image smaller).
#[inline(always)]
pub fn reset_part(
    dict: &Dictionary,
    image: &mut [u8],
    node_id: u8,
    storage: &mut dyn Storage,
    set: Option<&StoredSet>,
    part: Part,
) -> bool {
    let communication = part == Part::Communication;
    let rest = dict.stored_len.saturating_add(dict.comm_rest);
    let [stored, others] =
        if communication { [0..dict.comm_len, dict.stored_len..rest] } else { [dict.comm_len..dict.stored_len, rest..dict.defaults.len] };
    let start = stored.start.saturating_add(HEADER);
    let set = set.filter(|set| image.get_mut(stored.clone()).is_some_and(|dst| storage.read(set.region, start, dst).is_ok()));
    // The defaults where the set was not read (none read for an empty range: `read` walks every default).
    // Two calls, not a loop over an array of the ranges, which LLVM kept on the stack.
    let limit = dict.defaults.len;
    if set.is_none()
        && let Some(dst) = image.get_mut(stored.clone()).filter(|dst| !dst.is_empty() && stored.end <= limit)
    {
        dict.defaults.read(stored.start, dst);
    }
    if let Some(dst) = image.get_mut(others.clone()).filter(|dst| !dst.is_empty() && others.end <= limit) {
        dict.defaults.read(others.start, dst);
    }
    let mut used = false;
    for e in dict.entries.iter().filter(|e| e.communication() == communication && !e.in_rom()) {
        let r = e.range();
        if let Some(value) = image.get_mut(r.clone()).filter(|_| r.end <= dict.defaults.len) {
            let held = set.map(|set| e.attr.contains(Attr::WRITE) && set.defaults & entry_scope(e) == 0);
            if held == Some(false) && in_set(dict, e) {
                dict.defaults.read(r.start, value);
            }
            if e.attr.contains(Attr::NODE_ID) {
                crate::od::add_node_id(value, node_id, false);
            }
            used |= held == Some(true) && in_set(dict, e);
        }
    }
    used
}

/// 0x1010 "save": stores the scope's parameters.
pub fn save(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    Job::save(scope, None).finish(dict, image, node_id, storage)
}

/// 0x1010 "save" of a device that stores the objects `keep` (an inclusive
/// index range) only through its own command: they keep their stored values.
pub fn save_except(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    scope: Scope,
    keep: Option<(u16, u16)>,
) -> Result<(), StoreError> {
    Job::save(scope, keep).finish(dict, image, node_id, storage)
}

/// Stores the objects `first..=last` alone: every other value keeps what the
/// newest set holds (or its default), so unsaved changes elsewhere stay
/// unsaved. Objects no set holds are [`StoreError::NotStored`], not stored as nothing.
pub fn save_objects(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    first: u16,
    last: u16,
) -> Result<(), StoreError> {
    Job::save_objects(dict, first, last)?.finish(dict, image, node_id, storage)
}

/// Whether a stored set holds `entry`'s value: a RAM value in the stored prefix
/// (which holds whole values: od-gen lays it out so, and a value it does not
/// hold starts at its end or after).
fn in_set(dict: &Dictionary, entry: &Entry) -> bool {
    !entry.in_rom() && entry.len > 0 && usize::from(entry.offset) < dict.stored_len
}

/// 0x1011 "load": the scope uses its defaults from the next reset on.
pub fn restore_defaults(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    Job::restore(scope).finish(dict, image, node_id, storage)
}

/// LSS "store configuration" (CiA 305 §5.2.4): the node-id and bit-rate
/// table index for the next start, written as a new set (the parameters stay
/// as stored), so a power cut leaves the old configuration or the new one.
pub fn save_lss(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    lss_node_id: u8,
    bit_rate: u8,
) -> Result<(), StoreError> {
    Job::lss(lss_node_id, bit_rate).finish(dict, image, node_id, storage)
}

/// The value of (index, sub) in the newest stored set, copied into the
/// front of `out`, if the set holds one (an entry whose scope was saved);
/// its length. For a device's start-up, before power-on: one value read
/// from the storage, no image built. A read-only entry gives what the
/// image held when the set was saved: a value the device keeps across
/// power cycles itself (an encoder's preset offset), which a reset does not
/// load. `None` for a value the set does not hold (see [`Dictionary::stored_len`]).
// An entry's range: two u16s, and 24 more fit a usize.
#[allow(clippy::arithmetic_side_effects)]
pub fn stored_value(dict: &Dictionary, storage: &mut dyn Storage, node_id: u8, index: u16, sub: u8, out: &mut [u8]) -> Option<usize> {
    let set = newest(dict, storage)?;
    let entry = dict.find(index, sub).ok()?;
    if !in_set(dict, entry) || set.defaults & entry_scope(entry) != 0 {
        return None;
    }
    let range = entry.range();
    let value = out.get_mut(..range.len())?;
    storage.read(set.region, HEADER + range.start, value).ok()?;
    if entry.attr.contains(Attr::NODE_ID) {
        crate::od::add_node_id(value, node_id, false);
    }
    Some(range.len())
}

/// Which part of the image a reset reloads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// 0x1000–0x1FFF, at reset communication.
    Communication,
    /// 0x2000 and up, at reset application.
    Application,
}

/// Resets `part` of the image from the newest stored set ([`reset_part`]);
/// returns whether a value was taken from one (without a set, the image is
/// left as it is). A reset that loads both parts finds the set once with
/// [`newest`] and calls [`StoredSet::load`] for each.
pub fn load(dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
    newest(dict, storage).is_some_and(|set| set.load(dict, image, node_id, storage, part))
}

mod job;
mod refused;
#[cfg(test)]
mod tests;

pub(crate) use job::check;
pub use job::{Job, STAGE, newest};
pub use refused::refused;
