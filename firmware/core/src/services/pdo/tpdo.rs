//! One transmit PDO. CiA 301 v4.2 §7.2.2; objects 0x1800–0x19FF
//! (communication) and 0x1A00–0x1BFF (mapping).
//!
//! Transmission types (sub 2, §7.5.2.37 table 72):
//! - 0, synchronous acyclic: sent on the SYNC after an event (a change of
//!   the mapped data, or [`super::Pdos::trigger`]).
//! - 1..=240, synchronous cyclic: sent on every n-th SYNC. With a SYNC
//!   counter (0x1019 > 0) and a SYNC start value (sub 6) other than 0, the
//!   SYNC whose counter equals the start value counts as the first one.
//! - 252, RTR-only synchronous: sampled on each SYNC, sent on RTR.
//! - 253, RTR-only event-driven: built and sent on RTR.
//! - 254, 255, event-driven: sent on an event (change of the mapped data,
//!   event timer sub 5 in ms, [`super::Pdos::trigger`], or an RTR), at most
//!   once per inhibit time (sub 3, 100 µs): an event during the inhibit
//!   time waits for its end. Each transmission restarts the event timer.
//!
//! Inhibit time and event timer apply to types 254/255 only (sub 3 and sub 5
//! descriptions of §7.5.2.37). RTRs are answered for 252..=255 unless COB-ID
//! bit 30 says "no RTR"; a synchronous cyclic PDO ignores them.
//!
//! A frame the transmit queue refuses stays pending: an event-driven PDO
//! retries at the next poll, a synchronous one at the next poll while the
//! synchronous window (0x1007) is still open, after which it is dropped.

use super::config::{Change, Config};
use super::map::{MAX_LEN, Mapping};
use super::{CommParams, PdoTx, TpdoRules};
use crate::services::sync::SyncEvent;
use crate::time::{At, Far, NEVER, at_by, later, shift, shift_opt};

/// The state of one TPDO.
// In this order (`repr(C)`): the flags the paths test and set first,
// then the parameters, where thumbv7m reaches them with 2-byte
// instructions (a byte within 32 of the PDO's start, a halfword within
// 64); the deadlines and the frames, read as words, after.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tpdo {
    /// Whether a change of the mapped data is *not* an event (types 0, 254,
    /// 255): negated so that [`Tpdo::UNCONFIGURED`] is all zero bits.
    no_change_detection: bool,
    sent: bool,
    /// An event (initial send, event timer, trigger, RTR) waits to be sent.
    event: bool,
    /// A change of the mapped data waits for the inhibit time to end; it is
    /// checked again then, so a change undone meanwhile sends nothing.
    change_pending: bool,
    /// The transmit queue refused the last frame: no deadline until the next poll.
    blocked: bool,
    /// SYNCs still to come before the next cyclic transmission, counting
    /// the one that sends it; 0 when the count starts over (it then waits
    /// for the transmission type's n SYNCs), so that a SYNC is one
    /// decrement and one compare.
    sync_left: u8,
    /// Waiting for the SYNC whose counter equals the start value.
    await_start: bool,
    /// Type 252: `held` is the sample of the last SYNC.
    sampled: bool,
    /// `held` is a synchronous frame the queue refused, retried inside the window.
    pending_sync: bool,
    /// Parameters and mapping ([`Config`]).
    pub(super) config: Config,
    /// End of the inhibit time; 0: none (a plain `At`: an end that has
    /// passed and none behave alike, in the send's test and in [`Tpdo::due`]).
    inhibit_until: At,
    event_at: Option<At>,
    /// The last data sent, for change detection.
    last: [u8; MAX_LEN],
    /// Type 252: the data sampled at the last SYNC (`sampled`); types
    /// 0..=240: a frame the queue refused (`pending_sync`). One buffer:
    /// a type has one use for it, and a new type starts the PDO over.
    held: [u8; MAX_LEN],
    /// Unused: keeps the size at 128 B, a power of two, so that the TPDOs
    /// are indexed by a shift (120 B took a multiply at each index, 16 B
    /// more code than the 4 B of RAM).
    pad: u32,
}

// The pad's job: a power of two (a field added or removed shows here).
const _: () = assert!(core::mem::size_of::<Tpdo>() == 128);

