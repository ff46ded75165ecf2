//! The power drive system finite state automaton (PDS FSA): CiA 402-2 §6.2
//! figure "State machine" and its transitions 0-16. Pure: a state and a
//! command in, the next state and the transition out. What a transition does
//! to the motor (power stage, braking ramps) is the profile's
//! ([`super::Cia402`]), chosen by the option codes ([`Reaction`]).

use super::controlword::Command;

/// PDS states (CiA 402-2 §6.2.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PdsState {
    /// Low-level power on, the drive initialises; no command is taken.
    #[default]
    NotReadyToSwitchOn,
    /// Initialised; high voltage may be off.
    SwitchOnDisabled,
    /// High voltage may be applied; the drive function is off.
    ReadyToSwitchOn,
    /// The power amplifier is ready; the drive function is off.
    SwitchedOn,
    /// The drive function is on: the axis follows the mode's set-points.
    OperationEnabled,
    /// The quick stop function runs (0x605A).
    QuickStopActive,
    /// A fault occurred; the fault reaction runs (0x605E).
    FaultReactionActive,
    /// The fault reaction is over; the drive function is off.
    Fault,
}

impl PdsState {
    /// Statusword bits 0-3, 5 and 6 of the state (CiA 402-2 table "State
    /// coding"); bit 4 "voltage enabled" is the drive's DC link, added by the profile.
    pub const fn statusword(self) -> u16 {
        match self {
            PdsState::NotReadyToSwitchOn => 0x0000,
            PdsState::SwitchOnDisabled => 0x0040,
            PdsState::ReadyToSwitchOn => 0x0021,
            PdsState::SwitchedOn => 0x0023,
            PdsState::OperationEnabled => 0x0027,
            PdsState::QuickStopActive => 0x0007,
            PdsState::FaultReactionActive => 0x000F,
            PdsState::Fault => 0x0008,
        }
    }

    /// The drive function is on (the motor holds torque).
    pub const fn drive_function(self) -> bool {
        matches!(self, PdsState::OperationEnabled | PdsState::QuickStopActive | PdsState::FaultReactionActive)
    }
}

/// A transition the command asks for: the next state and its number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transition {
    /// The state after it.
    pub to: PdsState,
    /// Its number in CiA 402-2 (2-16).
    pub number: u8,
}

/// The transition `command` triggers in `state`, if any. `quick_stop_stays`
/// tells whether the quick stop option code (0x605A = 5..8) keeps the drive
/// in Quick stop active, which alone allows transition 16.
pub const fn next(state: PdsState, command: Command, quick_stop_stays: bool) -> Option<Transition> {
    use Command as C;
    use PdsState as S;
    let (to, number) = match (state, command) {
        (S::SwitchOnDisabled, C::Shutdown) => (S::ReadyToSwitchOn, 2),
        (S::ReadyToSwitchOn, C::SwitchOn | C::EnableOperation) => (S::SwitchedOn, 3),
        (S::SwitchedOn, C::EnableOperation) => (S::OperationEnabled, 4),
        (S::OperationEnabled, C::SwitchOn) => (S::SwitchedOn, 5),
        (S::SwitchedOn, C::Shutdown) => (S::ReadyToSwitchOn, 6),
        (S::ReadyToSwitchOn, C::DisableVoltage | C::QuickStop) => (S::SwitchOnDisabled, 7),
        (S::OperationEnabled, C::Shutdown) => (S::ReadyToSwitchOn, 8),
        (S::OperationEnabled, C::DisableVoltage) => (S::SwitchOnDisabled, 9),
        (S::SwitchedOn, C::DisableVoltage | C::QuickStop) => (S::SwitchOnDisabled, 10),
        (S::OperationEnabled, C::QuickStop) => (S::QuickStopActive, 11),
        (S::QuickStopActive, C::DisableVoltage) => (S::SwitchOnDisabled, 12),
        (S::Fault, C::FaultReset) => (S::SwitchOnDisabled, 15),
        (S::QuickStopActive, C::EnableOperation) if quick_stop_stays => (S::OperationEnabled, 16),
        _ => return None,
    };
    Some(Transition { to, number })
}

