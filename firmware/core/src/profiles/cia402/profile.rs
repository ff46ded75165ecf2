//! The profile's state and the slot hooks that drive it.

use super::controlword::{self as cw, Command};
use super::drive::Drive;
use super::fsa::{self, PdsState, Reaction, Transition};
use super::hm::Hm;
use super::ip::Ip;
use super::motion::{Demand, speed_q, speed_q_call};
use super::objects::{self, Located, index, signed, signed_at, unsigned_or};
use super::pp::{Pp, SetPointRequest};
use super::units::{self, Factor, Units};
use super::velocity::{Window, vl_limit};
use super::{TICK_US, mode};
use crate::abort::AbortCode;
use crate::node::{CommError, Ctx, ImageSlot, NmtEvent};
use crate::od::EntryRef;
use crate::services::nmt::NmtState;
use crate::time::Instant;
use crate::wire::emcy::EmcyCode;

mod status;
mod trajectory;

use status::{supported_modes, units};

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
    /// The device's own velocity unit, if 0x606C and 0x606F are not user
    /// units per second (the b maXX 4400's min⁻¹): the factor from that
    /// unit to user units per second. The standstill window (0x606F) is
    /// compared in it.
    pub velocity_unit: Option<fn(&Ctx<'_>) -> Factor>,
}

/// While idle (drive function off, axis at rest) the profile looks for
/// drive faults this often, not every tick.
const IDLE_POLL_US: u64 = 100_000;
/// At most this many ticks are caught up in one poll (a late call does not
/// stall the node; the motion then runs slower than real time).
const MAX_CATCH_UP: u64 = 200;
/// Error code 0x603F / EMCY of a communication error (0x6007 = 1): CiA 301 0x8100
/// communication, 0x8130 life guarding or heartbeat, 0x8140 bus-off recovered.
const fn comm_error_code(error: Option<CommError>) -> EmcyCode {
    match error {
        Some(CommError::Heartbeat(_) | CommError::LifeGuarding) => EmcyCode::LIFE_GUARD_OR_HEARTBEAT,
        Some(CommError::BusOff) => EmcyCode::RECOVERED_FROM_BUS_OFF,
        _ => EmcyCode::COMMUNICATION,
    }
}

/// The CiA 402 profile with the drive it controls. `const`-constructible
/// and all zero bits with a zero-bits drive ([`crate::node`]).
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
    ip: Ip,
    /// pv or vl target [Q16 inc/tick].
    velocity_target: i64,
    internal_limit: bool,
    reached: bool,
    /// The axis stands: the velocity actual value within the standstill
    /// window (0x606F) for 0x6070 ms (pv statusword bit 12, and the end of
    /// every stop).
    speed_zero: bool,
    following: bool,
    reached_window: Window,
    zero_window: Window,
    following_window: Window,
    error_code: EmcyCode,
    next_tick: u64,
    ticking: bool,
    operational: bool,
    /// [`Cia402::refresh`]: the statusword is written at the next idle poll.
    refresh: bool,
    /// The objects of every frame and tick, found at reset application.
    at: Located,
    /// 0x6041's image bytes, found with them: the statusword changes with most frames.
    status_out: ImageSlot,
}

impl Profile {
    const NEW: Profile = Profile {
        state: PdsState::NotReadyToSwitchOn,
        controlword: 0,
        statusword: 0,
        mode: 0,
        supported: 0,
        units: Units::ZERO,
        demand: Demand::ZERO,
        braking: false,
        pending: PdsState::NotReadyToSwitchOn,
        reaction: Reaction::Coast,
        quick_stop_holds: false,
        pp: Pp::NEW,
        hm: Hm::NEW,
        hm_started: false,
        ip: Ip::NEW,
        velocity_target: 0,
        internal_limit: false,
        reached: false,
        speed_zero: false,
        following: false,
        reached_window: Window::NEW,
        zero_window: Window::NEW,
        following_window: Window::NEW,
        error_code: EmcyCode::NO_ERROR,
        next_tick: 0,
        ticking: false,
        operational: false,
        refresh: false,
        at: Located::NONE,
        status_out: ImageSlot::NONE,
    };
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