impl Default for Tpdo {
    fn default() -> Self {
        Tpdo { config: Config::DEFAULT, ..Tpdo::UNCONFIGURED }
    }
}

impl Tpdo {
    /// Before the first [`super::Pdos::configure`]: all zero bits
    /// ([`crate::node`]), an empty mapping, so it sends nothing.
    pub(super) const UNCONFIGURED: Tpdo = Tpdo {
        config: Config::UNCONFIGURED,
        no_change_detection: false,
        last: [0; MAX_LEN],
        sent: false,
        event: false,
        change_pending: false,
        blocked: false,
        inhibit_until: 0,
        event_at: None,
        sync_left: 0,
        await_start: false,
        held: [0; MAX_LEN],
        sampled: false,
        pending_sync: false,
        pad: 0,
    };
}

impl Tpdo {
    /// The cached communication parameters.
    pub fn params(&self) -> &CommParams {
        &self.config.params
    }

    /// The resolved mapping, or `None` if the configured one is invalid.
    pub fn mapping(&self) -> Option<&Mapping> {
        (!self.config.unresolved).then_some(&self.config.mapping)
    }

    /// The CAN-ID it sends on: `Some` when the COB-ID is valid and a
    /// non-empty mapping resolved (a mapping of sub 0 = 0 disables the PDO).
    pub fn cob_id(&self) -> Option<u16> {
        self.config.cob_id()
    }

    /// Whether change detection is switched on ([`super::Pdos::set_change_detection`]);
    /// the timer-only types of a device's [`super::TpdoRules`] ignore changes whatever it says.
    pub fn change_detection(&self) -> bool {
        !self.no_change_detection
    }

    fn is_event_driven(&self) -> bool {
        matches!(self.config.params.transmission_type, 254 | 255)
    }

    /// Whether this PDO is of type 254 on a device that makes 254 timer-only,
    /// or of type 255 with an event timer on a device that makes that timer-only.
    fn timer_only<P: TpdoRules>(&self) -> bool {
        match self.config.params.transmission_type {
            254 => P::TYPE_254,
            255 => P::TYPE_255_WITH_TIMER && self.config.params.event_timer_ms != 0,
            _ => false,
        }
    }

    /// Whether a change of the mapped data may be an event: change
    /// detection on, or a `P` that never turns it off (the node's).
    fn detects_changes<P: TpdoRules>(&self) -> bool {
        !(P::SWITCHES_CHANGE_DETECTION && self.no_change_detection)
    }

    pub(super) fn set_change_detection(&mut self, on: bool) {
        self.no_change_detection = !on;
    }

    /// Back to an unconfigured PDO but for the application's choice,
    /// which survives a reset: change detection.
    /// For a [`Tpdo::restart`] to follow, which sets the state it keeps
    /// (what was sent, the events, the timers, the SYNC count); the last
    /// frame and the held one are not read before they are written again.
    pub(super) fn unconfigure(&mut self) {
        self.config = Config::UNCONFIGURED;
    }

    /// Starts over, as on entering Operational: nothing counts as sent, so
    /// an event-driven PDO goes out at the first poll, and a synchronous
    /// acyclic one at the first SYNC. With `now`, the event timer runs from
    /// `now`; without, it is armed at the next poll.
    // Out of line: two callers each had a copy (168 bytes more).
    #[inline(never)]
    pub(super) fn restart<P: TpdoRules>(&mut self, now: Option<At>) {
        let timer = self.config.params.event_timer();
        self.sent = false;
        self.event = self.is_event_driven() && !self.timer_only::<P>();
        self.change_pending = false;
        self.blocked = false;
        self.inhibit_until = 0;
        self.event_at = now.filter(|_| timer != 0).map(|t| later(t, timer));
        self.sync_left = 0;
        self.await_start = self.config.params.sync_start != 0;
        self.sampled = false;
        self.pending_sync = false;
    }

    /// Acts on what a download or the configuration changed
    /// ([`Config::change`]), in `Pdos::parameters_changed`'s walk.
    pub(super) fn act<P: TpdoRules>(&mut self) {
        match core::mem::take(&mut self.config.change) {
            Change::None => {}
            Change::Restart => self.restart::<P>(None),
            Change::Timer => self.rearm_timer(),
        }
    }

