//! A store in stages ([`Job`]): the node runs one [`Job::step`] per
//! `process` call, so that no call writes more than [`STAGE`] bytes or
//! checks more than one set (docs/firmware.md, "Store and restore in
//! stages").
//!
//! The steps are those of one store, in order: find the newest valid set
//! (its payload's CRC, [`check`]; the older set's in a step of its own if
//! the newer one is broken), erase the other region, write the
//! payload (a piece per step, each ending at a value's end, so that every
//! value is taken whole from the image of one step), then the header. A
//! power cut at any step leaves the old set valid until the header of the
//! new one is written, as in one call.

use super::{
    HEADER, MAGIC, PIECE, Scope, StoreError, StoredSet, VERSION, crc32_update, entry_scope, in_set, payload_crc, read_header, scope_bit,
};
use crate::od::{Attr, Dictionary, Entry};
use crate::storage::{Storage, StorageError};

/// Payload bytes a step writes at most (a value longer than this goes
/// whole into one step, a piece at a time), each value composed from its
/// source in one walk of the entries that also finds the step's end: the
/// longest step of a store of the interop dictionary is 9,746 thumbv7m
/// instructions (`cargo xtask icount`, round 17; 11,369 with a walk of its
/// own for the step's end, 9,660 with the payload composed span by span).
pub const STAGE: usize = super::PIECE;

/// Where a value of a new set comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    /// The image, as the node holds it now.
    Image,
    /// The dictionary's defaults.
    Defaults,
    /// The newest set: the value read from it on its own.
    Old,
}

/// Where a [`Job`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Nothing to do (zero bits: a node's job before any store).
    Idle,
    /// Finding the newest valid set (the CRC of the newer header's payload).
    Find,
    /// The newer set is broken: checking the older one's payload.
    FindOlder,
    /// Erasing the region not holding it.
    Erase,
    /// Writing the payload, then the header.
    Write,
}

/// A store or restore in progress: what it writes and how far it got. All
/// zero bits when idle ([`Job::IDLE`]), so a node holding one stays in `.bss`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Job {
    phase: Phase,
    /// Scopes saved from the image, and scopes marked as defaults ([`Scope`] bits).
    save: u8,
    reset: u8,
    /// A new LSS configuration (node-id, bit-rate table index), if `new_lss`.
    lss: [u8; 2],
    new_lss: bool,
    /// The objects whose values the saved scopes take from the image: the
    /// indices `first..=first + span`, counted with wrap-around, so that one
    /// such range is also all objects but an inclusive range (the objects a
    /// device keeps: they keep the newest set's values).
    objects: (u16, u16),
    /// Unused: the job's size as it was with a flag here, so that the node's
    /// fields keep their offsets (without it, ds301-lean, which has no
    /// storage, was 24 bytes larger).
    _spare: bool,
    /// The newest valid set found, which the new one follows; [`NO_SET`] if
    /// there is none (set by the find step before any use).
    old: StoredSet,
    /// Unused: the job's size as it was with `old` an `Option` (the node's
    /// fields keep their offsets).
    _pad: [u8; 4],
    /// Payload bytes written so far, and their CRC (kept inverted: `!running`, 0 before the first byte).
    pos: u16,
    crc: u32,
}

/// The set a store follows where no region holds a valid one: every scope
/// default (so no value is taken from it), no LSS configuration, sequence
/// number 0, and in region 1, so that the new set goes to region 0.
const NO_SET: StoredSet = StoredSet { region: 1, defaults: 0b111, lss: [0xFF, 0xFF], seq: 0 };

/// The newest valid set: only the newer header's payload is checked when
/// it is intact (an older set cannot win over it, valid or not). In one
/// call, for [`super::load`] and [`super::stored_value`] (a device's
/// start-up read); a store, a power-on and an NMT reset check a set per
/// step instead.
pub fn newest(dict: &Dictionary, storage: &mut dyn Storage) -> Option<StoredSet> {
    check(dict, storage, false).or_else(|()| check(dict, storage, true)).ok().flatten()
}

