//! The servo behind the registers: enable and disable through MODE 0x51,
//! the speed, torque and position set-points with their "Num" scaling
//! (manual §6.1, English items 5 and 6) driving a [`Drive`] (the core's
//! axis model until a board drives a motor), STATUS 0x40 and the other
//! actual-value registers, homing 0x78, clearing errors 0x8E and the CAN
//! timeout 0xD0. Decisions U-D1… in docs/devices/unitek-ds.md.
//!
//! Units: positions 65536 increments per revolution (L887); speed ±32767 =
//! ±Nmax of 0xC8 [rpm] (L908-930); torque ±32767 = ±150 % (L1142-1167),
//! which the drive takes in per mille of the rated torque.

use canopen_core::node::Ctx;
use canopen_core::profiles::cia402::drive::{Drive, SetPoint};
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::emcy::EmcyCode;

use super::registers::{self as reg, read_i32, set};

/// Increments per revolution (L887).
pub const INCREMENTS_PER_REV: i64 = 65536;
/// ±32767 "Num" is ±100 % speed or ±150 % torque.
const NUM_MAX: i64 = 32767;
/// Torque at ±32767 [‰ of rated torque].
const TORQUE_AT_NUM_MAX: i64 = 1500;

/// STATUS 0x40 bits (L630-632, L692, L713-714, L795).
pub mod status {
    /// Bit 0 Ena: the drive is enabled.
    pub const ENA: u32 = 1 << 0;
    /// Bit 2: positive limit switch (U-D4).
    pub const LIM_POSITIVE: u32 = 1 << 2;
    /// Bit 3: negative limit switch.
    pub const LIM_NEGATIVE: u32 = 1 << 3;
    /// Bit 7 P-N: position control configured.
    pub const P_N: u32 = 1 << 7;
    /// Bit 8 N-I: speed control configured.
    pub const N_I: u32 = 1 << 8;
    /// Bit 12 Cal: homed.
    pub const CAL: u32 = 1 << 12;
    /// Bit 13 Tol: the position is within POS_WINDOW of POS_DEST.
    pub const TOL: u32 = 1 << 13;
}

/// ERR_BITMAP1 0x8F bits: the manual does not list them (L1469-1501); the
/// project's assignment (U-D8).
pub mod error {
    /// Bit 1: power stage fault.
    pub const POWER_STAGE: u32 = 1 << 1;
    /// Bit 3: CAN timeout 0xD0 expired.
    pub const CAN_TIMEOUT: u32 = 1 << 3;
    /// Bit 5: DC link voltage.
    pub const DC_LINK: u32 = 1 << 5;
    /// Bit 6: over-temperature.
    pub const TEMPERATURE: u32 = 1 << 6;
    /// Bit 10: following error.
    pub const FOLLOWING: u32 = 1 << 10;
}

/// MODE 0x51 bit 2 "Sperre": disabled (Ex. 2).
pub const MODE_DISABLE: u32 = 1 << 2;
/// MODE 0x51 bit 4: send STATUS on a change of its bits under STATUS_MASK (Ex. 10).
pub const MODE_EVENT: u32 = 1 << 4;

/// The set-point the drive follows: the last one written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Loop {
    /// SPEED_CMD 0x31.
    #[default]
    Speed,
    /// TORQUE_SETPOINT 0x90.
    Torque,
    /// POS_DEST 0x6E.
    Position,
}

/// The servo: its drive and what the registers make of it.
#[derive(Clone, Debug)]
pub struct Servo<D> {
    /// The motor.
    pub drive: D,
    enabled: bool,
    set_point: Loop,
    homed: bool,
    timed_out: bool,
    /// STATUS at the last poll, for the event frames.
    reported: u32,
    /// The next drive tick, while the motor runs.
    next_tick: Option<Instant>,
    /// The last frame on the RX id, for the CAN timeout.
    last_frame: Instant,
}

/// One drive tick.
const TICK: Duration = Duration::from_micros(canopen_core::profiles::cia402::TICK_US);
/// Ticks one poll catches up at most; a longer gap restarts the tick clock.
const MAX_CATCH_UP: u32 = 1000;

impl<D: Drive + Limits> Servo<D> {
    /// Disabled, at rest: `const` when `drive` is.
    pub const fn new(drive: D) -> Servo<D> {
        Servo {
            drive,
            enabled: false,
            set_point: Loop::Speed,
            homed: false,
            timed_out: false,
            reported: 0,
            next_tick: None,
            last_frame: Instant::ZERO,
        }
    }

