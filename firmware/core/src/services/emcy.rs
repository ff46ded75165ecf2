//! EMCY producer with the error register (0x1001) it reports and the set of
//! active errors behind it. CiA 301 v4.2 §7.2.7, objects 0x1001, 0x1003,
//! 0x1014, 0x1015.
//!
//! Messages wait in a bounded queue for the inhibit time (0x1015, 100 µs
//! units). A full queue drops the new message, counts it, and sets the
//! generic bit of the error register, so the loss is visible.
//!
//! An active error may be held: it clears by itself once its hold ends
//! ([`EmcyProducer::raise_held`], [`EmcyProducer::expire`]), as the CAN
//! controller's transient errors do; one list and one walk for them all.

use crate::time::{At, NEVER, at_by, later, shift, span_100us};
use crate::wire::emcy::EmcyCode;

/// Error register bits (0x1001, CiA 301 table 47).
pub mod register {
    /// Generic error: set while any error is active.
    pub const GENERIC: u8 = 1 << 0;
    /// Current.
    pub const CURRENT: u8 = 1 << 1;
    /// Voltage.
    pub const VOLTAGE: u8 = 1 << 2;
    /// Temperature.
    pub const TEMPERATURE: u8 = 1 << 3;
    /// Communication error (overrun, error state, heartbeat, PDO length).
    pub const COMMUNICATION: u8 = 1 << 4;
    /// Device profile specific.
    pub const PROFILE: u8 = 1 << 5;
    /// Manufacturer specific.
    pub const MANUFACTURER: u8 = 1 << 7;
}

/// The error register bit an error code sets besides GENERIC (CiA 301 table 21).
pub const fn register_bit(code: EmcyCode) -> u8 {
    match code.0 >> 12 {
        0x2 => register::CURRENT,
        0x3 => register::VOLTAGE,
        0x4 => register::TEMPERATURE,
        0x8 => register::COMMUNICATION,
        0x6 | 0x7 | 0x9 => register::PROFILE,
        0xF => register::MANUFACTURER,
        _ => 0,
    }
}

/// An active error.
#[derive(Clone, Copy, Debug)]
struct Active {
    code: EmcyCode,
    /// Error register bits it sets beyond its code's class (a device whose
    /// manual gives a generic code a profile bit).
    bits: u8,
    /// When it clears by itself ([`NEVER`]: it does not).
    until: At,
}

/// The EMCY producer and the active-error set, for up to `A` active errors
/// and `Q` queued messages. Not `PartialEq`: [`EmcyProducer::reset`] and
/// [`EmcyProducer::clear`] leave entries past the lists' ends as they were.
#[derive(Clone, Copy, Debug)]
// Flags and counters first, the lists last: thumbv7m's 2-byte loads reach a byte only within 32.
#[repr(C)]
pub struct EmcyProducer<const A: usize, const Q: usize> {
    cob_id: Option<u16>,
    lost_errors: bool,
    /// The transmit queue refused frames and has not drained since: an
    /// error of its own, beside the active list, because it shares its code
    /// (0x8110) with the receive overrun, which comes and goes apart from it.
    tx_overflow: bool,
    /// The error register bits of the transmit queue overflow while it is
    /// active, GENERIC with them; 0 while it is not (and at power-on: the
    /// node is all zero bits).
    tx_bits: u8,
    /// 0x1015 in µs (at most 6.6 s).
    inhibit: u32,
    /// When the next message may go out (its inhibit time ends); 0 before
    /// the first, which may go out at once (an armed time is never
    /// [`NEVER`]: a shift moves it as an `Option` would).
    free_at: At,
    active_len: usize,
    head: usize,
    len: usize,
    overflows: u32,
    /// No held error clears before this ([`NEVER`]: none is held; 0 at
    /// power-on, the node being all zero bits, and after a reset: the next
    /// look finds none).
    held: At,
    active: [Active; A],
    /// The messages' data bytes ([`crate::wire::emcy::Emcy::emit`]), as they go out and are recorded.
    queue: [[u8; 8]; Q],
}

impl<const A: usize, const Q: usize> Default for EmcyProducer<A, Q> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const A: usize, const Q: usize> EmcyProducer<A, Q> {
    /// A producer with no COB-ID (silent) and no active error, until
    /// [`EmcyProducer::set_cob_id`].
    pub const fn new() -> Self {
        EmcyProducer {
            cob_id: None,
            inhibit: 0,
            free_at: 0,
            active: [Active { code: EmcyCode::NO_ERROR, bits: 0, until: 0 }; A],
            active_len: 0,
            held: 0,
            queue: [[0; 8]; Q],
            head: 0,
            len: 0,
            overflows: 0,
            lost_errors: false,
            tx_overflow: false,
            tx_bits: 0,
        }
    }

