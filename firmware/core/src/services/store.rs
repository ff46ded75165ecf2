//! Store and restore parameters: 0x1010 / 0x1011. CiA 301 v4.2 §7.5.2.13–14.
//!
//! A parameter set is the RAM image, written to the [`Storage`] region not
//! holding the newest valid set: erase, payload, then the header last. The
//! header carries a sequence number, the dictionary layout it belongs to and
//! a CRC-32 of the payload, so a power cut at any step leaves either the old
//! set or the new one valid, never a mix.
//!
//! Scopes follow the sub-indices of 0x1010/0x1011: 1 all, 2 communication
//! (0x1000–0x1FFF), 3 application (0x6000–0x9FFF), 4 manufacturer
//! (0x2000–0x5FFF). The image is in index order, so each scope is a byte
//! range. "Restore defaults" writes a set that marks its scopes as default.
//! Only writable entries are taken from a stored set; `$NODEID` entries are
//! stored relative to the node-id, so they follow a node-id change.

use crate::od::{Attr, Dictionary};
use crate::storage::{Storage, StorageError};

/// 0x1010 signature "save" (ASCII, little-endian).
pub const SAVE: u32 = 0x6576_6173;
/// 0x1011 signature "load".
pub const LOAD: u32 = 0x6461_6F6C;

const MAGIC: u32 = 0x5350_4F43; // "COPS"
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

/// Byte ranges of the three areas in the RAM image: comm, manufacturer, application.
fn areas(dict: &Dictionary) -> [core::ops::Range<usize>; 3] {
    let first_ram_offset_from = |index: u16| {
        dict.entries
            .iter()
            .filter(|e| e.index >= index && !e.in_rom() && e.len > 0)
            .map(|e| usize::from(e.offset))
            .next()
            .unwrap_or(dict.defaults.len())
    };
    let manufacturer = first_ram_offset_from(0x2000).max(dict.comm_len);
    let application = first_ram_offset_from(0x6000).max(manufacturer);
    [0..manufacturer, manufacturer..application, application..dict.defaults.len()]
}

/// FNV-1a over the entry table: a set written for another dictionary layout is ignored.
fn layout_id(dict: &Dictionary) -> u32 {
    let mut h: u32 = 0x811C_9DC5;
    for e in dict.entries {
        for b in [e.index.to_le_bytes().as_slice(), &[e.sub, e.data_type as u8, e.attr.0], &e.len.to_le_bytes(), &e.offset.to_le_bytes()] {
            for &x in b {
                h = (h ^ u32::from(x)).wrapping_mul(0x0100_0193);
            }
        }
    }
    h
}

