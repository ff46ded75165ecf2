//! The trajectory generator: parameters read once per poll, one tick of
//! the active mode or stop reaction, and the monitoring windows.

use super::{Cia402, Config};
use crate::node::Ctx;
use crate::profiles::cia402::controlword as cw;
use crate::profiles::cia402::drive::{Drive, SetPoint};
use crate::profiles::cia402::fsa::{PdsState, Reaction};
use crate::profiles::cia402::hm::Step;
use crate::profiles::cia402::mode;
use crate::profiles::cia402::motion::{Demand, FRACTION, acceleration_q, speed_per_s, speed_q, speed_q_call};
use crate::profiles::cia402::objects::{index, signed, unsigned, unsigned_or};
use crate::profiles::cia402::units::Units;
use crate::profiles::cia402::velocity::{vl_ramp, vl_ramp_time};

/// Parameters read once per poll: windows in increments, speeds and ramps
/// in [`crate::profiles::cia402::motion`]'s Q24 per-tick units, times in ticks.
pub(super) struct Params {
    acceleration: i64,
    deceleration: i64,
    quick_stop: i64,
    limit: i64,
    speed: i64,
    halt: Reaction,
    position_window: i64,
    position_window_ticks: u32,
    following_window: Option<i64>,
    following_ticks: u32,
    velocity_window: i64,
    velocity_window_ticks: u32,
    /// The standstill window [inc/s] and how long the axis stays in it.
    standstill: i64,
    threshold_ticks: u32,
    homing: (i64, i64),
    homing_acceleration: i64,
    home: i64,
}

/// Milliseconds as ticks (one tick is a millisecond, see `motion`).
fn ticks(ms: u32) -> u32 {
    ms
}

/// The standstill window [inc/s]: the largest speed at which the velocity
/// actual value, as its object shows it, reads within the velocity
/// threshold 0x606F (0 or missing: reads 0). That is 0x606C's unit (user
/// units per second, or the device's [`Config::velocity_unit`]), and in vl
/// 0x6044's (min⁻¹ times the vl dimension factor), where 0x606F does not
/// apply. The threshold plus half a unit, the value's rounding, doubled so
/// that it stays an integer.
// `doubled` ≤ 2^33: the Q32 factors keep it within an i64.
#[allow(clippy::arithmetic_side_effects)]
fn standstill(ctx: &Ctx<'_>, config: &Config, u: &Units, vl: bool) -> i64 {
    if vl {
        return u.vl_to_inc.apply(1).abs() >> 1;
    }
    let doubled = i64::from(unsigned_or(ctx, index::VELOCITY_THRESHOLD, 0, 0)) * 2 + 1;
    let user = match config.velocity_unit {
        Some(unit) => unit(ctx).apply(doubled),
        None => doubled,
    };
    u.to_inc.apply(user).abs() >> 1
}

/// vl ramp `i` (0 acceleration, 1 deceleration, 2 quick stop) [inc/s²]: its
/// time (0x604F + `i`) while that is not 0, else its delta speed per delta
/// time (0x6048 + `i`); none → `limit`. `max`: the drive's maximum speed.
/// Out of line: inlined at its three calls it cost each drive image about 450 B more.
// `i` ≤ 2: the indices stay in 0x6048..=0x6051.
#[allow(clippy::arithmetic_side_effects)]
#[inline(never)]
fn vl_ramp_of(ctx: &Ctx<'_>, config: &Config, u: &Units, i: u16, max: u32, limit: u32) -> u32 {
    let per_s2 = match unsigned_or(ctx, index::VL_RAMP_FUNCTION_TIME + i, 0, 0) {
        0 => {
            let delta = index::VL_ACCELERATION + i;
            let rpm_per_s = vl_ramp(unsigned_or(ctx, delta, 1, 0), unsigned_or(ctx, delta, 2, 1));
            // A magnitude: a negative vl dimension factor turns the motor, not the ramp.
            u.vl_to_inc.apply(i64::from(rpm_per_s)).abs()
        }
        ms => i64::from(vl_ramp_time(vl_reference(ctx, config, max), ms)),
    };
    match per_s2 {
        0 => limit,
        a => a.clamp(1, i64::from(u32::MAX)) as u32,
    }
}

/// The speed the vl ramp times refer to [inc/s]: the max motor speed
/// 0x6080 (min⁻¹) while it is not 0, else the drive's maximum (the b maXX
/// 4400's "MotorMaxSpeed"). DSP 402's vl velocity reference 0x604E is in no
/// dictionary here and is not read.
// A saturated product is a reference beyond any motor: its ramps are steep.
fn vl_reference(ctx: &Ctx<'_>, config: &Config, max: u32) -> u32 {
    match unsigned(ctx, index::MAX_MOTOR_SPEED, 0) {
        Some(rpm) if rpm != 0 => rpm.saturating_mul(config.increments_per_rev) / 60,
        _ => max,
    }
}

