//! The device: its dictionary (generated from `device.eds` by `build.rs`)
//! running the CiA 402 drive profile of canopen-core, with the core's axis
//! model as the motor until your board drives a real one.
//!
//! The profile owns the CiA 402 objects: a controlword 0x6040 (by SDO or
//! RPDO) runs the power drive system state machine and the statusword
//! 0x6041 follows; in Operation enabled the mode 0x6060 moves the axis
//! (0x6064 position, 0x606C velocity). Your own rules go around the calls
//! into the profile, as in the devices of canopen-firmware (`ec5000.rs`,
//! `agile.rs`). A drive of your own that keeps the axis model but reports
//! its own fault codes (`Drive::fault`, an `EmcyCode`) or monitors the motor
//! implements `canopen_core::axis::AxisDrive` around the `Axis` and writes
//! only those methods (the EC5000's `Roller`, the b maXX 4400's `BmaxxDrive`).

/// The object dictionary generated from `device.eds`.
#[allow(missing_docs, dead_code, clippy::all)]
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/od.rs"));
}

use canopen_core::abort::AbortCode;
use canopen_core::axis::{Axis, AxisParams};
use canopen_core::node::{Application, Ctx, NmtEvent, Source};
use canopen_core::profiles::cia402::{Cia402, Config};
use canopen_core::time::Instant;

/// The device's state: the profile and the drive behind it. `const` and
/// all zero bits, so the node lies in `.bss`.
#[derive(Debug)]
pub struct App {
    /// The CiA 402 profile and the drive it controls (the axis model).
    pub drive: Cia402<Axis>,
}

impl App {
    /// The state at power-on.
    pub const NEW: App = App { drive: Cia402::new(Axis::NEW) };
}

/// What the drive fixes that no object holds (used where the dictionary lacks the object).
pub const PROFILE: Config = Config {
    // The motor encoder's increments per revolution.
    increments_per_rev: 4096,
    // NMT leaving Operational counts as a communication error for 0x6007.
    leaving_operational_aborts: true,
    // Position window (0x6067) and velocity window (0x606D) when the EDS has none.
    position_window: 10,
    velocity_window: 100,
    // Homing speeds (0x6099) when the EDS has none: homing does not move.
    homing_speeds: (0, 0),
    // 0x606C and 0x606F are user units per second (the factor group's).
    velocity_unit: None,
};

/// The motor the axis model simulates: 4096 increments per revolution, up
/// to 3000 min⁻¹, 0.2 s from standstill to full speed, a 24 V DC link.
pub const AXIS: AxisParams = AxisParams {
    increments_per_rev: 4096,
    max_acceleration: 1_024_000,
    max_velocity: 204_800,
    position_gain: 40,
    friction_permille: 0,
    ambient_c: 25,
    rise_at_rated_c: 50,
    thermal_tau_s: 300,
    warning_c: 0,
    fault_c: 0,
    dc_link_mv: 24_000,
    following_limit: 0,
    limits: (0, 0),
    home_switch: None,
};

impl Application for App {
    /// 0x6060 takes only the modes the drive supports.
    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.drive.check_write(index, data)
    }

    /// A CiA 402 object written by SDO or RPDO: the state machine and the modes follow.
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, _sub: u8, _by: Source) {
        self.drive.written(ctx, &PROFILE, index);
    }

    /// Actual values at a SYNC, before the synchronous TPDOs are built.
    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.drive.sample(ctx);
    }

    /// The motion, one tick at a time.
    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        self.drive.poll(ctx, &PROFILE)
    }

    /// Reset application configures the motor; NMT changes reach 0x6007.
    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.drive.drive.configure(AXIS);
        }
        self.drive.on_nmt(ctx, &PROFILE, event);
    }
}

/// The node this device runs, on storage `S`.
pub type Node<S> = od::Node<App, S>;

/// The device, as the image uses it.
pub const DEVICE: canopen_firmware::devices::Device = canopen_firmware::devices::Device {
    name: "canopen-template",
    description: "A CiA 402 drive on canopen-firmware",
    dictionary: &od::DICTIONARY,
    default_node_id: 0x10,
    startup: None,
};