    /// 0x1014 (bit 31 set: EMCY off).
    pub fn set_cob_id(&mut self, cob_id: u32) {
        self.cob_id = (cob_id & 0x8000_0000 == 0).then_some((cob_id & 0x7FF) as u16);
    }

    /// 0x1015, the inhibit time in 100 µs.
    pub fn set_inhibit(&mut self, inhibit_100us: u16) {
        self.inhibit = span_100us(inhibit_100us);
    }

    /// The COB-ID messages go out on, if EMCY is on.
    pub fn cob_id(&self) -> Option<u16> {
        self.cob_id
    }

    /// The error register as the active errors make it.
    pub fn register(&self) -> u8 {
        // GENERIC while anything is active or lost (`tx_bits` holds it with the overflow's).
        let mut r = self.tx_bits | if self.lost_errors { register::GENERIC } else { 0 };
        for e in self.active.iter().take(self.active_len) {
            r |= register::GENERIC | register_bit(e.code) | e.bits;
        }
        r
    }

    /// Whether `code` is active.
    pub fn is_active(&self, code: EmcyCode) -> bool {
        self.position(code).is_some()
    }

    /// Where `code` is in the active list.
    // Out of line: raising, clearing and recording a sent EMCY each had a copy.
    // From the end (a raise adds a code only if it is not active: each is
    // there once): the loop counts down to 0, one compare fewer (4 bytes).
    #[inline(never)]
    fn position(&self, code: EmcyCode) -> Option<usize> {
        self.active.get(..self.active_len)?.iter().rposition(|e| e.code == code)
    }

    /// Raises an error: records it as active and queues its message.
    /// Returns false if it was active already (nothing is sent again).
    pub fn raise(&mut self, code: EmcyCode, info: [u8; 5]) -> bool {
        self.raise_with(code, 0, info)
    }

    /// Raises an error that also sets the error register bits `register`
    /// while it lasts, beyond those of its code's class (the Sendix's
    /// position error, generic code 0x1000, sets bit 5 "device profile").
    pub fn raise_with(&mut self, code: EmcyCode, register: u8, info: [u8; 5]) -> bool {
        self.raise_or_repeat(code, register, info, false, NEVER)
    }

    /// [`EmcyProducer::raise_with`] of an error that clears by itself at
    /// `until` ([`EmcyProducer::expire`]) unless it is raised so again
    /// meanwhile, which holds it until the new moment (and sends nothing:
    /// it is active). An error raised without a hold keeps none.
    pub fn raise_held(&mut self, code: EmcyCode, register: u8, info: [u8; 5], until: At) -> bool {
        self.raise_or_repeat(code, register, info, false, until)
    }

    /// Raises an error whose every event sends its message, also while it
    /// is active (a heartbeat consumer's timeout, once for each node).
    pub fn raise_each(&mut self, code: EmcyCode, info: [u8; 5]) {
        self.raise_or_repeat(code, 0, info, true, NEVER);
    }

    /// [`EmcyProducer::raise_held`]; `repeat`: an active error's message
    /// is sent again (with the register as it is); `until` [`NEVER`]: no
    /// hold (an active error keeps the one it has).
    // Out of line: one copy for all three.
    #[inline(never)]
    fn raise_or_repeat(&mut self, code: EmcyCode, register: u8, info: [u8; 5], repeat: bool, until: At) -> bool {
        let pos = self.position(code);
        match pos {
            // Active: a hold moves (the next full call looks at them all
            // again); its message goes again only if each event sends one.
            Some(pos) => {
                if until != NEVER
                    && let Some(e) = self.active.get_mut(pos)
                {
                    e.until = until;
                    self.held = 0;
                }
                if !repeat {
                    return false;
                }
            }
            // New, in the next free entry, with its hold if any ([`NEVER`]: none).
            None => match self.active.get_mut(self.active_len) {
                Some(e) => {
                    *e = Active { code, bits: register, until };
                    if until != NEVER {
                        self.held = 0;
                    }
                    // `get_mut` found the slot: `active_len` < A.
                    #[allow(clippy::arithmetic_side_effects)]
                    {
                        self.active_len += 1;
                    }
                }
                None => self.lost_errors = true,
            },
        }
        let [i0, i1, i2, i3, i4] = info;
        self.push(code, 0, i0, [i1, i2, i3, i4]);
        pos.is_none()
    }

