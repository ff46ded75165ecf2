//! Process data objects. CiA 301 v4.2 §7.2.2; objects 0x1400–0x15FF RPDO
//! communication, 0x1600–0x17FF RPDO mapping, 0x1800–0x19FF TPDO
//! communication, 0x1A00–0x1BFF TPDO mapping (§7.5.2.35–§7.5.2.38).
//!
//! Read first: §7.2.2 (transmission types, triggering, inhibit time,
//! event timer), §7.5.2.35–38 (the parameter records and the mapping
//! procedure), §7.2.5 (SYNC, synchronous window).
//!
//! [`Pdos`] caches the parameters at [`Pdos::configure`] (after reset
//! communication) and keeps them in step with the image through
//! [`Pdos::write_object`], which is where an SDO download of a PDO parameter
//! goes. Frames leave through [`PdoTx::send`]; what the node must act on
//! (data written into the dictionary, EMCY conditions) comes out through
//! [`PdoTx::event`].
//!
//! This file holds [`Pdos`] (configuration and the frames in and out);
//! `comm_params` the cached communication record and its rules, `config`
//! what an RPDO and a TPDO have alike (record, mapping: one code path to
//! configure and write either), `write` the SDO downloads of the parameter
//! records, `map` the mappings, `rpdo` and `tpdo` one PDO each.
//!
//! Every call does bounded work: finding an RPDO or TPDO by COB-ID is a
//! walk over the `R` or `T` PDOs, building or applying a PDO copies at most
//! 8 bytes, and the dictionary is searched only when a mapping is configured
//! or written (at most 10 binary searches).
//!
//! Decisions where CiA 301 leaves room, or where the device files ask:
//! - A valid PDO whose mapping count (sub 0) is 0, or whose configured
//!   mapping does not resolve, is disabled: it sends and processes nothing.
//! - The mapping procedure of §7.5.2.36: entries (sub 1..8) may be written
//!   only while sub 0 is 0, and sub 0 only while the PDO is invalid (COB-ID
//!   bit 31). Otherwise the download is aborted with 0x06010000
//!   "unsupported access", the code CiA 310 (conformance test) expects and
//!   CANopenNode returns. Rewriting the current value is always accepted,
//!   so a read-back/write-back of the whole dictionary passes. Where sub 1
//!   is read-only (ec5000 RPDOs), the PDO cannot be invalidated, so sub 0 = 0
//!   alone opens the mapping (docs/devices/ec5000.md, decision 13).
//! - Sub 1 (COB-ID): bits 11..29 set (29-bit identifiers are not supported)
//!   or a restricted CAN-ID (§7.3.5) in a valid COB-ID → 0x06090030; the
//!   CAN-ID may change only while the PDO is or becomes invalid → 0x06090030.
//!   A TPDO of type 252/253 cannot be made "no RTR" (bit 30), nor the reverse.
//! - Sub 2: 241..=251 → 0x06090030; for an RPDO also 252/253.
//! - Sub 3 (inhibit time) and sub 6 (SYNC start value, ≤ 240) change only
//!   while the PDO is invalid → 0x06090030.
//! - On entering Operational, event-driven TPDOs send once (nothing has been
//!   sent yet, so the data "changed"); synchronous acyclic ones on the first
//!   SYNC. Event timers start then.

mod comm_params;
mod config;
pub mod map;
pub mod rpdo;
pub mod tpdo;
mod write;

pub use comm_params::{COB_ID_INVALID, COB_ID_NO_RTR, CommParams};

#[cfg(test)]
mod tests;

use core::marker::PhantomData;

use crate::abort::AbortCode;
use crate::od::{Dictionary, index};
use crate::services::sync::SyncEvent;
use crate::time::{At, Far, NEVER, at, deadline_of};
use crate::wire::emcy::EmcyCode;
use config::{Change, Config};
use map::{Direction, Mapping};
use rpdo::Rpdo;
use tpdo::Tpdo;

/// What the PDOs tell the node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PdoEvent {
    /// RPDO `n` (0-based) wrote its data into the dictionary: event-driven
    /// at once, synchronous at the SYNC.
    Received(usize),
    /// An error condition of RPDO `rpdo` began (a timeout), or a frame of
    /// a wrong length arrived (each one): the node raises EMCY `code` (sent
    /// once while it lasts: 0x8210 too short, 0x8220 too long, 0x8250
    /// timeout) and tells the device.
    Error {
        /// The RPDO (0-based).
        rpdo: usize,
        /// The EMCY error code.
        code: EmcyCode,
    },
    /// That condition ended (a good RPDO arrived): the node clears `code`.
    ErrorCleared {
        /// The RPDO (0-based).
        rpdo: usize,
        /// The EMCY error code.
        code: EmcyCode,
    },
}

