//! Profile position mode (pp, 0x6060 = 1; CiA 402-2 §12): the set-point
//! handshake (controlword bit 4 new set-point, statusword bit 12 set-point
//! acknowledge), change set immediately (bit 5), relative targets (bit 6,
//! 0x60F2), the one-deep set-point buffer with change on set-point (bit 9),
//! software position limits (0x607D) and target reached (0x6067/0x6068).

use super::motion::{Demand, FRACTION};

/// The set-points the trajectory generator holds.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pp {
    /// A set-point is being executed.
    active: bool,
    /// Its target [Q24 inc].
    target_q: i64,
    /// A second set-point waits in the buffer.
    buffered: bool,
    /// Its target [Q24 inc].
    next_q: i64,
    /// The buffered set-point follows without a stop (bit 9 when it came).
    blend: bool,
    /// The last accepted target [inc], the base of relative set-points.
    last_target: i64,
    /// Statusword bit 12.
    pub acknowledge: bool,
}

/// How a new set-point is given.
#[derive(Clone, Copy, Debug)]
pub struct SetPointRequest {
    /// The target [inc], polarity applied, relative not yet.
    pub target: i64,
    /// Controlword bit 6.
    pub relative: bool,
    /// Controlword bit 5.
    pub immediately: bool,
    /// Controlword bit 9.
    pub blend: bool,
    /// 0x60F2 bits 0-1: relative to the preceding target (0), the position
    /// demand (1) or the actual position (2).
    pub relative_to: u8,
}

impl Pp {
    /// No set-point: all zero bits.
    pub const NEW: Pp = Pp { active: false, target_q: 0, buffered: false, next_q: 0, blend: false, last_target: 0, acknowledge: false };

    /// Clears every set-point (entering the mode, enabling operation).
    pub fn clear(&mut self, position: i64) {
        *self = Pp { last_target: position, ..Pp::default() };
    }

    /// The absolute target [inc] of a set-point.
    pub fn absolute(&self, request: &SetPointRequest, demand: &Demand, actual: i64) -> i64 {
        if !request.relative {
            return request.target;
        }
        let base = match request.relative_to & 3 {
            1 => demand.position(),
            2 => actual,
            _ => self.last_target,
        };
        base.saturating_add(request.target)
    }

    /// Controlword bit 4 rose: takes the set-point to absolute `target`
    /// [inc] if there is room.
    pub fn new_set_point(&mut self, target: i64, request: &SetPointRequest) {
        let target_q = target << FRACTION;
        if !self.active || request.immediately {
            (self.active, self.target_q, self.buffered) = (true, target_q, false);
        } else if !self.buffered {
            (self.buffered, self.next_q, self.blend) = (true, target_q, request.blend);
        } else {
            // Buffer full: the set-point is not taken (bit 12 stays as it is).
            return;
        }
        self.last_target = target;
        self.acknowledge = true;
    }

    /// Controlword bit 4 fell: the acknowledge clears unless the buffer is full.
    pub fn set_point_released(&mut self) {
        if !(self.active && self.buffered) {
            self.acknowledge = false;
        }
    }

    /// One tick of the trajectory (`new_set_point_held`: controlword bit 4
    /// is still set); speed and ramps in [`super::motion`]'s Q24 per-tick units.
    pub fn tick(&mut self, demand: &mut Demand, speed: i64, acceleration: i64, deceleration: i64, new_set_point_held: bool) {
        if !self.active {
            demand.ramp(0, acceleration, deceleration);
            return;
        }
        // Positions wrap (`Demand::ramp`): so do their differences.
        let direction = self.target_q.wrapping_sub(demand.position_q).signum();
        let ahead = self.next_q.wrapping_sub(self.target_q);
        let beyond = if self.buffered && self.blend && ahead.signum() == direction { ahead.unsigned_abs() } else { 0 };
        if demand.move_to(self.target_q, beyond, speed, acceleration, deceleration) {
            if self.buffered {
                (self.target_q, self.buffered) = (self.next_q, false);
                if !self.blend {
                    demand.velocity_q = 0;
                }
                if !new_set_point_held {
                    self.acknowledge = false;
                }
            } else {
                self.active = false;
                demand.velocity_q = 0;
            }
        }
    }

    /// No set-point left: the trajectory is at its last target.
    pub fn done(&self) -> bool {
        !self.active
    }

    /// The target the trajectory ends at [inc].
    pub fn final_target(&self) -> i64 {
        self.last_target
    }
}
