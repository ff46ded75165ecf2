//! The communication services of a node and their configuration from the
//! communication area of the dictionary (0x1000–0x1FFF).

use core::marker::PhantomData;
use core::ops::{Deref, DerefMut};

use super::Application;
use super::app::OptionsOf;
use crate::abort::AbortCode;
use crate::od::index;
use crate::od::{Dictionary, Entry, ObjectDictionary, object, value_u32};
use crate::services::emcy::EmcyProducer;
use crate::services::heartbeat::{Consumer, Guarding, Producer};
use crate::services::pdo::map::Mapping;
use crate::services::pdo::{Cia301, Pdos, TpdoRules};
use crate::services::sync::SyncService;
use crate::time::At;
use crate::wire::emcy::EmcyCode;
use crate::wire::sync::SYNC_COB_ID;

/// (index, sub) as an integer, `default` if the dictionary lacks it.
pub(super) fn u32_of(dict: &Dictionary, image: &[u8], index: u16, sub: u8, default: u32) -> u32 {
    dict.read_u32(image, index, sub).unwrap_or(default)
}

/// The objects reset communication applies as a download would (sub 0 of
/// each). One the dictionary lacks counts as 0, but 0x1005 as the
/// pre-defined SYNC COB-ID and 0x1014 as EMCY off.
// Those two first: their defaults by position (0x80, then 0x80 << 24), a
// shift where a match on the index took two compares. Each service's objects keep
// their order (SYNC's COB-ID before its period; guarding before the
// heartbeat that disarms it).
static CONFIGURED: [u16; 10] = [
    index::COB_ID_SYNC,
    index::COB_ID_EMCY,
    index::INHIBIT_TIME_EMCY,
    index::GUARD_TIME,
    index::LIFE_TIME_FACTOR,
    index::PRODUCER_HEARTBEAT_TIME,
    index::COB_ID_TIME_STAMP,
    index::COMMUNICATION_CYCLE_PERIOD,
    index::SYNCHRONOUS_WINDOW_LENGTH,
    index::SYNCHRONOUS_COUNTER_OVERFLOW,
];

/// Active errors and queued EMCY messages a node keeps.
pub const EMCY_SLOTS: usize = 8;

/// What 0x1029 sub 1 asks for on a communication error (CiA 301 §7.5.2.32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorBehaviour {
    /// 0: enter Pre-operational (if Operational).
    PreOperational,
    /// 1: no state change.
    NoChange,
    /// 2: enter Stopped.
    Stopped,
}

/// The communication services and the identifiers they use.
#[derive(Clone, Debug)]
// The small services and flags first, the consumers' and the PDOs' arrays last: shorter offsets on thumbv7m.
#[repr(C)]
pub struct Comm<const R: usize, const T: usize, const HB: usize, P = Cia301> {
    /// TIME consumer COB-ID, if 0x1012 bit 31 (consume) is set.
    pub time_cob_id: Option<u16>,
    /// The RPDOs' mapping failed at this reset (counted with the TPDOs').
    rpdo_mapping_failed: bool,
    /// Resets communication at which a PDO mapping did not resolve (counted
    /// once each, at its TPDOs' stage; wrapping, as [`super::Counters`]).
    pub mapping_errors: u32,
    /// Heartbeat producer (0x1017).
    pub heartbeat: Producer,
    /// SYNC consumer and producer (0x1005–0x1007, 0x1019).
    pub sync: SyncService,
    /// Node and life guarding (0x100C, 0x100D).
    pub guarding: Guarding,
    /// EMCY producer (0x1014, 0x1015) and the error register.
    pub emcy: EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>,
    /// Heartbeat consumer (0x1016).
    pub consumers: Consumer<HB>,
    /// RPDOs and TPDOs (0x1400–0x1BFF), the TPDOs as `P` says ([`TpdoRules`]).
    pub pdos: Pdos<R, T, P>,
}

impl<const R: usize, const T: usize, const HB: usize, P: TpdoRules> Default for Comm<R, T, HB, P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const R: usize, const T: usize, const HB: usize, P: TpdoRules> Comm<R, T, HB, P> {
    /// The services before the first reset communication configures them:
    /// all off, and all zero bits ([`crate::node`]).
    pub const fn new() -> Self {
        Comm {
            heartbeat: Producer::new(),
            consumers: Consumer::new(),
            guarding: Guarding::new(),
            emcy: EmcyProducer::new(),
            time_cob_id: None,
            sync: SyncService::UNCONFIGURED,
            pdos: Pdos::unconfigured(),
            mapping_errors: 0,
            rpdo_mapping_failed: false,
        }
    }

