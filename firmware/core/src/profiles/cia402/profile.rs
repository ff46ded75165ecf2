//! The profile's state and the slot hooks that drive it.

use super::controlword::{self as cw, Command};
use super::drive::{Drive, SetPoint};
use super::fsa::{self, PdsState, Reaction, Transition};
use super::hm::{Hm, Phase, Step};
use super::motion::Demand;
use super::objects::{self, index, signed, unsigned, unsigned_or};
use super::pp::{Pp, SetPointRequest};
use super::units::Units;
use super::velocity::{Window, vl_limit, vl_ramp};
use super::{TICK_US, mode, statusword as sw};
use crate::abort::AbortCode;
use crate::node::{CommError, Ctx, NmtEvent};
use crate::services::nmt::State;
use crate::time::Instant;

/// A device's constants for the profile (what its manual fixes and no object holds).
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Encoder increments per motor revolution (the factor group's base).
    pub increments_per_rev: u32,
    /// NMT leaving Operational counts as a communication error for 0x6007.
    pub leaving_operational_aborts: bool,
    /// Position window [user units] when 0x6067 is missing.
    pub position_window: u32,
    /// Velocity window [user units/s] when 0x606D is missing.
    pub velocity_window: u32,
    /// Homing speeds [user units/s] (switch, zero) when 0x6099 is missing.
    pub homing_speeds: (u32, u32),
}

/// While idle (drive function off, axis at rest) the profile looks for
/// drive faults this often, not every tick.
const IDLE_POLL_US: u64 = 100_000;
/// At most this many ticks are caught up in one poll (a late call does not
/// stall the node; the motion then runs slower than real time).
const MAX_CATCH_UP: u64 = 200;
/// Error code 0x603F / EMCY of a communication error (0x6007 = 1): CiA 301 0x8100
/// communication, 0x8130 life guarding or heartbeat, 0x8140 bus-off recovered.
const fn comm_error_code(error: Option<CommError>) -> u16 {
    match error {
        Some(CommError::Heartbeat(_) | CommError::LifeGuarding) => 0x8130,
        Some(CommError::BusOff) => 0x8140,
        _ => 0x8100,
    }
}

/// The CiA 402 profile with the drive it controls. `const`-constructible
/// and all zero bits (with a zero-bits drive), so it lives in `.bss`.
#[derive(Clone, Debug)]
pub struct Cia402<D> {
    /// The drive (the axis model, or a board's motor control).
    pub drive: D,
    s: Profile,
}

/// Everything but the drive: reset application restores [`Profile::NEW`].
#[derive(Clone, Debug)]
struct Profile {
    state: PdsState,
    controlword: u16,
    statusword: u16,
    mode: i8,
    supported: u32,
    units: Units,
    demand: Demand,
    /// Transitions 5 and 8 on a ramp: the state stays Operation enabled
    /// until the axis stands, then becomes `pending`.
    braking: bool,
    pending: PdsState,
    /// How Quick stop active, Fault reaction active or a braking transition stops.
    reaction: Reaction,
    /// Quick stop option code 5-8: Quick stop active holds the axis.
    quick_stop_holds: bool,
    pp: Pp,
    hm: Hm,
    hm_started: bool,
    /// pv or vl target [milli-inc/s].
    velocity_target_m: i64,
    internal_limit: bool,
    reached: bool,
    speed_zero: bool,
    following: bool,
    reached_window: Window,
    zero_window: Window,
    following_window: Window,
    error_code: u16,
    next_tick: u64,
    ticking: bool,
    operational: bool,
}

