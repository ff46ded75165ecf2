//! An axis model: a simulated motor and load behind the CiA 402
//! [`Drive`] trait, so an image without motor control still shows a PLC a
//! drive that moves (vnode, QEMU, the STM32 board until it drives a motor).
//!
//! Integer arithmetic only (Cortex-M3 has no FPU). The state advances one
//! [`TICK_US`] tick at a time:
//! - a velocity loop follows the set-point within the acceleration limit;
//!   in position mode it adds a proportional position correction to the
//!   velocity feed-forward;
//! - the position integrates the velocity (Q24 fixed point per tick, as
//!   the profile's [`crate::profiles::cia402::motion`], so slow motion is not
//!   lost to rounding and no tick divides 64-bit numbers);
//! - the torque estimate is the acceleration against the limit plus friction;
//! - the temperature rises with the square of the torque and cools towards
//!   ambient;
//! - faults are injected ([`Axis::inject`]) or follow from the model:
//!   over-temperature, under- and over-voltage, a following error the
//!   drive's own monitoring sees, a power stage fault;
//! - an external load ([`Axis::set_load`], a conveyor's slope) turns a
//!   coasting axis; the loops hold against it up to the torque limit;
//! - limit and home switches sit at fixed positions.

mod forward;

pub use forward::AxisDrive;

use crate::profiles::cia402::drive::{Drive, SetPoint, Switches};
use crate::profiles::cia402::motion::{FRACTION, acceleration_q, speed_per_s, speed_q};
use crate::wire::emcy::EmcyCode;

/// Error codes the model reports (CiA 402 / CiA 301 EMCY codes, 0x603F).
pub mod fault {
    use crate::wire::emcy::EmcyCode;

    /// 0x2320 short circuit / earth leakage at the output: the power stage failed.
    pub const POWER_STAGE: EmcyCode = EmcyCode(0x2320);
    /// 0x3210 DC link over-voltage.
    pub const OVER_VOLTAGE: EmcyCode = EmcyCode(0x3210);
    /// 0x3220 DC link under-voltage.
    pub const UNDER_VOLTAGE: EmcyCode = EmcyCode(0x3220);
    /// 0x4310 excess temperature of the drive.
    pub const OVER_TEMPERATURE: EmcyCode = EmcyCode(0x4310);
    /// 0x8611 following error: the load does not follow the position demand.
    pub const FOLLOWING_ERROR: EmcyCode = EmcyCode(0x8611);
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
    /// The supply rises to 1.5 times the DC link voltage.
    OverVoltage,
}

/// The torque the power stage gives at most [‰ of rated torque].
const TORQUE_LIMIT: i64 = 3000;

/// The motor and load a device simulates ([`AxisParams::ZERO`]: an axis
/// that cannot move, until [`Axis::configure`]).
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
    /// Temperature rise at rated torque, steady state [°C]; at most 200
    /// (the model's heat, in µ°C at 3× rated torque, then fits an i32).
    pub rise_at_rated_c: i16,
    /// Thermal time constant [s].
    pub thermal_tau_s: u16,
    /// Warning (statusword bit 7) at this temperature [°C]; 0 for none.
    pub warning_c: i16,
    /// Fault at this temperature [°C], cleared 10 °C below; 0 for none.
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

impl AxisParams {
    /// No motor: all zero bits.
    pub const ZERO: AxisParams = AxisParams {
        increments_per_rev: 0,
        max_acceleration: 0,
        max_velocity: 0,
        position_gain: 0,
        friction_permille: 0,
        ambient_c: 0,
        rise_at_rated_c: 0,
        thermal_tau_s: 0,
        warning_c: 0,
        fault_c: 0,
        dc_link_mv: 0,
        following_limit: 0,
        limits: (0, 0),
        home_switch: None,
    };
}