/// The set of the newer header (of the older one if `older`) if its
/// payload's CRC holds: `Ok(None)` if there is none, `Err` if the newer
/// set's payload is broken (the older one is then the one to check; a
/// broken older one is none). One CRC over the stored prefix per call:
/// about 10,000 thumbv7m instructions for the interop dictionary's 796
/// bytes, so that a broken newer set costs a second call, not a call twice
/// as long (`cargo xtask icount`, `*-newer-broken`).
pub(crate) fn check(dict: &Dictionary, storage: &mut dyn Storage, older: bool) -> Result<Option<StoredSet>, ()> {
    let (a, b) = (read_header(storage, 0, dict), read_header(storage, 1, dict));
    // Region 1 first if it is newer (sequence numbers compared with wrap-around) or region 0 holds none.
    let b_first = match (&a, &b) {
        (Some(a), Some(b)) => b.0.seq.wrapping_sub(a.0.seq) as i32 > 0,
        (a, _) => a.is_none(),
    };
    let Some((set, crc)) = (if b_first != older { b } else { a }) else { return Ok(None) };
    let valid = payload_crc(storage, set.region, dict.stored_len) == Ok(crc);
    if valid || older { Ok(valid.then_some(set)) } else { Err(()) }
}

impl Job {
    /// No store in progress.
    pub const IDLE: Job = Job {
        phase: Phase::Idle,
        save: 0,
        reset: 0,
        lss: [0; 2],
        new_lss: false,
        objects: (0, 0),
        _spare: false,
        old: StoredSet { region: 0, defaults: 0, lss: [0; 2], seq: 0 },
        _pad: [0; 4],
        pos: 0,
        crc: 0,
    };

    /// Starts `job` in place of this one, which is idle: every field but the
    /// newest set found (`old`), which the job's find step sets before any
    /// use, so that a caller building the job in place stores 12 bytes fewer.
    pub fn begin(&mut self, job: Job) {
        let Job { phase, save, reset, lss, new_lss, objects, pos, crc, .. } = job;
        (self.phase, self.save, self.reset, self.lss, self.new_lss, self.objects, self.pos, self.crc) =
            (phase, save, reset, lss, new_lss, objects, pos, crc);
    }

    const fn new(save: u8, reset: u8, objects: (u16, u16)) -> Job {
        Job { phase: Phase::Find, save, reset, objects, ..Job::IDLE }
    }

    /// 0x1010 "save" of `scope`; the objects `keep` (an inclusive index
    /// range), if any, keep their stored values.
    pub const fn save(scope: Scope, keep: Option<(u16, u16)>) -> Job {
        Job::command(scope, true, keep)
    }

    /// 0x1010 "save" of `scope` (with `save`, as [`Job::save`]) or 0x1011
    /// "load" (as [`Job::restore`]): one job built for either command.
    pub const fn command(scope: Scope, save: bool, keep: Option<(u16, u16)>) -> Job {
        let mask = scope.mask();
        let (save, reset) = if save { (mask, 0) } else { (0, mask) };
        let objects = match keep {
            // Every object kept: only 0x0000, of which no set holds a value.
            Some((0, u16::MAX)) => (0, 0),
            // All objects but those kept: the range after them round to the one before them.
            Some((first, last)) if first <= last => (last.wrapping_add(1), first.wrapping_sub(last).wrapping_sub(2)),
            // None kept: all but 0x0000 (no value a set holds is its).
            _ => (1, u16::MAX - 1),
        };
        Job::new(save, reset, objects)
    }

    /// Stores the objects `first..=last` alone (see [`super::save_objects`]);
    /// [`StoreError::NotStored`] if no set holds a value of them.
    pub fn save_objects(dict: &Dictionary, first: u16, last: u16) -> Result<Job, StoreError> {
        if !dict.entries.iter().any(|e| (first..=last).contains(&{ e.index }) && in_set(dict, e)) {
            return Err(StoreError::NotStored);
        }
        Ok(Job::new(scope_bit(first) | scope_bit(last), 0, (first, last.wrapping_sub(first))))
    }

    /// 0x1011 "load": the scope uses its defaults from the next reset on.
    pub const fn restore(scope: Scope) -> Job {
        Job::new(0, scope.mask(), (0, 0))
    }

