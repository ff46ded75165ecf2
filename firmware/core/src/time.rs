//! Monotonic time as the core sees it: passed in by the caller, never read
//! from a clock. Microsecond resolution covers the 100 µs units of CiA 301
//! inhibit times.
//!
//! Two widths. The board and the device's hooks see [`Instant`] and
//! [`Duration`], 64 bits that never overflow in practice (every operation
//! saturates instead of panicking, also if time steps back). The services
//! keep their timers as [`At`]s, 32 bits of microseconds since the node's
//! epoch, which the node moves forward before they would wrap (see
//! [`At`]): a compare, an add or a store of one is a single instruction
//! on a 32-bit core. The few timers that may lie further ahead than 2^31
//! µs (35.8 minutes) are [`Far`]s.

use core::ops::{Add, AddAssign};

/// A span of time in microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Duration(u64);

impl Duration {
    /// No time.
    pub const ZERO: Duration = Duration(0);

    /// From microseconds.
    pub const fn from_micros(us: u64) -> Self {
        Duration(us)
    }

    /// From milliseconds (saturating).
    pub const fn from_millis(ms: u64) -> Self {
        Duration(ms.saturating_mul(1_000))
    }

    /// From seconds (saturating).
    pub const fn from_secs(s: u64) -> Self {
        Duration(s.saturating_mul(1_000_000))
    }

    /// In microseconds.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// In whole milliseconds.
    pub const fn as_millis(self) -> u64 {
        self.0 / 1_000
    }
}

impl Add for Duration {
    type Output = Duration;
    fn add(self, rhs: Duration) -> Duration {
        Duration(self.0.saturating_add(rhs.0))
    }
}

/// A point in time, in microseconds since an arbitrary start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Instant(u64);

impl Instant {
    /// The start of time.
    pub const ZERO: Instant = Instant(0);

    /// From microseconds since the start.
    pub const fn from_micros(us: u64) -> Self {
        Instant(us)
    }

    /// Microseconds since the start.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// Time from `earlier` to `self`, or zero if `earlier` is later.
    pub const fn saturating_duration_since(self, earlier: Instant) -> Duration {
        Duration(self.0.saturating_sub(earlier.0))
    }
}

/// A sum saturates at the end of time.
impl Add<Duration> for Instant {
    type Output = Instant;
    // Out of line: the 64-bit saturating add was copied to every device's deadline.
    #[inline(never)]
    fn add(self, rhs: Duration) -> Instant {
        Instant(self.0.saturating_add(rhs.0))
    }
}

/// The earlier of two deadlines, where `None` is no deadline: for the
/// devices' [`crate::node::Application::poll`] deadlines (`Iterator::min`
/// over `Option<Instant>` chains took 250 bytes more flash). The core's
/// own fold as [`At`]s.
pub fn earliest<T: Ord>(a: Option<T>, b: Option<T>) -> Option<T> {
    match b {
        Some(ref t) if a.as_ref().is_none_or(|s| t < s) => b,
        _ => a,
    }
}

/// A moment as the core's services keep it: microseconds since the node's
/// epoch, 32 bits (a 64-bit compare, add or store costs a second register
/// and an `adc`/`sbc` on a 32-bit core). The node converts each
/// [`Instant`] it is given ([`Node::process`](crate::node::Node::process),
/// [`Node::on_frame`](crate::node::Node::on_frame), ...) into an `At` and
/// moves its epoch forward ([`REBASE`]) before `now` reaches 2^31 µs, so a
/// moment is never ambiguous: every deadline a service arms lies less
/// than 2^31 µs ahead (a longer one is kept as a [`Far`]), `now + span`
/// never overflows and a plain compare orders any two. [`NEVER`] is no
/// deadline, so that the earlier of two is a plain `min`. The services
/// answer their deadlines as `At`; [`crate::node::Node::process`] hands
/// the drivers an `Option<Instant>`.
pub type At = u32;

/// No deadline.
pub const NEVER: At = u32::MAX;

/// The node moves its epoch to `now` when `now` is this far past it: every
/// `At` a service holds drops by the same amount (a past one to 0), so
/// `now` stays below 2^31 and a span below 2^31 µs added to it stays below
/// [`NEVER`].
pub const REBASE: u32 = 1 << 31;

/// The longest span an [`At`] deadline may lie ahead of `now`: the
/// services' spans of u16 milliseconds (65.5 s) and u16 × 100 µs (6.6 s)
/// are far below it; the longer ones (guarding's life time, the SYNC
/// period and window of 0x1006/0x1007) are [`Far`]s, an SDO timeout set
/// longer is cut to it.
pub const MAX_SPAN: u32 = REBASE - 1;

/// `span` µs after `now`. It cannot overflow: `now` is below [`REBASE`]
/// (the node moves its epoch before) and `span` at most [`MAX_SPAN`].
pub(crate) const fn later(now: At, span: u32) -> At {
    now.wrapping_add(span)
}

/// `ms` milliseconds in µs (at most 65.5 s).
pub(crate) const fn ms_span(ms: u16) -> u32 {
    // 65,535 × 1000 fits a u32.
    #[allow(clippy::arithmetic_side_effects)]
    {
        ms as u32 * 1000
    }
}

/// `n` × 100 µs in µs (an inhibit time: at most 6.6 s).
pub(crate) const fn span_100us(n: u16) -> u32 {
    // 65,535 × 100 fits a u32.
    #[allow(clippy::arithmetic_side_effects)]
    {
        n as u32 * 100
    }
}

