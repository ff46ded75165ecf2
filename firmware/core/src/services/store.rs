//! Store and restore parameters: 0x1010 / 0x1011. CiA 301 v4.2 §7.5.2.13–14.
//!
//! A parameter set is the RAM image, written to the [`Storage`] region not
//! holding the newest valid set: erase, payload, then the header last. The
//! header carries a sequence number, the dictionary layout it belongs to
//! ([`Dictionary::layout_id`], a constant of the generated dictionary) and a
//! CRC-32 of the payload, so a power cut at any step leaves either the old
//! set or the new one valid, never a mix. A reset checks the sets once
//! ([`newest`]) and loads each part from the set found ([`StoredSet::load`]).
//!
//! Scopes follow the sub-indices of 0x1010/0x1011: 1 all, 2 communication
//! (0x1000–0x1FFF), 3 application (0x6000–0x9FFF), 4 manufacturer
//! (0x2000–0x5FFF). The image is in index order, so each scope is a byte
//! range. "Restore defaults" writes a set that marks its scopes as default.
//! Only writable entries are taken from a stored set; `$NODEID` entries are
//! stored relative to the node-id, so they follow a node-id change.

use crate::od::{Attr, Dictionary};
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
}

impl From<StorageError> for StoreError {
    fn from(e: StorageError) -> Self {
        StoreError::Storage(e)
    }
}

/// The scope bit (see [`Scope::mask`]) of the object at `index`: the image
/// is in index order, so this is also the byte range the entry lies in.
const fn scope_bit(index: u16) -> u16 {
    match index {
        0x0000..=0x1FFF => Scope::Communication.mask(),
        0x2000..=0x5FFF => Scope::Manufacturer.mask(),
        _ => Scope::Application.mask(),
    }
}

/// Where the manufacturer and the application scope begin in the image (the
/// communication scope begins at 0): the offset of the first value in RAM at
/// or after 0x2000 and 0x6000.
fn scope_starts(dict: &Dictionary) -> [usize; 2] {
    let start = |index: u16| {
        let first = dict.entries.partition_point(|e| e.index < index);
        let later = dict.entries.get(first..).unwrap_or(&[]);
        later.iter().find(|e| !e.in_rom() && e.len > 0).map_or(dict.defaults.len(), |e| usize::from(e.offset))
    };
    let manufacturer = start(0x2000).max(dict.comm_len);
    [manufacturer, start(0x6000).max(manufacturer)]
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
    // As in `od::load`: a wrapped end is below `i`, and `get` refuses it.
    let word = |i: usize| h.get(i..i.wrapping_add(4)).and_then(|s| s.try_into().ok()).map(u32::from_le_bytes);
    let half = |i: usize| h.get(i..i.wrapping_add(2)).and_then(|s| s.try_into().ok()).map(u16::from_le_bytes);
    if word(0)? != MAGIC || half(4)? != VERSION || word(8)? != dict.layout_id {
        return None;
    }
    let lss = [*h.get(6)?, *h.get(7)?];
    let header = Header { lss, seq: word(12)?, len: half(16)?, defaults: half(18)?, crc: word(20)? };
    (usize::from(header.len) == dict.defaults.len()).then_some(header)
}

/// Whether the payload of `region` matches the header's CRC (else the write was cut short).
// `off` < `header.len` in the loop, and `off + n` ≤ `header.len` (a u16).
#[allow(clippy::arithmetic_side_effects)]
fn payload_intact(storage: &mut dyn Storage, region: u8, header: &Header) -> bool {
    let mut crc = !0u32;
    let mut buf = [0u8; 64];
    let mut off = 0;
    while off < usize::from(header.len) {
        let n = buf.len().min(usize::from(header.len) - off);
        let Some(chunk) = buf.get_mut(..n) else { return false };
        if storage.read(region, HEADER + off, chunk).is_err() {
            return false;
        }
        crc = crc32_update(crc, chunk);
        off += n;
    }
    !crc == header.crc
}