/// Where the PDOs put what they produce.
pub trait PdoTx {
    /// Queues a frame; false if the queue refused it (the PDO then retries
    /// at a later poll, see [`tpdo`]).
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool;

    /// Queues a frame of the first `len` (at most 8) of `data`, whose
    /// bytes past `len` are zero (what a TPDO builds), so that a sink can
    /// copy the whole 8 bytes as words. The default calls [`PdoTx::send`].
    fn send_data(&mut self, cob_id: u16, data: &[u8; map::MAX_LEN], len: usize) -> bool {
        self.send(cob_id, data.get(..len).unwrap_or(data))
    }

    /// Queues a frame of what `mapping` maps in `image` (a TPDO's
    /// [`Mapping::build`]), built where the sink keeps it if it can. The
    /// default builds it and calls [`PdoTx::send_data`].
    fn send_mapped(&mut self, cob_id: u16, mapping: &Mapping, image: &[u8]) -> bool {
        let mut data = [0; map::MAX_LEN];
        let len = mapping.build(image, &mut data);
        self.send_data(cob_id, &data, len)
    }

    /// RPDO `n` (0-based) wrote its data ([`PdoEvent::Received`]); the
    /// default reports it through [`PdoTx::event`].
    fn received(&mut self, n: usize) {
        self.event(PdoEvent::Received(n));
    }

    /// An error condition of RPDO `rpdo` began, or a frame of a wrong
    /// length arrived ([`PdoEvent::Error`]); the default reports it
    /// through [`PdoTx::event`].
    fn error(&mut self, rpdo: usize, code: EmcyCode) {
        self.event(PdoEvent::Error { rpdo, code });
    }

    /// That condition ended ([`PdoEvent::ErrorCleared`]); the default
    /// reports it through [`PdoTx::event`].
    fn error_cleared(&mut self, rpdo: usize, code: EmcyCode) {
        self.event(PdoEvent::ErrorCleared { rpdo, code });
    }

    /// Reports an event; the default ignores it.
    fn event(&mut self, event: PdoEvent) {
        let _ = event;
    }
}

/// A mapping of the dictionary that did not resolve at configuration; its PDO stays silent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappingError {
    /// The mapping record (0x1600+n or 0x1A00+n).
    pub index: u16,
    /// Why, as the abort code a download of that mapping would get.
    pub code: AbortCode,
}

/// How the TPDOs of a device treat a change of the mapped data: where its
/// manual makes event-driven types timer-only (the node's
/// `ServiceOptions::tpdo_254_timer_only` and `tpdo_255_timer_only_with_timer`),
/// and whether change detection can be turned off. Constants of the
/// device, so that a device without them links none of the code that asks.
pub trait TpdoRules {
    /// Transmission type 254 is timer-only: sent when the event timer
    /// expires, on a trigger or an RTR; never on a change of the mapped
    /// data or on entering Operational.
    const TYPE_254: bool;
    /// Type 255 is timer-only while its event timer runs (not 0): sent when
    /// the timer expires (or on a trigger or RTR), not on a change of the
    /// mapped data; with event timer 0 a change sends it, as CiA 301 says.
    const TYPE_255_WITH_TIMER: bool;
    /// Whether [`Pdos::set_change_detection`] may turn a TPDO's change
    /// detection off; false where nothing calls it (a node), so that the
    /// PDOs need not ask.
    const SWITCHES_CHANGE_DETECTION: bool;
}

/// CiA 301's reading: types 254 and 255 send on a change of the mapped data too.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cia301;

impl TpdoRules for Cia301 {
    const TYPE_254: bool = false;
    const TYPE_255_WITH_TIMER: bool = false;
    const SWITCHES_CHANGE_DETECTION: bool = true;
}