    /// Sends a message for an event that has no lasting state (e.g. a PDO
    /// length error): it sets no active error.
    pub fn signal(&mut self, code: EmcyCode, info: [u8; 5]) {
        let [i0, i1, i2, i3, i4] = info;
        self.push(code, register::GENERIC | register_bit(code), i0, [i1, i2, i3, i4]);
    }

    /// The transmit queue refused frames (`refused`: so far): raises `code`
    /// (0x8110, or the device's code for lost frames) once, with bytes 3–6
    /// the count and byte 7 = 1 (transmit; a receive overrun has 0 there),
    /// until [`EmcyProducer::tx_drained`]. Apart from the receive overrun's
    /// 0x8110: each raises and clears on its own.
    pub fn tx_overflow(&mut self, code: EmcyCode, refused: u32) {
        if self.tx_overflow {
            return;
        }
        self.tx_overflow = true;
        self.tx_bits = register::GENERIC | register::COMMUNICATION | register_bit(code);
        let [a, b, c, d] = refused.to_le_bytes();
        self.push(code, 0, a, [b, c, d, 1]);
    }

    /// The transmit queue drained after an overflow: the error clears, and
    /// "error reset" goes out if no other error is active.
    pub fn tx_drained(&mut self) {
        if !self.tx_overflow {
            return;
        }
        (self.tx_overflow, self.tx_bits) = (false, 0);
        self.error_reset();
    }

    /// "Error reset" (0x0000) once no error is left: nothing active, no
    /// transmit queue overflow; the lost errors are forgotten with them.
    // Out of line: `tx_drained` and `remove` share it.
    #[inline(never)]
    fn error_reset(&mut self) {
        if self.active_len == 0 && !self.tx_overflow {
            self.lost_errors = false;
            // Nothing active, nothing lost, no overflow: the register `push` reads is 0.
            self.push(EmcyCode::NO_ERROR, 0, 0, [0; 4]);
        }
    }

    /// Whether a transmit queue overflow is active.
    pub fn tx_overflow_active(&self) -> bool {
        self.tx_overflow
    }

    /// Clears an error; when the last one goes, queues "error reset" (0x0000).
    // Out of line: its callers (the PDOs' sink, heartbeat recovery, the device) each took a copy.
    #[inline(never)]
    pub fn clear(&mut self, code: EmcyCode) {
        if let Some(pos) = self.position(code) {
            self.remove(pos);
        }
    }

    /// Clears the active error at `pos` (< `active_len`).
    // Out of line: `clear` and `expire_held` share it.
    #[inline(never)]
    fn remove(&mut self, pos: usize) {
        // The set has no order (only membership and the register bits
        // count): the last entry takes the cleared one's place.
        // The callers' `pos` < `active_len`: it is at least 1.
        #[allow(clippy::arithmetic_side_effects)]
        {
            self.active_len -= 1;
        }
        if let Some(&last) = self.active.get(self.active_len)
            && let Some(slot) = self.active.get_mut(pos)
        {
            *slot = last;
        }
        self.error_reset();
    }

    /// Clears the held errors whose hold ended by `now`; when the next
    /// one ends ([`NEVER`]: no error is held). Every full `Node::process`
    /// asks, so the common answer takes one compare.
    #[inline(always)]
    pub fn expire(&mut self, now: At) -> At {
        if self.held <= now { self.expire_held(now) } else { self.held }
    }

    fn expire_held(&mut self, now: At) -> At {
        let mut held = NEVER;
        // From the last entry down: `remove` moves the last one, which was looked at already.
        for i in (0..self.active_len).rev() {
            match self.active.get(i) {
                Some(e) if e.until <= now => self.remove(i),
                Some(e) => held = held.min(e.until),
                None => {}
            }
        }
        self.held = held;
        held
    }

    /// Forgets every error and message (reset communication keeps nothing).
    pub fn reset(&mut self) {
        // In place: the lists are read only up to their lengths.
        // `held` 0: the next full call looks (and finds none), as at power-on;
        // all five fields zero are one store of zeros (4 bytes less than `NEVER`).
        (self.active_len, self.head, self.len, self.free_at, self.held) = (0, 0, 0, 0, 0);
        (self.lost_errors, self.tx_overflow, self.tx_bits) = (false, false, 0);
    }