/// The newest valid parameter set in a [`Storage`]: found once by
/// [`newest`], then read by each part of a reset without checking it again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoredSet {
    region: u8,
    header: Header,
}

/// Finds the newest valid set. Only the newer header's payload is checked
/// when it is intact: an older set cannot win over it, valid or not.
pub fn newest(dict: &Dictionary, storage: &mut dyn Storage) -> Option<StoredSet> {
    let headers = [read_header(storage, 0, dict), read_header(storage, 1, dict)];
    // Region 1 first if it is newer (sequence numbers compared with wrap-around) or region 0 holds none.
    let one_first = match &headers {
        [Some(a), Some(b)] => b.seq.wrapping_sub(a.seq) as i32 > 0,
        [a, _] => a.is_none(),
    };
    for region in if one_first { [1u8, 0] } else { [0, 1] } {
        if let Some(header) = headers.get(usize::from(region)).copied().flatten()
            && payload_intact(storage, region, &header)
        {
            return Some(StoredSet { region, header });
        }
    }
    None
}

impl StoredSet {
    /// The LSS configuration stored with the set (node-id, bit-rate table index), if any.
    pub fn lss(&self) -> Option<(u8, u8)> {
        let [id, rate] = self.header.lss;
        (id != 0xFF || rate != 0xFF).then_some((id, rate))
    }

    /// Overwrites the writable entries of `part` with this set (after the
    /// reset copied the defaults). Returns whether any value was taken from it.
    pub fn load(&self, dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
        // The table is sorted by index, so each part is one run of it.
        let split = dict.entries.partition_point(|e| e.index < 0x2000);
        let Some((communication, application)) = dict.entries.split_at_checked(split) else { return false };
        let entries = match part {
            Part::Communication => communication,
            Part::Application => application,
        };
        // Adjacent values to load are read with one call: a call per entry cost more than the copying.
        let mut run = 0..0;
        let mut used = false;
        for e in entries.iter().filter(|e| !e.in_rom() && e.len > 0) {
            let r = e.range();
            let wanted = e.attr.contains(Attr::WRITE) && self.header.defaults & scope_bit(e.index) == 0;
            let relative = e.attr.contains(Attr::NODE_ID);
            if wanted && !relative && !run.is_empty() && run.end == r.start {
                run.end = r.end;
                continue;
            }
            // `e` does not extend the run: read what it holds.
            if !self.read_into(dict, image, storage, run.clone()) {
                return used;
            }
            used |= !run.is_empty();
            run = 0..0;
            if !wanted {
                continue;
            }
            if !relative {
                run = r;
                continue;
            }
            if !self.read_into(dict, image, storage, r.clone()) {
                return used;
            }
            if let Some(value) = image.get_mut(r) {
                crate::od::add_le(value, u64::from(node_id));
                used = true;
            }
        }
        let last = self.read_into(dict, image, storage, run.clone());
        used || (last && !run.is_empty())
    }

    /// Copies `range` of the stored image into `image`. If the storage
    /// fails, the range gets its defaults back (`$NODEID` entries are loaded
    /// one at a time, so an absolute default is right) and the load stops.
    // `range` lies in the image (a slice, below isize::MAX): 24 more fit.
    #[allow(clippy::arithmetic_side_effects)]
    fn read_into(&self, dict: &Dictionary, image: &mut [u8], storage: &mut dyn Storage, range: core::ops::Range<usize>) -> bool {
        let (Some(dst), Some(defaults)) = (image.get_mut(range.clone()), dict.defaults.get(range.clone())) else { return false };
        if dst.is_empty() || storage.read(self.region, HEADER + range.start, dst).is_ok() {
            return true;
        }
        dst.copy_from_slice(defaults);
        false
    }
}