    /// Power-on (reset application): the drive starts disabled (MODE bit 2
    /// set) with zero set-points, whatever was stored (U-D2).
    pub fn power_on(&mut self, ctx: &mut Ctx<'_>) {
        self.drive.reset();
        self.enabled = false;
        self.set_point = Loop::Speed;
        self.homed = false;
        self.timed_out = false;
        self.next_tick = None;
        self.last_frame = ctx.now();
        let mode = reg::read_u32(ctx, reg::MODE);
        set(ctx, reg::MODE, mode | MODE_DISABLE);
        for r in [reg::SPEED_CMD, reg::TORQUE_CMD, reg::POS_DEST] {
            set(ctx, r, 0);
        }
        self.configure(ctx);
        self.refresh(ctx);
        self.reported = self.status(ctx);
    }

    /// Gives the drive its speed limit (Nmax 0xC8) and acceleration (ramp
    /// 0x35, ms from 0 to Nmax, low word: U-D3).
    pub fn configure(&mut self, ctx: &Ctx<'_>) {
        let v_max = max_velocity(ctx);
        let ramp_ms = i64::from(reg::read_u32(ctx, reg::ACC_RAMP) as u16).max(1);
        let a_max = (v_max * 1000 / ramp_ms).clamp(1, i64::from(u32::MAX));
        self.drive.set_limits(v_max as u32, a_max as u32);
    }

    /// A frame arrived on the RX id: the CAN timeout starts again.
    pub fn heard(&mut self, now: Instant) {
        self.last_frame = now;
    }

    /// Register `regid` holds a value a master wrote.
    pub fn written(&mut self, ctx: &mut Ctx<'_>, regid: u8) {
        match regid {
            reg::MODE => self.apply_enable(ctx),
            reg::SPEED_CMD => self.follow(ctx, Loop::Speed),
            reg::TORQUE_CMD => self.follow(ctx, Loop::Torque),
            reg::POS_DEST => self.follow(ctx, Loop::Position),
            reg::SPEED_RPMMAX | reg::ACC_RAMP => {
                self.configure(ctx);
                self.command(ctx);
            }
            // U-D6: homing on the current position: it becomes the reference offset 0x72.
            reg::FUN_REF_START => {
                self.drive.set_position(i64::from(read_i32(ctx, reg::POS_REF_OFFSET)));
                self.homed = true;
                self.command(ctx);
            }
            reg::FUN_ERRCANCEL => {
                self.timed_out = false;
                self.drive.reset_fault();
            }
            _ => {}
        }
        self.refresh(ctx);
    }

    fn follow(&mut self, ctx: &mut Ctx<'_>, set_point: Loop) {
        self.set_point = set_point;
        self.command(ctx);
    }

    /// Enabled when MODE bit 2 is clear, the drive has no fault and the CAN
    /// timeout has not struck (the RUN input is always on in the model).
    fn apply_enable(&mut self, ctx: &mut Ctx<'_>) {
        let mode = reg::read_u32(ctx, reg::MODE);
        let want = mode & MODE_DISABLE == 0 && self.drive.fault() == EmcyCode::NO_ERROR && !self.timed_out;
        if want != self.enabled {
            self.enabled = want;
            self.drive.enable(want);
            self.command(ctx);
        }
    }

    /// Hands the drive the set-point of the register written last.
    fn command(&mut self, ctx: &Ctx<'_>) {
        if !self.enabled {
            return;
        }
        let set_point = match self.set_point {
            Loop::Speed => {
                let num = i64::from(read_i32(ctx, reg::SPEED_CMD));
                SetPoint::Velocity(div_round(num * max_velocity(ctx), NUM_MAX) as i32)
            }
            Loop::Torque => SetPoint::Torque(div_round(i64::from(read_i32(ctx, reg::TORQUE_CMD)) * TORQUE_AT_NUM_MAX, NUM_MAX) as i16),
            Loop::Position => SetPoint::Position { position: i64::from(read_i32(ctx, reg::POS_DEST)), velocity: 0 },
        };
        self.drive.command(set_point);
        if self.next_tick.is_none() {
            self.next_tick = Some(ctx.now() + TICK);
        }
    }