/// How the drive stops, from an option code (0x605A-0x605E, CiA 402-2 §6.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reaction {
    /// Disable the drive function at once: the motor coasts.
    Coast,
    /// Slow down on the slow down ramp (profile deceleration 0x6084, vl 0x6049).
    SlowDownRamp,
    /// Slow down on the quick stop ramp (0x6085, vl 0x604A).
    QuickStopRamp,
    /// Slow down at the current (or voltage) limit: the drive's maximum deceleration.
    Limit,
}

impl Reaction {
    /// The reaction of an option code value: 0 coast, 1 and 5 slow down
    /// ramp, 2 and 6 quick stop ramp, 3, 4, 7, 8 current or voltage limit.
    /// Values the standard does not define (manufacturer-specific negative
    /// ones included) fall back to `default`.
    pub const fn of(code: i32, default: Reaction) -> Reaction {
        match code {
            0 => Reaction::Coast,
            1 | 5 => Reaction::SlowDownRamp,
            2 | 6 => Reaction::QuickStopRamp,
            3 | 4 | 7 | 8 => Reaction::Limit,
            _ => default,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Command as C;
    use PdsState as S;

    const STATES: [PdsState; 8] = [
        S::NotReadyToSwitchOn,
        S::SwitchOnDisabled,
        S::ReadyToSwitchOn,
        S::SwitchedOn,
        S::OperationEnabled,
        S::QuickStopActive,
        S::FaultReactionActive,
        S::Fault,
    ];
    const COMMANDS: [Command; 6] = [C::Shutdown, C::SwitchOn, C::EnableOperation, C::DisableVoltage, C::QuickStop, C::FaultReset];

    #[test]
    fn every_command_in_every_state() {
        // (state, command) → transition number, 0 for none; quick stop option 2 (to Switch on disabled).
        let table: [[u8; 6]; 8] = [
            [0, 0, 0, 0, 0, 0],   // Not ready to switch on: automatic only
            [2, 0, 0, 0, 0, 0],   // Switch on disabled
            [0, 3, 3, 7, 7, 0],   // Ready to switch on
            [6, 0, 4, 10, 10, 0], // Switched on
            [8, 5, 0, 9, 11, 0],  // Operation enabled
            [0, 0, 0, 12, 0, 0],  // Quick stop active
            [0, 0, 0, 0, 0, 0],   // Fault reaction active: automatic only
            [0, 0, 0, 0, 0, 15],  // Fault
        ];
        for (state, row) in STATES.iter().zip(table) {
            for (command, number) in COMMANDS.iter().zip(row) {
                assert_eq!(next(*state, *command, false).map_or(0, |t| t.number), number, "{state:?} {command:?}");
            }
        }
        assert_eq!(next(S::QuickStopActive, C::EnableOperation, true), Some(Transition { to: S::OperationEnabled, number: 16 }));
    }

    #[test]
    fn state_coding() {
        assert_eq!(S::SwitchOnDisabled.statusword() & 0x4F, 0x40);
        assert_eq!(S::ReadyToSwitchOn.statusword() & 0x6F, 0x21);
        assert_eq!(S::SwitchedOn.statusword() & 0x6F, 0x23);
        assert_eq!(S::OperationEnabled.statusword() & 0x6F, 0x27);
        assert_eq!(S::QuickStopActive.statusword() & 0x6F, 0x07);
        assert_eq!(S::FaultReactionActive.statusword() & 0x4F, 0x0F);
        assert_eq!(S::Fault.statusword() & 0x4F, 0x08);
        assert_eq!(S::NotReadyToSwitchOn.statusword() & 0x4F, 0x00);
    }

    #[test]
    fn option_codes() {
        assert_eq!(Reaction::of(0, Reaction::Limit), Reaction::Coast);
        assert_eq!(Reaction::of(6, Reaction::Coast), Reaction::QuickStopRamp);
        assert_eq!(Reaction::of(-1, Reaction::QuickStopRamp), Reaction::QuickStopRamp);
    }
}
