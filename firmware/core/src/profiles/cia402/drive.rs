//! The drive behind the profile: power stage, set-points, actual values,
//! faults, temperature and switches. The profile never touches hardware; a
//! board implements this trait for its motor control, and
//! [`crate::axis::Axis`] simulates a motor and load until one does.
//!
//! Units are the drive's own (CiA 402 "internal units"): positions in
//! increments, velocities in increments per second, accelerations in
//! increments per second squared, torque in per mille of the rated torque.

use crate::wire::emcy::EmcyCode;

/// What the drive's control loops follow during the next tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SetPoint {
    /// Power stage off or nothing commanded: the drive holds no torque.
    #[default]
    None,
    /// Position loop: be at `position` [inc] moving at `velocity` [inc/s]
    /// (velocity feed-forward), the profile's demand values.
    Position {
        /// Position demand value [inc].
        position: i64,
        /// Velocity demand value [inc/s], fed forward.
        velocity: i32,
    },
    /// Velocity loop alone [inc/s] (vl).
    Velocity(i32),
    /// Torque [‰ of rated torque].
    Torque(i16),
}

/// Switch inputs the homing methods use (CiA 402 digital inputs 0x60FD bits 0-2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Switches {
    /// Negative limit switch active.
    pub negative_limit: bool,
    /// Positive limit switch active.
    pub positive_limit: bool,
    /// Home switch active.
    pub home: bool,
}

/// A motor with its power stage, as the CiA 402 profile drives it.
pub trait Drive {
    /// Reset application: the drive returns to its power-on state (power
    /// stage off, no set-point, faults that a reset clears cleared).
    fn reset(&mut self);
    /// Switches the power stage on (the motor holds torque) or off (it coasts).
    fn enable(&mut self, on: bool);
    /// The set-point for the coming ticks.
    fn command(&mut self, set_point: SetPoint);
    /// Advances the drive by one profile tick ([`super::TICK_US`]); a real
    /// drive samples its feedback here.
    fn tick(&mut self);
    /// Position actual value [inc].
    fn position(&self) -> i64;
    /// Redefines the actual position as `position` [inc] (homing), without motion.
    fn set_position(&mut self, position: i64);
    /// Velocity actual value [inc/s].
    fn velocity(&self) -> i32;
    /// Torque actual value [‰ of rated torque].
    fn torque(&self) -> i16;
    /// Motor or power stage temperature [°C].
    fn temperature(&self) -> i16;
    /// DC link voltage [mV].
    fn dc_link_mv(&self) -> u32;
    /// The active fault as a CiA 402 error code (0x603F), [`EmcyCode::NO_ERROR`] for none.
    fn fault(&self) -> EmcyCode;
    /// The manufacturer-specific field of the fault's EMCY (bytes 3-7),
    /// such as the drive's own error number; zeros unless a drive has one.
    fn fault_info(&self) -> [u8; 5] {
        [0; 5]
    }
    /// A warning condition (statusword bit 7), such as a temperature near its limit.
    fn warning(&self) -> bool;
    /// The velocity window [inc/s] within which a pv or vl velocity counts
    /// as reached (statusword bit 10), where the drive sets it (a frequency
    /// converter's hysteresis); `None`: 0x606D's.
    fn velocity_window(&self) -> Option<u32> {
        None
    }
    /// The statusword `word` with the bits the drive decides: bit 9
    /// remote (the controlword is processed, by default always) and the
    /// manufacturer-specific bits 8, 14 and 15.
    fn status_bits(&self, word: u16) -> u16 {
        word | super::statusword::REMOTE
    }
    /// Clears the fault if its cause is gone; false if it persists.
    fn reset_fault(&mut self) -> bool;
    /// The switch inputs.
    fn switches(&self) -> Switches;
    /// The drive's own acceleration limit [inc/s²]: the "current limit"
    /// deceleration of the option codes, and the ramp when an object gives none.
    fn max_acceleration(&self) -> u32;
    /// The motor's speed limit [inc/s]: the trajectory never asks for more
    /// (a demand the motor cannot follow would overshoot).
    fn max_velocity(&self) -> u32;
    /// The lowest speed the motor runs at [inc/s], 0 for none: a pv or vl
    /// target below it stops the axis, and a stop ramp (halt, quick stop, a
    /// braking transition, pv to 0) ends once the demand falls below it: the
    /// position of that moment is held ("Zero Motion Hold" of a drive without
    /// a brake).
    fn min_velocity(&self) -> u32 {
        0
    }
    /// The drive stays at rest without ticks, so the profile may stop
    /// ticking it while its function is off (a load that turns a
    /// freewheeling motor keeps it ticking).
    fn at_rest(&self) -> bool {
        self.velocity() == 0
    }
}
