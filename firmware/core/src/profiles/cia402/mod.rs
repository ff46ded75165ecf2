//! CiA 402 drive profile (CiA 402-2, CANopen mapping of IEC 61800-7-201/-301)
//! on the application slot: the power drive system state machine
//! ([`fsa`], controlword 0x6040 / statusword 0x6041), the option codes
//! 0x605A-0x605E, error code 0x603F, abort connection 0x6007, and the modes
//! profile position ([`pp`]), profile velocity, velocity ([`velocity`]),
//! homing ([`hm`]) and interpolated position ([`ip`]), with the factor
//! group ([`units`]).
//!
//! Read first: CiA 402-2 §6 (device control: figure "State machine",
//! tables "Command coding" and "State coding"), §6.3 (option codes), then
//! the mode clauses. The profile drives a [`drive::Drive`] and never a CAN
//! frame; a device module calls it from its [`crate::node::Application`]
//! hooks:
//! - `written` → [`Cia402::written`]: an RPDO writes 0x6040, the state
//!   machine runs, 0x6041 changes, and the node sends the change-of-state
//!   TPDO in the same `process`;
//! - `sample` → [`Cia402::sample`]: actual values before SYNC TPDOs;
//! - `poll` → [`Cia402::poll`]: the motion, one [`TICK_US`] tick at a time;
//! - `on_nmt` → [`Cia402::on_nmt`]: reset application, 0x6007;
//! - `check_write` → [`Cia402::check_write`]: 0x6060 takes supported modes only.
//!
//! Objects a device's dictionary lacks take the standard's defaults; a
//! mode whose objects are missing is unsupported.

pub mod controlword;
pub mod drive;
pub mod fsa;
pub mod hm;
pub mod ip;
pub mod motion;
pub mod objects;
pub mod pp;
pub mod units;
pub mod velocity;

mod profile;

pub use profile::{Cia402, Config};

/// The motion tick [µs]: trajectories, the drive's loops and the monitoring windows advance by it.
pub const TICK_US: u64 = 1000;

/// Modes of operation (0x6060 values).
pub mod mode {
    /// Profile position.
    pub const PP: i8 = 1;
    /// Velocity (frequency converters).
    pub const VL: i8 = 2;
    /// Profile velocity.
    pub const PV: i8 = 3;
    /// Homing.
    pub const HM: i8 = 6;
    /// Interpolated position.
    pub const IP: i8 = 7;

    /// The bit of a mode in 0x6502 supported drive modes (CiA 402-2 §6.4.2):
    /// pp 0, vl 1, pv 2, tq 3, hm 5, ip 6, csp 7, csv 8, cst 9.
    // `mode` is 1..=10 where it shifts.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn supported_bit(mode: i8) -> u32 {
        match mode {
            1..=4 => 1 << (mode - 1),
            6..=10 => 1 << (mode - 1),
            _ => 0,
        }
    }
}

/// Statusword 0x6041 bits besides the state coding.
pub mod statusword {
    /// Bit 4 voltage enabled: the DC link is up.
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Bit 7 warning.
    pub const WARNING: u16 = 1 << 7;
    /// Bit 9 remote: the controlword is processed.
    pub const REMOTE: u16 = 1 << 9;
    /// Bit 10 target reached (pp, pv, hm; halt and quick stop: standing still).
    pub const TARGET_REACHED: u16 = 1 << 10;
    /// Bit 11 internal limit active (a software limit or min/max amount clipped a target).
    pub const INTERNAL_LIMIT: u16 = 1 << 11;
    /// Bit 12: pp set-point acknowledge, pv speed is zero, hm homing attained, ip mode active.
    pub const BIT12: u16 = 1 << 12;
    /// Bit 13: pp following error, hm homing error.
    pub const BIT13: u16 = 1 << 13;
}