    /// The epoch moved by `by` µs ([`crate::time`]). `guarding`: whether
    /// the node links node guarding (without, its deadline is never armed).
    pub(crate) fn shift(&mut self, by: u64, guarding: bool) {
        self.heartbeat.shift(by);
        self.consumers.shift(by);
        if guarding {
            self.guarding.shift(by);
        }
        self.emcy.shift(by);
        self.sync.shift(by);
        self.pdos.shift(by);
    }

    /// Configures the RPDOs (`transmit` false) or the TPDOs from the image
    /// (after reset communication: the RPDOs first). A mapping that does not
    /// resolve leaves its PDO disabled and counts once per reset in
    /// `mapping_errors` (with the TPDOs: one test and one store where
    /// counting at either half took ds301 16 B more), for tools and tests.
    pub fn configure_pdos(&mut self, dict: &Dictionary, image: &[u8], transmit: bool) {
        let failed = self.pdos.configure_half(dict, image, transmit).is_err();
        if !transmit {
            self.rpdo_mapping_failed = failed;
        } else if failed || self.rpdo_mapping_failed {
            self.mapping_errors = self.mapping_errors.wrapping_add(1);
        }
    }

    /// What 0x1029 sub 1 says to do on a communication error.
    pub fn error_behaviour(dict: &Dictionary, image: &[u8]) -> ErrorBehaviour {
        Self::error_behaviour_of(dict, image, 1)
    }

    /// What 0x1029 sub `class` says to do on an error of that class (1
    /// communication, 2 device profile, 3 manufacturer specific).
    // Read as the other communication parameters are (`read_u32`, whose
    // `Dictionary::read` then has no caller of its own in the references:
    // ds301 46 B, ds301-lean 38 B less). Its entries are UNSIGNED8 (CiA 301
    // §7.5.2.32); one of another type (which od-gen does not refuse) now
    // reads as its value, where only a one-byte 1 or 2 counted before.
    pub fn error_behaviour_of(dict: &Dictionary, image: &[u8], class: u8) -> ErrorBehaviour {
        match dict.read_u32(image, index::ERROR_BEHAVIOUR, class) {
            Some(1) => ErrorBehaviour::NoChange,
            Some(2) => ErrorBehaviour::Stopped,
            _ => ErrorBehaviour::PreOperational,
        }
    }

    /// Records a sent EMCY (its data bytes, [`crate::wire::emcy::Emcy::emit`]): 0x1001 and,
    /// for an error, a new 0x1003 entry (newest at sub 1).
    // Out of line: `process_emcy` had it in line around its queue loop, and
    // its registers cost more than the call.
    #[inline(never)]
    pub fn record(&mut self, dict: &Dictionary, image: &mut [u8], e: &[u8; 8]) {
        let [c0, c1, register, i0, i1, ..] = *e;
        let code = EmcyCode(u16::from_le_bytes([c0, c1]));
        // An error still active: the register as it is now, not as it was when the
        // message was queued (an error cleared since, without a message, has left it).
        let register = if self.emcy.is_active(code) { self.emcy.register() } else { register };
        let _ = dict.write_unchecked(image, index::ERROR_REGISTER, 0, &[register]);
        if code == EmcyCode::NO_ERROR {
            return;
        }
        // The record's entries found once, sorted by sub-index with unique keys
        // (as every dictionary's): sub 0 is the first if the record has it.
        let record = object(dict, index::PRE_DEFINED_ERROR_FIELD);
        let Some((count, subs)) = record.split_first().filter(|(e, _)| e.sub == 0) else { return };
        // Every entry but sub 0 (`subs`).
        let capacity = subs.len().min(254) as u8;
        // Its first byte (an UNSIGNED8; 0 if empty), by the call the walk makes anyway.
        let used = value_u32(dict, image, count) as u8;
        // The newest at sub 1, each older one a sub-index on (the 32-bit entries
        // of CiA 301 §7.5.2.4: the error code, then the first 2 bytes of the
        // manufacturer-specific field). One `u32` carried down the record in a
        // register (4 bytes apart: ds301 12 B more).
        let mut carry = u32::from_le_bytes([c0, c1, i0, i1]);
        // One more than the count, at most the capacity (a count above it is cut).
        let len = used.saturating_add(1).min(capacity);
        // Sub-indices 1..=len: sub k is at position k while none before it is
        // missing; the walk ends at the first one missing, as a search for each would.
        // The positions zipped with `subs` (no bound check of their own per
        // step), as a `Range` of `usize` (an inclusive range keeps a flag of
        // its end). `len` is a `u8`: one more fits.
        #[allow(clippy::arithmetic_side_effects)]
        let end = usize::from(len) + 1;
        for (k, entry) in (1..end).zip(subs) {
            if usize::from(entry.sub) != k {
                break;
            }
            let older = value_u32(dict, image, entry);
            let _ = dict.write_unchecked_entry(image, entry, &carry.to_le_bytes());
            carry = older;
        }
        let _ = dict.write_unchecked_entry(image, count, &[len]);
    }

