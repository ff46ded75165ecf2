//! Monotonic time as the core sees it: passed in by the caller, never read
//! from a clock. Microsecond resolution covers the 100 µs units of CiA 301
//! inhibit times; 64 bits never overflow in practice, and every operation
//! saturates instead of panicking if time ever steps back.

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

/// A sum saturates at the last microsecond but one, so that a deadline
/// at the end of time is still a deadline as an [`At`] (earlier is harmless).
impl Add<Duration> for Instant {
    type Output = Instant;
    // Out of line: the 64-bit saturating add was copied to every deadline (240 bytes more).
    #[inline(never)]
    fn add(self, rhs: Duration) -> Instant {
        let sum = self.0.saturating_add(rhs.0);
        Instant(sum.wrapping_sub(u64::from(sum == NEVER)))
    }
}

/// The earlier of two deadlines, where `None` is no deadline: for the
/// devices' [`crate::node::Application::poll`] deadlines (`Iterator::min`
/// over `Option<Instant>` chains took 250 bytes more flash). The core's
/// own fold as [`At`]s.
pub fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match b {
        Some(t) if a.is_none_or(|s| t < s) => b,
        _ => a,
    }
}

/// A deadline as the core keeps and folds it: microseconds since the
/// start, [`NEVER`] for none, so that the earlier of two is a plain `min`.
/// On a 32-bit core an `Option<Instant>` is 16 bytes returned through
/// memory and compared in two steps; this is one register pair and one
/// compare. A deadline is never [`NEVER`]: adding to an [`Instant`]
/// saturates a microsecond before it. The services answer their deadlines
/// as `At`; [`crate::node::Node::process`] hands the drivers an
/// `Option<Instant>`.
pub type At = u64;

/// No deadline.
pub const NEVER: At = u64::MAX;

/// `deadline` as an [`At`].
pub(crate) fn at(deadline: Option<Instant>) -> At {
    deadline.map_or(NEVER, Instant::as_micros)
}

/// `at` as a deadline.
pub(crate) fn deadline_of(at: At) -> Option<Instant> {
    (at != NEVER).then_some(Instant(at))
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
        assert_eq!(t.as_micros(), u64::MAX - 1, "a microsecond before the end: an `At` deadline, not `NEVER`");
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
        assert_eq!(earliest(None, None), None);
    }
}