/// A microsecond span as an [`At`] span, at most [`MAX_SPAN`].
pub(crate) fn span(d: Duration) -> u32 {
    d.as_micros().min(u64::from(MAX_SPAN)) as u32
}

/// An epoch move of `by` µs as the [`At`] shifts take it: cut to
/// `u32::MAX` (an `At` moved that far is 0 either way).
// In line: every service's shift is inlined into the node's rebase, where
// LLVM computes the cut once and passes one register to each call.
#[inline(always)]
pub(crate) fn at_by(by: u64) -> u32 {
    u32::try_from(by).unwrap_or(u32::MAX)
}

/// `t` moved back by `by` µs (an epoch move, [`at_by`]): 0 once past,
/// [`NEVER`] stays.
// Out of line, as the other shifts: an epoch move is rare, and each of its
// twenty-odd fields in line cost 30 bytes.
#[inline(never)]
pub(crate) fn shift(t: &mut At, by: u32) {
    if *t != NEVER {
        *t = t.saturating_sub(by);
    }
}

/// `t` moved back by `by` µs ([`at_by`]), `None` staying `None` (an armed
/// deadline is never [`NEVER`]).
#[inline(never)]
pub(crate) fn shift_opt(t: &mut Option<At>, by: u32) {
    if let Some(t) = t {
        *t = t.saturating_sub(by);
    }
}

/// A deadline that may lie further ahead than an [`At`] can (up to 4.6
/// hours: a guard time of 65,535 ms × a life time factor of 255; 0x1006
/// and 0x1007 up to 71.6 minutes): microseconds since the node's epoch in
/// 64 bits, compared with `now` exactly. Its [`At`] is cut to the last
/// microsecond an `At` holds, which wakes the node early (harmless: the
/// epoch moves then, and the cut is taken again from there).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Far(u64);

impl Far {
    /// No deadline (no synchronous window).
    pub const NEVER: Far = Far(u64::MAX);

    /// The epoch (all zero bits).
    pub const ZERO: Far = Far(0);

    /// `span` µs after `now`.
    /// (No overflow: `now` and the spans, at most 2^34 µs, are far below 2^63.)
    pub(crate) fn after(now: At, span: u64) -> Far {
        Far(u64::from(now).wrapping_add(span))
    }

    /// `span` µs after this deadline (an armed one: not [`Far::NEVER`]).
    pub(crate) fn then(self, span: u64) -> Far {
        Far(self.0.wrapping_add(span))
    }

    /// Whether `now` is past the deadline (a window ending at it has closed).
    pub(crate) fn passed(self, now: At) -> bool {
        u64::from(now) > self.0
    }

    /// Whether the deadline has come at `now`.
    pub(crate) fn reached(self, now: At) -> bool {
        u64::from(now) >= self.0
    }

    /// The deadline as an [`At`], or earlier if it lies beyond one.
    pub(crate) fn at(self) -> At {
        self.0.min(u64::from(NEVER - 1)) as At
    }

    /// Moved back by `by` µs (an epoch move), 0 once past; [`Far::NEVER`] stays.
    #[inline(never)]
    pub(crate) fn shift(&mut self, by: u64) {
        if *self != Far::NEVER {
            self.0 = self.0.saturating_sub(by);
        }
    }
}

/// `deadline` as an [`At`] ([`NEVER`] for none).
pub(crate) fn at(deadline: Option<At>) -> At {
    deadline.unwrap_or(NEVER)
}

/// A device's deadline (an [`Instant`]) as an [`At`] of the node whose
/// epoch is `epoch`: 0 if it has passed, cut to the last `At` but one if
/// it lies further ahead (the node then wakes early, which is harmless).
pub(crate) fn at_since(epoch: u64, deadline: Option<Instant>) -> At {
    match deadline {
        Some(t) => t.as_micros().saturating_sub(epoch).min(u64::from(NEVER - 1)) as At,
        None => NEVER,
    }
}

/// `at` as a deadline (`None` for [`NEVER`]).
pub(crate) fn deadline_of(at: At) -> Option<At> {
    (at != NEVER).then_some(at)
}

impl AddAssign<Duration> for Instant {
    fn add_assign(&mut self, rhs: Duration) {
        *self = *self + rhs;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_saturates_instead_of_panicking() {
        let t = Instant::from_micros(u64::MAX - 1) + Duration::from_secs(1);
        assert_eq!(t.as_micros(), u64::MAX);
        assert_eq!(Instant::from_micros(5).saturating_duration_since(Instant::from_micros(9)), Duration::ZERO);
        assert_eq!(Duration::from_millis(u64::MAX).as_micros(), u64::MAX);
        assert_eq!(Duration::from_millis(3) + Duration::from_micros(500), Duration::from_micros(3_500));
        assert_eq!(Duration::from_micros(3_999).as_millis(), 3);
    }

    #[test]
    fn earliest_ignores_missing_deadlines() {
        let (early, late) = (Some(Instant::from_micros(3)), Some(Instant::from_micros(7)));
        assert_eq!(earliest(early, late), early);
        assert_eq!(earliest(late, early), early);
        assert_eq!(earliest(None, late), late);
        assert_eq!(earliest(late, None), late);
        assert_eq!(earliest::<Instant>(None, None), None);
    }
}