    /// The service that owns (index, sub) takes the `value` just stored
    /// ([`Services::apply`], its one caller). `guarding`: whether the node
    /// links node guarding (without, the guarding stays unconfigured).
    #[inline(always)]
    fn apply(&mut self, index: u16, sub: u8, value: u32, now: At, guarding: bool) {
        match index {
            // Sub 0 is no consumer's: its position wraps past them all.
            index::CONSUMER_HEARTBEAT_TIME => self.consumers.configure(usize::from(sub).wrapping_sub(1), value),
            // Each with its index a constant: SYNC's own match folds into this one.
            index::COB_ID_SYNC => self.sync.apply(index::COB_ID_SYNC, value),
            index::COMMUNICATION_CYCLE_PERIOD => self.sync.apply(index::COMMUNICATION_CYCLE_PERIOD, value),
            index::SYNCHRONOUS_WINDOW_LENGTH => self.sync.apply(index::SYNCHRONOUS_WINDOW_LENGTH, value),
            index::SYNCHRONOUS_COUNTER_OVERFLOW => self.sync.apply(index::SYNCHRONOUS_COUNTER_OVERFLOW, value),
            index::PRODUCER_HEARTBEAT_TIME => {
                self.heartbeat.configure(value as u16, now);
                if guarding && self.heartbeat.active() {
                    // Heartbeat replaces guarding (CiA 301 §7.2.8.3.2): no life guarding either.
                    self.guarding.disarm();
                }
            }
            index::COB_ID_TIME_STAMP => self.time_cob_id = (value & 0x8000_0000 != 0).then_some((value & 0x7FF) as u16),
            // The value as written: the service keeps each object's part.
            index::GUARD_TIME if guarding => self.guarding.set_guard_time(value as u16),
            index::LIFE_TIME_FACTOR if guarding => self.guarding.set_life_time_factor(value as u8),
            index::COB_ID_EMCY => self.emcy.set_cob_id(value),
            index::INHIBIT_TIME_EMCY => self.emcy.set_inhibit(value as u16),
            // Nothing for an object no service uses.
            _ => {}
        }
    }

    /// 0x1003 sub 0 ← 0: the history is empty.
    pub fn clear_history(&mut self, dict: &Dictionary, image: &mut [u8]) {
        clear_history(dict, image);
    }
}

/// [`Comm::clear_history`], which needs no service: a write of 0x1003 sub 0
/// (an SDO download or [`Ctx::write_object`](super::Ctx::write_object), both
/// through the communication objects' write in `objects.rs`) calls it
/// without a call through the [`Services`] vtable.
pub(super) fn clear_history(dict: &Dictionary, image: &mut [u8]) {
    // Every entry of the record zero (an empty value is zero-filled).
    for entry in object(dict, index::PRE_DEFINED_ERROR_FIELD) {
        let _ = dict.write_unchecked_entry(image, entry, &[]);
    }
}

/// The communication services as a hook's [`super::Ctx`] reaches them,
/// whatever the node's PDO and heartbeat-consumer counts.
pub(crate) trait Services {
    /// The EMCY producer.
    fn emcy(&mut self) -> &mut EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>;

    /// [`Pdos::trigger`].
    fn trigger_tpdo(&mut self, n: usize) -> bool;

    /// The mapping RPDO `n` (0-based) uses, if it resolved.
    fn rpdo_mapping(&self, n: usize) -> Option<&Mapping>;