/// The PDOs of a node: `R` RPDOs and `T` TPDOs (the generated
/// `RPDO_COUNT` and `TPDO_COUNT`), the TPDOs as `P` says ([`TpdoRules`]).
// In this order (`repr(C)`): the TPDOs first (the first one's fields at
// the offsets `Tpdo` keeps short), then the masks and flags that every
// path reads, then the RPDOs' arrays: fewer 4-byte thumbv7m loads and
// stores than the compiler's order (ds301 −56 B; the RPDOs first cost a
// node with TPDOs only 32 B).
#[repr(C)]
#[derive(Clone, Debug)]
pub struct Pdos<const R: usize, const T: usize, P = Cia301> {
    tpdos: [Tpdo; T],
    /// End of the synchronous window opened by the last SYNC; [`Far::NEVER`]:
    /// no window. Read only while Operational ([`Pdos::enter_operational`]
    /// sets it; 0 before is all zero bits).
    window_end: Far,
    /// The last [`Pdos::tpdos_mapping`]: image offset and length
    /// (`offset << 16 | len`, 0: none) and its TPDOs, until a parameter or
    /// a mapping changes (a device sets its statusword with most frames).
    last_write: (u32, u32),
    /// What [`Pdos::poll`] last returned, while `settled`: no PDO changed
    /// since, so [`Pdos::due`] answers without walking them (after every
    /// frame that is not for the PDOs). Every other `&mut self` method
    /// that may change a PDO clears `settled`. Read only while `settled`
    /// (0 before the first poll: all zero bits).
    settled_deadline: At,
    /// Bit n: RPDO n's event timer may be running (only a received RPDO
    /// starts one), so [`Pdos::poll_changed`] walks only those RPDOs, not
    /// every RPDO after every frame. RPDOs past 31 set every bit.
    rpdo_timers: u32,
    /// Bit t: TPDO t has a valid COB-ID and a mapping (it can send), worked
    /// out whenever a parameter or a mapping changes; TPDOs past 31 count
    /// as live. The others are not walked by [`Pdos::poll_changed`].
    tpdo_live: u32,
    /// Bit n: RPDO n is synchronous (only those buffer data for a SYNC).
    /// PDOs past 31 have no bit and are always looked at.
    sync_rpdos: u32,
    /// Bit t: TPDO t is valid and synchronous (types 0..=240 and 252: the
    /// only ones a SYNC does something for), so that a SYNC visits just those.
    sync_tpdos: u32,
    operational: bool,
    settled: bool,
    /// Per RPDO, the frames it takes ([`Rpdo::rx_key`]): in the low 16
    /// bits the CAN-ID it listens to (`NO_KEY`'s 0xFFFF when off), so that
    /// matching a received frame is one compare per RPDO; the whole word is
    /// the key of the frame it takes the plain way (its CAN-ID and length,
    /// [`frame_key`]; with `NOT_PLAIN` set when there is none), so that the
    /// usual frame costs one compare per RPDO and a copy. Kept whenever a
    /// parameter or a mapping changes, and after each frame the general
    /// path handled (which may raise or end a length error).
    rx_keys: [u32; R],
    /// Bit t of entry n: RPDO n writes an object event-driven TPDO t maps,
    /// worked out whenever a mapping or a type changes, so that an RPDO
    /// only makes the TPDOs it can change look for a change.
    rpdo_reach: [u32; R],
    rpdos: [Rpdo; R],
    /// A type, no data (`fn`: `Pdos` is `Send` and `Sync` whatever `P`).
    rules: PhantomData<fn() -> P>,
}

/// All TPDOs (a mask of [`Pdos::poll_changed`]).
pub const ALL_TPDOS: u32 = u32::MAX;

/// `rx_keys` entry of an RPDO that listens to nothing: its low 16 bits are
/// no valid 11-bit id, and it is no frame's key ([`frame_key`] is below 2^24).
const NO_KEY: u32 = u32::MAX;

/// `rx_keys` bit of an RPDO that takes its frames the general way only: no
/// frame's key has it ([`frame_key`] is below 2^24).
const NOT_PLAIN: u32 = 1 << 31;

/// A data frame's key for `rx_keys`: its COB-ID and, from bit 16, its
/// length (capped: a frame longer than 255 bytes matches no RPDO's).
fn frame_key(cob_id: u16, len: usize) -> u32 {
    u32::from(cob_id) | (len.min(0xFF) as u32) << 16
}

impl<const R: usize, const T: usize, P> Default for Pdos<R, T, P> {
    fn default() -> Self {
        Pdos {
            rpdos: [Rpdo::default(); R],
            rx_keys: [NO_KEY; R],
            tpdos: [Tpdo::default(); T],
            window_end: Far::NEVER,
            operational: false,
            settled_deadline: 0,
            settled: false,
            rpdo_reach: [ALL_TPDOS; R],
            rpdo_timers: 0,
            tpdo_live: 0,
            sync_rpdos: 0,
            sync_tpdos: 0,
            last_write: (0, 0),
            rules: PhantomData,
        }
    }
}

impl<const R: usize, const T: usize, P: TpdoRules> Pdos<R, T, P> {
    /// Whether a PDO acts on what a download or its configuration changed
    /// ([`Config::change`](config::Config)) in the walk of
    /// [`Pdos::parameters_changed`], which follows each: with both kinds of
    /// PDO, one store where a download chose the reaction per direction
    /// (and the configuration's and [`Pdos::reload_mappings`]' restarts a
    /// call per PDO). With one kind the
    /// choice is a constant: the PDO acts at once, less code than the walk's test.
    const ACT_IN_WALK: bool = R != 0 && T != 0;