/// A simulated motor and load.
#[derive(Clone, Debug)]
pub struct Axis {
    params: AxisParams,
    /// Position [Q24 inc].
    position_q: i64,
    /// Velocity [Q24 inc/tick].
    velocity_q: i64,
    set_point: SetPoint,
    enabled: bool,
    torque: i16,
    /// Temperature above ambient [µ°C].
    heat_uc: i32,
    fault: EmcyCode,
    injected: [bool; 5],
    /// External load torque [‰ of rated torque], positive in the positive direction.
    load: i16,
}

impl Axis {
    /// Unconfigured, at rest: `const` and all zero bits.
    pub const NEW: Axis = Axis {
        params: AxisParams::ZERO,
        position_q: 0,
        velocity_q: 0,
        set_point: SetPoint::None,
        enabled: false,
        torque: 0,
        heat_uc: 0,
        fault: EmcyCode::NO_ERROR,
        injected: [false; 5],
        load: 0,
    };

    /// Gives the axis its motor and load (at reset application).
    pub fn configure(&mut self, params: AxisParams) {
        self.params = params;
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
    }

    /// Sets the ambient temperature [°C] (a test's or a demo's: a warm hall).
    pub fn set_ambient(&mut self, celsius: i16) {
        self.params.ambient_c = celsius;
    }

    /// Sets the external load torque [‰ of rated torque] (a test's or a
    /// demo's: goods on an inclined conveyor). With the power stage off it
    /// turns the axis once it overcomes friction; the loops hold against it
    /// up to the torque limit (3000 ‰), and a larger load slips through.
    pub fn set_load(&mut self, permille: i16) {
        self.load = permille;
    }

    fn injected(&self, fault: Injected) -> bool {
        self.injected.get(fault as usize).copied().unwrap_or(false)
    }

    /// The cause of a fault, if one is present now.
    fn cause(&self) -> EmcyCode {
        if self.injected(Injected::PowerStage) {
            fault::POWER_STAGE
        } else if self.injected(Injected::UnderVoltage) {
            fault::UNDER_VOLTAGE
        } else if self.injected(Injected::OverVoltage) {
            fault::OVER_VOLTAGE
        } else if self.params.fault_c != 0 && self.temperature() >= self.params.fault_c {
            fault::OVER_TEMPERATURE
        } else {
            EmcyCode::NO_ERROR
        }
    }
}

impl Drive for Axis {
    fn reset(&mut self) {
        // All zero bits but the parameters: a clear and the parameters put
        // back (the struct update copied the rest from a 120-byte constant).
        let params = self.params;
        *self = Axis::NEW;
        self.params = params;
    }

    fn enable(&mut self, on: bool) {
        self.enabled = on && self.fault == EmcyCode::NO_ERROR;
        if !self.enabled {
            self.set_point = SetPoint::None;
        }
    }

    fn command(&mut self, set_point: SetPoint) {
        if self.enabled {
            self.set_point = set_point;
        }
    }

