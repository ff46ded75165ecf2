//! Interpolated position mode (ip, 0x6060 = 7; CiA 402-2 §13), linear
//! interpolation (sub-mode 0x60C0 = 0) with a one-record buffer:
//! controlword bit 4 enables the interpolation, statusword bit 12 shows it
//! active. On every SYNC the device hands the profile the interpolation
//! data record (0x60C1 sub 1, converted to increments as its manual says)
//! and the interpolation time period (0x60C2) as a power of two of ticks;
//! the position demand then moves in equal steps to that set-point within
//! one period, so the axis follows the master's set-points at the SYNC
//! rate. A device calls [`super::Cia402::interpolate`] from its `sample` hook.

use super::motion::{Demand, FRACTION};

/// The segment being interpolated.
#[derive(Clone, Copy, Debug, Default)]
pub struct Ip {
    /// The set-point the segment ends on [Q24 inc].
    target_q: i64,
    /// Position step per tick [Q24 inc/tick].
    step_q: i64,
    /// Ticks left in the segment.
    remaining: u8,
}

impl Ip {
    /// No segment: all zero bits.
    pub const NEW: Ip = Ip { target_q: 0, step_q: 0, remaining: 0 };

    /// A new set-point `target` [inc], reached from `demand` after
    /// `1 << period_log2` ticks (a shift, not a division: the periods are
    /// powers of two of the tick).
    pub fn set_point(&mut self, demand: &Demand, target: i64, period_log2: u8) {
        let period_log2 = period_log2.min(7);
        self.target_q = target << FRACTION;
        self.step_q = self.target_q.wrapping_sub(demand.position_q) >> period_log2;
        self.remaining = 1 << period_log2;
    }

    /// One tick: the next step of the segment, or standing on its end.
    pub fn tick(&mut self, demand: &mut Demand) {
        if self.remaining == 0 {
            // No record came when the segment ended: the demand stands.
            (demand.velocity_q, self.step_q) = (0, 0);
            return;
        }
        // `remaining` != 0: checked above.
        #[allow(clippy::arithmetic_side_effects)]
        {
            self.remaining -= 1;
        }
        demand.velocity_q = self.step_q;
        // The last step lands exactly on the set-point (the shift rounds down).
        demand.position_q = if self.remaining == 0 { self.target_q } else { demand.position_q.wrapping_add(self.step_q) };
    }

    /// The demand stands on the last set-point: the record repeated the
    /// one before, or a tick passed after the segment without a new one.
    /// (Not at the end of every segment: target reached would flicker at
    /// the SYNC rate while the axis follows a moving set-point.)
    pub fn done(&self) -> bool {
        self.step_q == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_of_four_ticks_moves_in_equal_steps_and_ends_on_the_set_point() {
        let mut d = Demand::at(1000, 0);
        let mut ip = Ip::NEW;
        ip.set_point(&d, 1403, 2);
        let mut seen = Vec::new();
        for _ in 0..5 {
            ip.tick(&mut d);
            seen.push(d.position());
        }
        assert_eq!(seen, [1100, 1201, 1302, 1403, 1403]);
        assert!(ip.done());
        assert_eq!(d.velocity_q, 0);
        ip.set_point(&d, 1003, 1);
        ip.tick(&mut d);
        assert_eq!((d.position(), d.velocity()), (1203, -200_000), "backwards at 200 inc/ms");
    }
}
