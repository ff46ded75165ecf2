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
use core::ops::Range;

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

    const fn mask(self) -> u16 {
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
const fn scope_bit(index: u16) -> u16 {
    match index {
        0x0000..=0x1FFF => Scope::Communication.mask(),
        0x2000..=0x5FFF => Scope::Manufacturer.mask(),
        _ => Scope::Application.mask(),
    }
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

// Out of line: save and load each had a copy of the table loop.
#[inline(never)]
fn crc32_update(mut crc: u32, data: &[u8]) -> u32 {
    // The index is masked to 4 bits, so the look-up is always in the table.
    let step = |crc: u32| (crc >> 4) ^ CRC32_NIBBLE.get((crc & 0xF) as usize).copied().unwrap_or(0);
    for &b in data {
        crc = step(step(crc ^ u32::from(b)));
    }
    crc
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    /// LSS configuration stored with the set: node-id, bit-rate table index
    /// (0xFF, 0xFF = none; an erased header reads that way).
    lss: [u8; 2],
    seq: u32,
    len: u16,
    defaults: u16,
    crc: u32,
}

/// The header of `region` if it belongs to this dictionary; the payload is not checked yet.
fn read_header(storage: &mut dyn Storage, region: u8, dict: &Dictionary) -> Option<Header> {
    let mut h = [0u8; HEADER];
    storage.read(region, 0, &mut h).ok()?;
    // Little-endian words: magic, version and LSS, layout id, sequence number, length and default scopes, CRC.
    let mut words = [0u32; HEADER / 4];
    for (word, bytes) in words.iter_mut().zip(h.chunks_exact(4)) {
        *word = u32::from_le_bytes(bytes.try_into().unwrap_or_default());
    }
    let [magic, version_lss, layout, seq, len_defaults, crc] = words;
    if magic != MAGIC || version_lss as u16 != VERSION || layout != dict.layout_id {
        return None;
    }
    let lss = [(version_lss >> 16) as u8, (version_lss >> 24) as u8];
    let header = Header { lss, seq, len: len_defaults as u16, defaults: (len_defaults >> 16) as u16, crc };
    // A set of another prefix is refused even where the entries' offsets agree.
    (usize::from(header.len) == dict.stored_len).then_some(header)
}

/// The CRC-32 of `range` of the payload of `region`, continued from `crc`
/// (`None` if the storage fails).
// `off` ≤ `range.end`, a payload offset (below 64 KiB: 24 more fit).
#[allow(clippy::arithmetic_side_effects)]
fn crc_of(storage: &mut dyn Storage, region: u8, range: Range<usize>, mut crc: u32) -> Option<u32> {
    let mut buf = [0u8; 64];
    let mut off = range.start;
    while off < range.end {
        let chunk = buf.get_mut(..(range.end - off).min(64))?;
        storage.read(region, HEADER + off, chunk).ok()?;
        crc = crc32_update(crc, chunk);
        off += chunk.len();
    }
    Some(crc)
}

/// The newest valid parameter set in a [`Storage`]: found once by
/// [`newest`], then read by each part of a reset without checking it again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoredSet {
    region: u8,
    header: Header,
}

/// [`newest`] a piece at a time: the headers, then the payload's CRC in
/// pieces, a step each (a store's first stages, [`Job`]). All zero bits
/// before its first step ([`Finder::NEW`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Finder {
    /// Sets found broken so far: the region checked is the newer one's,
    /// then the other; 2 = none left.
    tried: u8,
    /// Payload bytes of the set in hand checked so far, and their CRC
    /// inverted (0 before the first byte, so that a new finder is all zero bits).
    pos: u16,
    crc: u32,
}

impl Finder {
    /// Nothing checked yet.
    const NEW: Finder = Finder { tried: 0, pos: 0, crc: 0 };

    /// Checks at most `budget` payload bytes; the newest valid set (or
    /// none) once found. Only the newer header's payload is checked when it
    /// is intact: an older set cannot win over it, valid or not. The
    /// headers are read at every step (the storage does not change between
    /// steps), which costs less than keeping them.
    fn step_with(&mut self, dict: &Dictionary, storage: &mut dyn Storage, budget: usize) -> Option<Option<StoredSet>> {
        let headers = [read_header(storage, 0, dict), read_header(storage, 1, dict)];
        // Region 1 first if it is newer (sequence numbers compared with wrap-around) or region 0 holds none.
        let first = match &headers {
            [Some(a), Some(b)] => u8::from(b.seq.wrapping_sub(a.seq) as i32 > 0),
            [a, _] => u8::from(a.is_none()),
        };
        while self.tried < 2 {
            let region = first ^ self.tried;
            if let Some(header) = headers.get(usize::from(region)).copied().flatten() {
                let (pos, len) = (usize::from(self.pos), usize::from(header.len));
                let end = len.min(pos.saturating_add(budget));
                match crc_of(storage, region, pos..end, !self.crc) {
                    Some(crc) if end < len => {
                        (self.pos, self.crc) = (end as u16, !crc);
                        return None;
                    }
                    Some(crc) if !crc == header.crc => return Some(Some(StoredSet { region, header })),
                    // Cut short, or the storage failed: the other set, in the next step.
                    _ => {}
                }
                (self.tried, self.pos, self.crc) = (self.tried.wrapping_add(1), 0, 0);
                return None;
            }
            self.tried = self.tried.wrapping_add(1);
        }
        Some(None)
    }
}

