//! Virtual time. Tests own a clock and move it forward explicitly, so every
//! timing assertion is exact and independent of host load.

use canopen_core::time::{Duration, Instant};

/// A clock that only moves when told to, and never backwards.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VirtualClock {
    now: Instant,
}

impl VirtualClock {
    /// A clock at time zero.
    pub fn new() -> Self {
        VirtualClock::default()
    }

    /// The current time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// Moves forward by `d`; returns the new time.
    pub fn advance(&mut self, d: Duration) -> Instant {
        self.now += d;
        self.now
    }

    /// Moves forward to `t`; a `t` in the past leaves the clock where it is.
    /// Returns the new time.
    pub fn advance_to(&mut self, t: Instant) -> Instant {
        self.now = self.now.max(t);
        self.now
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_only_forward() {
        let mut c = VirtualClock::new();
        assert_eq!(c.advance(Duration::from_millis(10)), Instant::from_micros(10_000));
        assert_eq!(c.advance_to(Instant::from_micros(5)), Instant::from_micros(10_000));
        assert_eq!(c.advance_to(Instant::from_micros(12_000)), Instant::from_micros(12_000));
        assert_eq!(c.now(), Instant::from_micros(12_000));
    }
}