/// An acceleration in increments, 0 or missing → `fallback`. Out of line,
/// as are [`window`] and [`homing_speed`]: `params` runs once a poll, not
/// per frame, and inlined at their calls they cost each drive image some
/// hundreds of bytes.
#[inline(never)]
fn ramp(units: &Units, user: Option<u32>, fallback: u32) -> u32 {
    match user {
        Some(a) if a != 0 => units.magnitude_to_inc(a).clamp(1, i64::from(u32::MAX)) as u32,
        _ => fallback,
    }
}

/// A window object (0x6067, 0x606D) in increments, missing → `default`.
#[inline(never)]
fn window(ctx: &Ctx<'_>, u: &Units, index: u16, default: u32) -> i64 {
    u.magnitude_to_inc(unsigned(ctx, index, 0).unwrap_or(default))
}

/// Homing speed 0x6099 `sub` (1 fast, 2 slow) in Q24 per tick, 0 or
/// missing → `default`, at most the drive's maximum speed `max`.
#[inline(never)]
fn homing_speed(ctx: &Ctx<'_>, u: &Units, sub: u8, default: u32, max: u32) -> i64 {
    let v = unsigned(ctx, index::HOMING_SPEEDS, sub).filter(|v| *v != 0).unwrap_or(default);
    speed_q_call(u.magnitude_to_inc(v).min(i64::from(max)))
}

impl<D: Drive> Cia402<D> {
    // ---- motion --------------------------------------------------------------------

    pub(super) fn params(&self, ctx: &Ctx<'_>, config: &Config) -> Params {
        let u = &self.s.units;
        let limit = match unsigned(ctx, index::MAX_DECELERATION, 0) {
            Some(a) if a != 0 => ramp(u, Some(a), 1),
            _ => self.drive.max_acceleration(),
        };
        let vl = self.s.mode == mode::VL;
        let (acceleration, deceleration, quick_stop) = if vl {
            let max = self.drive.max_velocity();
            let ramp = |i| vl_ramp_of(ctx, config, u, i, max, limit);
            (ramp(0), ramp(1), ramp(2))
        } else {
            (
                ramp(u, unsigned(ctx, index::PROFILE_ACCELERATION, 0), limit),
                ramp(u, unsigned(ctx, index::PROFILE_DECELERATION, 0), limit),
                ramp(u, unsigned(ctx, index::QUICK_STOP_DECELERATION, 0), limit),
            )
        };
        // Profile velocity 0 or missing: the max profile velocity, else unbounded.
        let speed = match (unsigned(ctx, index::PROFILE_VELOCITY, 0), unsigned(ctx, index::MAX_PROFILE_VELOCITY, 0)) {
            (Some(v), Some(m)) if v != 0 && m != 0 => v.min(m),
            (Some(v), _) if v != 0 => v,
            (_, Some(m)) if m != 0 => m,
            _ => u32::MAX / 2,
        };
        let max = self.drive.max_velocity();
        let following = unsigned(ctx, index::FOLLOWING_ERROR_WINDOW, 0).filter(|w| *w != u32::MAX);
        Params {
            acceleration: acceleration_q(acceleration),
            deceleration: acceleration_q(deceleration),
            quick_stop: acceleration_q(quick_stop),
            limit: acceleration_q(limit),
            speed: speed_q_call(u.magnitude_to_inc(speed).min(i64::from(max))),
            halt: Reaction::of(signed(ctx, index::HALT_OPTION, 0).map_or(-1, |v| v), Reaction::SlowDownRamp),
            position_window: window(ctx, u, index::POSITION_WINDOW, config.position_window),
            position_window_ticks: ticks(unsigned_or(ctx, index::POSITION_WINDOW_TIME, 0, 0)),
            following_window: following.map(|w| u.magnitude_to_inc(w)),
            following_ticks: ticks(unsigned_or(ctx, index::FOLLOWING_ERROR_TIMEOUT, 0, 0)),
            velocity_window: self
                .drive
                .velocity_window()
                .map_or_else(|| window(ctx, u, index::VELOCITY_WINDOW, config.velocity_window), i64::from),
            velocity_window_ticks: ticks(unsigned_or(ctx, index::VELOCITY_WINDOW_TIME, 0, 0)),
            standstill: standstill(ctx, config, u, vl),
            threshold_ticks: ticks(unsigned_or(ctx, index::VELOCITY_THRESHOLD_TIME, 0, 0)),
            homing: (homing_speed(ctx, u, 1, config.homing_speeds.0, max), homing_speed(ctx, u, 2, config.homing_speeds.1, max)),
            homing_acceleration: acceleration_q(ramp(u, unsigned(ctx, index::HOMING_ACCELERATION, 0), acceleration)),
            home: u.position_to_inc(signed(ctx, index::HOME_OFFSET, 0).unwrap_or(0)),
        }
    }

    /// The deceleration of a stop reaction [inc/s²].
    pub(super) fn deceleration(p: &Params, reaction: Reaction) -> i64 {
        match reaction {
            Reaction::SlowDownRamp => p.deceleration,
            Reaction::QuickStopRamp => p.quick_stop,
            Reaction::Limit | Reaction::Coast => p.limit,
        }
    }

