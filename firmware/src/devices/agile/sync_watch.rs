//! SYNC monitoring (§9.2.4, M-L1440-1448; D55 in docs/devices/agile.md):
//! with 0x1006 set, a SYNC that comes more than 50 % later than the
//! communication cycle period after the one before is a communication
//! error, the inverter's F20.24 "SYNC error (SYNC timing)", reacting as
//! 0x6007 says. The watch starts with the first SYNC in Operational and
//! stops on leaving it (0x1006 = 0: no monitoring, as the manual says).

use canopen_core::node::Ctx;
use canopen_core::time::{Duration, Instant};

/// 0x1006 communication cycle period [µs].
const CYCLE_PERIOD: u16 = 0x1006;

/// The last SYNC, while watched. All zero bits at power-on.
#[derive(Clone, Copy, Debug)]
pub(super) struct SyncWatch {
    last: Instant,
    armed: bool,
}

impl SyncWatch {
    /// Not watching.
    pub(super) const NEW: SyncWatch = SyncWatch { last: Instant::ZERO, armed: false };

    /// A SYNC came at `now`.
    pub(super) fn seen(&mut self, now: Instant) {
        (self.last, self.armed) = (now, true);
    }

    /// Stops watching (until the next SYNC).
    pub(super) fn stop(&mut self) {
        self.armed = false;
    }

    /// Whether the next SYNC is overdue now (the watch then stops), and
    /// otherwise when it will be.
    pub(super) fn check(&mut self, ctx: &Ctx<'_>) -> (bool, Option<Instant>) {
        let period = u64::from(ctx.read_u32(CYCLE_PERIOD, 0).unwrap_or(0));
        if !self.armed || period == 0 {
            return (false, None);
        }
        // "um mehr als 50 %": later than 1.5 periods.
        let deadline = self.last + Duration::from_micros(period + period / 2 + 1);
        if ctx.now() >= deadline {
            self.armed = false;
            (true, None)
        } else {
            (false, Some(deadline))
        }
    }
}
