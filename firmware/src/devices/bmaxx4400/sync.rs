//! The drive's synchronisation to the SYNC (§5.4 M-L2293-2365; P0830 bits
//! 6 and 8, §4.3.7/§4.3.8 M-L749-762; D66). With a SYNC interval in 0x1006
//! ("muss das Sync-Intervall auf die Zeit des Sync-Telegramms eingestellt
//! werden") the drive follows the SYNC in its position control (−4, and ip
//! 7, which runs as −4); "Wird der Regler nicht über CANopen synchronisiert,
//! darf im Regler keine Überwachung der Synchronisierung erfolgen".
//! The card's PLL ("nach dem ersten empfangenen Sync-Telegramm aktiviert")
//! evens out the SYNC's jitter; without it (bit 8) the drive's own
//! tolerance, 40 µs, applies. A SYNC outside the tolerance, or none, is
//! drive error 00A5h "Regler nicht synchron zu externem Signal" (EMCY
//! 8100h). Once the SYNC is back, the PLL runs in step again after "im
//! worst case eine halbe Minute", unless bit 6 resets it after the loss:
//! until then a fault reset does not acknowledge the error.

use canopen_core::node::Ctx;

use super::speed::configured;
use crate::devices::sync_watch::SyncWatch;

/// Drive error 00A5h, the drive not synchronous to the SYNC.
pub(super) const NOT_SYNCHRONOUS: u8 = 0xA5;
/// P0830 bit 6: the synchronisation is reset after a SYNC loss.
const RESET_AFTER_LOSS: u32 = 1 << 6;
/// P0830 bit 8: the PLL is off.
const PLL_OFF: u32 = 1 << 8;
/// "Sync Toleranz: max. 40 µs" without the PLL.
const TOLERANCE_US: u64 = 40;
/// The PLL's worst case to run in step again after a SYNC loss.
const RELOCK_US: u64 = 30_000_000;

/// When the SYNCs came: all zero bits before the first.
#[derive(Clone, Copy, Debug)]
pub(super) struct Monitor {
    /// The last SYNC, since reset communication.
    watch: SyncWatch,
    /// The first SYNC of the run without a gap [µs].
    run: u64,
}

impl Monitor {
    /// No SYNC yet.
    pub(super) const NEW: Monitor = Monitor { watch: SyncWatch::NEW, run: 0 };

    /// The SYNC interval and how far a SYNC may be off it [µs], if the drive is synchronised to the SYNC.
    fn window(ctx: &Ctx<'_>) -> Option<(u64, u64)> {
        let period = SyncWatch::period(ctx)?;
        // The PLL evens out a SYNC up to half a period off; a later one is a lost one.
        Some((period, if configured(ctx, PLL_OFF) { TOLERANCE_US } else { period / 2 }))
    }

    /// A SYNC arrived: true if it came outside the window (the drive is not synchronous).
    pub(super) fn on_sync(&mut self, ctx: &Ctx<'_>) -> bool {
        let now = ctx.now();
        let since = self.watch.seen(now);
        let off = since.is_some_and(|since| Self::window(ctx).is_some_and(|(period, tolerance)| since.abs_diff(period) > tolerance));
        if since.is_none() || off {
            self.run = now.as_micros();
        }
        off
    }

    /// True if the SYNC is overdue (none within the window since the last).
    pub(super) fn missing(&self, ctx: &Ctx<'_>) -> bool {
        self.watch.since(ctx.now()).is_some_and(|since| Self::window(ctx).is_some_and(|(period, tolerance)| since > period + tolerance))
    }

    /// True once the PLL runs in step again: at once with bit 6 or without
    /// the PLL, else after the SYNC came for [`RELOCK_US`] without a gap.
    pub(super) fn in_step(&self, ctx: &Ctx<'_>) -> bool {
        configured(ctx, RESET_AFTER_LOSS | PLL_OFF) || ctx.now().as_micros().saturating_sub(self.run) >= RELOCK_US
    }
}
