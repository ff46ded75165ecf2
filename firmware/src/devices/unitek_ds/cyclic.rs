//! The cyclic read slots of READ 0x3D (manual §5.2, Ex. 9, English item 8):
//! "Es können maximal 8 Zustandswerte konfiguriert werden, die zyklisch
//! ihren Status senden" (L680); "Entries with suspended transmissions can
//! be overwritten by newer requests" (L1605-1606).
//!
//! A request for a register that already has a slot changes its period
//! (one stream per register); a stop suspends the slot, which the next new
//! register may take; a ninth register while eight stream is refused and
//! the eight keep streaming (decision U-D5 in docs/devices/unitek-ds.md).

use canopen_core::time::{Duration, Instant};

/// Cyclic slots (L680, L1596).
pub const SLOTS: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Slot {
    regid: u8,
    /// 0: suspended (free for a new register).
    period_ms: u8,
    due: Instant,
}

impl Slot {
    const FREE: Slot = Slot { regid: 0, period_ms: 0, due: Instant::ZERO };
}

/// The eight slots.
#[derive(Clone, Debug)]
pub struct Cyclic {
    slots: [Slot; SLOTS],
}

impl Cyclic {
    /// All slots suspended: `const` and all zero bits.
    pub const NEW: Cyclic = Cyclic { slots: [Slot::FREE; SLOTS] };

    /// Sends `regid` every `period_ms` from `now` on (its first frame at
    /// `now`); false if all eight slots stream other registers.
    pub fn start(&mut self, regid: u8, period_ms: u8, now: Instant) -> bool {
        let same = self.slots.iter().position(|s| s.period_ms != 0 && s.regid == regid);
        let free = || self.slots.iter().position(|s| s.period_ms == 0);
        match same.or_else(free).and_then(|i| self.slots.get_mut(i)) {
            Some(slot) => {
                *slot = Slot { regid, period_ms, due: now };
                true
            }
            None => false,
        }
    }

    /// Suspends `regid`'s stream (nothing if it has none).
    pub fn stop(&mut self, regid: u8) {
        for slot in self.slots.iter_mut().filter(|s| s.regid == regid) {
            slot.period_ms = 0;
        }
    }

    /// Suspends every stream (power-on).
    pub fn stop_all(&mut self) {
        *self = Cyclic::NEW;
    }

    /// The register of a slot that is due at `now`, its next time set one
    /// period on (from its due time, so the period does not drift; from
    /// `now` if it fell a whole period behind, so a late call sends once,
    /// not a burst). Call until `None`.
    pub fn next_due(&mut self, now: Instant) -> Option<u8> {
        let slot = self.slots.iter_mut().find(|s| s.period_ms != 0 && s.due <= now)?;
        let period = Duration::from_millis(u64::from(slot.period_ms));
        let next = slot.due + period;
        slot.due = if next <= now { now + period } else { next };
        Some(slot.regid)
    }

    /// Puts back a register [`Cyclic::next_due`] gave but that could not go
    /// out (the transmit burst was full): it is due again at `now`.
    pub fn retry(&mut self, regid: u8, now: Instant) {
        for slot in self.slots.iter_mut().filter(|s| s.period_ms != 0 && s.regid == regid) {
            slot.due = now;
        }
    }

    /// When the next slot is due.
    pub fn deadline(&self) -> Option<Instant> {
        self.slots.iter().filter(|s| s.period_ms != 0).map(|s| s.due).min()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn ms(t: u64) -> Instant {
        Instant::from_micros(t * 1000)
    }

    fn due(c: &mut Cyclic, now: Instant) -> Vec<u8> {
        core::iter::from_fn(|| c.next_due(now)).collect()
    }

    #[test]
    fn a_stream_keeps_its_period_without_drift() {
        let mut c = Cyclic::NEW;
        assert!(c.start(0x30, 10, ms(0)));
        assert_eq!(due(&mut c, ms(0)), [0x30]);
        assert_eq!(c.deadline(), Some(ms(10)));
        // Called late by 3 ms: the next one is still at 20 ms.
        assert_eq!(due(&mut c, ms(13)), [0x30]);
        assert_eq!(c.deadline(), Some(ms(20)));
        // A whole period behind: once, then a period from now.
        assert_eq!(due(&mut c, ms(45)), [0x30]);
        assert_eq!(c.deadline(), Some(ms(55)));
    }

    #[test]
    fn eight_slots_a_ninth_is_refused_and_a_stopped_slot_is_reused() {
        let mut c = Cyclic::NEW;
        for r in 0..8 {
            assert!(c.start(0x20 + r, 10, ms(0)));
        }
        assert!(!c.start(0x40, 10, ms(0)), "a ninth register");
        // The same register again only changes its period.
        assert!(c.start(0x20, 20, ms(0)));
        c.stop(0x21);
        assert!(c.start(0x40, 10, ms(0)));
        let mut sent = due(&mut c, ms(0));
        sent.sort_unstable();
        assert_eq!(sent, [0x20, 0x22, 0x23, 0x24, 0x25, 0x26, 0x27, 0x40]);
        assert_eq!(due(&mut c, ms(10)).len(), 7, "0x20 now every 20 ms");
    }

    #[test]
    fn stopped_streams_have_no_deadline() {
        let mut c = Cyclic::NEW;
        c.start(0x30, 100, ms(0));
        c.stop(0x30);
        c.stop(0x31);
        assert_eq!(c.deadline(), None);
        assert_eq!(c.next_due(ms(1000)), None);
    }
}