impl Profile {
    const NEW: Profile = Profile {
        state: PdsState::NotReadyToSwitchOn,
        controlword: 0,
        statusword: 0,
        mode: 0,
        supported: 0,
        units: Units::ZERO,
        demand: Demand { position_u: 0, velocity_m: 0 },
        braking: false,
        pending: PdsState::NotReadyToSwitchOn,
        reaction: Reaction::Coast,
        quick_stop_holds: false,
        pp: Pp::NEW,
        hm: Hm::NEW,
        hm_started: false,
        velocity_target_m: 0,
        internal_limit: false,
        reached: false,
        speed_zero: false,
        following: false,
        reached_window: Window::NEW,
        zero_window: Window::NEW,
        following_window: Window::NEW,
        error_code: 0,
        next_tick: 0,
        ticking: false,
        operational: false,
    };
}

/// Parameters read once per poll, in increments.
struct Params {
    acceleration: u32,
    deceleration: u32,
    quick_stop: u32,
    limit: u32,
    speed_m: i64,
    halt: Reaction,
    position_window: i64,
    position_window_ticks: u32,
    following_window: Option<i64>,
    following_ticks: u32,
    velocity_window: i64,
    velocity_window_ticks: u32,
    threshold: i64,
    threshold_ticks: u32,
    homing_m: (i64, i64),
    homing_acceleration: u32,
    home: i64,
}

/// Milliseconds as ticks.
fn ticks(ms: u32) -> u32 {
    (u64::from(ms) * 1000 / TICK_US).min(u64::from(u32::MAX)) as u32
}

/// An acceleration in increments, 0 or missing → `fallback`.
fn ramp(units: &Units, user: Option<u32>, fallback: u32) -> u32 {
    match user {
        Some(a) if a != 0 => units.magnitude_to_inc(a).clamp(1, i64::from(u32::MAX)) as u32,
        _ => fallback,
    }
}

impl<D: Drive> Cia402<D> {
    /// The profile before reset application: Not ready to switch on.
    pub const fn new(drive: D) -> Self {
        Cia402 { drive, s: Profile::NEW }
    }

    /// The PDS state.
    pub fn state(&self) -> PdsState {
        self.s.state
    }

    /// The mode of operation in force (0x6061).
    pub fn mode(&self) -> i8 {
        self.s.mode
    }

    /// Reset application (and power-on): transitions 0 and 1 to Switch on
    /// disabled, the factors and supported modes from the dictionary.
    pub fn reset(&mut self, ctx: &mut Ctx<'_>, config: &Config) {
        self.drive.reset();
        self.s = Profile::NEW;
        self.s.units = units(ctx, config);
        self.s.supported = supported_modes(ctx);
        self.s.state = PdsState::SwitchOnDisabled;
        self.s.operational = ctx.state() == State::Operational;
        objects::set(ctx, index::ERROR_CODE, 2, 0);
        self.set_mode(ctx);
        self.publish(ctx);
        self.actuals(ctx);
    }

