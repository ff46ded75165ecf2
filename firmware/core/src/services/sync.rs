//! SYNC consumer and producer. CiA 301 v4.2 §7.2.5; objects 0x1005 COB-ID
//! SYNC, 0x1006 communication cycle period, 0x1007 synchronous window
//! length, 0x1019 synchronous counter overflow value (§7.5.2.5–7, §7.5.2.22).
//!
//! Every node consumes the SYNC on the CAN-ID of 0x1005 bits 0..10; with
//! bit 30 set it also produces it every 0x1006 µs (0 = not produced). With
//! 0x1019 > 0 a SYNC carries a counter that runs 1..=0x1019 and starts over
//! at 1; a received SYNC must then have exactly one data byte, or it is not
//! a SYNC and the node raises EMCY 0x8240. With 0x1019 = 0 the data of a
//! received SYNC is ignored.
//!
//! Each SYNC opens the synchronous window (0x1007 µs, 0 = no window):
//! synchronous PDOs are neither sent nor accepted once it has closed, until
//! the next SYNC (see [`SyncEvent::window_end`]).
//!
//! SDO downloads (CiA 301 and CiA 310 cases 6.5, 6.9):
//! - 0x1005: bits 11..29 set (no 29-bit identifiers) or a restricted CAN-ID
//!   → 0x06090030; the CAN-ID may not change while the node produces the
//!   SYNC and keeps producing it → 0x06090030.
//! - 0x1019: 1 or 241..=255 → 0x06090030; any write while 0x1006 ≠ 0 →
//!   0x08000022 (the counter may only change while no SYNC is produced).

use crate::abort::AbortCode;
use crate::id::CobRule;
use crate::od::{Dictionary, index, le_u32, object, precheck, store_checked, sub_entry, value_u32};
use crate::time::{At, Far, NEVER};
use crate::wire::emcy::EmcyCode;
use crate::wire::sync::{CobIdSync, SYNC_COB_ID, SyncMessage};

/// A SYNC, received or produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncEvent {
    /// When it was received or became due.
    pub at: At,
    /// The SYNC counter, when 0x1019 > 0.
    pub counter: Option<u8>,
    /// When the synchronous window closes ([`Far::NEVER`]: 0x1007 = 0, no
    /// window; up to 71.6 minutes after `at`).
    pub window_end: Far,
}

impl SyncEvent {
    /// The SYNC message (what a producer sends).
    pub fn message(&self) -> SyncMessage {
        SyncMessage { counter: self.counter }
    }

    /// Whether synchronous PDOs may still be sent or accepted at `now`.
    pub fn window_open(&self, now: At) -> bool {
        !self.window_end.passed(now)
    }
}

/// A received SYNC whose data length does not fit 0x1019 (EMCY 0x8240).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncLengthError {
    /// The data length received.
    pub len: usize,
}

impl SyncLengthError {
    /// The EMCY error code the node raises: 0x8240 unexpected SYNC data length.
    pub const fn emcy_code(&self) -> EmcyCode {
        EmcyCode::UNEXPECTED_SYNC_LENGTH
    }
}

/// The SYNC consumer, and producer when 0x1005 bit 30 is set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncService {
    cob_id: u16,
    producer: bool,
    /// 0x1006 in µs (0: no SYNC produced).
    period: u32,
    /// 0x1007 in µs (0: no window).
    window: u32,
    overflow: u8,
    /// The counter of the last SYNC produced (0: none yet).
    counter: u8,
    /// When the next SYNC is due; `None` while the producer is not yet armed.
    next: Option<Far>,
}

impl Default for SyncService {
    fn default() -> Self {
        SyncService { cob_id: SYNC_COB_ID, ..Self::UNCONFIGURED }
    }
}

/// 0x1019 as used: 1 is not a valid overflow value and counts as 2, above
/// 240 as 240 (a stored value can be invalid; downloads are checked).
const fn clamp_overflow(value: u8) -> u8 {
    match value {
        1 => 2,
        241.. => 240,
        v => v,
    }
}