    // Positions wrap (as `Demand::ramp`'s). Every other term is bounded:
    // velocities by `speed_q` (< 2^47), steps by `acceleration_q` (< 2^37),
    // the position error to 2^40 times a gain below 2^32, torques to
    // ±3000 ‰ and loads to an i16, the heat by `rise_at_rated_c` (≤ 200 °C).
    #[allow(clippy::arithmetic_side_effects)]
    fn tick(&mut self) {
        let p = self.params;
        if self.fault == EmcyCode::NO_ERROR {
            self.fault = self.cause();
        }
        if self.fault != EmcyCode::NO_ERROR {
            self.enabled = false;
            self.set_point = SetPoint::None;
        }
        // Velocity change per tick at the limit, and the speed limit [Q24 per tick].
        let step = acceleration_q(p.max_acceleration);
        let v_max = speed_q(i64::from(p.max_velocity));
        // The velocity the loops ask for, or the torque's acceleration.
        let wanted = match self.set_point {
            SetPoint::None => None,
            SetPoint::Velocity(v) => Some(speed_q(i64::from(v))),
            SetPoint::Position { position, velocity } => {
                let error = (position << FRACTION).wrapping_sub(self.position_q);
                if p.following_limit != 0 && (error >> FRACTION).unsigned_abs() > u64::from(p.following_limit) {
                    self.fault = fault::FOLLOWING_ERROR;
                }
                // Gain [1/s] per tick as a Q24 factor, as `speed_q`; both terms
                // clamped so that the product fits (65,536 inc, 250/s).
                let gain = speed_q(i64::from(p.position_gain.min(250)));
                let error = error.clamp(-(1 << 40), 1 << 40);
                Some(speed_q(i64::from(velocity)) + ((error * gain) >> FRACTION))
            }
            // t ‰ of the limit: × t / 1000 as × t × 1049 / 2^20.
            SetPoint::Torque(t) => Some(self.velocity_q + ((step * i64::from(t) * 1049) >> 20)),
        };
        let before = self.velocity_q;
        // The external load's acceleration [Q24 per tick²]; the loops' torque
        // holds against it up to the torque limit.
        let load = per_mille(step * i64::from(self.load));
        let authority = step * (TORQUE_LIMIT / 1000);
        self.velocity_q = match wanted {
            // A blocked load stops dead; with no torque the axis coasts down
            // with friction (an eighth of the acceleration limit), or turns
            // with a load that overcomes it.
            _ if self.injected(Injected::Blocked) => 0,
            None => toward(self.velocity_q + load, 0, (step >> 3).max(1)).clamp(-v_max, v_max),
            Some(w) => {
                let change = (w.clamp(-v_max, v_max) - self.velocity_q).clamp(-step, step);
                self.velocity_q + (change - load).clamp(-authority, authority) + load
            }
        };
        self.position_q = self.position_q.wrapping_add(self.velocity_q);
        // Torque: the acceleration against the limit, plus friction while moving [‰].
        // The change against the step, both cut to 19 bits so that the ‰
        // ratio divides in 32 bits (|change| ≤ 3 steps: 3 · 2^19 · 1000 < 2^31).
        let step = step.max(1);
        let shift = (64 - step.leading_zeros()).saturating_sub(19);
        let change = (self.velocity_q - before).clamp(-3 * step, 3 * step) >> shift;
        let accel = (change as i32 * 1000) / ((step >> shift) as i32).max(1);
        let friction = if self.velocity_q == 0 { 0 } else { i32::from(p.friction_permille) * self.velocity_q.signum() as i32 };
        // The drive holds the load against its direction.
        let limit = TORQUE_LIMIT as i32;
        self.torque = if self.enabled { (accel + friction - i32::from(self.load)).clamp(-limit, limit) as i16 } else { 0 };
        // First-order thermal model: the steady rise grows with torque².
        let tau_ticks = i32::from(p.thermal_tau_s.max(1)) * 1000;
        let load = i32::from(self.torque) * i32::from(self.torque) / 1000;
        let steady_uc = i32::from(p.rise_at_rated_c) * load * 1000;
        self.heat_uc += (steady_uc - self.heat_uc) / tau_ticks;
    }

    fn position(&self) -> i64 {
        self.position_q >> FRACTION
    }

    fn set_position(&mut self, position: i64) {
        self.position_q = position << FRACTION;
    }

    fn velocity(&self) -> i32 {
        speed_per_s(self.velocity_q) as i32
    }

    fn torque(&self) -> i16 {
        self.torque
    }

    // Out of line: the fault checks, the warning and the device's reads
    // each had a copy of the division by 10^6 (six in a drive image).
    #[inline(never)]
    fn temperature(&self) -> i16 {
        let p = &self.params;
        let extra = if self.injected(Injected::OverTemperature) { p.fault_c.saturating_sub(p.ambient_c).saturating_add(30) } else { 0 };
        p.ambient_c.saturating_add((self.heat_uc / 1_000_000) as i16).saturating_add(extra)
    }

