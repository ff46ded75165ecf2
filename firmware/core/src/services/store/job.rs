//! A store in stages ([`Job`]): the node runs one [`Job::step`] per
//! `process` call, so that no call writes more than [`STAGE`] bytes or
//! checks more than [`CHECK_STAGE`] (docs/firmware.md, "Store and restore
//! in stages").
//!
//! The steps are those of one store, in order: find the newest valid set
//! (its payload's CRC, a piece per step), erase the other region, write the
//! payload (a piece per step, each ending at a value's end, so that every
//! value is taken whole from the image of one step), then the header. A
//! power cut at any step leaves the old set valid until the header of the
//! new one is written, as in one call.

use super::{Finder, HEADER, MAGIC, Scope, StoreError, StoredSet, VERSION, byte_range, crc32_update, in_set, scope_bit};
use crate::od::{Attr, Dictionary};
use crate::storage::Storage;
use core::ops::Range;

/// Payload bytes a step writes at most (a value longer than this goes
/// whole into one step): at most about 9,000 instructions on thumbv7m, for
/// the communication parameters with their many `$NODEID` values, each a
/// run of its own (`cargo xtask icount`, the interop dictionary).
pub const STAGE: usize = 128;
/// Payload bytes a step checks at most (the CRC of the newest set, at a
/// store and at a reset): about 7,000 instructions.
pub const CHECK_STAGE: usize = 4 * STAGE;

/// Where a run of the payload comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    Defaults,
    Image,
    /// The newest valid set.
    Stored,
}

/// Where a [`Job`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Nothing to do (zero bits: a node's job before any store).
    Idle,
    /// Finding the newest valid set (the CRC of its payload).
    Find,
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
    save: u16,
    reset: u16,
    /// A new LSS configuration (node-id, bit-rate table index), if `new_lss`.
    lss: [u8; 2],
    new_lss: bool,
    /// The image bytes the saved scopes take from the image (start, end),
    /// but for those of `keep`, which keep the newest set's.
    from_image: (u16, u16),
    keep: (u16, u16),
    find: Finder,
    /// The newest valid set found, which the new one follows.
    old: Option<StoredSet>,
    /// Payload bytes written, the entry the next step starts from, and the CRC so far.
    pos: u16,
    entry: u16,
    crc: u32,
}

/// A range of the image as a [`Job`] keeps it (images are checked to be below 64 KiB).
fn span(range: core::ops::Range<usize>) -> (u16, u16) {
    (range.start as u16, range.end as u16)
}

impl Job {
    /// No store in progress.
    pub const IDLE: Job = Job {
        phase: Phase::Idle,
        save: 0,
        reset: 0,
        lss: [0; 2],
        new_lss: false,
        from_image: (0, 0),
        keep: (0, 0),
        find: Finder::NEW,
        old: None,
        pos: 0,
        entry: 0,
        crc: 0,
    };

    // Out of line: a job is some 60 bytes, built in one place.
    #[inline(never)]
    const fn new(save: u16, reset: u16, from_image: (u16, u16), keep: (u16, u16)) -> Job {
        Job { phase: Phase::Find, save, reset, from_image, keep, ..Job::IDLE }
    }

    /// 0x1010 "save" of `scope`; the objects `keep` (an inclusive index
    /// range), if any, keep their stored values.
    pub fn save(dict: &Dictionary, scope: Scope, keep: Option<(u16, u16)>) -> Job {
        let keep = keep.map_or((0, 0), |(first, last)| span(byte_range(dict, first, last)));
        Job::new(scope.mask(), 0, (0, u16::MAX), keep)
    }

    /// Stores the objects `first..=last` alone (see [`super::save_objects`]);
    /// [`StoreError::NotStored`] if no set holds a value of them.
    pub fn save_objects(dict: &Dictionary, first: u16, last: u16) -> Result<Job, StoreError> {
        let range = byte_range(dict, first, last);
        if range.is_empty() {
            return Err(StoreError::NotStored);
        }
        Ok(Job::new(scope_bit(first) | scope_bit(last), 0, span(range), (0, 0)))
    }

    /// 0x1011 "load": the scope uses its defaults from the next reset on.
    pub const fn restore(scope: Scope) -> Job {
        Job::new(0, scope.mask(), (0, 0), (0, 0))
    }

    /// LSS "store configuration": the parameters as stored, with a new LSS configuration.
    pub const fn lss(node_id: u8, bit_rate: u8) -> Job {
        Job { lss: [node_id, bit_rate], new_lss: true, ..Job::new(0, 0, (0, 0), (0, 0)) }
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
    // Out of line: the device's stores and the synchronous API share it.
    #[inline(never)]
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
        match self.advance(dict, image, node_id, storage, budget) {
            Ok(false) => None,
            done => {
                self.phase = Phase::Idle;
                Some(done.map(|_| ()))
            }
        }
    }