impl SyncService {
    /// Before the first [`SyncService::configure`]: COB-ID 0, NMT's, which
    /// never reaches a SYNC consumer, and all zero bits ([`crate::node`];
    /// [`SyncService::default`] is a consumer on 0x80).
    pub const UNCONFIGURED: SyncService =
        SyncService { cob_id: 0, producer: false, period: 0, window: 0, overflow: 0, counter: 0, next: None };

    /// Reads 0x1005, 0x1006, 0x1007 and 0x1019 as reset communication takes
    /// them (the node hands the same values to [`SyncService::apply`] with
    /// its other services'). Objects the dictionary lacks read as the
    /// defaults: COB-ID 0x80, consumer only, no period, no window, no
    /// counter; an invalid stored COB-ID keeps the default's. The producer
    /// restarts: its first SYNC comes one period after the next poll.
    pub fn configure(&mut self, dict: &Dictionary, image: &[u8]) {
        *self = SyncService::default();
        for (index, default) in [
            (index::COB_ID_SYNC, u32::from(SYNC_COB_ID)),
            (index::COMMUNICATION_CYCLE_PERIOD, 0),
            (index::SYNCHRONOUS_WINDOW_LENGTH, 0),
            (index::SYNCHRONOUS_COUNTER_OVERFLOW, 0),
        ] {
            let value = sub_entry(object(dict, index), 0).map_or(default, |e| value_u32(dict, image, e));
            self.apply(index, value);
        }
    }

    /// The CAN-ID of the SYNC, consumed and, when producing, sent.
    pub fn cob_id(&self) -> u16 {
        self.cob_id
    }

    /// Whether this node produces the SYNC (0x1005 bit 30 and 0x1006 ≠ 0).
    pub fn is_producing(&self) -> bool {
        self.producer && self.period != 0
    }

    /// The synchronous counter overflow value in use (0: no counter).
    pub fn counter_overflow(&self) -> u8 {
        self.overflow
    }

    /// The SYNC at `at` with `counter`, its window from 0x1007 (the node
    /// builds the event it hands the PDOs here, at one place for both a
    /// received and a produced SYNC).
    pub(crate) fn event(&self, at: At, counter: Option<u8>) -> SyncEvent {
        let window_end = if self.window != 0 { Far::after(at, u64::from(self.window)) } else { Far::NEVER };
        SyncEvent { at, counter, window_end }
    }

    /// A frame on the SYNC COB-ID.
    // In line: its one caller, the node's frame dispatch, then hands the
    // counter on in a register (`synchronise` builds the event from it);
    // out of line, ds301 was 12 bytes smaller but the core image 36 larger.
    #[inline(always)]
    pub fn on_frame(&mut self, now: At, data: &[u8]) -> Result<SyncEvent, SyncLengthError> {
        // The counter first, then one event for either (its window end in one place).
        let counter = if self.overflow == 0 {
            None
        } else {
            match SyncMessage::parse(data) {
                Ok(SyncMessage { counter: Some(counter) }) => Some(counter),
                _ => return Err(SyncLengthError { len: data.len() }),
            }
        };
        Ok(self.event(now, counter))
    }

    /// The producer: `Some` when a SYNC is due at `now`; the node sends
    /// [`SyncEvent::message`] on [`SyncService::cob_id`] and hands the event
    /// to the PDOs. Late polls keep the period's grid.
    pub fn poll(&mut self, now: At) -> Option<SyncEvent> {
        if !self.is_producing() {
            return None;
        }
        let period = u64::from(self.period);
        match self.next {
            None => {
                self.next = Some(Far::after(now, period));
                None
            }
            Some(due) if due.reached(now) => {
                let mut next = due.then(period);
                if next.reached(now) {
                    next = Far::after(now, period);
                }
                self.next = Some(next);
                let counter = (self.overflow != 0).then(|| {
                    self.counter = if self.counter >= self.overflow { 1 } else { self.counter.wrapping_add(1) };
                    self.counter
                });
                Some(self.event(now, counter))
            }
            Some(_) => None,
        }
    }

    /// When the next SYNC is due (0: poll at once to start the producer;
    /// earlier for a period beyond an [`At`]).
    pub fn deadline(&self) -> At {
        if self.is_producing() { self.next.map_or(0, Far::at) } else { NEVER }
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        if let Some(next) = &mut self.next {
            next.shift(by);
        }
    }