    /// Reset application (and power-on): transitions 0 and 1 to Switch on
    /// disabled, the factors and supported modes from the dictionary.
    pub fn reset(&mut self, ctx: &mut Ctx<'_>, config: &Config) {
        self.drive.reset();
        self.s = Profile::NEW;
        self.s.at = Located::find(ctx);
        self.s.status_out = ctx.image_slot(self.s.at.at(Located::STATUSWORD));
        self.s.units = units(ctx, config);
        self.s.supported = supported_modes(ctx);
        self.s.state = PdsState::SwitchOnDisabled;
        self.s.operational = ctx.state() == NmtState::Operational;
        objects::set(ctx, index::ERROR_CODE, 2, 0);
        self.set_mode(ctx);
        self.publish(ctx);
        self.actuals(ctx);
    }

    /// Validates a download before it is stored: 0x6060 takes the
    /// supported modes only, 0x6098 the homing methods [`Hm`] runs (abort
    /// 0x06090030).
    pub fn check_write(&self, index: u16, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            (index::MODES_OF_OPERATION, [m]) if *m != 0 && mode::supported_bit(*m as i8) & self.s.supported == 0 => {
                Err(AbortCode::InvalidValue)
            }
            (index::HOMING_METHOD, [m]) if !Hm::supports(i32::from(*m as i8)) => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    /// An object has a new value (RPDO, SDO or the device).
    pub fn written(&mut self, ctx: &mut Ctx<'_>, config: &Config, index: u16) {
        match index {
            index::CONTROLWORD => self.controlword(ctx),
            index::MODES_OF_OPERATION => self.set_mode(ctx),
            index::TARGET_VELOCITY | index::VL_TARGET_VELOCITY => {
                // Of the statusword, a new target changes bit 11 alone (pv and vl limits).
                let limited = self.s.internal_limit;
                self.velocity_target(ctx);
                if self.s.internal_limit == limited {
                    return;
                }
            }
            // A vl ramp set as delta speed and time after its time (0x604F-0x6051, which
            // rules while it is not 0): the one written last rules, so the time goes.
            // 0x6048..=0x604A: the time is 7 indices on.
            #[allow(clippy::arithmetic_side_effects)]
            index::VL_ACCELERATION..=index::VL_QUICK_STOP => {
                let _ = ctx.set_value(index + 7, 0, &[0; 4]);
                return;
            }
            index::GEAR_RATIO | index::FEED_CONSTANT | index::POLARITY | index::VL_DIMENSION_FACTOR => {
                self.s.units = units(ctx, config);
                self.velocity_target(ctx);
            }
            _ => return,
        }
        self.publish(ctx);
    }

    /// RPDO-mapped object `at` holds `value` (zero-extended, `len` bytes:
    /// [`Ctx::rpdo_object`]): the controlword, and pv's target velocity, are
    /// taken at once, as [`Cia402::written`] takes them, without reading the
    /// dictionary again. False for any other object, which the device hands
    /// to [`Cia402::written`].
    pub fn rpdo_object(&mut self, ctx: &mut Ctx<'_>, at: EntryRef, value: u32, len: u8) -> bool {
        if !at.is_some() {
            return false;
        }
        // The target velocity first: a device that keeps its RPDOs' objects
        // hands the controlword over apart ([`Cia402::rpdo_controlword`]).
        if at == self.s.at.at(Located::TARGET_VELOCITY) {
            if self.s.mode != mode::PV || len != 4 {
                return false;
            }
            // Of the statusword, a new target changes bit 11 alone (pv clears it).
            self.s.velocity_target = speed_q(self.s.units.velocity_to_inc_in_line(value as i32));
            if !core::mem::replace(&mut self.s.internal_limit, false) {
                return true;
            }
        } else if at == self.s.at.at(Located::CONTROLWORD) {
            self.rpdo_controlword(ctx, value as u16);
            return true;
        } else {
            return false;
        }
        self.publish(ctx);
        true
    }

    /// Whether `at` is the controlword (0x6040), which [`Cia402::rpdo_controlword`]
    /// takes as [`Cia402::rpdo_object`] does: for a device that keeps its
    /// RPDOs' objects and hands the controlword over without the compares.
    pub fn is_controlword(&self, at: EntryRef) -> bool {
        at.is_some() && at == self.s.at.at(Located::CONTROLWORD)
    }

    /// The controlword `word` from an RPDO, as [`Cia402::rpdo_object`]
    /// takes it: the command, the mode's set-point bits, then 0x6041.
    pub fn rpdo_controlword(&mut self, ctx: &mut Ctx<'_>, word: u16) {
        self.control(ctx, word);
        self.publish(ctx);
    }

    /// The drive's warning (bit 7) changed: while the profile is idle, its
    /// next poll writes 0x6041 (ticking, it writes it at each tick).
    pub fn refresh(&mut self) {
        self.s.refresh = true;
    }

    /// A SYNC's interpolation data record (ip): the position demand
    /// reaches `target` [inc] after `1 << period_log2` ticks. Taken while
    /// the interpolation runs (Operation enabled, controlword bit 4, no
    /// halt); otherwise the record is ignored.
    pub fn interpolate(&mut self, target: i64, period_log2: u8) {
        if self.s.mode == mode::IP && self.ip_active() && self.s.controlword & cw::HALT == 0 {
            self.s.ip.set_point(&self.s.demand, target, period_log2);
        }
    }

    /// Statusword bit 12 in ip: the interpolation runs.
    fn ip_active(&self) -> bool {
        self.s.state == PdsState::OperationEnabled && !self.s.braking && self.s.controlword & cw::NEW_SET_POINT != 0
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
            // A fault, or a warning the device reported (`refresh`), changes the statusword.
            if code != EmcyCode::NO_ERROR && !matches!(self.s.state, PdsState::Fault | PdsState::FaultReactionActive) {
                self.fault(ctx, code);
                self.publish(ctx);
            } else if core::mem::take(&mut self.s.refresh) {
                self.publish(ctx);
            }
            if !self.drive.at_rest() {
                self.start_ticking(ctx);
                return Some(Instant::from_micros(self.s.next_tick));
            }
            return (self.s.state != PdsState::NotReadyToSwitchOn).then(|| Instant::from_micros(now.saturating_add(IDLE_POLL_US)));
        }
        if now < self.s.next_tick {
            return Some(Instant::from_micros(self.s.next_tick));
        }
        // 32-bit arithmetic: a 64-bit division is a library call on a Cortex-M3.
        // `now` ≥ `next_tick` (checked above) and `late` ≤ MAX_CATCH_UP ticks: no term overflows.
        #[allow(clippy::arithmetic_side_effects)]
        let late = (now - self.s.next_tick).min(MAX_CATCH_UP * TICK_US) as u32;
        #[allow(clippy::arithmetic_side_effects)]
        let due = u64::from(late / TICK_US as u32 + 1).min(MAX_CATCH_UP);
        let p = self.params(ctx, config);
        for _ in 0..due {
            self.tick(&p);
            let code = self.drive.fault();
            if code != EmcyCode::NO_ERROR && !matches!(self.s.state, PdsState::Fault | PdsState::FaultReactionActive) {
                self.fault(ctx, code);
            }
            self.monitor(&p);
        }
        // `due` ≤ MAX_CATCH_UP.
        #[allow(clippy::arithmetic_side_effects)]
        let advance = due * TICK_US;
        self.s.next_tick = self.s.next_tick.saturating_add(advance).max(now.saturating_add(1));
        self.actuals(ctx);
        self.publish(ctx);
        if !self.s.state.drive_function() && self.drive.at_rest() {
            self.s.ticking = false;
            return Some(Instant::from_micros(now.saturating_add(IDLE_POLL_US)));
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
                let left = self.s.operational && state != NmtState::Operational;
                self.s.operational = state == NmtState::Operational;
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
        let word = ctx.read_at(self.s.at.at(Located::CONTROLWORD)).map_or(0, crate::od::le_u32) as u16;
        self.control(ctx, word);
    }

    /// A new controlword `word`: its command, and the mode's set-point bits.
    fn control(&mut self, ctx: &mut Ctx<'_>, word: u16) {
        let previous = core::mem::replace(&mut self.s.controlword, word);
        if let Some(command) = cw::decode(word, previous) {
            self.command(ctx, command);
        }
        // Only a change of bit 4 does anything in the modes that use it.
        if (word ^ previous) & cw::NEW_SET_POINT != 0 {
            self.set_point_bit(ctx, word);
        }
    }

    /// Controlword bit 4 changed to `word`'s: pp's new set-point, homing's
    /// start, ip's enable. Out of line: the per-frame path (a command, bit
    /// 4 as it was) stays a small function.
    #[inline(never)]
    fn set_point_bit(&mut self, ctx: &mut Ctx<'_>, word: u16) {
        let rose = word & cw::NEW_SET_POINT != 0;
        let fell = !rose;
        let running = self.s.state == PdsState::OperationEnabled && !self.s.braking;
        match self.s.mode {
            mode::PP if rose && running => self.new_set_point(ctx, word),
            mode::PP if fell => self.s.pp.set_point_released(),
            mode::HM if rose && running => {
                self.s.hm.start(signed(ctx, index::HOMING_METHOD, 0).unwrap_or(0));
                self.s.hm_started = true;
            }
            mode::HM if fell => self.s.hm.interrupt(),
            // Enabling or disabling the interpolation starts from where the demand is.
            mode::IP => self.s.ip = Ip::NEW,
            _ => {}
        }
    }

    fn command(&mut self, ctx: &mut Ctx<'_>, command: Command) {
        if command == Command::FaultReset && self.s.state == PdsState::Fault {
            // Transition 15 once the cause is gone.
            if self.drive.reset_fault() {
                ctx.clear_error(self.s.error_code);
                self.s.error_code = EmcyCode::NO_ERROR;
                objects::set(ctx, index::ERROR_CODE, 2, 0);
                self.s.state = PdsState::SwitchOnDisabled;
            }
            return;
        }
        // 0x605A decides only transition 16, out of Quick stop active.
        let stays =
            self.s.state == PdsState::QuickStopActive && matches!(signed_at(ctx, self.s.at.at(Located::QUICK_STOP_OPTION)), Some(5..=8));
        match fsa::next(self.s.state, command, stays) {
            // The steps between states without the drive function (2, 3, 6,
            // 7, 10: the ones a master goes through most) in line, as
            // `transition` takes them; 3 on "enable operation" goes on to 4.
            Some(t @ Transition { number: 2 | 3 | 6 | 7 | 10, .. }) if !(t.number == 3 && command == Command::EnableOperation) => {
                self.s.next_tick = self.s.next_tick.max(ctx.now().as_micros().saturating_add(TICK_US));
                (self.s.braking, self.s.state) = (false, t.to);
            }
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
        self.s.next_tick = self.s.next_tick.max(ctx.now().as_micros().saturating_add(TICK_US));
        let option = |index, default| Reaction::of(signed(ctx, index, 0).map_or(-1, |v| v), default);
        match t.number {
            4 | 16 => {
                if t.number == 4 {
                    self.s.demand = Demand::at(self.drive.position(), self.drive.velocity());
                    self.s.pp.clear(self.drive.position());
                    self.s.hm = Hm::NEW;
                    self.s.ip = Ip::NEW;
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
                let code = signed_at(ctx, self.s.at.at(Located::QUICK_STOP_OPTION));
                self.s.quick_stop_holds = matches!(code, Some(5..=8));
                self.s.reaction = Reaction::of(code.unwrap_or(-1), Reaction::QuickStopRamp);
                self.s.braking = false;
                if self.s.reaction == Reaction::Coast {
                    self.stop_now(PdsState::SwitchOnDisabled);
                } else {
                    self.s.state = PdsState::QuickStopActive;
                }
            }
            // From a state without the drive function (3 on its way to 4;
            // `command` takes 2, 3, 6, 7 and 10 itself) `stop_now` has
            // nothing to switch off: in line, no call.
            _ if !self.s.state.drive_function() => (self.s.braking, self.s.state) = (false, t.to),
            _ => self.stop_now(t.to),
        }
    }

    /// The drive function goes off at once (the motor coasts) in `state`.
    /// Out of line: its seven callers are state transitions, not the
    /// per-frame path, and inlined at each it cost 150-170 B per drive.
    #[inline(never)]
    fn stop_now(&mut self, state: PdsState) {
        if self.s.state.drive_function() {
            self.drive.enable(false);
        }
        self.s.braking = false;
        self.s.state = state;
    }

    /// Transition 13: a fault in any state; the reaction 0x605E (default 2,
    /// quick stop ramp) runs if the drive still can, then transition 14.
    fn fault(&mut self, ctx: &mut Ctx<'_>, code: EmcyCode) {
        let reaction = Reaction::of(signed(ctx, index::FAULT_REACTION_OPTION, 0).map_or(-1, |v| v), Reaction::QuickStopRamp);
        self.fault_reacting(ctx, code, self.drive.fault_info(), reaction);
    }

    /// A fault the device detects (transition 13): 0x603F and an EMCY with
    /// `code` and `info` (EMCY bytes 3-7), then `reaction` if the drive
    /// function is on (Fault reaction active until the axis stands), else Fault
    /// at once. For a device's own reactions, such as manufacturer-specific
    /// 0x6007 values.
    pub fn raise_fault(&mut self, ctx: &mut Ctx<'_>, code: EmcyCode, info: [u8; 5], reaction: Reaction) {
        self.fault_reacting(ctx, code, info, reaction);
        self.publish(ctx);
    }

    /// Transition 13 with the given fault reaction.
    fn fault_reacting(&mut self, ctx: &mut Ctx<'_>, code: EmcyCode, info: [u8; 5], reaction: Reaction) {
        self.s.error_code = code;
        objects::set(ctx, index::ERROR_CODE, 2, i32::from(code.value()));
        ctx.raise_error(code, info);
        if self.s.state.drive_function() && reaction != Reaction::Coast && self.drive.fault() == EmcyCode::NO_ERROR {
            (self.s.state, self.s.reaction, self.s.braking) = (PdsState::FaultReactionActive, reaction, false);
        } else {
            self.stop_now(PdsState::Fault);
        }
    }

    fn start_ticking(&mut self, ctx: &mut Ctx<'_>) {
        if !self.s.ticking {
            // From an RPDO's hook too: the first tick is due before the idle deadline.
            ctx.wake();
            self.s.ticking = true;
            self.s.next_tick = ctx.now().as_micros().saturating_add(TICK_US);
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
            self.s.ip = Ip::NEW;
            self.s.mode = requested;
            self.velocity_target(ctx);
        }
        let _ = ctx.set_value(index::MODES_OF_OPERATION_DISPLAY, 0, &[self.s.mode as u8]);
    }

    fn velocity_target(&mut self, ctx: &mut Ctx<'_>) {
        let u = &self.s.units;
        self.s.velocity_target = match self.s.mode {
            mode::PV => {
                let target = signed_at(ctx, self.s.at.at(Located::TARGET_VELOCITY)).unwrap_or(0);
                self.s.internal_limit = false;
                speed_q_call(u.velocity_to_inc(target))
            }
            mode::VL => {
                let target = signed_at(ctx, self.s.at.at(Located::VL_TARGET_VELOCITY)).unwrap_or(0);
                let min = unsigned_or(ctx, index::VL_MIN_MAX, 1, 0);
                let max = unsigned_or(ctx, index::VL_MIN_MAX, 2, 0);
                let (limited, clipped) = vl_limit(target, min, max);
                self.s.internal_limit = clipped;
                let inc = u.vl_to_inc.apply(i64::from(limited));
                speed_q_call(units::negate(inc, u.velocity_negative))
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
}
