//! The trajectory generator's demand values and the ramps every mode
//! shares, one [`super::TICK_US`] tick at a time. Fine units keep slow
//! motion exact without division: positions in micro-increments,
//! velocities in milli-increments per second, accelerations in
//! increments per second squared.

use super::TICK_US;

/// Ticks per second.
pub const TICKS_PER_S: i64 = 1_000_000 / TICK_US as i64;

/// Position demand value [µinc] and velocity demand value [milli-inc/s].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Demand {
    /// Position demand [µinc].
    pub position_u: i64,
    /// Velocity demand [milli-inc/s].
    pub velocity_m: i64,
}

impl Demand {
    /// Starts from where the axis is: `position` [inc], `velocity` [inc/s].
    pub fn at(position: i64, velocity: i32) -> Demand {
        Demand { position_u: position.saturating_mul(1_000_000), velocity_m: i64::from(velocity) * 1000 }
    }

    /// Position demand [inc].
    pub fn position(&self) -> i64 {
        self.position_u.div_euclid(1_000_000)
    }

    /// Velocity demand [inc/s].
    pub fn velocity(&self) -> i32 {
        (self.velocity_m / 1000).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// One tick towards velocity `target` [milli-inc/s]: `acceleration` while
    /// the speed grows, `deceleration` while it falls (both [inc/s²]).
    pub fn ramp(&mut self, target: i64, acceleration: u32, deceleration: u32) {
        let v = self.velocity_m;
        let speeding_up = (target > 0 && target > v && v >= 0) || (target < 0 && target < v && v <= 0);
        let step = per_tick(if speeding_up { acceleration } else { deceleration });
        self.velocity_m = if target > v { (v + step).min(target) } else { (v - step).max(target) };
        self.advance();
    }

    /// The position moves by one tick of the velocity.
    pub fn advance(&mut self) {
        self.position_u += self.velocity_m * 1000 / TICKS_PER_S;
    }

    /// One tick of a point-to-point move to `target` [µinc], `beyond` [µinc]
    /// further in the same direction without a stop (a blended set-point):
    /// at most `speed` [milli-inc/s], braking so as to stop there. True when
    /// the target is reached (the demand is then exactly on it).
    pub fn move_to(&mut self, target: i64, beyond: u64, speed: i64, acceleration: u32, deceleration: u32) -> bool {
        let distance = target - self.position_u;
        // v² = 2·a·d in fine units: (milli-inc/s)² = 2 · inc/s² · µinc.
        let room = distance.unsigned_abs().saturating_add(beyond);
        let braking = u64::from(deceleration).saturating_mul(2).saturating_mul(room).isqrt();
        let wanted = (braking.min(speed.unsigned_abs()) as i64) * distance.signum();
        let before = self.position_u;
        self.ramp(wanted, acceleration, deceleration);
        let moved = self.position_u - before;
        if distance == 0 || (moved.signum() == distance.signum() && moved.abs() >= distance.abs()) {
            self.position_u = target;
            if beyond == 0 {
                self.velocity_m = 0;
            }
            return true;
        }
        false
    }
}

/// Velocity change per tick [milli-inc/s] at `acceleration` [inc/s²].
fn per_tick(acceleration: u32) -> i64 {
    (i64::from(acceleration) * 1000 / TICKS_PER_S).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_speeds_up_and_slows_down_at_their_own_rates() {
        let mut d = Demand::default();
        for _ in 0..100 {
            d.ramp(1_000_000, 2000, 500);
        }
        assert_eq!(d.velocity(), 200, "100 ms at 2000 inc/s²");
        for _ in 0..100 {
            d.ramp(0, 2000, 500);
        }
        assert_eq!(d.velocity(), 150, "100 ms at 500 inc/s²");
    }

    #[test]
    fn point_to_point_stops_exactly_on_the_target() {
        let mut d = Demand::default();
        let mut ticks = 0;
        while !d.move_to(10_000_000_000, 0, 5_000_000, 20_000, 20_000) {
            ticks += 1;
            assert!(d.velocity() <= 5000);
            assert!(ticks < 10_000);
        }
        assert_eq!((d.position(), d.velocity()), (10_000, 0));
        // Trapezoid: 0.25 s up, 1.75 s at 5000 inc/s, 0.25 s down: about 2.25 s.
        assert!((2200..2300).contains(&ticks), "{ticks} ticks");
    }
}