    /// The PDOs before their first [`Pdos::configure`]: stopped, with empty
    /// mappings, and all zero bits ([`crate::node`]; [`Pdos::default`] is
    /// invalid PDOs as a dictionary without
    /// PDO records gives). The `rx_keys` of 0 are NMT's COB-ID, which never
    /// reaches the PDOs, and they do not listen before `configure` anyway.
    pub const fn unconfigured() -> Self {
        Pdos {
            rpdos: [Rpdo::UNCONFIGURED; R],
            // Not `NO_KEY`: all zero bits. Key 0 is an empty frame on COB-ID 0
            // (NMT), which never reaches the PDOs, and they are not Operational before `configure`.
            rx_keys: [0; R],
            tpdos: [Tpdo::UNCONFIGURED; T],
            window_end: Far::ZERO,
            operational: false,
            settled_deadline: 0,
            settled: false,
            rpdo_reach: [0; R],
            rpdo_timers: 0,
            tpdo_live: 0,
            sync_rpdos: 0,
            sync_tpdos: 0,
            last_write: (0, 0),
            rules: PhantomData,
        }
    }

    /// Reads every PDO parameter from the image (after reset communication).
    /// The PDOs stop until [`Pdos::enter_operational`]. `Err` names the first
    /// mapping that did not resolve; every PDO is configured either way.
    pub fn configure(&mut self, dict: &Dictionary, image: &[u8]) -> Result<(), MappingError> {
        let receive = self.configure_rpdos(dict, image);
        let transmit = self.configure_tpdos(dict, image);
        receive.and(transmit)
    }

    /// The RPDO half of [`Pdos::configure`] (a reset does the halves in
    /// separate steps, RPDOs first): the PDOs leave Operational too.
    pub fn configure_rpdos(&mut self, dict: &Dictionary, image: &[u8]) -> Result<(), MappingError> {
        self.configure_half(dict, image, false)
    }

    /// The TPDO half of [`Pdos::configure`].
    pub fn configure_tpdos(&mut self, dict: &Dictionary, image: &[u8]) -> Result<(), MappingError> {
        self.configure_half(dict, image, true)
    }

    /// [`Pdos::configure_tpdos`] if `transmit`, else [`Pdos::configure_rpdos`].
    /// With both kinds of PDO, one loop over either kind's configurations
    /// (through `config_mut`, as a download), each PDO restarted by
    /// [`Pdos::parameters_changed`]'s walk: two loops cost 20 to 24 B more.
    pub(crate) fn configure_half(&mut self, dict: &Dictionary, image: &[u8], transmit: bool) -> Result<(), MappingError> {
        self.settled = false;
        if !transmit {
            // Not the window's end: it is read only while Operational, and
            // `enter_operational` sets it.
            self.operational = false;
        }
        let mut first_error = None;
        if Self::ACT_IN_WALK {
            let (direction, base) = if transmit {
                (Direction::Transmit, index::TPDO_COMMUNICATION_PARAMETER)
            } else {
                // Reset communication also resets the node's errors: nothing
                // is raised any more, nothing buffered, no timer runs.
                self.rpdos = [Rpdo::UNCONFIGURED; R];
                (Direction::Receive, index::RPDO_COMMUNICATION_PARAMETER)
            };
            let mut n = 0;
            while let Some(config) = self.config_mut(direction, usize::from(n)) {
                // From the all-zero configuration (a clear, where the
                // default's `None` mapping was a copy from a constant; a
                // TPDO keeps its other settings, which its restart sets),
                // its mapping resolved in place.
                *config = Config::UNCONFIGURED;
                first_error = first_error.or(config.read(dict, image, nth(base, n), direction));
                // Restarted by `parameters_changed` below.
                config.change = Change::Restart;
                n = nth(n, 1);
            }
        } else if transmit {
            // One kind only: the PDOs act at once.
            for (tpdo, n) in self.tpdos.iter_mut().zip(0u16..) {
                tpdo.unconfigure();
                let comm = nth(index::TPDO_COMMUNICATION_PARAMETER, n);
                first_error = first_error.or(tpdo.config.read(dict, image, comm, Direction::Transmit));
                tpdo.restart::<P>(None);
            }
        } else {
            for (rpdo, n) in self.rpdos.iter_mut().zip(0u16..) {
                *rpdo = Rpdo::UNCONFIGURED;
                let comm = nth(index::RPDO_COMMUNICATION_PARAMETER, n);
                first_error = first_error.or(rpdo.config.read(dict, image, comm, Direction::Receive));
            }
        }
        // What each RPDO reaches depends on the TPDOs' mappings.
        self.parameters_changed();
        first_error.map_or(Ok(()), Err)
    }

