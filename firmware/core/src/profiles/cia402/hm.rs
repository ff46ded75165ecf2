//! Homing mode (hm, 0x6060 = 6; CiA 402-2 §10): controlword bit 4 starts
//! homing, statusword bit 12 homing attained, bit 13 homing error.
//! Methods: 35 and 37 (the current position is the home position), 17 and
//! 18 (the negative or positive limit switch: search it at the switch
//! speed 0x6099 sub 1, leave it at the zero speed sub 2; its edge is home).
//! The home position is the home offset 0x607C.

use super::drive::Switches;

/// Where a homing run is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Phase {
    /// Not started (or interrupted).
    #[default]
    Idle,
    /// Moving towards the switch.
    Search,
    /// On the switch, moving off it.
    Leave,
    /// Homed: the position is the home offset.
    Attained,
    /// The method is not supported or the run failed.
    Error,
}

/// What a homing tick asks of the trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Run at this velocity [sign: direction] (switch speed or zero speed).
    Run(i8, bool),
    /// Stop here; the actual position becomes the home offset.
    SetHome,
    /// Stand still.
    Stop,
}

/// The homing state.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hm {
    /// Where the run is.
    pub phase: Phase,
    /// The direction of the switch search: -1 or +1.
    direction: i8,
}

impl Hm {
    /// Not homing: all zero bits.
    pub const NEW: Hm = Hm { phase: Phase::Idle, direction: 0 };

    /// Controlword bit 4 rose: starts `method`.
    pub fn start(&mut self, method: i32) {
        *self = match method {
            35 | 37 => Hm { phase: Phase::Attained, direction: 0 },
            17 => Hm { phase: Phase::Search, direction: -1 },
            18 => Hm { phase: Phase::Search, direction: 1 },
            _ => Hm { phase: Phase::Error, direction: 0 },
        };
    }

    /// True if `method` is one this module runs.
    pub const fn supports(method: i32) -> bool {
        matches!(method, 17 | 18 | 35 | 37)
    }

    /// Controlword bit 4 fell or the mode changed: a run in progress stops.
    pub fn interrupt(&mut self) {
        if matches!(self.phase, Phase::Search | Phase::Leave) {
            self.phase = Phase::Idle;
        }
    }

    /// One tick: what the trajectory does, given the switches. Method 35/37
    /// sets home at its start ([`Step::SetHome`] once).
    // `direction` is -1, 0 or +1: its negation fits.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn tick(&mut self, switches: Switches, just_started: bool) -> Step {
        let on_switch = if self.direction < 0 { switches.negative_limit } else { switches.positive_limit };
        match self.phase {
            Phase::Attained if just_started => Step::SetHome,
            Phase::Search if on_switch => {
                self.phase = Phase::Leave;
                Step::Run(-self.direction, false)
            }
            Phase::Search => Step::Run(self.direction, true),
            Phase::Leave if !on_switch => {
                self.phase = Phase::Attained;
                Step::SetHome
            }
            Phase::Leave => Step::Run(-self.direction, false),
            _ => Step::Stop,
        }
    }
}