    /// Validates a download before it is stored: 0x6060 takes the
    /// supported modes only (abort 0x06090030).
    pub fn check_write(&self, index: u16, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            (index::MODES_OF_OPERATION, [m]) if *m != 0 && mode::supported_bit(*m as i8) & self.s.supported == 0 => {
                Err(AbortCode::InvalidValue)
            }
            _ => Ok(()),
        }
    }

    /// An object has a new value (RPDO, SDO or the device).
    pub fn written(&mut self, ctx: &mut Ctx<'_>, config: &Config, index: u16) {
        match index {
            index::CONTROLWORD => self.controlword(ctx),
            index::MODES_OF_OPERATION => self.set_mode(ctx),
            index::TARGET_VELOCITY | index::VL_TARGET_VELOCITY => self.velocity_target(ctx),
            index::GEAR_RATIO | index::FEED_CONSTANT | index::POLARITY => {
                self.s.units = units(ctx, config);
                self.velocity_target(ctx);
            }
            _ => return,
        }
        self.publish(ctx);
    }

    /// Before SYNC TPDOs: the actual values.
    pub fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.actuals(ctx);
    }

    /// The motion timer: runs the ticks due; returns when it wants to run again.
    pub fn poll(&mut self, ctx: &mut Ctx<'_>, config: &Config) -> Option<Instant> {
        let now = ctx.now().as_micros();
        if !self.s.ticking {
            let code = self.drive.fault();
            if code != 0 && !matches!(self.s.state, PdsState::Fault | PdsState::FaultReactionActive) {
                self.fault(ctx, code);
                self.publish(ctx);
            }
            return (self.s.state != PdsState::NotReadyToSwitchOn).then(|| Instant::from_micros(now + IDLE_POLL_US));
        }
        if now < self.s.next_tick {
            return Some(Instant::from_micros(self.s.next_tick));
        }
        let due = ((now - self.s.next_tick) / TICK_US + 1).min(MAX_CATCH_UP);
        let p = self.params(ctx, config);
        for _ in 0..due {
            self.tick(&p);
            let code = self.drive.fault();
            if code != 0 && !matches!(self.s.state, PdsState::Fault | PdsState::FaultReactionActive) {
                self.fault(ctx, code);
            }
            self.monitor(&p);
        }
        self.s.next_tick = (self.s.next_tick + due * TICK_US).max(now + 1);
        self.actuals(ctx);
        self.publish(ctx);
        if !self.s.state.drive_function() && self.drive.velocity() == 0 {
            self.s.ticking = false;
            return Some(Instant::from_micros(now + IDLE_POLL_US));
        }
        Some(Instant::from_micros(self.s.next_tick))
    }

    /// NMT and communication events: reset application, and the abort
    /// connection option code 0x6007 on a communication error (heartbeat or
    /// guarding loss, bus-off, and leaving Operational if the device says so).
    pub fn on_nmt(&mut self, ctx: &mut Ctx<'_>, config: &Config, event: NmtEvent) {
        let error = match event {
            NmtEvent::ResetApplication => {
                self.reset(ctx, config);
                return;
            }
            NmtEvent::Entered(state) => {
                let left = self.s.operational && state != State::Operational;
                self.s.operational = state == State::Operational;
                if !(left && config.leaving_operational_aborts) {
                    return;
                }
                None
            }
            NmtEvent::CommunicationError(e @ (CommError::Heartbeat(_) | CommError::LifeGuarding | CommError::BusOff)) => Some(e),
            _ => return,
        };
        // Only a drive whose function is on has a connection to abort.
        if !matches!(self.s.state, PdsState::OperationEnabled | PdsState::QuickStopActive) {
            return;
        }
        match signed(ctx, index::ABORT_CONNECTION, 0).unwrap_or(0) {
            1 => self.fault(ctx, comm_error_code(error)),
            2 => self.command(ctx, Command::DisableVoltage),
            3 => self.command(ctx, Command::QuickStop),
            _ => {}
        }
        self.publish(ctx);
    }

    // ---- device control ------------------------------------------------------------

    fn controlword(&mut self, ctx: &mut Ctx<'_>) {
        let word = unsigned(ctx, index::CONTROLWORD, 0).unwrap_or(0) as u16;
        let previous = core::mem::replace(&mut self.s.controlword, word);
        if let Some(command) = cw::decode(word, previous) {
            self.command(ctx, command);
        }
        let rose = word & cw::NEW_SET_POINT != 0 && previous & cw::NEW_SET_POINT == 0;
        let fell = word & cw::NEW_SET_POINT == 0 && previous & cw::NEW_SET_POINT != 0;
        let running = self.s.state == PdsState::OperationEnabled && !self.s.braking;
        match self.s.mode {
            mode::PP if rose && running => self.new_set_point(ctx, word),
            mode::PP if fell => self.s.pp.set_point_released(),
            mode::HM if rose && running => {
                self.s.hm.start(signed(ctx, index::HOMING_METHOD, 0).unwrap_or(0));
                self.s.hm_started = true;
            }
            mode::HM if fell => self.s.hm.interrupt(),
            _ => {}
        }
    }

    fn command(&mut self, ctx: &mut Ctx<'_>, command: Command) {
        if command == Command::FaultReset && self.s.state == PdsState::Fault {
            // Transition 15 once the cause is gone.
            if self.drive.reset_fault() {
                ctx.clear_error(self.s.error_code);
                self.s.error_code = 0;
                objects::set(ctx, index::ERROR_CODE, 2, 0);
                self.s.state = PdsState::SwitchOnDisabled;
            }
            return;
        }
        let stays = matches!(signed(ctx, index::QUICK_STOP_OPTION, 0), Some(5..=8));
        match fsa::next(self.s.state, command, stays) {
            Some(t) => {
                self.transition(ctx, t);
                // "Switch on + enable operation" in Ready to switch on: 3, then 4.
                if t.number == 3 && command == Command::EnableOperation {
                    self.transition(ctx, Transition { to: PdsState::OperationEnabled, number: 4 });
                }
            }
            // Enable operation again while braking towards Switched on / Ready: braking ends.
            None if self.s.braking && command == Command::EnableOperation => self.s.braking = false,
            None => {}
        }
    }

    fn transition(&mut self, ctx: &mut Ctx<'_>, t: Transition) {
        // The new state shows for at least one tick (a stop at rest completes on the next).
        self.s.next_tick = self.s.next_tick.max(ctx.now().as_micros() + TICK_US);
        let option = |index, default| Reaction::of(signed(ctx, index, 0).map_or(-1, |v| v), default);
        match t.number {
            4 | 16 => {
                if t.number == 4 {
                    self.s.demand = Demand::at(self.drive.position(), self.drive.velocity());
                    self.s.pp.clear(self.drive.position());
                    self.s.hm = Hm::NEW;
                    (self.s.reached, self.s.speed_zero, self.s.following) = (false, false, false);
                    (self.s.reached_window, self.s.zero_window, self.s.following_window) = (Window::NEW, Window::NEW, Window::NEW);
                }
                self.drive.enable(true);
                self.s.braking = false;
                self.s.state = PdsState::OperationEnabled;
                self.start_ticking(ctx);
            }
            5 | 8 => {
                // 0x605C default 1 (slow down ramp), 0x605B default 0 (disable the drive function).
                let reaction = if t.number == 5 {
                    option(index::DISABLE_OPERATION_OPTION, Reaction::SlowDownRamp)
                } else {
                    option(index::SHUTDOWN_OPTION, Reaction::Coast)
                };
                if reaction == Reaction::Coast {
                    self.stop_now(t.to);
                } else {
                    (self.s.braking, self.s.pending, self.s.reaction) = (true, t.to, reaction);
                }
            }
            11 => {
                // 0x605A default 2: quick stop ramp, then Switch on disabled.
                let code = signed(ctx, index::QUICK_STOP_OPTION, 0);
                self.s.quick_stop_holds = matches!(code, Some(5..=8));
                self.s.reaction = Reaction::of(code.unwrap_or(-1), Reaction::QuickStopRamp);
                self.s.braking = false;
                if self.s.reaction == Reaction::Coast {
                    self.stop_now(PdsState::SwitchOnDisabled);
                } else {
                    self.s.state = PdsState::QuickStopActive;
                }
            }
            _ => self.stop_now(t.to),
        }
    }

    /// The drive function goes off at once (the motor coasts) in `state`.
    fn stop_now(&mut self, state: PdsState) {
        if self.s.state.drive_function() {
            self.drive.enable(false);
        }
        self.s.braking = false;
        self.s.state = state;
    }

    /// Transition 13: a fault in any state; the reaction 0x605E (default 2,
    /// quick stop ramp) runs if the drive still can, then transition 14.
    fn fault(&mut self, ctx: &mut Ctx<'_>, code: u16) {
        self.s.error_code = code;
        objects::set(ctx, index::ERROR_CODE, 2, i32::from(code));
        ctx.raise_error(code, [0; 5]);
        let reaction = Reaction::of(signed(ctx, index::FAULT_REACTION_OPTION, 0).map_or(-1, |v| v), Reaction::QuickStopRamp);
        if self.s.state.drive_function() && reaction != Reaction::Coast && self.drive.fault() == 0 {
            (self.s.state, self.s.reaction, self.s.braking) = (PdsState::FaultReactionActive, reaction, false);
        } else {
            self.stop_now(PdsState::Fault);
        }
    }

    fn start_ticking(&mut self, ctx: &Ctx<'_>) {
        if !self.s.ticking {
            self.s.ticking = true;
            self.s.next_tick = ctx.now().as_micros() + TICK_US;
        }
    }

    // ---- modes ---------------------------------------------------------------------

    fn set_mode(&mut self, ctx: &mut Ctx<'_>) {
        // A write-only 0x6060 (agile) cannot be read back: the mode stays.
        let requested = signed(ctx, index::MODES_OF_OPERATION, 0).or_else(|| signed(ctx, index::MODES_OF_OPERATION_DISPLAY, 0));
        let Some(requested) = requested else {
            let _ = ctx.set_value(index::MODES_OF_OPERATION_DISPLAY, 0, &[self.s.mode as u8]);
            return;
        };
        let requested = requested as i8;
        if requested != 0 && mode::supported_bit(requested) & self.s.supported == 0 {
            return;
        }
        if requested != self.s.mode {
            self.s.hm.interrupt();
            self.s.pp.clear(self.s.demand.position());
            self.s.mode = requested;
            self.velocity_target(ctx);
        }
        let _ = ctx.set_value(index::MODES_OF_OPERATION_DISPLAY, 0, &[self.s.mode as u8]);
    }

    fn velocity_target(&mut self, ctx: &mut Ctx<'_>) {
        let u = &self.s.units;
        self.s.velocity_target_m = match self.s.mode {
            mode::PV => {
                let target = signed(ctx, index::TARGET_VELOCITY, 0).unwrap_or(0);
                self.s.internal_limit = false;
                u.velocity_to_inc(target) * 1000
            }
            mode::VL => {
                let target = signed(ctx, index::VL_TARGET_VELOCITY, 0).unwrap_or(0);
                let min = unsigned_or(ctx, index::VL_MIN_MAX, 1, 0);
                let max = unsigned_or(ctx, index::VL_MIN_MAX, 2, 0);
                let (limited, clipped) = vl_limit(target, min, max);
                self.s.internal_limit = clipped;
                let inc = u.vl_to_inc.apply(i64::from(limited));
                (if u.velocity_negative { -inc } else { inc }) * 1000
            }
            _ => return,
        };
    }

    fn new_set_point(&mut self, ctx: &mut Ctx<'_>, word: u16) {
        let u = self.s.units;
        let request = SetPointRequest {
            target: u.position_to_inc(signed(ctx, index::TARGET_POSITION, 0).unwrap_or(0)),
            relative: word & cw::RELATIVE != 0,
            immediately: word & cw::CHANGE_IMMEDIATELY != 0,
            blend: word & cw::CHANGE_OF_SET_POINT != 0,
            relative_to: unsigned_or(ctx, index::POSITIONING_OPTION, 0, 0) as u8,
        };
        let mut target = self.s.pp.absolute(&request, &self.s.demand, self.drive.position());
        // Software position limits (0x607D; min ≥ max: none) bound the target (bit 11).
        self.s.internal_limit = false;
        if let (Some(min), Some(max)) = (signed(ctx, index::SOFTWARE_POSITION_LIMIT, 1), signed(ctx, index::SOFTWARE_POSITION_LIMIT, 2))
            && min < max
        {
            let (a, b) = (u.position_to_inc(min), u.position_to_inc(max));
            let limited = target.clamp(a.min(b), a.max(b));
            self.s.internal_limit = limited != target;
            target = limited;
        }
        self.s.pp.new_set_point(target, &request);
        self.s.reached = false;
        self.s.reached_window = Window::NEW;
    }

    // ---- motion --------------------------------------------------------------------

    fn params(&self, ctx: &Ctx<'_>, config: &Config) -> Params {
        let u = &self.s.units;
        let limit = match unsigned(ctx, index::MAX_DECELERATION, 0) {
            Some(a) if a != 0 => ramp(u, Some(a), 1),
            _ => self.drive.max_acceleration(),
        };
        let vl = self.s.mode == mode::VL;
        let vl_ramp_of = |index| {
            let rpm_per_s = vl_ramp(unsigned_or(ctx, index, 1, 0), unsigned_or(ctx, index, 2, 1));
            match u.vl_to_inc.apply(i64::from(rpm_per_s)) {
                0 => limit,
                a => a.clamp(1, i64::from(u32::MAX)) as u32,
            }
        };
        let (acceleration, deceleration, quick_stop) = if vl {
            (vl_ramp_of(index::VL_ACCELERATION), vl_ramp_of(index::VL_DECELERATION), vl_ramp_of(index::VL_QUICK_STOP))
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
        let window = |index, default: u32| u.magnitude_to_inc(unsigned(ctx, index, 0).unwrap_or(default));
        let homing_speed = |sub, default: u32| {
            let v = unsigned(ctx, index::HOMING_SPEEDS, sub).filter(|v| *v != 0).unwrap_or(default);
            u.magnitude_to_inc(v) * 1000
        };
        let following = unsigned(ctx, index::FOLLOWING_ERROR_WINDOW, 0).filter(|w| *w != u32::MAX);
        Params {
            acceleration,
            deceleration,
            quick_stop,
            limit,
            speed_m: u.magnitude_to_inc(speed).saturating_mul(1000),
            halt: Reaction::of(signed(ctx, index::HALT_OPTION, 0).map_or(-1, |v| v), Reaction::SlowDownRamp),
            position_window: window(index::POSITION_WINDOW, config.position_window),
            position_window_ticks: ticks(unsigned_or(ctx, index::POSITION_WINDOW_TIME, 0, 0)),
            following_window: following.map(|w| u.magnitude_to_inc(w)),
            following_ticks: ticks(unsigned_or(ctx, index::FOLLOWING_ERROR_TIMEOUT, 0, 0)),
            velocity_window: window(index::VELOCITY_WINDOW, config.velocity_window),
            velocity_window_ticks: ticks(unsigned_or(ctx, index::VELOCITY_WINDOW_TIME, 0, 0)),
            threshold: window(index::VELOCITY_THRESHOLD, 0),
            threshold_ticks: ticks(unsigned_or(ctx, index::VELOCITY_THRESHOLD_TIME, 0, 0)),
            homing_m: (homing_speed(1, config.homing_speeds.0), homing_speed(2, config.homing_speeds.1)),
            homing_acceleration: ramp(u, unsigned(ctx, index::HOMING_ACCELERATION, 0), acceleration),
            home: u.position_to_inc(signed(ctx, index::HOME_OFFSET, 0).unwrap_or(0)),
        }
    }

    /// The deceleration of a stop reaction [inc/s²].
    fn deceleration(p: &Params, reaction: Reaction) -> u32 {
        match reaction {
            Reaction::SlowDownRamp => p.deceleration,
            Reaction::QuickStopRamp => p.quick_stop,
            Reaction::Limit | Reaction::Coast => p.limit,
        }
    }

    fn tick(&mut self, p: &Params) {
        let s = &mut self.s;
        if !s.state.drive_function() {
            self.drive.tick();
            s.demand = Demand::at(self.drive.position(), self.drive.velocity());
            return;
        }
        let d = &mut s.demand;
        let halt = s.controlword & cw::HALT != 0 && s.state == PdsState::OperationEnabled;
        if s.braking || matches!(s.state, PdsState::QuickStopActive | PdsState::FaultReactionActive) {
            d.ramp(0, p.acceleration, Self::deceleration(p, s.reaction));
        } else if halt {
            d.ramp(0, p.acceleration, Self::deceleration(p, p.halt));
        } else {
            match s.mode {
                mode::PP => s.pp.tick(d, p.speed_m, p.acceleration, p.deceleration, s.controlword & cw::NEW_SET_POINT != 0),
                mode::PV | mode::VL => d.ramp(s.velocity_target_m, p.acceleration, p.deceleration),
                mode::HM => {
                    let started = core::mem::take(&mut s.hm_started);
                    match s.hm.tick(self.drive.switches(), started) {
                        Step::Run(direction, fast) => {
                            let speed = if fast { p.homing_m.0 } else { p.homing_m.1 };
                            d.ramp(speed * i64::from(direction), p.homing_acceleration, p.homing_acceleration);
                        }
                        Step::SetHome => {
                            self.drive.set_position(p.home);
                            *d = Demand { position_u: p.home.saturating_mul(1_000_000), velocity_m: 0 };
                        }
                        Step::Stop => d.ramp(0, p.homing_acceleration, p.homing_acceleration),
                    }
                }
                _ => d.ramp(0, p.acceleration, p.deceleration),
            }
        }
        let set_point = if s.mode == mode::VL {
            SetPoint::Velocity(d.velocity())
        } else {
            SetPoint::Position { position: d.position(), velocity: d.velocity() }
        };
        self.drive.command(set_point);
        self.drive.tick();
        if d.velocity_m == 0 {
            self.stopped();
        }
    }

    /// The demand reached standstill: a braking transition, a quick stop or
    /// a fault reaction completes.
    fn stopped(&mut self) {
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

    /// Target reached, speed zero and following error, one tick.
    fn monitor(&mut self, p: &Params) {
        let s = &mut self.s;
        let position = self.drive.position();
        let velocity = i64::from(self.drive.velocity());
        match s.mode {
            mode::PP => {
                let near = s.pp.done() && (position - s.pp.final_target()).abs() <= p.position_window;
                s.reached = s.reached_window.tick(near, p.position_window_ticks);
                let lagging = p.following_window.is_some_and(|w| (s.demand.position() - position).abs() > w);
                s.following = s.following_window.tick(lagging, p.following_ticks);
            }
            mode::PV | mode::VL => {
                let near = (s.velocity_target_m / 1000 - velocity).abs() <= p.velocity_window;
                s.reached = s.reached_window.tick(near, p.velocity_window_ticks);
                s.speed_zero = s.zero_window.tick(velocity.abs() <= p.threshold, p.threshold_ticks);
            }
            _ => {}
        }
    }

    // ---- objects -------------------------------------------------------------------

    fn statusword(&self) -> u16 {
        let s = &self.s;
        let mut word = s.state.statusword() | sw::REMOTE;
        if s.state != PdsState::NotReadyToSwitchOn && self.drive.dc_link_mv() > 0 {
            word |= sw::VOLTAGE_ENABLED;
        }
        if self.drive.warning() {
            word |= sw::WARNING;
        }
        if s.internal_limit {
            word |= sw::INTERNAL_LIMIT;
        }
        if matches!(s.state, PdsState::OperationEnabled | PdsState::QuickStopActive) {
            let halted = s.controlword & cw::HALT != 0 || s.state == PdsState::QuickStopActive;
            let standing = s.demand.velocity_m == 0;
            let (reached, bit12, bit13) = match s.mode {
                mode::PP => (s.reached, s.pp.acknowledge, s.following),
                mode::PV => (s.reached, s.speed_zero, false),
                mode::VL => (s.reached, false, false),
                mode::HM => (
                    s.hm.phase == Phase::Attained || (s.hm.phase == Phase::Idle && standing),
                    s.hm.phase == Phase::Attained,
                    s.hm.phase == Phase::Error,
                ),
                _ => (false, false, false),
            };
            if reached || (halted && standing) {
                word |= sw::TARGET_REACHED;
            }
            if bit12 {
                word |= sw::BIT12;
            }
            if bit13 {
                word |= sw::BIT13;
            }
        }
        word
    }

    /// Writes 0x6041 if it changed (the node then checks the TPDOs that map it).
    fn publish(&mut self, ctx: &mut Ctx<'_>) {
        let word = self.statusword();
        if word != self.s.statusword {
            self.s.statusword = word;
            objects::set(ctx, index::STATUSWORD, 2, i32::from(word));
        }
    }

    /// The actual values in user units.
    fn actuals(&mut self, ctx: &mut Ctx<'_>) {
        let u = &self.s.units;
        let d = &self.drive;
        if self.s.mode == mode::VL {
            let rpm = |inc: i32| {
                let v = u.vl_to_user.apply(i64::from(inc));
                (if u.velocity_negative { -v } else { v }).clamp(-32768, 32767) as i32
            };
            objects::set(ctx, index::VL_VELOCITY_DEMAND, 2, rpm(self.s.demand.velocity()));
            objects::set(ctx, index::VL_VELOCITY_ACTUAL, 2, rpm(d.velocity()));
        }
        objects::set(ctx, index::POSITION_ACTUAL, 4, u.position_to_user(d.position()));
        objects::set(ctx, index::VELOCITY_ACTUAL, 4, u.velocity_to_user(i64::from(d.velocity())));
        objects::set(ctx, index::TORQUE_ACTUAL, 2, i32::from(d.torque()));
        objects::set(ctx, index::POSITION_DEMAND, 4, u.position_to_user(self.s.demand.position()));
        objects::set(ctx, index::VELOCITY_DEMAND, 4, u.velocity_to_user(i64::from(self.s.demand.velocity())));
        objects::set(ctx, index::POSITION_INTERNAL, 4, d.position() as i32);
        let switches = d.switches();
        let inputs = u32::from(switches.negative_limit) | u32::from(switches.positive_limit) << 1 | u32::from(switches.home) << 2;
        objects::set(ctx, index::DIGITAL_INPUTS, 4, inputs as i32);
    }
}

/// The factor group from the dictionary (missing objects: 1:1).
fn units(ctx: &Ctx<'_>, config: &Config) -> Units {
    let pair = |index| (unsigned_or(ctx, index, 1, 0), unsigned_or(ctx, index, 2, 0));
    let gear = match pair(index::GEAR_RATIO) {
        (0, _) | (_, 0) => (1, 1),
        g => g,
    };
    let feed = match pair(index::FEED_CONSTANT) {
        (0, _) | (_, 0) => (config.increments_per_rev, 1),
        f => f,
    };
    Units::new(config.increments_per_rev, gear, feed, unsigned_or(ctx, index::POLARITY, 0, 0) as u8)
}

/// The modes this dictionary supports: 0x6502 (if present) and the objects
/// each mode needs.
fn supported_modes(ctx: &Ctx<'_>) -> u32 {
    let has = |index| ctx.read(index, 0).is_ok() || ctx.read_u32(index, 1).is_some();
    let mut modes = 0;
    for (m, object) in [
        (mode::PP, index::TARGET_POSITION),
        (mode::VL, index::VL_TARGET_VELOCITY),
        (mode::PV, index::TARGET_VELOCITY),
        (mode::HM, index::HOMING_METHOD),
    ] {
        if has(object) {
            modes |= mode::supported_bit(m);
        }
    }
    match unsigned(ctx, index::SUPPORTED_DRIVE_MODES, 0) {
        Some(declared) => modes & declared,
        None => modes,
    }
}