    /// An SDO download of (index, sub): `None` unless it is 0x1005, 0x1006,
    /// 0x1007 or 0x1019; else the outcome, with the image and the service
    /// updated on success.
    pub fn write_object(&mut self, index: u16, sub: u8, data: &[u8], dict: &Dictionary, image: &mut [u8]) -> Option<Result<(), AbortCode>> {
        if !matches!(
            index,
            index::COB_ID_SYNC | index::COMMUNICATION_CYCLE_PERIOD | index::SYNCHRONOUS_WINDOW_LENGTH | index::SYNCHRONOUS_COUNTER_OVERFLOW
        ) {
            return None;
        }
        Some(self.write(index, sub, data, dict, image))
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8], dict: &Dictionary, image: &mut [u8]) -> Result<(), AbortCode> {
        let entry = precheck::<true>(dict, index, sub, data)?;
        let value = le_u32(data);
        // The object's own rules first, then one write for all four.
        self.check(index, value)?;
        store_checked(image, entry, data)?;
        self.apply(index, value);
        Ok(())
    }

    /// The rules of a download of `value` into `index` (0x1005–0x1007,
    /// 0x1019): [`CobRule::SYNC`], and an overflow of 0 or 2..=240 set
    /// only while no SYNC is produced (0x08000022).
    pub fn check(&self, index: u16, value: u32) -> Result<(), AbortCode> {
        match index {
            index::COB_ID_SYNC => {
                let old = CobIdSync { can_id: self.cob_id, producer: self.producer }.to_u32();
                CobRule::SYNC.check(Some(old), value, u16::MAX)
            }
            index::SYNCHRONOUS_COUNTER_OVERFLOW => overflow_rule(value, || self.period),
            _ => Ok(()),
        }
    }

    /// Takes `value`, which passed [`SyncService::check`] (or the node's
    /// communication-object rules, which share [`overflow_rule`]) and is
    /// now in `index`'s entry.
    pub fn apply(&mut self, index: u16, value: u32) {
        match index {
            index::COB_ID_SYNC => {
                // The check refused a 29-bit identifier.
                let new = CobIdSync::from_u32(value).unwrap_or(CobIdSync { can_id: self.cob_id, producer: self.producer });
                self.cob_id = new.can_id;
                self.producer = new.producer;
                self.restart_producer();
            }
            index::COMMUNICATION_CYCLE_PERIOD => {
                self.period = value;
                self.next = None;
            }
            index::SYNCHRONOUS_WINDOW_LENGTH => self.window = value,
            _ => {
                // A stored value can be invalid (downloads are checked).
                self.overflow = clamp_overflow(value as u8);
                self.restart_producer();
            }
        }
    }

    /// The counter starts over at 1 and the first SYNC comes one period after the next poll.
    fn restart_producer(&mut self) {
        self.counter = 0;
        self.next = None;
    }
}