/// Subtracts `n` from the little-endian integer in `bytes`, wrapping at its width.
// `v` is -255..=255, and `borrow >> 8` plus 1 cannot reach u64::MAX.
#[allow(clippy::arithmetic_side_effects)]
fn sub_le(bytes: &mut [u8], n: u64) {
    let mut borrow = n;
    for b in bytes.iter_mut() {
        let v = i64::from(*b) - (borrow & 0xFF) as i64;
        borrow >>= 8;
        if v < 0 {
            *b = (v + 256) as u8;
            borrow += 1;
        } else {
            *b = v as u8;
        }
    }
}

/// Writes a new set: the scopes in `save` from the image, the scopes in
/// `reset` marked as defaults, every other scope kept from the newest set.
///
/// Within the saved scopes, only the bytes of `from_image` come from the
/// image, never those of `keep`: the rest keeps the newest set (the
/// defaults if there is none).
// `len` is a slice's length (below isize::MAX: 24 more fit), every position
// below it, `set.region` 0 or 1, and each subtraction follows the comparison
// that orders it.
#[allow(clippy::too_many_arguments, clippy::arithmetic_side_effects)]
fn write_set(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    save: u16,
    reset: u16,
    lss: Option<[u8; 2]>,
    from_image: Range<usize>,
    keep: Range<usize>,
) -> Result<(), StoreError> {
    let len = dict.defaults.len();
    if HEADER + len > storage.region_size() || len > usize::from(u16::MAX) {
        return Err(StoreError::TooLarge);
    }
    let old = newest(dict, storage);
    let target = old.map_or(0, |set| 1 - set.region);
    let mut defaults = old.map_or(0b111, |set| set.header.defaults);
    defaults = (defaults & !save) | reset;
    storage.erase(target)?;
    let [manufacturer, application] = scope_starts(dict);
    let mut crc = !0u32;
    let mut buf = [0u8; 64];
    let mut pos = 0;
    // The payload in chunks, each within one scope and taken from one source.
    while pos < len {
        let (bit, end) = match pos {
            p if p < manufacturer => (Scope::Communication.mask(), manufacturer),
            p if p < application => (Scope::Manufacturer.mask(), application),
            _ => (Scope::Application.mask(), len),
        };
        let mut n = buf.len().min(end - pos);
        // A chunk lies wholly inside or outside each of the two ranges.
        for edge in [from_image.start, from_image.end, keep.start, keep.end] {
            if edge > pos && edge < pos + n {
                n = edge - pos;
            }
        }
        let picked = save & bit != 0 && from_image.contains(&pos) && !keep.contains(&pos);
        let from_image = picked || (old.is_none() && save & bit == 0);
        let relative = || dict.node_id_relative.iter().filter_map(|&i| dict.entries.get(usize::from(i))).map(|e| e.range());
        if from_image {
            // A `$NODEID` value (at most 8 bytes) is adjusted whole, so no chunk cuts one.
            if let Some(r) = relative().find(|r| r.start > pos && r.start < pos + n && r.end > pos + n) {
                n = r.start - pos;
            }
        }
        let chunk = buf.get_mut(..n).ok_or(StoreError::TooLarge)?;
        // A scope the newest set marks as default holds stale bytes: a partial save must not revive them.
        let stale = old.is_some_and(|set| set.header.defaults & bit != 0);
        match old {
            Some(set) if !from_image && !stale => storage.read(set.region, HEADER + pos, chunk)?,
            // No set (or a scope at default): what is not saved from the image is the default (stored relative, as defaults are).
            _ if !from_image => chunk.copy_from_slice(dict.defaults.get(pos..pos + n).ok_or(StoreError::TooLarge)?),
            _ => {
                chunk.copy_from_slice(image.get(pos..pos + n).ok_or(StoreError::TooLarge)?);
                // `$NODEID` values are kept relative to the node-id.
                for r in relative().filter(|r| r.start >= pos && r.end <= pos + n) {
                    if let Some(value) = chunk.get_mut(r.start - pos..r.end - pos) {
                        sub_le(value, u64::from(node_id));
                    }
                }
            }
        }
        storage.write(target, HEADER + pos, chunk)?;
        crc = crc32_update(crc, chunk);
        pos += n;
    }
    let seq = old.map_or(1, |set| set.header.seq.wrapping_add(1));
    // The LSS configuration rides along with every set: a new one or the old one.
    let lss_bytes = lss.or(old.map(|set| set.header.lss)).unwrap_or([0xFF, 0xFF]);
    let [m0, m1, m2, m3] = MAGIC.to_le_bytes();
    let [v0, v1] = VERSION.to_le_bytes();
    let [l0, l1, l2, l3] = dict.layout_id.to_le_bytes();
    let [s0, s1, s2, s3] = seq.to_le_bytes();
    let [n0, n1] = (len as u16).to_le_bytes();
    let [d0, d1] = defaults.to_le_bytes();
    let [c0, c1, c2, c3] = (!crc).to_le_bytes();
    let [i0, i1] = lss_bytes;
    let h: [u8; HEADER] = [m0, m1, m2, m3, v0, v1, i0, i1, l0, l1, l2, l3, s0, s1, s2, s3, n0, n1, d0, d1, c0, c1, c2, c3];
    storage.write(target, 0, &h)?;
    Ok(())
}