    /// One step; true when the job is done.
    // `len` is a slice's length (below isize::MAX: 24 more fit).
    #[allow(clippy::arithmetic_side_effects)]
    fn advance(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        budget: usize,
    ) -> Result<bool, StoreError> {
        let len = dict.stored_len;
        match self.phase {
            Phase::Idle => return Ok(true),
            Phase::Find => {
                if HEADER + len > storage.region_size() || len >= usize::from(u16::MAX) {
                    return Err(StoreError::TooLarge);
                }
                if let Some(old) = self.find.step_with(dict, storage, budget.saturating_mul(4)) {
                    (self.old, self.phase) = (old, Phase::Erase);
                }
            }
            Phase::Erase => {
                storage.erase(self.target())?;
                (self.phase, self.crc) = (Phase::Write, !0);
            }
            Phase::Write => {
                if self.write(dict, image, node_id, storage, budget)? {
                    self.write_header(dict, storage)?;
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// The region the new set goes to: the one not holding the newest.
    fn target(&self) -> u8 {
        self.old.map_or(0, |set| set.region ^ 1)
    }

    /// Writes the next whole values, about `budget` bytes of them (at
    /// least one), each from its source: the image for the scopes and
    /// objects saved, the newest set for the others (the defaults where it
    /// marks the scope as default, or where there is none). Adjacent values
    /// from one source go in one run. True once the whole payload is written.
    // `entry` counts entries of a slice.
    #[allow(clippy::arithmetic_side_effects)]
    fn write(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        budget: usize,
    ) -> Result<bool, StoreError> {
        let start = usize::from(self.pos);
        let from_image = self.from_image.0..self.from_image.1;
        let keep = self.keep.0..self.keep.1;
        // The run in hand: its source, its bytes, and the length of the
        // `$NODEID` value it starts with (0: none).
        let mut run = (Source::Defaults, start..start, 0);
        for e in dict.entries.get(usize::from(self.entry)..).unwrap_or(&[]) {
            let r = e.range();
            if in_set(dict, e) && r.end > run.1.end {
                if run.1.end > start && r.end > start.saturating_add(budget) {
                    self.pos = run.1.end as u16;
                    self.copy(dict, image, node_id, storage, run)?;
                    return Ok(false);
                }
                let bit = scope_bit(e.index);
                let source = if self.save & bit != 0 && from_image.contains(&{ e.offset }) && !keep.contains(&{ e.offset }) {
                    Source::Image
                } else if self.old.is_some_and(|set| set.header.defaults & bit == 0) {
                    Source::Stored
                } else {
                    // A scope the newest set marks as default holds stale bytes: a partial save must not revive them.
                    Source::Defaults
                };
                // `$NODEID` values are stored relative to the node-id: each starts a run of its own.
                let relative = if source == Source::Image && e.attr.contains(Attr::NODE_ID) { e.len } else { 0 };
                if source == run.0 && relative == 0 && run.2 == 0 {
                    run.1.end = r.end;
                } else {
                    // The bytes before the value (none in a generated image) go with the run before.
                    run.1.end = r.start;
                    self.copy(dict, image, node_id, storage, run)?;
                    run = (source, r, relative);
                }
            }
            self.entry += 1;
        }
        run.1.end = dict.stored_len;
        self.copy(dict, image, node_id, storage, run)?;
        Ok(true)
    }

    /// Writes a run of the payload from its source, in pieces.
    // `pos` ≤ `range.end`, a payload offset (below 64 KiB: 24 more fit).
    #[allow(clippy::arithmetic_side_effects)]
    fn copy(
        &mut self,
        dict: &Dictionary,
        image: &[u8],
        node_id: u8,
        storage: &mut dyn Storage,
        (source, range, relative): (Source, Range<usize>, u16),
    ) -> Result<(), StoreError> {
        let target = self.target();
        let mut buf = [0u8; 64];
        let mut pos = range.start;
        while pos < range.end {
            let n = (range.end - pos).min(buf.len());
            let piece = buf.get_mut(..n).ok_or(StoreError::TooLarge)?;
            match (source, self.old) {
                (Source::Stored, Some(set)) => storage.read(set.region, HEADER + pos, piece)?,
                // The defaults are stored relative, as the set keeps them.
                _ => {
                    let from = if source == Source::Image { image } else { dict.defaults };
                    piece.copy_from_slice(from.get(pos..pos + n).ok_or(StoreError::TooLarge)?);
                    if pos == range.start
                        && let Some(value) = piece.get_mut(..usize::from(relative))
                    {
                        sub_le(value, node_id);
                    }
                }
            }
            storage.write(target, HEADER + pos, piece)?;
            self.crc = crc32_update(self.crc, piece);
            pos += n;
        }
        Ok(())
    }

    /// The header, last: the new set is valid from here on.
    fn write_header(&self, dict: &Dictionary, storage: &mut dyn Storage) -> Result<(), StoreError> {
        let old = self.old;
        let defaults = (old.map_or(0b111, |set| set.header.defaults) & !self.save) | self.reset;
        let seq = old.map_or(1, |set| set.header.seq.wrapping_add(1));
        // The LSS configuration rides along with every set: a new one or the old one.
        let lss = if self.new_lss { self.lss } else { old.map_or([0xFF, 0xFF], |set| set.header.lss) };
        // Magic, version and LSS, layout id, sequence number, length and default scopes, CRC: little-endian words.
        let words = [
            MAGIC,
            u32::from(VERSION) | u32::from(lss[0]) << 16 | u32::from(lss[1]) << 24,
            dict.layout_id,
            seq,
            dict.stored_len as u32 | u32::from(defaults) << 16,
            !self.crc,
        ];
        let mut h = [0u8; HEADER];
        for (dst, word) in h.chunks_exact_mut(4).zip(words) {
            dst.copy_from_slice(&word.to_le_bytes());
        }
        storage.write(self.target(), 0, &h)?;
        Ok(())
    }
}

/// Subtracts `n` from a little-endian value (a `$NODEID` value stored relative).
fn sub_le(bytes: &mut [u8], n: u8) {
    let mut borrow = u16::from(n);
    for b in bytes.iter_mut() {
        let v = u16::from(*b).wrapping_sub(borrow);
        *b = v as u8;
        borrow = u16::from(v > 0xFF);
    }
}