    /// The event timer was rewritten: it restarts at the next poll (where
    /// a type 255 may have become timer-only or ceased to be: `service_event` asks).
    pub(super) fn rearm_timer(&mut self) {
        self.event_at = None;
    }

    /// The application signals an event (types 0, 254, 255).
    pub(super) fn trigger(&mut self) -> bool {
        if self.cob_id().is_none() || !matches!(self.config.params.transmission_type, 0 | 254 | 255) {
            return false;
        }
        self.event = true;
        self.blocked = false;
        true
    }

    fn build(&self, image: &[u8]) -> ([u8; MAX_LEN], usize) {
        let mut buf = [0u8; MAX_LEN];
        let len = self.config.mapping.build(image, &mut buf);
        (buf, len)
    }

    /// Whole arrays compared (no slice compare call): `build` zeroes the
    /// bytes past the mapping's length, and `last` was built with the same
    /// mapping while `sent` holds (a new mapping restarts the PDO).
    fn changed(&self, buf: &[u8; MAX_LEN]) -> bool {
        !self.sent || self.last != *buf
    }

    /// Hands a frame to the queue; remembers it when accepted.
    fn transmit(&mut self, cob_id: u16, buf: [u8; MAX_LEN], len: usize, tx: &mut impl PdoTx) -> bool {
        // `buf` is zero past `len` (`build`): copied as two words, no `memcpy`.
        let ok = tx.send_data(cob_id, &buf, len);
        if ok {
            self.last = buf;
            self.sent = true;
            self.event = false;
            self.change_pending = false;
        }
        self.blocked = !ok;
        ok
    }

    /// Types 254/255: timers, change detection, and the send once the inhibit time allows.
    fn service_event<P: TpdoRules>(&mut self, now: At, cob_id: u16, image: &[u8], tx: &mut impl PdoTx) {
        let timer = self.config.params.event_timer();
        if timer != 0 {
            match self.event_at {
                None => self.event_at = Some(later(now, timer)),
                Some(t) if now >= t => self.event = true,
                Some(_) => {}
            }
        }
        let (buf, len) = self.build(image);
        // A change is no event with change detection off, nor while timer-only
        // (a constant for most devices: one flag to test).
        self.change_pending = self.detects_changes::<P>() && !self.timer_only::<P>() && self.changed(&buf);
        let due = self.event || self.change_pending;
        if due && now >= self.inhibit_until && self.transmit(cob_id, buf, len, tx) {
            let inhibit = self.config.params.inhibit_time();
            self.inhibit_until = if inhibit != 0 { later(now, inhibit) } else { 0 };
            self.event_at = (timer != 0).then(|| later(now, timer));
        }
    }

    /// Timers and retries, for a TPDO that can send (the caller checks:
    /// `Pdos::tpdo_live`); `window_end`: of the last SYNC's synchronous window (0x1007).
    pub(super) fn poll<P: TpdoRules>(&mut self, now: At, window_end: Far, image: &[u8], tx: &mut impl PdoTx) {
        let cob_id = self.config.params.can_id();
        if self.is_event_driven() {
            self.service_event::<P>(now, cob_id, image, tx);
        } else if self.pending_sync {
            let len = self.config.mapping.len();
            // No window ([`Far::NEVER`]) never closes.
            if window_end.passed(now) || self.transmit(cob_id, self.held, len, tx) {
                self.pending_sync = false;
            }
        }
    }

    /// Whether a SYNC has work for it: valid, of type 0..=240 or 252
    /// ([`Tpdo::on_sync`] does nothing for the others).
    pub(super) fn is_synchronous(&self) -> bool {
        self.cob_id().is_some() && matches!(self.config.params.transmission_type, 0..=240 | 252)
    }

