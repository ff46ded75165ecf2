//! An axis model: a simulated motor and load behind the CiA 402
//! [`Drive`] trait, so an image without motor control still shows a PLC a
//! drive that moves (vnode, QEMU, the STM32 board until it drives a motor).
//!
//! Integer arithmetic only (Cortex-M3 has no FPU). The state advances one
//! [`TICK_US`] tick at a time:
//! - a velocity loop follows the set-point within the acceleration limit;
//!   in position mode it adds a proportional position correction to the
//!   velocity feed-forward;
//! - the position integrates the velocity (micro-increments, so slow
//!   motion is not lost to rounding);
//! - the torque estimate is the acceleration against the limit plus friction;
//! - the temperature rises with the square of the torque and cools towards
//!   ambient;
//! - faults are injected ([`Axis::inject`]) or follow from the model:
//!   over-temperature, under-voltage, a following error the drive's own
//!   monitoring sees, a power stage fault;
//! - limit and home switches sit at fixed positions.

use crate::profiles::cia402::TICK_US;
use crate::profiles::cia402::drive::{Drive, SetPoint, Switches};

/// Ticks per second.
const TICKS_PER_S: i64 = 1_000_000 / TICK_US as i64;

/// Error codes the model reports (CiA 402 / CiA 301 EMCY codes, 0x603F).
pub mod fault {
    /// 0x2320 short circuit / earth leakage at the output: the power stage failed.
    pub const POWER_STAGE: u16 = 0x2320;
    /// 0x3220 DC link under-voltage.
    pub const UNDER_VOLTAGE: u16 = 0x3220;
    /// 0x4310 excess temperature of the drive.
    pub const OVER_TEMPERATURE: u16 = 0x4310;
    /// 0x8611 following error: the load does not follow the position demand.
    pub const FOLLOWING_ERROR: u16 = 0x8611;
}

/// Faults a test or a demo injects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Injected {
    /// The motor is 30 °C above the over-temperature limit.
    OverTemperature,
    /// The DC link collapses.
    UnderVoltage,
    /// The load is blocked: the axis stops whatever the set-point.
    Blocked,
    /// The power stage fails.
    PowerStage,
}

/// The motor and load a device simulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisParams {
    /// Encoder increments per motor revolution.
    pub increments_per_rev: u32,
    /// Acceleration limit [inc/s²].
    pub max_acceleration: u32,
    /// Speed limit [inc/s].
    pub max_velocity: u32,
    /// Position loop gain [1/s].
    pub position_gain: u32,
    /// Friction torque while moving [‰].
    pub friction_permille: i16,
    /// Temperature at rest [°C].
    pub ambient_c: i16,
    /// Temperature rise at rated torque, steady state [°C].
    pub rise_at_rated_c: i16,
    /// Thermal time constant [s].
    pub thermal_tau_s: u16,
    /// Warning (statusword bit 7) at this temperature [°C].
    pub warning_c: i16,
    /// Fault at this temperature [°C]; cleared 10 °C below.
    pub fault_c: i16,
    /// DC link voltage [mV].
    pub dc_link_mv: u32,
    /// The drive's own following-error limit [inc], 0 for none.
    pub following_limit: u32,
    /// Negative and positive limit switches [inc]: active at or beyond; equal for none.
    pub limits: (i64, i64),
    /// Home switch: active at or above this position [inc], if any.
    pub home_switch: Option<i64>,
}

/// A simulated motor and load.
#[derive(Clone, Debug)]
pub struct Axis {
    params: Option<AxisParams>,
    /// Position [µinc].
    position_u: i64,
    /// Velocity [milli-inc/s].
    velocity_m: i64,
    set_point: SetPoint,
    enabled: bool,
    torque: i16,
    /// Temperature [m°C] above ambient.
    heat_mc: i64,
    fault: u16,
    injected: [bool; 4],
}

impl Axis {
    /// Unconfigured, at rest: `const` and all zero bits.
    pub const NEW: Axis = Axis {
        params: None,
        position_u: 0,
        velocity_m: 0,
        set_point: SetPoint::None,
        enabled: false,
        torque: 0,
        heat_mc: 0,
        fault: 0,
        injected: [false; 4],
    };

    /// Gives the axis its motor and load (at reset application).
    pub fn configure(&mut self, params: AxisParams) {
        self.params = Some(params);
    }

    /// Injects a fault (a test's or a demo's).
    pub fn inject(&mut self, fault: Injected) {
        if let Some(f) = self.injected.get_mut(fault as usize) {
            *f = true;
        }
    }

    /// Removes an injected fault (the drive's fault stays until reset).
    pub fn remove(&mut self, fault: Injected) {
        if let Some(f) = self.injected.get_mut(fault as usize) {
            *f = false;
        }
        if fault == Injected::OverTemperature {
            self.heat_mc = 0;
        }
    }

    fn injected(&self, fault: Injected) -> bool {
        self.injected.get(fault as usize).copied().unwrap_or(false)
    }

    fn params(&self) -> AxisParams {
        self.params.unwrap_or(AxisParams {
            increments_per_rev: 4096,
            max_acceleration: 1_000_000,
            max_velocity: 1_000_000,
            position_gain: 50,
            friction_permille: 0,
            ambient_c: 25,
            rise_at_rated_c: 60,
            thermal_tau_s: 60,
            warning_c: i16::MAX,
            fault_c: i16::MAX,
            dc_link_mv: 24_000,
            following_limit: 0,
            limits: (0, 0),
            home_switch: None,
        })
    }