    /// Takes each PDO's mapping from the image again (where a device lets
    /// mapping entries change while the PDO is valid, they apply on entering
    /// Operational).
    pub fn reload_mappings(&mut self, dict: &Dictionary, image: &[u8]) {
        self.settled = false;
        // A mapping that does not resolve leaves the PDO's as it was.
        for (rpdo, n) in self.rpdos.iter_mut().zip(0u16..) {
            let mut mapping = Mapping::EMPTY;
            if mapping.read_record(dict, image, nth(index::RPDO_MAPPING_PARAMETER, n), Direction::Receive).is_ok() {
                (rpdo.config.mapping, rpdo.config.unresolved, rpdo.config.change) = (mapping, false, Change::Restart);
                if !Self::ACT_IN_WALK {
                    rpdo.act();
                }
            }
        }
        for (tpdo, n) in self.tpdos.iter_mut().zip(0u16..) {
            let mut mapping = Mapping::EMPTY;
            if mapping.read_record(dict, image, nth(index::TPDO_MAPPING_PARAMETER, n), Direction::Transmit).is_ok() {
                (tpdo.config.mapping, tpdo.config.unresolved, tpdo.config.change) = (mapping, false, Change::Restart);
                if !Self::ACT_IN_WALK {
                    tpdo.act::<P>();
                }
            }
        }
        self.parameters_changed();
    }

    /// NMT entered Operational: the PDOs start (see the module notes).
    pub fn enter_operational(&mut self, now: At) {
        self.settled = false;
        self.operational = true;
        self.window_end = Far::NEVER;
        self.rpdos.iter_mut().for_each(Rpdo::restart);
        self.tpdos.iter_mut().for_each(|t| t.restart::<P>(Some(now)));
    }

    /// NMT left Operational: the PDOs stop; frames, RTRs and SYNCs are ignored.
    pub fn stop(&mut self) {
        // `settled` is read only while Operational; `enter_operational` clears it.
        self.operational = false;
    }

    /// Whether the PDOs run.
    pub fn is_operational(&self) -> bool {
        self.operational
    }

    /// RPDO `n` (0-based).
    pub fn rpdo(&self, n: usize) -> Option<&Rpdo> {
        self.rpdos.get(n)
    }

    /// TPDO `n` (0-based).
    pub fn tpdo(&self, n: usize) -> Option<&Tpdo> {
        self.tpdos.get(n)
    }

    /// Signals an application event for TPDO `n` (types 0, 254, 255); false
    /// if that TPDO is not valid or of another type. Call [`Pdos::poll`] after.
    pub fn trigger(&mut self, n: usize) -> bool {
        self.settled = false;
        self.tpdos.get_mut(n).is_some_and(Tpdo::trigger)
    }

    /// Turns change-of-state detection of TPDO `n` on or off (on by default),
    /// for rules `P` that switch it ([`TpdoRules::SWITCHES_CHANGE_DETECTION`]):
    /// a call with rules that never switch it (a node's) does not compile.
    /// Off, only the event timer, [`Pdos::trigger`] and RTRs send it; for
    /// values that change all the time, such as an encoder position.
    pub fn set_change_detection(&mut self, n: usize, on: bool) {
        const { assert!(P::SWITCHES_CHANGE_DETECTION, "these TpdoRules never switch change detection") };
        self.settled = false;
        if let Some(t) = self.tpdos.get_mut(n) {
            t.set_change_detection(on);
        }
    }

    /// Works out again what the PDOs' parameters and mappings imply: the
    /// CAN-IDs the RPDOs listen to, the TPDOs each RPDO reaches, and which
    /// PDOs a SYNC has work for; the last [`Pdos::tpdos_mapping`] is
    /// forgotten. Every change of a parameter or a mapping ends here.
    // Out of line: configure and write_object each had a copy (100 bytes more).
    #[inline(never)]
    fn parameters_changed(&mut self) {
        self.last_write = (0, 0);
        // One walk over each kind of PDO, every mask at once.
        let (mut live, mut sync_tpdos) = (0, 0);
        for (t, tpdo) in self.tpdos.iter_mut().enumerate() {
            if Self::ACT_IN_WALK {
                tpdo.act::<P>();
            }
            if tpdo.cob_id().is_some() {
                live |= bit_of(t);
                if tpdo.is_synchronous() {
                    sync_tpdos |= low_bit(t);
                }
            }
        }
        let mut sync_rpdos = 0;
        for (n, (key, (reach, rpdo))) in self.rx_keys.iter_mut().zip(self.rpdo_reach.iter_mut().zip(&mut self.rpdos)).enumerate() {
            if Self::ACT_IN_WALK {
                rpdo.act();
            }
            *key = rpdo.rx_key();
            if rpdo.config.params.is_synchronous() {
                sync_rpdos |= low_bit(n);
            }
            // Byte by byte from the gather table (its constants and unused
            // bytes are no image byte): the TPDOs mapping any byte it writes.
            *reach = rpdo.config.mapping.ram_bytes().fold(0, |mask, offset| mask | tpdos_mapping(&self.tpdos, live, offset, 1));
        }
        (self.tpdo_live, self.sync_tpdos, self.sync_rpdos) = (live, sync_tpdos, sync_rpdos);
    }