/// 0x1019's rule (CiA 301): 0 or 2..=240 (0x06090030 otherwise,
/// as [`AbortCode::InvalidValue`]), and set only while the communication
/// cycle period (0x1006, read by `period` only for a value in range) is 0
/// (0x08000022).
#[inline(always)]
pub(crate) fn overflow_rule(value: u32, period: impl FnOnce() -> u32) -> Result<(), AbortCode> {
    if value == 1 || value > 240 {
        Err(AbortCode::InvalidValue)
    } else if period() != 0 {
        Err(AbortCode::DeviceState)
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{Attr, DataType, Entry};
    use crate::time::deadline_of;

    const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
    static ENTRIES: [Entry; 4] = [
        Entry::new(0x1005, 0, DataType::Unsigned32, RW, 4, 0),
        Entry::new(0x1006, 0, DataType::Unsigned32, RW, 4, 4),
        Entry::new(0x1007, 0, DataType::Unsigned32, RW, 4, 8),
        Entry::new(0x1019, 0, DataType::Unsigned8, RW, 1, 12),
    ];
    static DEFAULTS: [u8; 13] = [0x80, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    static DICT: Dictionary = Dictionary::comm_only(&ENTRIES, &DEFAULTS);
    static EMPTY: Dictionary = Dictionary { entries: &[], defaults: crate::od::Defaults::dense(&[]), comm_len: 0, stored_len: 0, ..DICT };

    fn ms(t: u32) -> At {
        t * 1000
    }

    fn setup() -> (SyncService, [u8; 13]) {
        let image = DEFAULTS;
        let mut sync = SyncService::default();
        sync.configure(&DICT, &image);
        (sync, image)
    }

    fn sdo(sync: &mut SyncService, image: &mut [u8; 13], index: u16, data: &[u8]) -> Result<(), AbortCode> {
        sync.write_object(index, 0, data, &DICT, image).expect("a SYNC object")
    }

    // ---- Consumer ------------------------------------------------------------

    #[test]
    fn consumer_without_counter_accepts_any_data() {
        let (mut sync, _) = setup();
        assert_eq!((sync.cob_id(), sync.is_producing(), deadline_of(sync.deadline())), (0x80, false, None));
        let e = sync.on_frame(ms(5), &[]).unwrap();
        assert_eq!(e, SyncEvent { at: ms(5), counter: None, window_end: Far::NEVER });
        assert_eq!(sync.on_frame(ms(6), &[7]).map(|e| e.counter), Ok(None), "0x1019 = 0: data ignored");
        assert_eq!(sync.poll(ms(100)), None, "a consumer produces nothing");
    }

    #[test]
    fn consumer_with_counter_needs_exactly_one_byte() {
        // CiA 310 case 6.7: with 0x1019 > 0 the SYNC carries the counter.
        let (mut sync, mut image) = setup();
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[10]), Ok(()));
        assert_eq!(sync.on_frame(ms(1), &[3]).map(|e| e.counter), Ok(Some(3)));
        for data in [&[][..], &[1, 2][..], &[0; 8][..]] {
            let err = sync.on_frame(ms(2), data).unwrap_err();
            assert_eq!((err.len, err.emcy_code()), (data.len(), EmcyCode(0x8240)));
        }
    }

    #[test]
    fn the_window_opens_with_each_sync() {
        let (mut sync, mut image) = setup();
        assert_eq!(sdo(&mut sync, &mut image, 0x1007, &2_500u32.to_le_bytes()), Ok(()));
        let e = sync.on_frame(ms(10), &[]).unwrap();
        assert_eq!(e.window_end, Far::after(0, 12_500));
        assert!(e.window_open(12_500));
        assert!(!e.window_open(12_501));
    }

    // ---- Producer ------------------------------------------------------------

    #[test]
    fn producer_keeps_its_period_and_wraps_the_counter() {
        let (mut sync, mut image) = setup();
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[3]), Ok(()));
        assert_eq!(sdo(&mut sync, &mut image, 0x1006, &10_000u32.to_le_bytes()), Ok(()));
        assert_eq!(sdo(&mut sync, &mut image, 0x1005, &0x4000_0080u32.to_le_bytes()), Ok(()));
        assert!(sync.is_producing());
        assert_eq!(deadline_of(sync.deadline()), Some(0), "poll at once to arm");
        assert_eq!(sync.poll(ms(0)), None);
        assert_eq!(deadline_of(sync.deadline()), Some(ms(10)));
        assert_eq!(sync.poll(ms(9)), None);
        let mut got = [0u8; 5];
        for (i, c) in got.iter_mut().enumerate() {
            let t = ms(10 * (i as u32 + 1));
            let e = sync.poll(t).expect("due");
            assert_eq!(e.at, t);
            *c = e.counter.unwrap();
        }
        assert_eq!(got, [1, 2, 3, 1, 2]);
        // A late poll sends once and keeps the grid.
        let e = sync.poll(ms(67)).unwrap();
        assert_eq!((e.counter, deadline_of(sync.deadline())), (Some(3), Some(ms(70))));
        let mut buf = [0u8; 1];
        assert_eq!(e.message().emit(&mut buf), &[3]);
    }

    #[test]
    fn producer_without_counter_sends_empty_syncs() {
        let (mut sync, mut image) = setup();
        assert_eq!(sdo(&mut sync, &mut image, 0x1006, &1_000u32.to_le_bytes()), Ok(()));
        assert_eq!(sdo(&mut sync, &mut image, 0x1005, &0x4000_0080u32.to_le_bytes()), Ok(()));
        assert_eq!(sync.poll(ms(0)), None);
        let e = sync.poll(ms(1)).unwrap();
        assert_eq!(e.counter, None);
        // CiA 310 case 6.4: 0x1006 = 0 stops the producer.
        assert_eq!(sdo(&mut sync, &mut image, 0x1006, &[0; 4]), Ok(()));
        assert_eq!((sync.poll(ms(5)), deadline_of(sync.deadline())), (None, None));
    }

    #[test]
    fn configure_reads_the_image_and_restarts() {
        let mut image = DEFAULTS;
        image[..4].copy_from_slice(&0x4000_0081u32.to_le_bytes());
        image[4..8].copy_from_slice(&500u32.to_le_bytes());
        image[12] = 1; // invalid in a stored image: used as 2
        let mut sync = SyncService::default();
        sync.configure(&DICT, &image);
        assert_eq!((sync.cob_id(), sync.is_producing(), sync.counter_overflow()), (0x81, true, 2));
        let mut none = SyncService::default();
        none.configure(&EMPTY, &[]);
        assert_eq!(none, SyncService::default());
    }

    // ---- SDO downloads -------------------------------------------------------

    #[test]
    fn counter_overflow_downloads() {
        let (mut sync, mut image) = setup();
        // CiA 310 case 6.5: reserved values.
        for v in [1u8, 241, 255] {
            assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[v]), Err(AbortCode::InvalidValue), "{v}");
        }
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[240]), Ok(()));
        // CiA 310 case 6.6: 0 turns the counter off.
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[0]), Ok(()));
        // CiA 310 case 6.9: not while a period is set.
        assert_eq!(sdo(&mut sync, &mut image, 0x1006, &1_000u32.to_le_bytes()), Ok(()));
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[2]), Err(AbortCode::DeviceState));
        assert_eq!(DICT.read(&image, 0x1019, 0), Ok(&[0u8][..]));
        assert_eq!(sdo(&mut sync, &mut image, 0x1019, &[2, 0]), Err(AbortCode::LengthTooHigh));
    }

    #[test]
    fn cob_id_downloads() {
        let (mut sync, mut image) = setup();
        let w = |sync: &mut SyncService, image: &mut [u8; 13], v: u32| sdo(sync, image, 0x1005, &v.to_le_bytes());
        assert_eq!(w(&mut sync, &mut image, 0x2000_0080), Err(AbortCode::InvalidValue), "29-bit");
        assert_eq!(w(&mut sync, &mut image, 0x0000_1080), Err(AbortCode::InvalidValue), "bits 11..28");
        assert_eq!(w(&mut sync, &mut image, 0x0000_0701), Err(AbortCode::InvalidValue), "restricted");
        assert_eq!(w(&mut sync, &mut image, 0x0000_0090), Ok(()));
        assert_eq!(sync.cob_id(), 0x90);
        assert_eq!(w(&mut sync, &mut image, 0x4000_0090), Ok(()));
        // While producing, the CAN-ID is fixed.
        assert_eq!(w(&mut sync, &mut image, 0x4000_0091), Err(AbortCode::InvalidValue));
        assert_eq!(w(&mut sync, &mut image, 0x0000_0091), Ok(()), "stop producing and move at once");
        assert_eq!(DICT.read(&image, 0x1005, 0), Ok(&0x91u32.to_le_bytes()[..]));
        assert_eq!(w(&mut sync, &mut image, 0x8000_0092), Ok(()), "bit 31 is do-not-care");
        assert_eq!(sync.cob_id(), 0x92);
        assert_eq!(sdo(&mut sync, &mut image, 0x1005, &[0x80]), Err(AbortCode::LengthTooLow));
        assert_eq!(sync.write_object(0x1008, 0, &[], &DICT, &mut image), None);
        assert_eq!(sync.write_object(0x1005, 1, &[0; 4], &DICT, &mut image), Some(Err(AbortCode::NoSubIndex)));
    }
}