    /// Whether 0x1016 entry `i` (0-based) set to `value` would monitor a
    /// node another entry monitors.
    fn consumer_conflicts(&self, i: usize, value: u32) -> bool;

    /// A download into a PDO record (0x1400–0x1BFF) whose `entry` passed
    /// the precheck, with the PDOs' rules (`rewrite`: a valid PDO may
    /// change): the PDO takes the value; the caller stores it if `Ok`.
    #[allow(clippy::too_many_arguments)]
    fn write_pdo(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        entry: &'static Entry,
        dict: &Dictionary,
        image: &[u8],
        rewrite: bool,
    ) -> Result<(), AbortCode>;

    /// The service that owns (index, sub) takes the `value` just stored.
    fn apply(&mut self, index: u16, sub: u8, value: u32, now: At);
}

/// [`Comm`] as a node with the application `A` and the dictionary `O`
/// holds it: the hooks' [`Services`] (one vtable per image) leave out the
/// PDO calls `A` does not make ([`Application::PDO_CALLS`]), which a
/// vtable would link whether called or not, and the guarding where `O`
/// has none ([`ObjectDictionary::SERVICES`]).
pub(super) struct Hooked<A, O, const R: usize, const T: usize, const HB: usize> {
    comm: Comm<R, T, HB, OptionsOf<A>>,
    app: PhantomData<A>,
    od: PhantomData<fn() -> O>,
}

impl<A: Application, O, const R: usize, const T: usize, const HB: usize> Hooked<A, O, R, T, HB> {
    /// [`Comm::new`].
    pub(super) const fn new() -> Self {
        Hooked { comm: Comm::new(), app: PhantomData, od: PhantomData }
    }
}

impl<A: Application, O: ObjectDictionary, const R: usize, const T: usize, const HB: usize> Hooked<A, O, R, T, HB> {
    /// Reads every communication parameter but the PDOs' again (after reset
    /// communication, which then configures the PDOs with [`Comm::configure_pdos`]).
    pub fn configure(&mut self, dict: &Dictionary, image: &[u8], now: At) {
        self.emcy.reset();
        if O::SERVICES.guarding {
            self.guarding.reset();
        }
        // Each object as a download applies it: the stored value, or the
        // default where the dictionary lacks the object.
        self.sync = SyncService::default();
        // The objects of `CONFIGURED` (sub 0), then the consumers 0x1016 sub
        // 1..=HB, in one loop: one call of each per image (two loops cost
        // 76 B more in ds301).
        for i in 0..CONFIGURED.len().wrapping_add(HB) {
            let index = CONFIGURED.get(i).copied().unwrap_or(index::CONSUMER_HEARTBEAT_TIME);
            // At most 127 consumers (0x1016 sub 1..=127): the sub-index fits.
            let sub = i.saturating_sub(CONFIGURED.len().wrapping_sub(1)) as u8;
            // 0x1005's 0x80 (i = 0) and 0x1014's 0x8000_0000 (i = 1): `CONFIGURED`'s order.
            let default = match i {
                0 => SYNC_COB_ID.into(),
                1 => 0x8000_0000,
                _ => 0,
            };
            let value = u32_of(dict, image, index, sub, default);
            Services::apply(self, index, sub, value, now);
        }
    }
}

impl<A, O, const R: usize, const T: usize, const HB: usize> Deref for Hooked<A, O, R, T, HB> {
    type Target = Comm<R, T, HB, OptionsOf<A>>;

    fn deref(&self) -> &Comm<R, T, HB, OptionsOf<A>> {
        &self.comm
    }
}

impl<A, O, const R: usize, const T: usize, const HB: usize> DerefMut for Hooked<A, O, R, T, HB> {
    fn deref_mut(&mut self) -> &mut Comm<R, T, HB, OptionsOf<A>> {
        &mut self.comm
    }
}

impl<A: Application, O: ObjectDictionary, const R: usize, const T: usize, const HB: usize> Services for Hooked<A, O, R, T, HB> {
    fn emcy(&mut self) -> &mut EmcyProducer<EMCY_SLOTS, EMCY_SLOTS> {
        &mut self.comm.emcy
    }

    fn trigger_tpdo(&mut self, n: usize) -> bool {
        A::PDO_CALLS && self.comm.pdos.trigger(n)
    }