    /// The event-driven TPDOs that map any byte of `len` image bytes at
    /// `offset` (what a write there may change).
    /// Answered from the last call if it asked for the same bytes and no
    /// parameter or mapping changed since.
    // In line, the remembered answer (a device sets its statusword with
    // most frames): one compare; the walk is out of line.
    #[inline(always)]
    pub fn tpdos_mapping(&mut self, offset: u16, len: u16) -> u32 {
        // One compare: offset and length in one word (0: none; no write is of 0 bytes).
        let key = u32::from(offset) << 16 | u32::from(len);
        if self.last_write.0 != key {
            self.last_write = (key, tpdos_mapping(&self.tpdos, self.tpdo_live, offset, len));
        }
        self.last_write.1
    }

    /// The event-driven TPDOs the RPDOs of `rpdos` (bit n: RPDO n) write
    /// to: those a [`Pdos::poll_changed`] after those RPDOs must look at.
    /// The TPDOs waiting to retry ([`Pdos::retrying`]) are the caller's to
    /// add, only if nothing else makes the next poll run (a poll for any
    /// TPDO retries every one waiting to).
    // Left to the inliner since round 15: in line in the SYNC path it costs
    // that row 9 instructions (874 → 883) and saves 24 B on every image with PDOs.
    pub fn reaches(&self, rpdos: u32) -> u32 {
        let mut mask = 0;
        let mut bits = rpdos;
        while bits != 0 {
            mask |= self.rpdo_reach.get(bits.trailing_zeros() as usize).copied().unwrap_or(ALL_TPDOS);
            bits &= bits.wrapping_sub(1); // clears the lowest set bit (bits != 0)
        }
        mask
    }

    /// The TPDOs waiting to retry a refused frame.
    pub fn retrying(&self) -> u32 {
        retry_mask(&self.tpdos)
    }

    /// A data frame on `cob_id`: true if it belongs to a valid RPDO (then it
    /// is processed, or buffered for the SYNC). Ignored unless Operational.
    pub fn on_frame(&mut self, now: At, cob_id: u16, data: &[u8], image: &mut [u8], out: &mut impl PdoTx) -> bool {
        self.on_frame_reaching(now, cob_id, data, image, out).is_some()
    }

    /// [`Pdos::on_frame`], with the event-driven TPDOs whose mapped data
    /// the frame wrote (its RPDO's [`Pdos::reaches`]; 0 when it wrote
    /// nothing now: a length error, or data that waits for the SYNC);
    /// `None` when no RPDO took it. The node marks those TPDOs without
    /// asking again.
    pub(crate) fn on_frame_reaching(&mut self, now: At, cob_id: u16, data: &[u8], image: &mut [u8], out: &mut impl PdoTx) -> Option<u32> {
        if !self.operational {
            return None;
        }
        let window_open = !self.window_end.passed(now);
        let n = self.rx_keys.iter().position(|&key| key as u16 == cob_id)?;
        let rpdo = self.rpdos.get_mut(n)?;
        let written = rpdo.on_frame(n, now, data, window_open, image, out);
        // A length error raised or ended changes whether the next frame is plain.
        if let Some(key) = self.rx_keys.get_mut(n) {
            *key = rpdo.rx_key();
        }
        if let Some(timeout) = rpdo.timeout_at() {
            self.rpdo_timers |= bit_of(n);
            // Only this RPDO's timeout moved, and only later (or it started):
            // the settled deadline stays good, or early, which is harmless.
            self.settled_deadline = self.settled_deadline.min(timeout);
        }
        Some(if written { self.rpdo_reach.get(n).copied().unwrap_or(ALL_TPDOS) } else { 0 })
    }

    /// The usual RPDO frame, for the node's short path: of its RPDO's
    /// mapped length, for an event-driven RPDO without an event timer and
    /// with no length or timeout error raised ([`Rpdo::rx_key`]). For it
    /// [`Pdos::on_frame_reaching`] would only write the data and report
    /// the RPDO received; this writes it and returns the RPDO and its reach
    /// (for the caller to report), or `None` for every other frame (which
    /// then takes [`Pdos::on_frame_reaching`]). Not Operational: `None`.
    #[inline(always)]
    pub(crate) fn on_plain_frame(&self, cob_id: u16, data: &[u8], image: &mut [u8]) -> Option<(usize, u32)> {
        if !self.operational {
            return None;
        }
        let key = frame_key(cob_id, data.len());
        let n = self.rx_keys.iter().position(|&k| k == key)?;
        self.rpdos.get(n)?.config.mapping.apply_in_line(image, data);
        Some((n, self.rpdo_reach.get(n).copied().unwrap_or(ALL_TPDOS)))
    }