/// 0x1010 "save": stores the scope's parameters.
pub fn save(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    save_except(dict, image, node_id, storage, scope, None)
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
    let keep = keep.map_or(0..0, |(first, last)| byte_range(dict, first, last));
    write_set(dict, image, node_id, storage, scope.mask(), 0, None, 0..image.len(), keep)
}

/// Stores the objects `first..=last` alone: every other value keeps what the
/// newest set holds (or its default), so unsaved changes elsewhere stay unsaved.
pub fn save_objects(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    first: u16,
    last: u16,
) -> Result<(), StoreError> {
    let range = byte_range(dict, first, last);
    let Some(scope_last) = range.end.checked_sub(1).filter(|_| !range.is_empty()) else { return Ok(()) };
    let scope_first = range.start;
    let [manufacturer, application] = scope_starts(dict);
    let bit = |pos: usize| match pos {
        p if p < manufacturer => Scope::Communication.mask(),
        p if p < application => Scope::Manufacturer.mask(),
        _ => Scope::Application.mask(),
    };
    write_set(dict, image, node_id, storage, bit(scope_first) | bit(scope_last), 0, None, range, 0..0)
}

/// The bytes of the image the RAM values of objects `first..=last` take
/// (the image is in index order, so they are one run).
fn byte_range(dict: &Dictionary, first: u16, last: u16) -> Range<usize> {
    let mut ram = dict.entries.iter().filter(|e| (first..=last).contains(&{ e.index }) && !e.in_rom() && e.len > 0);
    let Some(start) = ram.next().map(|e| e.range()) else { return 0..0 };
    let end = ram.next_back().map_or(start.end, |e| e.range().end);
    start.start..end
}

/// 0x1011 "load": the scope uses its defaults from the next reset on.
pub fn restore_defaults(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    write_set(dict, image, node_id, storage, 0, scope.mask(), None, 0..0, 0..0)
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
    write_set(dict, image, node_id, storage, 0, 0, Some([lss_node_id, bit_rate]), 0..0, 0..0)
}

/// The value of (index, sub) in the newest stored set, copied into the
/// front of `out`, if the set holds one (an entry whose scope was saved);
/// its length. For a device's start-up, before power-on: one value read
/// from the storage, no image built. A read-only entry gives what the
/// image held when the set was saved: a value the device keeps across
/// power cycles itself (an encoder's preset offset), which a reset does not load.
// An entry's range: two u16s, and 24 more fit a usize.
#[allow(clippy::arithmetic_side_effects)]
pub fn stored_value(dict: &Dictionary, storage: &mut dyn Storage, node_id: u8, index: u16, sub: u8, out: &mut [u8]) -> Option<usize> {
    let set = newest(dict, storage)?;
    let entry = dict.find(index, sub).ok()?;
    if entry.in_rom() || set.header.defaults & scope_bit(entry.index) != 0 {
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

#[cfg(test)]
mod tests;