    /// A SYNC (received or produced), for a TPDO that
    /// [`Tpdo::is_synchronous`] (the caller checks: `Pdos::sync_tpdos`).
    pub(super) fn on_sync<P: TpdoRules>(&mut self, sync: &SyncEvent, image: &[u8], tx: &mut impl PdoTx) {
        let cob_id = self.config.params.can_id();
        // A frame refused at the previous SYNC is stale now.
        self.pending_sync = false;
        let send = match self.config.params.transmission_type {
            n @ 1..=240 => {
                if self.await_start {
                    match sync.counter {
                        Some(counter) if counter != self.config.params.sync_start => return,
                        // The start SYNC counts as the first; without a counter the start value is ignored.
                        _ => self.await_start = false,
                    }
                }
                // `n` ≥ 1, and `sync_left` ≤ `n` (it starts over whenever the type changes).
                let left = if self.sync_left == 0 { n } else { self.sync_left };
                self.sync_left = left.wrapping_sub(1);
                if self.sync_left != 0 {
                    return;
                }
                // Cyclic: no change detection, so nothing to remember but
                // a refusal; built straight into the queue.
                if tx.send_mapped(cob_id, &self.config.mapping, image) {
                    self.blocked = false;
                } else {
                    self.refused_sync(image);
                }
                return;
            }
            0 => {
                let (buf, len) = self.build(image);
                (self.event || (self.detects_changes::<P>() && self.changed(&buf))).then_some((buf, len))
            }
            252 => {
                (self.held, self.sampled) = (self.build(image).0, true);
                None
            }
            _ => None,
        };
        if let Some((buf, len)) = send
            && !self.transmit(cob_id, buf, len, tx)
        {
            (self.held, self.pending_sync) = (buf, true);
        }
    }

    /// The queue refused a cyclic frame: the data of this SYNC waits for
    /// a retry inside the window.
    #[cold]
    #[inline(never)]
    fn refused_sync(&mut self, image: &[u8]) {
        self.blocked = true;
        (self.held, self.pending_sync) = (self.build(image).0, true);
    }

    /// An RTR for `cob_id`, this PDO's CAN-ID (the caller found the PDO
    /// by it: it is valid and has a mapping); true if it was answered or is pending.
    pub(super) fn on_rtr<P: TpdoRules>(&mut self, now: At, cob_id: u16, image: &[u8], tx: &mut impl PdoTx) -> bool {
        if !self.config.params.rtr_allowed() {
            return false;
        }
        match self.config.params.transmission_type {
            // 252 sends what the last SYNC sampled; before the first SYNC
            // there is no sample yet: what is there now (as Lely does), as
            // 253 sends (which has no sample: any restart clears it).
            252 | 253 => {
                let (fresh, len) = self.build(image);
                let buf = if self.sampled { self.held } else { fresh };
                self.transmit(cob_id, buf, len, tx)
            }
            254 | 255 => {
                self.event = true;
                self.blocked = false;
                self.service_event::<P>(now, cob_id, image, tx);
                true
            }
            _ => false,
        }
    }

    /// Whether a frame the queue refused waits to be retried.
    pub(super) fn retrying(&self) -> bool {
        self.blocked || self.pending_sync
    }

    /// Whether this TPDO is event-driven (it looks for changes) and maps an
    /// image byte in `start..end`.
    // Two u16s: the sum fits a u32.
    #[allow(clippy::arithmetic_side_effects)]
    pub(super) fn maps_any(&self, start: u32, end: u32) -> bool {
        if !self.is_event_driven() {
            return false;
        }
        self.config.mapping.maps_any(start, end)
    }

    /// The next time [`Tpdo::poll`] has work, for a TPDO that can send
    /// (`Pdos::tpdo_live`): the event timer, or the end of the inhibit time
    /// of a pending event; 0 means "now".
    #[inline(never)]
    pub(super) fn due(&self) -> At {
        if !self.is_event_driven() {
            return NEVER;
        }
        if self.event || self.change_pending {
            // The event timer has nothing to add to a pending event; a
            // refused frame waits for the next poll instead of spinning.
            return if self.blocked { NEVER } else { self.inhibit_until };
        }
        if self.config.params.event_timer_ms == 0 { NEVER } else { self.event_at.unwrap_or(0) }
    }

    /// The epoch moved by `by` µs.
    pub(super) fn shift(&mut self, by: u64) {
        let by = at_by(by);
        shift(&mut self.inhibit_until, by);
        shift_opt(&mut self.event_at, by);
    }
}