    /// Queues a message whose error register is the active errors' and
    /// `extra`; its manufacturer-specific bytes are `i0` and `info`.
    // Out of line: three callers each had a copy (76 bytes more); the
    // register read here, not at each of them. The first byte apart: the
    // last four are one register (the overflow's count and 1 by a shift,
    // not through the stack).
    #[inline(never)]
    fn push(&mut self, code: EmcyCode, extra: u8, i0: u8, info: [u8; 4]) {
        // Read before the check (after it, 8 bytes more).
        let register = self.register() | extra;
        if self.len == Q {
            self.overflows = self.overflows.saturating_add(1);
            self.lost_errors = true;
            return;
        }
        if let Some(slot) = self.queue.get_mut(Self::ring(self.head, self.len)) {
            // `Emcy::emit`'s bytes, built as two words: the code a half-word
            // (as bytes, LLVM split and joined it again: 12 bytes more).
            let low = u32::from(code.0) | u32::from(register) << 16 | u32::from(i0) << 24;
            let high = u32::from_le_bytes(info);
            *slot = (u64::from(high) << 32 | u64::from(low)).to_le_bytes();
            // `len` < Q: checked above.
            #[allow(clippy::arithmetic_side_effects)]
            {
                self.len += 1;
            }
        }
    }

    /// The ring position `n` after `head`.
    // `head` < Q and `n` ≤ Q: the sum fits; `Q.max(1)` is never zero.
    #[allow(clippy::arithmetic_side_effects)]
    fn ring(head: usize, n: usize) -> usize {
        (head + n) % Q.max(1)
    }

    /// Takes the oldest queued message (`len` != 0).
    fn pop(&mut self) -> Option<[u8; 8]> {
        let e = *self.queue.get(self.head)?;
        self.head = Self::ring(self.head, 1);
        // The callers checked `len` != 0.
        #[allow(clippy::arithmetic_side_effects)]
        {
            self.len -= 1;
        }
        Some(e)
    }

    /// The next queued message to hand on at `now`: with the COB-ID it goes
    /// out on, if it may (the inhibit time respected, and `room` in the
    /// transmit queue); while EMCY is off (0x1014 bit 31), with `None`
    /// whatever `room` says: it is not sent, but the node still records it
    /// (0x1001, 0x1003), and the queue does not fill up with messages that
    /// never leave. One call for both, so that the node has one loop. The
    /// message as its data bytes ([`crate::wire::emcy::Emcy::parse`] reads them).
    pub fn next(&mut self, now: At, room: bool) -> Option<(Option<u16>, [u8; 8])> {
        if self.len == 0 {
            return None;
        }
        let sending = self.cob_id.is_some();
        if sending && (!room || now < self.free_at) {
            return None;
        }
        if sending {
            self.free_at = later(now, self.inhibit);
        }
        // `len` != 0: a message is there.
        Some((self.cob_id, self.pop()?))
    }

    /// Whether messages wait to go out (or, while EMCY is off, to be recorded).
    pub fn has_queued(&self) -> bool {
        self.len != 0
    }

    /// When the next queued message may go out.
    pub fn deadline(&self) -> At {
        if self.cob_id.is_none() || self.len == 0 {
            return NEVER;
        }
        self.free_at
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        let by = at_by(by);
        shift(&mut self.free_at, by);
        // The next full call looks at the holds again (`rebase` makes it full).
        self.held = 0;
        // Every entry, the free ones too: a raise writes its entry whole, so
        // theirs is never read (one loop of a fixed count, no bound check).
        for e in &mut self.active {
            shift(&mut e.until, by);
        }
    }