    pub(super) fn tick(&mut self, p: &Params) {
        let s = &mut self.s;
        if !s.state.drive_function() {
            self.drive.tick();
            s.demand = Demand::at(self.drive.position(), self.drive.velocity());
            return;
        }
        let d = &mut s.demand;
        let halt = s.controlword & cw::HALT != 0 && s.state == PdsState::OperationEnabled;
        // Below the motor's minimum speed a stop ends, and a pv or vl target stops.
        let min = speed_q(i64::from(self.drive.min_velocity()));
        let mut stopping = true;
        if s.braking || matches!(s.state, PdsState::QuickStopActive | PdsState::FaultReactionActive) {
            d.ramp(0, p.acceleration, Self::deceleration(p, s.reaction));
        } else if halt {
            d.ramp(0, p.acceleration, Self::deceleration(p, p.halt));
        } else {
            stopping = false;
            match s.mode {
                mode::PP => s.pp.tick(d, p.speed, p.acceleration, p.deceleration, s.controlword & cw::NEW_SET_POINT != 0),
                mode::PV | mode::VL => {
                    let limit = speed_q(i64::from(self.drive.max_velocity()));
                    // `speed_q` keeps |limit| below 2^47: its negation fits.
                    #[allow(clippy::arithmetic_side_effects)]
                    let target = if s.velocity_target.abs() < min { 0 } else { s.velocity_target.clamp(-limit, limit) };
                    stopping = target == 0;
                    d.ramp(target, p.acceleration, p.deceleration);
                }
                mode::HM => {
                    let started = core::mem::take(&mut s.hm_started);
                    match s.hm.tick(self.drive.switches(), started) {
                        Step::Run(direction, fast) => {
                            let speed = if fast { p.homing.0 } else { p.homing.1 };
                            // `direction` is ±1.
                            #[allow(clippy::arithmetic_side_effects)]
                            let velocity = speed * i64::from(direction);
                            d.ramp(velocity, p.homing_acceleration, p.homing_acceleration);
                        }
                        Step::SetHome => {
                            self.drive.set_position(p.home);
                            *d = Demand { position_q: p.home << FRACTION, velocity_q: 0 };
                        }
                        Step::Stop => d.ramp(0, p.homing_acceleration, p.homing_acceleration),
                    }
                }
                mode::IP if s.controlword & cw::NEW_SET_POINT != 0 => s.ip.tick(d),
                _ => d.ramp(0, p.acceleration, p.deceleration),
            }
        }
        if stopping && d.velocity_q.abs() < min {
            d.velocity_q = 0;
        }
        let set_point = if s.mode == mode::VL {
            SetPoint::Velocity(d.velocity())
        } else {
            SetPoint::Position { position: d.position(), velocity: d.velocity() }
        };
        self.drive.command(set_point);
        self.drive.tick();
        // A stop completes when the demand is at rest and the axis has followed
        // it into the standstill window (disabling earlier would let the
        // motor coast on): at the tick 0x606C reads within 0x606F, not
        // when the position loop has settled the last increment.
        s.speed_zero = s.zero_window.tick(i64::from(self.drive.velocity()).abs() <= p.standstill, p.threshold_ticks);
        if d.velocity_q == 0 && s.speed_zero {
            self.stopped();
        }
    }

    /// The demand reached standstill: a braking transition, a quick stop or
    /// a fault reaction completes.
    pub(super) fn stopped(&mut self) {
        let s = &mut self.s;
        if s.braking {
            let to = s.pending;
            self.stop_now(to);
        } else if s.state == PdsState::FaultReactionActive {
            self.stop_now(PdsState::Fault);
        } else if s.state == PdsState::QuickStopActive && !matches!(s.reaction, Reaction::Coast) {
            // Option codes 1-4 end in Switch on disabled (transition 12); 5-8 hold.
            if !s.quick_stop_holds {
                self.stop_now(PdsState::SwitchOnDisabled);
            }
        }
    }

    /// Target reached and following error, one tick.
    pub(super) fn monitor(&mut self, p: &Params) {
        let s = &mut self.s;
        let position = self.drive.position();
        let velocity = i64::from(self.drive.velocity());
        match s.mode {
            mode::PP | mode::IP => {
                // In ip the demand stands on the last set-point once the segment is done.
                let (done, target) =
                    if s.mode == mode::PP { (s.pp.done(), s.pp.final_target()) } else { (s.ip.done(), s.demand.position()) };
                // Positions wrap (`Demand::ramp`): so do their differences.
                let near = done && position.wrapping_sub(target).abs() <= p.position_window;
                s.reached = s.reached_window.tick(near, p.position_window_ticks);
                let lagging = p.following_window.is_some_and(|w| s.demand.position().wrapping_sub(position).abs() > w);
                s.following = s.following_window.tick(lagging, p.following_ticks);
            }
            mode::PV | mode::VL => {
                // `speed_per_s` of a Q24 velocity and an i32: the difference fits.
                #[allow(clippy::arithmetic_side_effects)]
                let near = (speed_per_s(s.velocity_target) - velocity).abs() <= p.velocity_window;
                s.reached = s.reached_window.tick(near, p.velocity_window_ticks);
            }
            _ => {}
        }
    }
}