    /// LSS "store configuration": the parameters as stored, with a new LSS configuration.
    pub const fn lss(node_id: u8, bit_rate: u8) -> Job {
        Job { lss: [node_id, bit_rate], new_lss: true, ..Job::new(0, 0, (0, 0)) }
    }

    /// Whether the store has steps left.
    pub fn busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The next step: `None` while steps are left, then the result (at
    /// once for an idle job). A failed step ends the job; the old set stays.
    pub fn step(&mut self, dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage) -> Option<Result<(), StoreError>> {
        self.step_with(dict, image, node_id, storage, STAGE)
    }

    /// The whole store in one call.
    // In line (a hint): out of line, each caller copied the 36-byte job
    // into the call's argument (every image 32-48 B larger, the STM32
    // stack estimates 96-192 B deeper).
    #[inline]
    pub fn finish(mut self, dict: &Dictionary, image: &[u8], node_id: u8, storage: &mut dyn Storage) -> Result<(), StoreError> {
        loop {
            if let Some(result) = self.step(dict, image, node_id, storage) {
                return result;
            }
        }
    }

    /// [`Job::step`] with steps of `budget` bytes.
    pub(super) fn step_with(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        budget: usize,
    ) -> Option<Result<(), StoreError>> {
        let result = if self.phase == Phase::Idle {
            Ok(true)
        // The u16 test first: the sum after it cannot wrap (a saturating one costs 4 B a site).
        } else if dict.stored_len >= usize::from(u16::MAX) || HEADER.wrapping_add(dict.stored_len) > storage.region_size() {
            Err(StoreError::TooLarge)
        } else {
            self.advance(dict, image, node_id, storage, budget).map_err(StoreError::Storage)
        };
        match result {
            Ok(false) => None,
            done => {
                self.phase = Phase::Idle;
                Some(done.map(|_| ()))
            }
        }
    }

    /// One step of a busy job; true when the job is done.
    fn advance(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        budget: usize,
    ) -> Result<bool, StorageError> {
        let target = self.old.region ^ 1;
        // Here, not in the write arm alone: there it cost every image with
        // storage 32 B more and no stack (the frame holds it either way).
        let mut buf = [0u8; PIECE];
        match self.phase {
            Phase::Find | Phase::FindOlder => match check(dict, storage, self.phase == Phase::FindOlder) {
                Ok(old) => (self.old, self.phase) = (old.unwrap_or(NO_SET), Phase::Erase),
                Err(()) => self.phase = Phase::FindOlder,
            },
            Phase::Erase => {
                storage.erase(target)?;
                self.phase = Phase::Write;
            }
            _ => {
                let pos = usize::from(self.pos);
                // pos < 65,535 and budget at most STAGE (`step_with` is the module's
                // own, its callers pass STAGE or a test's few bytes): no wrap.
                let limit = pos.wrapping_add(budget);
                let mut at = pos;
                // A piece at a time: one, unless the step is a value longer than a
                // piece (or a gap no value holds). An empty prefix has no payload:
                // no write but the header's.
                let end = if pos >= dict.stored_len {
                    pos
                } else {
                    loop {
                        let (end, whole) = self.compose(dict, image, node_id, storage, at, limit, &mut buf)?;
                        let payload = buf.get(..end.wrapping_sub(at)).unwrap_or(&[]);
                        storage.write(target, at.wrapping_add(HEADER), payload)?;
                        self.crc = !crc32_update(!self.crc, payload);
                        at = end;
                        if whole {
                            break end;
                        }
                    }
                };
                self.pos = end as u16;
                if end == dict.stored_len {
                    storage.write(target, 0, &self.header(dict))?;
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// The new set's payload bytes from `at` into `buf`, value by value from
    /// its source: the image for the scopes and objects saved, the newest set
    /// for the others (the defaults where it marks the scope as default, or
    /// where there is none). A write step takes the values up to `limit`, or
    /// its first value if that is longer. The stored prefix is the set's
    /// values one after the other in the entries' order, so the walk ends at
    /// the step's end. Returns where the bytes end, and whether that is the
    /// step's end (not the buffer's, in a value longer than it).
    #[allow(clippy::too_many_arguments)]
    fn compose(
        &self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        at: usize,
        limit: usize,
        buf: &mut [u8; PIECE],
    ) -> Result<(usize, bool), StorageError> {
        let mut end = at;
        let mut defaults = false;
        for e in dict.entries.iter() {
            let r = e.range();
            // Values before the piece first, the cheapest test (a value not in the set is skipped either way).
            if r.end <= at || !in_set(dict, e) {
                continue;
            }
            // The step ends before a value past the limit, unless it is the first.
            if r.end > limit && end > at {
                return Ok((end, true));
            }
            // The part of the value in the buffer: all of it, unless the value is longer.
            let part = r.start.max(at)..r.end.min(at.wrapping_add(PIECE));
            // A value past the buffer (only the step's first: a later one is past
            // the limit) leaves the buffer a gap's bytes, which the set holds too.
            let Some(dst) = buf.get_mut(part.start.wrapping_sub(at)..part.end.wrapping_sub(at)) else {
                return Ok((at.wrapping_add(PIECE), false));
            };
            end = part.end;
            match self.source(e) {
                Source::Image => {
                    // The source cut to the destination's length: `copy_from_slice`'s length
                    // check folds (no panic, no formatting linked).
                    if let Some(src) = image.get(part.start..).and_then(|src| src.get(..dst.len())) {
                        dst.copy_from_slice(src);
                    }
                    // Stored relative to the node-id: an integer, never longer than a piece.
                    if e.attr.contains(Attr::NODE_ID) {
                        relative(dst, node_id);
                    }
                }
                Source::Old => storage.read(self.old.region, part.start.wrapping_add(HEADER), dst)?,
                // The defaults of the rest of the piece, once (a read walks every
                // default): the values after this one then overwrite theirs.
                _ if !defaults => {
                    if let Some(rest) = buf.get_mut(part.start.wrapping_sub(at)..) {
                        dict.defaults.read(part.start, rest);
                    }
                    defaults = true;
                }
                _ => {}
            }
            if end < r.end {
                return Ok((end, false));
            }
        }
        // No value left: the prefix's bytes after the last one (none in
        // od-gen's layouts, where the values lie back to back) go too, so that
        // the CRC covers the whole prefix as a check reads it.
        let last = dict.stored_len.min(at.wrapping_add(PIECE)).max(end);
        Ok((last, last == dict.stored_len))
    }

    /// Where the value of `e` in the new set comes from.
    fn source(&self, e: &Entry) -> Source {
        let bit = entry_scope(e);
        let (first, span) = self.objects;
        if self.save & bit != 0 && e.index.wrapping_sub(first) <= span {
            Source::Image
        } else if self.old.defaults & bit == 0 {
            Source::Old
        } else {
            // A scope the newest set marks as default holds stale bytes: a partial save must not revive them.
            Source::Defaults
        }
    }

    /// The header, written last: the new set is valid from here on.
    fn header(&self, dict: &Dictionary) -> [u8; HEADER] {
        let old = self.old;
        let defaults = (old.defaults & !self.save) | self.reset;
        let seq = old.seq.wrapping_add(1);
        // The LSS configuration rides along with every set: a new one or the old one.
        let [id, rate] = if self.new_lss { self.lss } else { old.lss };
        // Magic, version and LSS, layout id, sequence number, length and default scopes, CRC: little-endian words.
        let words = [
            MAGIC,
            u32::from_le_bytes([VERSION as u8, (VERSION >> 8) as u8, id, rate]),
            dict.layout_id,
            seq,
            dict.stored_len as u32 | u32::from(defaults) << 16,
            self.crc,
        ];
        let mut h = [0u8; HEADER];
        for (dst, word) in h.chunks_exact_mut(4).zip(words) {
            dst.copy_from_slice(&word.to_le_bytes());
        }
        h
    }
}

/// A `$NODEID` value made relative to the node-id, as a set stores it.
// Out of line: in the piece's composition the loop's registers spilled (8 B more of its frame).
#[inline(never)]
fn relative(value: &mut [u8], node_id: u8) {
    crate::od::add_node_id(value, node_id, true);
}