// Out of line: save and load each had a copy of the bit loop.
#[inline(never)]
fn crc32_update(mut crc: u32, data: &[u8]) -> u32 {
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
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

fn read_header(storage: &mut dyn Storage, region: u8, dict: &Dictionary) -> Option<Header> {
    let mut h = [0u8; HEADER];
    storage.read(region, 0, &mut h).ok()?;
    let word = |i: usize| h.get(i..i + 4).and_then(|s| s.try_into().ok()).map(u32::from_le_bytes);
    let half = |i: usize| h.get(i..i + 2).and_then(|s| s.try_into().ok()).map(u16::from_le_bytes);
    if word(0)? != MAGIC || half(4)? != VERSION || word(8)? != layout_id(dict) {
        return None;
    }
    let lss = [*h.get(6)?, *h.get(7)?];
    let header = Header { lss, seq: word(12)?, len: half(16)?, defaults: half(18)?, crc: word(20)? };
    if usize::from(header.len) != dict.defaults.len() {
        return None;
    }
    // The payload must match its CRC, or the write was cut short.
    let mut crc = !0u32;
    let mut buf = [0u8; 32];
    let mut off = 0;
    while off < usize::from(header.len) {
        let n = buf.len().min(usize::from(header.len) - off);
        let chunk = buf.get_mut(..n)?;
        storage.read(region, HEADER + off, chunk).ok()?;
        crc = crc32_update(crc, chunk);
        off += n;
    }
    (!crc == header.crc).then_some(header)
}

/// The region holding the newest valid set, with its header.
fn newest(storage: &mut dyn Storage, dict: &Dictionary) -> Option<(u8, Header)> {
    let a = read_header(storage, 0, dict).map(|h| (0u8, h));
    let b = read_header(storage, 1, dict).map(|h| (1u8, h));
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.1.seq.wrapping_sub(x.1.seq) as i32 > 0 { y } else { x }),
        (x, y) => x.or(y),
    }
}

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
fn write_set(
    dict: &Dictionary,
    image: &[u8],
    node_id: u8,
    storage: &mut dyn Storage,
    save: u16,
    reset: u16,
    lss: Option<[u8; 2]>,
) -> Result<(), StoreError> {
    let len = dict.defaults.len();
    if HEADER + len > storage.region_size() || len > usize::from(u16::MAX) {
        return Err(StoreError::TooLarge);
    }
    let old = newest(storage, dict);
    let target = old.map_or(0, |(r, _)| 1 - r);
    let mut defaults = old.map_or(0b111, |(_, h)| h.defaults);
    defaults = (defaults & !save) | reset;
    let areas = areas(dict);
    storage.erase(target)?;
    let mut crc = !0u32;
    let mut buf = [0u8; 32];
    // RAM offsets follow the entry order, so this walks the payload front to back.
    for e in dict.entries.iter().filter(|e| !e.in_rom() && e.len > 0) {
        let r = e.range();
        let k = areas.iter().position(|a| a.contains(&r.start)).unwrap_or(0);
        let from_image = save & (1 << k) != 0 || old.is_none();
        let mut pos = r.start;
        while pos < r.end {
            let n = buf.len().min(r.end - pos);
            let chunk = buf.get_mut(..n).ok_or(StoreError::TooLarge)?;
            match old {
                Some((region, _)) if !from_image => storage.read(region, HEADER + pos, chunk)?,
                _ => {
                    chunk.copy_from_slice(image.get(pos..pos + n).ok_or(StoreError::TooLarge)?);
                    // `$NODEID` entries (at most 8 bytes, one chunk) are kept relative to the node-id.
                    if e.attr.contains(Attr::NODE_ID) {
                        sub_le(chunk, u64::from(node_id));
                    }
                }
            }
            storage.write(target, HEADER + pos, chunk)?;
            crc = crc32_update(crc, chunk);
            pos += n;
        }
    }
    let seq = old.map_or(1, |(_, h)| h.seq.wrapping_add(1));
    // The LSS configuration rides along with every set: a new one or the old one.
    let lss_bytes = lss.or(old.map(|(_, h)| h.lss)).unwrap_or([0xFF, 0xFF]);
    let [m0, m1, m2, m3] = MAGIC.to_le_bytes();
    let [v0, v1] = VERSION.to_le_bytes();
    let [l0, l1, l2, l3] = layout_id(dict).to_le_bytes();
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
    write_set(dict, image, node_id, storage, scope.mask(), 0, None)
}

/// 0x1011 "load": the scope uses its defaults from the next reset on.
pub fn restore_defaults(dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage, scope: Scope) -> Result<(), StoreError> {
    write_set(dict, image, node_id, storage, 0, scope.mask(), None)
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
    write_set(dict, image, node_id, storage, 0, 0, Some([lss_node_id, bit_rate]))
}

/// The stored LSS configuration (node-id, bit-rate table index), if any.
pub fn load_lss(dict: &Dictionary, storage: &mut dyn Storage) -> Option<(u8, u8)> {
    let (_, header) = newest(storage, dict)?;
    let [id, rate] = header.lss;
    (id != 0xFF || rate != 0xFF).then_some((id, rate))
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
pub fn load(dict: &Dictionary, image: &mut [u8], node_id: u8, storage: &mut dyn Storage, part: Part) -> bool {
    let Some((region, header)) = newest(storage, dict) else { return false };
    let areas = areas(dict);
    let mut used = false;
    for (k, area) in areas.iter().enumerate() {
        let in_part = match part {
            Part::Communication => k == 0,
            Part::Application => k > 0,
        };
        if !in_part || header.defaults & (1 << k) != 0 {
            continue;
        }
        for e in dict.entries.iter().filter(|e| e.attr.contains(Attr::WRITE) && !e.in_rom() && e.len > 0) {
            let r = e.range();
            if r.start < area.start || r.end > area.end {
                continue;
            }
            let mut buf = [0u8; 64];
            let Some(chunk) = buf.get_mut(..r.len()) else { continue };
            if storage.read(region, HEADER + r.start, chunk).is_err() {
                return used;
            }
            if e.attr.contains(Attr::NODE_ID) {
                crate::od::add_le(chunk, u64::from(node_id));
            }
            if let Some(dst) = image.get_mut(r) {
                dst.copy_from_slice(chunk);
                used = true;
            }
        }
    }
    used
}

#[cfg(test)]
mod tests;