    /// A remote frame on `cob_id`: true if a TPDO answered it (or will, once
    /// its inhibit time is over). Ignored unless Operational.
    pub fn on_rtr(&mut self, now: At, cob_id: u16, image: &[u8], tx: &mut impl PdoTx) -> bool {
        if !self.operational {
            return false;
        }
        let Some(tpdo) = self.tpdos.iter_mut().find(|t| t.cob_id() == Some(cob_id)) else { return false };
        self.settled = false;
        tpdo.on_rtr::<P>(now, cob_id, image, tx)
    }

    /// A SYNC, received or produced: synchronous RPDO data is written, then
    /// synchronous TPDOs are sent. Ignored unless Operational.
    pub fn on_sync(&mut self, sync: &SyncEvent, image: &mut [u8], tx: &mut impl PdoTx) {
        if !self.operational {
            return;
        }
        // No deadline moves: synchronous TPDOs have none, and a refused
        // frame is retried at the next change ([`Pdos::retrying`]).
        self.window_end = sync.window_end;
        // Only the synchronous PDOs, in order (those past 31 always).
        let mut bits = self.sync_rpdos;
        while let Some(n) = next_bit(&mut bits) {
            if let Some(rpdo) = self.rpdos.get_mut(n) {
                rpdo.on_sync(n, image, tx);
            }
        }
        for (n, rpdo) in self.rpdos.iter_mut().enumerate().skip(32) {
            rpdo.on_sync(n, image, tx);
        }
        // `sync_tpdos` holds only valid synchronous TPDOs: no check each SYNC.
        let mut bits = self.sync_tpdos;
        while let Some(t) = next_bit(&mut bits) {
            if let Some(tpdo) = self.tpdos.get_mut(t) {
                tpdo.on_sync::<P>(sync, image, tx);
            }
        }
        for tpdo in self.tpdos.iter_mut().skip(32).filter(|t| t.is_synchronous()) {
            tpdo.on_sync::<P>(sync, image, tx);
        }
    }

    /// Runs the timers (event timers, inhibit times, RPDO deadlines), change
    /// detection and retries; returns the next deadline. Call it when that
    /// deadline is reached and after the application changed mapped objects.
    pub fn poll(&mut self, now: At, image: &[u8], tx: &mut impl PdoTx) -> Option<At> {
        self.poll_changed(now, ALL_TPDOS, image, tx)
    }

    /// [`Pdos::poll`] where only the TPDOs of `changed` (bit t: TPDO t;
    /// TPDOs past 31 always) may see changed data: the others are looked
    /// at only when a timer of theirs is due or they wait to retry.
    pub fn poll_changed(&mut self, now: At, changed: u32, image: &[u8], tx: &mut impl PdoTx) -> Option<At> {
        deadline_of(self.poll_marked(now, changed, image, tx))
    }

    /// [`Pdos::poll_changed`]: `marked` holds the TPDOs that may see
    /// changed data; a TPDO waiting to retry a refused frame is polled
    /// whether marked or not (a field it holds: no walk for them first).
    /// The deadline as an [`At`].
    // Left to the inliner: out of line it cost 16 / 36 B on the references
    // and no instruction on a row (round 15).
    pub fn poll_marked(&mut self, now: At, marked: u32, image: &[u8], tx: &mut impl PdoTx) -> At {
        if !self.operational {
            return NEVER;
        }
        // The earliest deadline, folded as the PDOs are visited: a TPDO
        // polled is asked again, one that was not keeps the deadline it
        // was checked against (no PDO's poll moves another's).
        let mut first = NEVER;
        if self.rpdo_timers != 0 {
            let mut timers = 0;
            for (n, rpdo) in self.rpdos.iter_mut().enumerate() {
                rpdo.poll(n, now, tx);
                if rpdo.timeout_at().is_some() {
                    timers |= bit_of(n);
                }
                first = first.min(at(rpdo.timeout_at()));
            }
            self.rpdo_timers = timers;
        }
        if T <= 32 {
            // Only the TPDOs that can send, each bit a TPDO.
            let mut bits = self.tpdo_live;
            while let Some(t) = next_bit(&mut bits) {
                if let Some(tpdo) = self.tpdos.get_mut(t) {
                    // A marked TPDO, or one waiting to retry, counts as due now (0).
                    let mut due = if marked & bit_of(t) != 0 || tpdo.retrying() { 0 } else { tpdo.due() };
                    if due <= now {
                        tpdo.poll::<P>(now, self.window_end, image, tx);
                        due = tpdo.due();
                    }
                    first = first.min(due);
                }
            }
        } else {
            for (t, tpdo) in self.tpdos.iter_mut().enumerate() {
                let bit = bit_of(t);
                if tpdo.cob_id().is_some() {
                    let mut due = if marked & bit != 0 || bit == u32::MAX || tpdo.retrying() { 0 } else { tpdo.due() };
                    if due <= now {
                        tpdo.poll::<P>(now, self.window_end, image, tx);
                        due = tpdo.due();
                    }
                    first = first.min(due);
                }
            }
        }
        self.settled_deadline = first;
        self.settled = true;
        first
    }