    fn rpdo_mapping(&self, n: usize) -> Option<&Mapping> {
        if !A::PDO_CALLS {
            return None;
        }
        self.comm.pdos.rpdo(n).and_then(|r| r.mapping())
    }

    fn consumer_conflicts(&self, i: usize, value: u32) -> bool {
        self.comm.consumers.conflicts(i, value)
    }

    fn write_pdo(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        entry: &'static Entry,
        dict: &Dictionary,
        image: &[u8],
        rewrite: bool,
    ) -> Result<(), AbortCode> {
        // Only a device whose manual allows it passes `rewrite` (its
        // options are `A::OPTIONS`): a constant, so that the others link
        // none of its rules (a vtable method would take it as a value).
        let rewrite = A::OPTIONS.pdo_rewrite_while_valid && rewrite;
        self.comm.pdos.write_checked(index, sub, data, entry, dict, image, rewrite)
    }

    fn apply(&mut self, index: u16, sub: u8, value: u32, now: At) {
        self.comm.apply(index, sub, value, now, O::SERVICES.guarding);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{Attr, DataType};

    const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
    static ENTRIES: [Entry; 5] = [
        Entry::new(0x1005, 0, DataType::Unsigned32, RW, 4, 0),
        Entry::new(0x1016, 0, DataType::Unsigned8, Attr::READ, 1, 4),
        Entry::new(0x1016, 1, DataType::Unsigned32, RW, 4, 5),
        Entry::new(0x1016, 2, DataType::Unsigned32, RW, 4, 9),
        Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 13),
    ];
    /// 0x1005 = 0x40000081, 0x1016 = [node 5 at 1000 ms, node 6 at 2000 ms], 0x1017 = 1000 ms.
    static DEFAULTS: [u8; 15] = [0x81, 0, 0, 0x40, 2, 0xE8, 0x03, 5, 0, 0xD0, 0x07, 6, 0, 0xE8, 0x03];
    static DICT: Dictionary = Dictionary::comm_only(&ENTRIES, &DEFAULTS);
    static EMPTY: Dictionary = Dictionary { entries: &[], defaults: crate::od::Defaults::dense(&[]), comm_len: 0, stored_len: 0, ..DICT };

    /// The dictionary type a node would have (its services: every one).
    struct Od;

    impl ObjectDictionary for Od {
        fn dictionary(&self) -> &'static Dictionary {
            &DICT
        }

        fn image(&self) -> &[u8] {
            &[]
        }