    /// The cause of a fault, if one is present now.
    fn cause(&self, p: &AxisParams) -> u16 {
        if self.injected(Injected::PowerStage) {
            fault::POWER_STAGE
        } else if self.injected(Injected::UnderVoltage) {
            fault::UNDER_VOLTAGE
        } else if self.temperature() >= p.fault_c {
            fault::OVER_TEMPERATURE
        } else {
            0
        }
    }
}

impl Drive for Axis {
    fn reset(&mut self) {
        let params = self.params;
        *self = Axis::NEW;
        self.params = params;
    }

    fn enable(&mut self, on: bool) {
        self.enabled = on && self.fault == 0;
        if !self.enabled {
            self.set_point = SetPoint::None;
        }
    }

    fn command(&mut self, set_point: SetPoint) {
        if self.enabled {
            self.set_point = set_point;
        }
    }

    fn tick(&mut self) {
        let p = self.params();
        if self.fault == 0 {
            self.fault = self.cause(&p);
        }
        if self.fault != 0 {
            self.enabled = false;
            self.set_point = SetPoint::None;
        }
        let a = i64::from(p.max_acceleration);
        // Velocity change per tick at the limit [milli-inc/s].
        let step = a * 1000 / TICKS_PER_S;
        let v_max = i64::from(p.max_velocity) * 1000;
        // Velocity the loops ask for [milli-inc/s], or the torque's acceleration.
        let wanted = match self.set_point {
            SetPoint::None => None,
            SetPoint::Velocity(v) => Some(i64::from(v) * 1000),
            SetPoint::Position { position, velocity } => {
                let error_u = position.saturating_mul(1_000_000) - self.position_u;
                if p.following_limit != 0 && error_u.unsigned_abs() / 1_000_000 > u64::from(p.following_limit) {
                    self.fault = fault::FOLLOWING_ERROR;
                }
                Some(i64::from(velocity) * 1000 + error_u / 1000 * i64::from(p.position_gain))
            }
            SetPoint::Torque(t) => Some(self.velocity_m + step * i64::from(t) / 1000),
        };
        let before = self.velocity_m;
        self.velocity_m = match wanted {
            // Blocked load or no torque: a blocked axis stops dead; a coasting one
            // slows with friction (a tenth of the acceleration limit).
            _ if self.injected(Injected::Blocked) => 0,
            None => toward(self.velocity_m, 0, step / 10),
            Some(w) => toward(self.velocity_m, w.clamp(-v_max, v_max), step),
        };
        self.position_u += self.velocity_m * 1000 / TICKS_PER_S;
        let accel = (self.velocity_m - before) * TICKS_PER_S / 1000;
        let friction = if self.velocity_m == 0 { 0 } else { i64::from(p.friction_permille) * self.velocity_m.signum() };
        self.torque = if self.enabled { (accel * 1000 / a.max(1) + friction).clamp(-3000, 3000) as i16 } else { 0 };
        // First-order thermal model: heat ∝ torque², time constant tau.
        let tau_ticks = i64::from(p.thermal_tau_s.max(1)) * TICKS_PER_S;
        let load = i64::from(self.torque) * i64::from(self.torque) / 1000;
        let steady_mc = i64::from(p.rise_at_rated_c) * load;
        self.heat_mc += (steady_mc - self.heat_mc) / tau_ticks;
    }

    fn position(&self) -> i64 {
        self.position_u.div_euclid(1_000_000)
    }

    fn set_position(&mut self, position: i64) {
        self.position_u = position.saturating_mul(1_000_000);
    }

    fn velocity(&self) -> i32 {
        (self.velocity_m / 1000) as i32
    }

    fn torque(&self) -> i16 {
        self.torque
    }

    fn temperature(&self) -> i16 {
        let p = self.params();
        let extra = if self.injected(Injected::OverTemperature) { p.fault_c.saturating_sub(p.ambient_c).saturating_add(30) } else { 0 };
        p.ambient_c.saturating_add((self.heat_mc / 1000) as i16).saturating_add(extra)
    }

    fn dc_link_mv(&self) -> u32 {
        if self.injected(Injected::UnderVoltage) { 0 } else { self.params().dc_link_mv }
    }

    fn fault(&self) -> u16 {
        // A cause shows at once, even while the axis is not ticking.
        if self.fault != 0 { self.fault } else { self.cause(&self.params()) }
    }

    fn warning(&self) -> bool {
        self.temperature() >= self.params().warning_c
    }

    fn reset_fault(&mut self) -> bool {
        let p = self.params();
        let cooled = self.temperature() < p.fault_c.saturating_sub(10);
        let cause = self.cause(&p);
        if cause == 0 && cooled && !self.injected(Injected::Blocked) {
            self.fault = 0;
        }
        self.fault == 0
    }

    fn switches(&self) -> Switches {
        let p = self.params();
        let at = self.position();
        let (low, high) = p.limits;
        Switches {
            negative_limit: low < high && at <= low,
            positive_limit: low < high && at >= high,
            home: p.home_switch.is_some_and(|h| at >= h),
        }
    }

    fn max_acceleration(&self) -> u32 {
        self.params().max_acceleration
    }
}

/// `from` moved towards `to` by at most `step`.
fn toward(from: i64, to: i64, step: i64) -> i64 {
    if to > from { (from + step).min(to) } else { (from - step).max(to) }
}