/// Finds the newest valid set. Only the newer header's payload is checked
/// when it is intact: an older set cannot win over it, valid or not.
pub fn newest(dict: &Dictionary, storage: &mut dyn Storage) -> Option<StoredSet> {
    let mut finder = Finder::NEW;
    loop {
        if let Some(found) = finder.step_with(dict, storage, usize::MAX) {
            return found;
        }
    }
}

impl StoredSet {
    /// The LSS configuration stored with the set (node-id, bit-rate table index), if any.
    pub fn lss(&self) -> Option<(u8, u8)> {
        let [id, rate] = self.header.lss;
        (id != 0xFF || rate != 0xFF).then_some((id, rate))
    }

    /// Overwrites the writable entries of `part` with this set (after the
    /// reset copied the defaults). Returns whether any value was taken from
    /// it. If the storage fails, the part gets its defaults back.
    // `run` lies in the image (a slice, below isize::MAX): 24 more fit.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn load(&self, dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
        let communication = part == Part::Communication;
        let wanted = |e: &Entry| {
            (e.index < 0x2000) == communication
                && e.attr.contains(Attr::WRITE)
                && in_set(dict, e)
                && self.header.defaults & scope_bit(e.index) == 0
        };
        // Adjacent values are read with one call: a call per entry cost more than the copying.
        let mut run = 0..0;
        let mut used = false;
        for r in dict.entries.iter().filter(|e| wanted(e)).map(Entry::range).chain(core::iter::once(usize::MAX..usize::MAX)) {
            if run.end != r.start {
                let read =
                    image.get_mut(run.clone()).map(|dst| dst.is_empty() || storage.read(self.region, HEADER + run.start, dst).is_ok());
                if read != Some(true) {
                    if communication {
                        dict.reset_communication(image, node_id)
                    } else {
                        dict.reset_application(image, node_id)
                    }
                    return false;
                }
                run.start = r.start;
            }
            run.end = r.end;
            used = true;
        }
        // `$NODEID` values are stored relative to the node-id.
        for e in dict.node_id_relative.iter().filter_map(|&i| dict.entries.get(usize::from(i))).filter(|e| wanted(e)) {
            if let Some(value) = image.get_mut(e.range()) {
                crate::od::add_le(value, u64::from(node_id));
            }
        }
        used
    }
}

/// 0x1010 "save": stores the scope's parameters.
pub fn save(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    Job::save(dict, scope, None).finish(dict, image, node_id, storage)
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
    Job::save(dict, scope, keep).finish(dict, image, node_id, storage)
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

/// The bytes of the stored prefix the values of objects `first..=last`
/// take (the prefix is in index order, so they are one run).
fn byte_range(dict: &Dictionary, first: u16, last: u16) -> Range<usize> {
    let mut ram = dict.entries.iter().filter(|e| (first..=last).contains(&{ e.index }) && in_set(dict, e));
    let Some(start) = ram.next().map(|e| e.range()) else { return 0..0 };
    let end = ram.next_back().map_or(start.end, |e| e.range().end);
    start.start..end
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
    if !in_set(dict, entry) || set.header.defaults & scope_bit(entry.index) != 0 {
        return None;
    }
    let range = entry.range();
    let value = out.get_mut(..range.len())?;
    storage.read(set.region, HEADER + range.start, value).ok()?;
    if entry.attr.contains(Attr::NODE_ID) {
        crate::od::add_le(value, u64::from(node_id));
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

/// Overwrites the writable entries of `part` with the newest stored set
/// (after the reset copied the defaults). Returns whether a set was used.
/// A reset that loads both parts finds the set once with [`newest`] and
/// calls [`StoredSet::load`] for each.
pub fn load(dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
    newest(dict, storage).is_some_and(|set| set.load(dict, image, node_id, storage, part))
}

mod job;
#[cfg(test)]
mod tests;

pub use job::{CHECK_STAGE, Job, STAGE};
