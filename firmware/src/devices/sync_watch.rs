//! The SYNC period watch two devices share: the time of the last SYNC, and
//! whether the next one is overdue against 0x1006 "communication cycle
//! period" (CiA 301 §7.5.2.6) plus the device's own tolerance. 0x1006 = 0
//! is no monitoring. What an overdue SYNC means stays with each device.

use canopen_core::node::Ctx;
use canopen_core::time::{Duration, Instant};

/// 0x1006 communication cycle period [µs].
const CYCLE_PERIOD: u16 = 0x1006;

/// The last SYNC, while watched. All zero bits before the first (an
/// `Option` would not be, see [`canopen_core::node`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SyncWatch {
    last: Instant,
    armed: bool,
}

impl SyncWatch {
    /// Not watching: no SYNC yet.
    pub(crate) const NEW: SyncWatch = SyncWatch { last: Instant::ZERO, armed: false };

    /// The communication cycle period [µs], `None` while 0x1006 is 0.
    pub(crate) fn period(ctx: &Ctx<'_>) -> Option<u64> {
        ctx.read_u32(CYCLE_PERIOD, 0).filter(|p| *p != 0).map(u64::from)
    }

    /// The time from the last SYNC to `now` [µs], if watched.
    pub(crate) fn since(&self, now: Instant) -> Option<u64> {
        self.armed.then(|| now.saturating_duration_since(self.last).as_micros())
    }

    /// A SYNC came at `now`: the time since the one before [µs], if watched.
    pub(crate) fn seen(&mut self, now: Instant) -> Option<u64> {
        let since = self.since(now);
        (self.last, self.armed) = (now, true);
        since
    }

    /// Stops watching (until the next SYNC).
    pub(crate) fn stop(&mut self) {
        self.armed = false;
    }

    /// When the next SYNC is overdue, more than `late` µs after the last
    /// one; `None` while not watching.
    pub(crate) fn deadline(&self, late: u64) -> Option<Instant> {
        self.armed.then(|| self.last + Duration::from_micros(late + 1))
    }
}