    // A DC link below 2.8 MV: × 1.5 fits a u32.
    #[allow(clippy::arithmetic_side_effects)]
    fn dc_link_mv(&self) -> u32 {
        if self.injected(Injected::UnderVoltage) {
            0
        } else if self.injected(Injected::OverVoltage) {
            self.params.dc_link_mv / 2 * 3
        } else {
            self.params.dc_link_mv
        }
    }

    fn fault(&self) -> EmcyCode {
        // A cause shows at once, even while the axis is not ticking.
        if self.fault != EmcyCode::NO_ERROR { self.fault } else { self.cause() }
    }

    fn warning(&self) -> bool {
        self.params.warning_c != 0 && self.temperature() >= self.params.warning_c
    }

    fn reset_fault(&mut self) -> bool {
        let cooled = self.temperature() < self.params.fault_c.saturating_sub(10);
        if self.cause() == EmcyCode::NO_ERROR && cooled && !self.injected(Injected::Blocked) {
            self.fault = EmcyCode::NO_ERROR;
        }
        self.fault == EmcyCode::NO_ERROR
    }

    fn switches(&self) -> Switches {
        let at = self.position();
        let (low, high) = self.params.limits;
        Switches {
            negative_limit: low < high && at <= low,
            positive_limit: low < high && at >= high,
            home: self.params.home_switch.is_some_and(|h| at >= h),
        }
    }

    fn max_acceleration(&self) -> u32 {
        self.params.max_acceleration
    }

    fn max_velocity(&self) -> u32 {
        self.params.max_velocity
    }

    fn at_rest(&self) -> bool {
        // Friction holds a coasting axis against a load of up to an eighth of the acceleration limit.
        self.velocity_q == 0 && (self.enabled || self.load.unsigned_abs() <= 125)
    }
}

/// `x` / 1000, truncated as `/` does, in 32-bit divisions: a 64-bit one
/// links about 1 KiB of compiler_builtins into every drive image.
// The quotient is below |x| / 1000: its negation fits.
#[allow(clippy::arithmetic_side_effects)]
fn per_mille(x: i64) -> i64 {
    let mut n = x.unsigned_abs();
    let mut q: u64 = 0;
    let mut r: u32 = 0;
    // Long division by 16-bit digits: r < 1000, so r · 2^16 + digit fits 32 bits.
    for _ in 0..4 {
        let cur = (r << 16) | (n >> 48) as u32;
        n <<= 16;
        q = (q << 16) | u64::from(cur / 1000);
        r = cur % 1000;
    }
    if x < 0 { -(q as i64) } else { q as i64 }
}