    /// Runs the drive's ticks due by now, the CAN timeout and the fault
    /// check (the actual-value registers wait for [`Servo::refresh`], before
    /// a reply: a tick stays cheap). Returns the next tick and the
    /// STATUS to send if MODE bit 4 asks for it and a masked bit changed.
    pub fn poll(&mut self, ctx: &mut Ctx<'_>) -> (Option<Instant>, Option<u32>) {
        let now = ctx.now();
        let timeout_ms = u64::from(reg::read_u32(ctx, reg::CAN_TIMEOUT) as u16);
        let mut deadline = None;
        if self.enabled && timeout_ms != 0 {
            let expiry = self.last_frame + Duration::from_millis(timeout_ms);
            if now >= expiry {
                // U-D7: the drive disables itself and says so in MODE and ERR_BITMAP1.
                self.timed_out = true;
                let mode = reg::read_u32(ctx, reg::MODE);
                set(ctx, reg::MODE, mode | MODE_DISABLE);
            } else {
                deadline = Some(expiry);
            }
        }
        if self.enabled && self.drive.fault() != EmcyCode::NO_ERROR || self.timed_out {
            self.apply_enable(ctx);
        }
        if let Some(mut tick) = self.next_tick {
            let mut ticks = 0;
            while tick <= now && ticks < MAX_CATCH_UP {
                self.drive.tick();
                tick += TICK;
                ticks += 1;
            }
            if tick <= now {
                tick = now + TICK;
            }
            // A disabled drive ticks until it has coasted to a stop.
            self.next_tick = (self.enabled || self.drive.velocity() != 0).then_some(tick);
        }
        let status = self.status(ctx);
        let mask = reg::read_u32(ctx, reg::STATUS_MASK);
        let event = (reg::read_u32(ctx, reg::MODE) & MODE_EVENT != 0 && (status ^ self.reported) & mask != 0).then_some(status);
        self.reported = status;
        (canopen_core::time::earliest(deadline, self.next_tick), event)
    }

    /// STATUS 0x40 as the registers and the drive stand.
    fn status(&self, ctx: &Ctx<'_>) -> u32 {
        let switches = self.drive.switches();
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        let window = i64::from(reg::read_u32(ctx, reg::POS_WINDOW) as u16);
        let error = i64::from(read_i32(ctx, reg::POS_DEST)) - self.drive.position();
        // U-D4: the loops are configured as a cascade, so P-N and N-I are always set (Ex. 8, the dump).
        status::P_N
            | status::N_I
            | flag(self.enabled, status::ENA)
            | flag(switches.positive_limit, status::LIM_POSITIVE)
            | flag(switches.negative_limit, status::LIM_NEGATIVE)
            | flag(self.homed, status::CAL)
            | flag(error.abs() <= window, status::TOL)
    }

    /// ERR_BITMAP1 0x8F.
    fn errors(&self) -> u32 {
        use canopen_core::axis::fault;
        let drive = match self.drive.fault() {
            EmcyCode::NO_ERROR => 0,
            fault::UNDER_VOLTAGE => error::DC_LINK,
            fault::OVER_TEMPERATURE => error::TEMPERATURE,
            fault::FOLLOWING_ERROR => error::FOLLOWING,
            _ => error::POWER_STAGE,
        };
        drive | if self.timed_out { error::CAN_TIMEOUT } else { 0 }
    }

    /// The actual-value registers: speed, position, torque, STATUS, the
    /// error map and the single-bit inputs and outputs.
    pub fn refresh(&self, ctx: &mut Ctx<'_>) {
        let v_max = max_velocity(ctx).max(1);
        let speed = div_round(i64::from(self.drive.velocity()) * NUM_MAX, v_max).clamp(-NUM_MAX, NUM_MAX);
        let torque = div_round(i64::from(self.drive.torque()) * NUM_MAX, TORQUE_AT_NUM_MAX).clamp(-NUM_MAX, NUM_MAX);
        let status = self.status(ctx);
        let switches = self.drive.switches();
        let ready = self.drive.fault() == EmcyCode::NO_ERROR && !self.timed_out;
        set(ctx, reg::SPEED_ACTUAL, speed as u32);
        set(ctx, reg::POS_ACTUAL, self.drive.position() as u32);
        set(ctx, reg::TORQUE_OUT, torque as u32);
        set(ctx, reg::STATUS, status);
        set(ctx, reg::ERR_BITMAP, self.errors());
        set(ctx, reg::BTB, u32::from(ready));
        set(ctx, reg::RUN, 1);
        set(ctx, reg::END1, u32::from(switches.positive_limit));
        set(ctx, reg::END2, u32::from(switches.negative_limit));
        set(ctx, reg::IN_TOLERANCE, u32::from(status & status::TOL != 0));
    }
}

/// What the servo sets on its drive beyond [`Drive`]: the speed limit
/// (Nmax) and the acceleration (the ramp), both from registers.
pub trait Limits {
    /// Speed limit [inc/s] and acceleration [inc/s²].
    fn set_limits(&mut self, max_velocity: u32, max_acceleration: u32);
}

/// Nmax 0xC8 in increments per second.
fn max_velocity(ctx: &Ctx<'_>) -> i64 {
    i64::from(reg::read_u32(ctx, reg::SPEED_RPMMAX) as u16) * INCREMENTS_PER_REV / 60
}

/// `a / b` rounded to the nearest integer (halves away from zero), `b` > 0:
/// so 10 % speed (3277 Num) reads back as 3277, not 3276.
fn div_round(a: i64, b: i64) -> i64 {
    let half = b / 2;
    if a >= 0 { (a + half) / b } else { (a - half) / b }
}