        fn image_mut(&mut self) -> &mut [u8] {
            &mut []
        }
    }

    #[test]
    fn reset_communication_applies_each_object_or_its_default() {
        let mut comm = Hooked::<crate::node::NoApplication, Od, 0, 0, 2>::new();
        comm.configure(&DICT, &DEFAULTS, 0);
        assert_eq!(comm.sync.cob_id(), 0x81, "0x1005 as the image holds it");
        assert!(comm.heartbeat.active(), "0x1017 = 1000 ms");
        assert!(comm.consumers.producers().eq([5, 6]), "0x1016 sub 1 and 2");
        comm.configure(&EMPTY, &[], 0);
        assert_eq!(comm.sync.cob_id(), 0x80, "no 0x1005: the pre-defined SYNC COB-ID");
        assert!(!comm.heartbeat.active(), "no 0x1017: no heartbeat");
        assert_eq!(comm.consumers.producers().count(), 0, "no 0x1016: no consumer");
        assert_eq!(comm.emcy.cob_id(), None, "no 0x1014: EMCY off");
    }

    #[test]
    fn a_consumer_takes_its_own_sub_index_and_sub_0_none() {
        let mut comm = Hooked::<crate::node::NoApplication, Od, 0, 0, 2>::new();
        comm.configure(&DICT, &DEFAULTS, 0);
        // Node 7 at 1000 ms.
        Services::apply(&mut comm, 0x1016, 0, 0x0007_03E8, 0);
        assert!(comm.consumers.producers().eq([5, 6]), "sub 0 is the count: no consumer changes");
        Services::apply(&mut comm, 0x1016, 2, 0x0007_03E8, 0);
        assert!(comm.consumers.producers().eq([5, 7]), "sub 2 is the second consumer");
        Services::apply(&mut comm, 0x1016, 3, 0x0008_03E8, 0);
        assert!(comm.consumers.producers().eq([5, 7]), "sub 3: beyond the two consumers");
    }

    /// 0x1029 sub 1 and 2 (UNSIGNED8) as CiA 301 §7.5.2.32 reads them; a
    /// sub-index the object lacks (3) is pre-operational.
    #[test]
    fn error_behaviour_follows_0x1029_and_is_pre_operational_without_it() {
        static BEHAVIOUR: [Entry; 3] = [
            Entry::new(0x1029, 0, DataType::Unsigned8, Attr::READ, 1, 0),
            Entry::new(0x1029, 1, DataType::Unsigned8, RW, 1, 1),
            Entry::new(0x1029, 2, DataType::Unsigned8, RW, 1, 2),
        ];
        static DICT_1029: Dictionary =
            Dictionary { entries: &BEHAVIOUR, defaults: crate::od::Defaults::dense(&[0; 3]), comm_len: 3, stored_len: 3, ..DICT };
        type C = Comm<0, 0, 0>;
        for (value, behaviour) in [
            (0, ErrorBehaviour::PreOperational),
            (1, ErrorBehaviour::NoChange),
            (2, ErrorBehaviour::Stopped),
            (3, ErrorBehaviour::PreOperational),
        ] {
            let image = [2, value, value];
            assert_eq!(C::error_behaviour(&DICT_1029, &image), behaviour, "sub 1 = {value}");
            assert_eq!(C::error_behaviour_of(&DICT_1029, &image, 2), behaviour, "sub 2 = {value}");
            assert_eq!(C::error_behaviour_of(&DICT_1029, &image, 3), ErrorBehaviour::PreOperational, "no sub 3");
        }
        assert_eq!(C::error_behaviour(&EMPTY, &[]), ErrorBehaviour::PreOperational, "no 0x1029");
    }

    /// 0x1001, and 0x1003 with sub-indices 0, 1, 2 and 4 (sub 3 missing).
    static HISTORY: [Entry; 5] = [
        Entry::new(0x1001, 0, DataType::Unsigned8, Attr::READ, 1, 0),
        Entry::new(0x1003, 0, DataType::Unsigned8, RW, 1, 1),
        Entry::new(0x1003, 1, DataType::Unsigned32, Attr::READ, 4, 2),
        Entry::new(0x1003, 2, DataType::Unsigned32, Attr::READ, 4, 6),
        Entry::new(0x1003, 4, DataType::Unsigned32, Attr::READ, 4, 10),
    ];
    static HISTORY_DICT: Dictionary =
        Dictionary { entries: &HISTORY, defaults: crate::od::Defaults::dense(&[0; 14]), comm_len: 14, stored_len: 14, ..DICT };

    #[test]
    fn the_history_shifts_down_to_the_first_missing_sub_index() {
        let mut comm = Hooked::<crate::node::NoApplication, Od, 0, 0, 0>::new();
        let mut image = [0u8; 14];
        let mut record = |image: &mut [u8], code: u8| comm.record(&HISTORY_DICT, image, &[code, 0x10, 0x01, 0xAA, 0xBB, 0, 0, 0]);
        record(&mut image, 1);
        assert_eq!(image[..6], [0x01, 1, 1, 0x10, 0xAA, 0xBB], "0x1001 as sent; one entry");
        record(&mut image, 2);
        record(&mut image, 3);
        // Three entries' room (every sub-index but 0), the third missing: the
        // count says 3, sub 4 is never written, the oldest is gone.
        assert_eq!(image, [0x01, 3, 3, 0x10, 0xAA, 0xBB, 2, 0x10, 0xAA, 0xBB, 0, 0, 0, 0]);
        record(&mut image, 4);
        assert_eq!(image[1..10], [3, 4, 0x10, 0xAA, 0xBB, 3, 0x10, 0xAA, 0xBB]);
        // A count above the room (the image as a device left it) is cut to the room.
        for count in [4, 200, 255] {
            image[1] = count;
            record(&mut image, 5);
            assert_eq!(image[1..6], [3, 5, 0x10, 0xAA, 0xBB], "count {count}");
        }
        image[1] = 0;
        record(&mut image, 6);
        assert_eq!(image[1..10], [1, 6, 0x10, 0xAA, 0xBB, 5, 0x10, 0xAA, 0xBB], "count 0: one entry, the older ones stay as they are");
    }
}