/// `from` moved towards `to` by at most `step`.
// Velocities and steps of the model (see `tick`): far from i64's ends.
#[allow(clippy::arithmetic_side_effects)]
fn toward(from: i64, to: i64, step: i64) -> i64 {
    if to > from { (from + step).min(to) } else { (from - step).max(to) }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARAMS: AxisParams = AxisParams {
        increments_per_rev: 4096,
        max_acceleration: 100_000,
        max_velocity: 50_000,
        position_gain: 50,
        friction_permille: 20,
        ambient_c: 25,
        rise_at_rated_c: 60,
        thermal_tau_s: 60,
        warning_c: 95,
        fault_c: 110,
        dc_link_mv: 24_000,
        following_limit: 1_000,
        limits: (-10_000, 10_000),
        home_switch: Some(500),
    };

    fn axis() -> Axis {
        let mut a = Axis::NEW;
        a.configure(PARAMS);
        a.enable(true);
        a
    }

    #[test]
    fn per_mille_divides_as_the_64_bit_division_does() {
        let mut x: i64 = 0x2545_F491_4F6C_DD1D;
        for special in [0, 1, -1, 999, -999, 1000, -1000, 1001, i64::MAX, i64::MIN, i64::MIN + 1] {
            assert_eq!(per_mille(special), special / 1000, "{special}");
        }
        for _ in 0..100_000 {
            // xorshift: values of every magnitude and both signs.
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = x >> (x as u64 % 64);
            assert_eq!(per_mille(v), v / 1000, "{v}");
        }
    }

    #[test]
    fn an_unconfigured_axis_neither_moves_nor_faults() {
        let mut a = Axis::NEW;
        a.enable(true);
        a.command(SetPoint::Velocity(1000));
        a.tick();
        assert_eq!((a.fault(), a.velocity(), a.warning()), (EmcyCode::NO_ERROR, 0, false));
    }

    #[test]
    fn the_velocity_loop_follows_within_the_acceleration_limit() {
        let mut a = axis();
        a.command(SetPoint::Velocity(80_000));
        for _ in 0..100 {
            a.tick();
        }
        assert_eq!(a.velocity(), 10_000, "100 ms at 100,000 inc/s²");
        assert!(a.torque() >= 1000, "at the limit: rated torque and friction");
        for _ in 0..1000 {
            a.tick();
        }
        assert_eq!(a.velocity(), 50_000, "the speed limit");
        // 0.5 s ramp (12,500 inc) and 0.6 s at 50,000 inc/s.
        assert!((42_400..42_600).contains(&a.position()), "{}", a.position());
        assert!(a.switches().positive_limit && a.switches().home && !a.switches().negative_limit);
    }

    #[test]
    fn the_position_loop_settles_on_the_set_point() {
        let mut a = axis();
        a.command(SetPoint::Position { position: 300, velocity: 0 });
        for _ in 0..500 {
            a.tick();
        }
        assert_eq!((a.position(), a.velocity()), (300, 0));
    }

    #[test]
    fn faults_stop_the_power_stage_and_clear_once_their_cause_is_gone() {
        for (fault, code) in [
            (Injected::OverTemperature, fault::OVER_TEMPERATURE),
            (Injected::UnderVoltage, fault::UNDER_VOLTAGE),
            (Injected::OverVoltage, fault::OVER_VOLTAGE),
            (Injected::PowerStage, fault::POWER_STAGE),
        ] {
            let mut a = axis();
            a.command(SetPoint::Velocity(10_000));
            a.tick();
            a.inject(fault);
            assert_eq!(a.fault(), code);
            a.tick();
            a.enable(true);
            assert_eq!(a.torque(), 0, "{fault:?}: the power stage is off");
            assert!(!a.reset_fault(), "the cause persists");
            a.remove(fault);
            assert!(a.reset_fault());
            assert_eq!(a.fault(), EmcyCode::NO_ERROR);
        }
        let mut a = axis();
        a.inject(Injected::Blocked);
        a.command(SetPoint::Position { position: 5_000, velocity: 0 });
        a.tick();
        assert_eq!(a.fault(), fault::FOLLOWING_ERROR, "a blocked load: the drive's following-error monitoring");
    }

    #[test]
    fn a_load_turns_a_coasting_axis_and_the_loops_hold_it() {
        // Friction holds a coasting axis against a load of up to 125 ‰ (an
        // eighth of the acceleration limit).
        let mut a = axis();
        a.enable(false);
        a.set_load(100);
        for _ in 0..100 {
            a.tick();
        }
        assert_eq!((a.position(), a.velocity()), (0, 0), "static friction holds");
        // 625 ‰: 500 ‰ net, 50,000 inc/s² for 100 ms = 250 inc.
        a.set_load(625);
        for _ in 0..100 {
            a.tick();
        }
        assert_eq!((a.position(), a.velocity()), (252, 5_000), "the load turns it");
        // The position loop holds the same load where it is, the torque against it.
        let mut a = axis();
        a.set_load(625);
        a.command(SetPoint::Position { position: 0, velocity: 0 });
        for _ in 0..1000 {
            a.tick();
        }
        assert_eq!((a.position(), a.velocity(), a.torque()), (0, 0, -625));
        // Beyond the torque limit it slips.
        a.set_load(3500);
        for _ in 0..100 {
            a.tick();
        }
        assert!(a.position() > 0, "{}", a.position());
    }
}