    /// Messages lost to a full queue.
    pub fn overflows(&self) -> u32 {
        self.overflows
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::deadline_of;
    use crate::wire::emcy::Emcy;

    fn us(n: u32) -> At {
        n
    }

    /// [`EmcyProducer::next`] with the message parsed.
    fn next<const A: usize, const Q: usize>(e: &mut EmcyProducer<A, Q>, now: At, room: bool) -> Option<(Option<u16>, Emcy)> {
        e.next(now, room).map(|(id, data)| (id, Emcy::parse(&data).unwrap_or_else(|| unreachable!())))
    }

    #[test]
    fn raise_and_clear_drive_the_register_and_error_reset() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x81);
        assert!(e.raise(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [3, 0, 0, 0, 0]));
        assert!(!e.raise(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [3, 0, 0, 0, 0]), "already active");
        assert_eq!(e.register(), 0x11);
        assert_eq!(e.next(us(0), true), Some((Some(0x81), [0x30, 0x81, 0x11, 3, 0, 0, 0, 0])));
        e.clear(EmcyCode::LIFE_GUARD_OR_HEARTBEAT);
        assert_eq!(e.register(), 0);
        assert_eq!(e.next(us(1), true), Some((Some(0x81), [0; 8])));
        assert_eq!(e.next(us(2), true), None);
    }

    #[test]
    fn extra_register_bits_last_as_long_as_their_error() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x81);
        assert!(e.raise_with(EmcyCode(0x1000), register::PROFILE, [0; 5]));
        assert!(e.raise(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [0; 5]));
        assert_eq!(e.register(), 0x31);
        e.clear(EmcyCode(0x1000));
        assert_eq!(e.register(), 0x11, "bit 5 went with 0x1000, the heartbeat's bits stay");
        assert!(e.raise(EmcyCode(0x1000), [0; 5]));
        assert_eq!(e.register(), 0x11, "raised again without extra bits");
        assert_eq!(next(&mut e, us(0), true).map(|(_, m)| m.register), Some(0x21));
    }

    #[test]
    fn an_error_raised_each_time_sends_each_time() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x81);
        e.raise_each(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [3, 0, 0, 0, 0]);
        e.raise_each(EmcyCode::LIFE_GUARD_OR_HEARTBEAT, [4, 0, 0, 0, 0]);
        assert_eq!(e.register(), 0x11);
        let sent = |e: &mut EmcyProducer<4, 4>| next(e, us(0), true).map(|(_, m)| (m.register, m.info[0]));
        assert_eq!((sent(&mut e), sent(&mut e), sent(&mut e)), (Some((0x11, 3)), Some((0x11, 4)), None));
        e.clear(EmcyCode::LIFE_GUARD_OR_HEARTBEAT);
        assert_eq!(e.register(), 0, "one clear: the error was active once");
    }

    #[test]
    fn a_held_error_clears_when_its_hold_ends() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x81);
        assert_eq!(e.expire(us(0)), NEVER, "nothing held (all zero bits: the first look finds none)");
        assert!(e.raise_held(EmcyCode(0x8110), register::COMMUNICATION, [3, 0, 0, 0, 0], us(1000)));
        assert!(e.raise(EmcyCode(0x8130), [0; 5]));
        assert!(!e.raise_held(EmcyCode(0x8110), register::COMMUNICATION, [5, 0, 0, 0, 0], us(1500)), "active: held longer, nothing sent");
        assert!(!e.raise(EmcyCode(0x8110), [0; 5]), "a raise without a hold keeps the hold");
        assert_eq!(e.expire(us(999)), us(1500));
        assert_eq!(e.expire(us(1000)), us(1500), "the later hold counts");
        e.shift(500);
        assert_eq!(e.expire(us(999)), us(1000), "moved with the epoch");
        assert_eq!(e.expire(us(1000)), NEVER);
        assert!(!e.is_active(EmcyCode(0x8110)));
        assert!(e.is_active(EmcyCode(0x8130)), "not held: it stays");
        let codes: [_; 3] = core::array::from_fn(|_| next(&mut e, us(0), true).map(|(_, m)| m.code));
        assert_eq!(codes, [Some(EmcyCode(0x8110)), Some(EmcyCode(0x8130)), None], "no error reset: 0x8130 is active");
        e.clear(EmcyCode(0x8130));
        assert!(e.raise_held(EmcyCode(0x8140), register::COMMUNICATION, [0; 5], us(10)));
        assert!(e.raise_held(EmcyCode(0x8110), register::COMMUNICATION, [0; 5], us(20)));
        assert_eq!(e.expire(us(20)), NEVER, "both in one look");
        let codes: [_; 4] = core::array::from_fn(|_| next(&mut e, us(0), true).map(|(_, m)| (m.code, m.register)));
        assert_eq!(codes[3], Some((EmcyCode::NO_ERROR, 0)), "one error reset, after the last");
        assert!(e.raise_held(EmcyCode(0x8110), register::COMMUNICATION, [0; 5], us(30)));
        e.reset();
        assert_eq!(e.expire(us(40)), NEVER, "a reset forgets the held error: nothing to clear, nothing held");
        assert_eq!(e.next(us(40), true), None, "and its message");
    }

    #[test]
    fn an_epoch_move_leaves_nothing_held_in_a_free_entry() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x81);
        assert!(e.raise_held(EmcyCode(0x8110), register::COMMUNICATION, [0; 5], us(1000)));
        e.clear(EmcyCode(0x8110));
        // The free entry's old hold moves too, past: to 0.
        e.shift(5000);
        assert!(e.raise(EmcyCode(0x8130), [0; 5]));
        assert_eq!(e.expire(us(0)), NEVER, "the new error in that entry is not held");
        assert!(e.is_active(EmcyCode(0x8130)));
    }

    #[test]
    fn inhibit_time_spaces_messages() {
        let mut e = EmcyProducer::<4, 4>::default();
        e.set_cob_id(0x85);
        e.set_inhibit(10); // 1 ms
        e.signal(EmcyCode::PDO_LENGTH, [0; 5]);
        e.signal(EmcyCode::PDO_LENGTH_EXCEEDED, [0; 5]);
        assert_eq!(e.next(us(100), false), None, "no room in the transmit queue");
        assert!(e.next(us(100), true).is_some());
        assert_eq!(deadline_of(e.deadline()), Some(us(1100)));
        assert_eq!(e.next(us(1099), true), None);
        assert_eq!(next(&mut e, us(1100), true).map(|(_, m)| m.code), Some(EmcyCode(0x8220)));
    }

    #[test]
    fn a_full_queue_counts_and_shows_in_the_register() {
        let mut e = EmcyProducer::<1, 2>::default();
        e.set_cob_id(0x8000_0081);
        e.signal(EmcyCode(0x8210), [0; 5]);
        e.signal(EmcyCode(0x8210), [0; 5]);
        e.signal(EmcyCode(0x8210), [0; 5]);
        assert_eq!(e.overflows(), 1);
        assert_eq!(e.register() & register::GENERIC, register::GENERIC);
        // EMCY off (bit 31): recorded, not sent, whether or not the transmit queue has room.
        assert_eq!(next(&mut e, us(0), false).map(|(id, m)| (id, m.code)), Some((None, EmcyCode(0x8210))));
        assert_eq!(next(&mut e, us(0), true).map(|(id, m)| (id, m.code)), Some((None, EmcyCode(0x8210))));
        assert_eq!(e.next(us(0), true), None);
        assert!(e.raise(EmcyCode(0x8130), [0; 5]));
        assert!(e.raise(EmcyCode(0x8110), [0; 5]), "more active errors than slots are still reported");
        assert_eq!(register_bit(EmcyCode(0x4210)), register::TEMPERATURE);
        assert_eq!(register_bit(EmcyCode(0xFF00)), register::MANUFACTURER);
    }

    #[test]
    fn the_register_follows_the_transmit_overflow_lost_errors_and_codes_without_a_class() {
        let mut e = EmcyProducer::<1, 2>::default();
        e.set_cob_id(0x81);
        // A manufacturer-specific code (class 0xF) for the overflow: its bit and COMMUNICATION.
        e.tx_overflow(EmcyCode(0xF110), 3);
        assert_eq!(e.register(), 0x91);
        assert_eq!(e.next(us(0), true), Some((Some(0x81), [0x10, 0xF1, 0x91, 3, 0, 0, 0, 1])));
        // A code without a class bit is GENERIC alone, beside the overflow's.
        assert!(e.raise(EmcyCode(0x1000), [0; 5]));
        assert_eq!(e.register(), 0x91);
        e.tx_drained();
        assert_eq!(e.register(), 0x01, "the overflow's bits went with it, the error's GENERIC stays");
        assert_eq!(e.next(us(0), true).map(|(_, m)| m[2]), Some(0x91), "queued with the overflow active");
        // The list is full: a lost error keeps GENERIC until the last one clears.
        assert!(e.raise(EmcyCode(0x2310), [0; 5]), "sent, though not kept");
        assert_eq!(e.register(), 0x01);
        e.clear(EmcyCode(0x1000));
        assert_eq!(e.register(), 0);
        assert_eq!(e.next(us(0), true).map(|(_, m)| m[..3] == [0x10, 0x23, 0x01]), Some(true), "the lost error's message");
        assert_eq!(e.next(us(0), true), Some((Some(0x81), [0; 8])), "error reset: register 0");
        // Overflow and drain with nothing else active: error reset with register 0.
        e.tx_overflow(EmcyCode(0x8110), 1);
        assert_eq!(e.register(), 0x11);
        e.tx_drained();
        assert_eq!(e.register(), 0);
        assert_eq!(e.next(us(0), true).map(|(_, m)| m[2]), Some(0x11));
        assert_eq!(e.next(us(0), true), Some((Some(0x81), [0; 8])));
    }
}