    /// Whether an RPDO's event timer may run: only then does a received RPDO
    /// move [`Pdos::settled`]'s deadline.
    pub fn rpdo_timers(&self) -> bool {
        self.rpdo_timers != 0
    }

    /// [`Pdos::due`] when it is known without walking the PDOs.
    pub fn settled(&self) -> Option<At> {
        (self.settled || !self.operational).then_some(if self.operational { self.settled_deadline } else { NEVER })
    }

    /// When [`Pdos::poll`] next has work (a soft deadline; 0 means at
    /// once). `None` while not Operational.
    pub fn deadline(&self) -> Option<At> {
        deadline_of(self.due())
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        self.rpdos.iter_mut().for_each(|r| r.shift(by));
        self.tpdos.iter_mut().for_each(|t| t.shift(by));
        self.window_end.shift(by);
        // The settled deadline is walked again.
        self.settled = false;
    }

    /// [`Pdos::deadline`] as an [`At`].
    pub fn due(&self) -> At {
        if !self.operational {
            return NEVER;
        }
        if self.settled { self.settled_deadline } else { self.walk() }
    }

    /// The PDOs' earliest deadline, walked: only the RPDOs whose timer may
    /// run and the TPDOs that can send have one.
    fn walk(&self) -> At {
        let mut first = NEVER;
        if self.rpdo_timers != 0 {
            first = self.rpdos.iter().fold(first, |d, r| d.min(at(r.timeout_at())));
        }
        if T <= 32 {
            let mut bits = self.tpdo_live;
            while let Some(t) = next_bit(&mut bits) {
                if let Some(tpdo) = self.tpdos.get(t) {
                    first = first.min(tpdo.due());
                }
            }
        } else {
            for tpdo in self.tpdos.iter().filter(|t| t.cob_id().is_some()) {
                first = first.min(tpdo.due());
            }
        }
        first
    }
}

/// Bit n of the PDO masks; PDOs past 31 share every bit (each is then always looked at).
fn bit_of(n: usize) -> u32 {
    1u32.checked_shl(n as u32).unwrap_or(u32::MAX)
}

/// Object `base` + `n`: PDO `n`'s (0-based) parameter record.
// Fewer than 512 PDOs of a kind (0x1400..=0x15FF and the like): the index fits.
#[allow(clippy::arithmetic_side_effects)]
const fn nth(base: u16, n: u16) -> u16 {
    base + n
}

/// [`Pdos::tpdos_mapping`] (a free function: it runs while the RPDOs are borrowed).
// Two u16s: the sum fits a u32.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
fn tpdos_mapping(tpdos: &[Tpdo], live: u32, offset: u16, len: u16) -> u32 {
    let (start, end) = (u32::from(offset), u32::from(offset) + u32::from(len));
    let mut mask = 0;
    for (t, tpdo) in tpdos.iter().enumerate() {
        // A TPDO that cannot send is not polled ([`Pdos::poll_changed`]): no need to look.
        let bit = 1u32.checked_shl(t as u32).unwrap_or(0);
        if live & bit != 0 && tpdo.maps_any(start, end) {
            mask |= bit;
        }
    }
    // TPDOs past 31 have no bit: they are always looked at.
    if tpdos.len() > 32 { mask | ALL_TPDOS } else { mask }
}

/// Bit n of the masks that PDOs past 31 are not in (they have no bit).
fn low_bit(n: usize) -> u32 {
    1u32.checked_shl(n as u32).unwrap_or(0)
}

/// The lowest set bit of `bits`, cleared.
fn next_bit(bits: &mut u32) -> Option<usize> {
    let n = bits.trailing_zeros() as usize;
    *bits &= bits.wrapping_sub(1);
    (n < 32).then_some(n)
}

/// Bit t: TPDO t waits to retry.
fn retry_mask(tpdos: &[Tpdo]) -> u32 {
    // TPDOs past 31 have no bit (they are always looked at).
    tpdos.iter().take(32).enumerate().fold(0, |mask, (t, tpdo)| mask | u32::from(tpdo.retrying()) << t)
}
