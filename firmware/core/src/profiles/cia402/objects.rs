//! The CiA 402 objects the profile uses (CiA 402-2 §6-§8) and typed reads
//! through the slot's context. Each device's dictionary comes from its own
//! EDS, so any object may be missing: a read gives `None` and the profile
//! takes the standard's default (or the mode is unsupported).

use crate::node::Ctx;
use crate::od::EntryRef;

/// Object indices of CiA 402-2 (a profile namespace: 0x6040 is a
/// controlword here and an acceleration in CiA 406).
pub mod index {
    /// 0x603F error code (UNSIGNED16).
    pub const ERROR_CODE: u16 = 0x603F;
    /// 0x6007 abort connection option code (INTEGER16).
    pub const ABORT_CONNECTION: u16 = 0x6007;
    /// 0x6040 controlword (UNSIGNED16).
    pub const CONTROLWORD: u16 = 0x6040;
    /// 0x6041 statusword (UNSIGNED16).
    pub const STATUSWORD: u16 = 0x6041;
    /// 0x6042 vl target velocity (INTEGER16).
    pub const VL_TARGET_VELOCITY: u16 = 0x6042;
    /// 0x6043 vl velocity demand (INTEGER16).
    pub const VL_VELOCITY_DEMAND: u16 = 0x6043;
    /// 0x6044 vl velocity actual value (control effort, INTEGER16).
    pub const VL_VELOCITY_ACTUAL: u16 = 0x6044;
    /// 0x6046 vl velocity min (sub 1) / max (sub 2) amount (UNSIGNED32).
    pub const VL_MIN_MAX: u16 = 0x6046;
    /// 0x6048 vl velocity acceleration: delta speed (sub 1), delta time [s] (sub 2).
    pub const VL_ACCELERATION: u16 = 0x6048;
    /// 0x6049 vl velocity deceleration.
    pub const VL_DECELERATION: u16 = 0x6049;
    /// 0x604A vl velocity quick stop.
    pub const VL_QUICK_STOP: u16 = 0x604A;
    /// 0x604F vl ramp function time [ms] (UNSIGNED32): from 0 to the reference speed.
    pub const VL_RAMP_FUNCTION_TIME: u16 = 0x604F;
    /// 0x6050 vl slow down time [ms] (UNSIGNED32): from the reference speed to 0.
    pub const VL_SLOW_DOWN_TIME: u16 = 0x6050;
    /// 0x6051 vl quick stop time [ms] (UNSIGNED32): from the reference speed to 0.
    pub const VL_QUICK_STOP_TIME: u16 = 0x6051;
    /// 0x604C vl dimension factor: numerator (sub 1), denominator (sub 2), INTEGER32.
    pub const VL_DIMENSION_FACTOR: u16 = 0x604C;
    /// 0x605A quick stop option code (INTEGER16).
    pub const QUICK_STOP_OPTION: u16 = 0x605A;
    /// 0x605B shutdown option code.
    pub const SHUTDOWN_OPTION: u16 = 0x605B;
    /// 0x605C disable operation option code.
    pub const DISABLE_OPERATION_OPTION: u16 = 0x605C;
    /// 0x605D halt option code.
    pub const HALT_OPTION: u16 = 0x605D;
    /// 0x605E fault reaction option code.
    pub const FAULT_REACTION_OPTION: u16 = 0x605E;
    /// 0x6060 modes of operation (INTEGER8).
    pub const MODES_OF_OPERATION: u16 = 0x6060;
    /// 0x6061 modes of operation display (INTEGER8).
    pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
    /// 0x6062 position demand value (INTEGER32, user units).
    pub const POSITION_DEMAND: u16 = 0x6062;
    /// 0x6064 position actual value (INTEGER32).
    pub const POSITION_ACTUAL: u16 = 0x6064;
    /// 0x6065 following error window (UNSIGNED32).
    pub const FOLLOWING_ERROR_WINDOW: u16 = 0x6065;
    /// 0x6066 following error time out [ms] (UNSIGNED16).
    pub const FOLLOWING_ERROR_TIMEOUT: u16 = 0x6066;
    /// 0x6067 position window (UNSIGNED32).
    pub const POSITION_WINDOW: u16 = 0x6067;
    /// 0x6068 position window time [ms] (UNSIGNED16).
    pub const POSITION_WINDOW_TIME: u16 = 0x6068;
    /// 0x606B velocity demand value (INTEGER32).
    pub const VELOCITY_DEMAND: u16 = 0x606B;
    /// 0x606C velocity actual value (INTEGER32).
    pub const VELOCITY_ACTUAL: u16 = 0x606C;
    /// 0x606D velocity window (UNSIGNED16).
    pub const VELOCITY_WINDOW: u16 = 0x606D;
    /// 0x606E velocity window time [ms] (UNSIGNED16).
    pub const VELOCITY_WINDOW_TIME: u16 = 0x606E;
    /// 0x606F velocity threshold (UNSIGNED16).
    pub const VELOCITY_THRESHOLD: u16 = 0x606F;
    /// 0x6070 velocity threshold time [ms] (UNSIGNED16).
    pub const VELOCITY_THRESHOLD_TIME: u16 = 0x6070;
    /// 0x6077 torque actual value [‰] (INTEGER16).
    pub const TORQUE_ACTUAL: u16 = 0x6077;
    /// 0x607A target position (INTEGER32).
    pub const TARGET_POSITION: u16 = 0x607A;
    /// 0x607C home offset (INTEGER32).
    pub const HOME_OFFSET: u16 = 0x607C;
    /// 0x607D software position limit: min (sub 1), max (sub 2) (INTEGER32).
    pub const SOFTWARE_POSITION_LIMIT: u16 = 0x607D;
    /// 0x607E polarity (UNSIGNED8).
    pub const POLARITY: u16 = 0x607E;
    /// 0x607F max profile velocity (UNSIGNED32).
    pub const MAX_PROFILE_VELOCITY: u16 = 0x607F;
    /// 0x6080 max motor speed [min⁻¹] (UNSIGNED32).
    pub const MAX_MOTOR_SPEED: u16 = 0x6080;
    /// 0x6081 profile velocity (UNSIGNED32).
    pub const PROFILE_VELOCITY: u16 = 0x6081;
    /// 0x6083 profile acceleration (UNSIGNED32).
    pub const PROFILE_ACCELERATION: u16 = 0x6083;
    /// 0x6084 profile deceleration (UNSIGNED32).
    pub const PROFILE_DECELERATION: u16 = 0x6084;
    /// 0x6085 quick stop deceleration (UNSIGNED32).
    pub const QUICK_STOP_DECELERATION: u16 = 0x6085;
    /// 0x6091 gear ratio: motor revolutions (sub 1), shaft revolutions (sub 2).
    pub const GEAR_RATIO: u16 = 0x6091;
    /// 0x6092 feed constant: feed (sub 1), shaft revolutions (sub 2).
    pub const FEED_CONSTANT: u16 = 0x6092;
    /// 0x6098 homing method (INTEGER8).
    pub const HOMING_METHOD: u16 = 0x6098;
    /// 0x6099 homing speeds: search for switch (sub 1), for zero (sub 2).
    pub const HOMING_SPEEDS: u16 = 0x6099;
    /// 0x609A homing acceleration (UNSIGNED32).
    pub const HOMING_ACCELERATION: u16 = 0x609A;
    /// 0x60C1 interpolation data record: the set-point (sub 1, INTEGER32).
    pub const INTERPOLATION_DATA_RECORD: u16 = 0x60C1;
    /// 0x60C6 max deceleration (UNSIGNED32).
    pub const MAX_DECELERATION: u16 = 0x60C6;
    /// 0x60F2 positioning option code (UNSIGNED16).
    pub const POSITIONING_OPTION: u16 = 0x60F2;
    /// 0x60FF target velocity (INTEGER32).
    pub const TARGET_VELOCITY: u16 = 0x60FF;
    /// 0x6502 supported drive modes (UNSIGNED32).
    pub const SUPPORTED_DRIVE_MODES: u16 = 0x6502;
}

// The readers and the setter are out of line: the profile calls them from
// some fifty places, and each inlined dictionary look-up costs flash.

/// A signed value (INTEGER8/16/32, sign-extended), if the object exists.
#[inline(never)]
pub fn signed(ctx: &Ctx<'_>, index: u16, sub: u8) -> Option<i32> {
    signed_at(ctx, ctx.locate(index, sub))
}

/// [`signed`] of an object [`Located`] found.
#[inline(never)]
pub fn signed_at(ctx: &Ctx<'_>, at: EntryRef) -> Option<i32> {
    match *ctx.read_at(at).ok()? {
        [a] => Some(i32::from(a as i8)),
        [a, b] => Some(i32::from(i16::from_le_bytes([a, b]))),
        [a, b, c, d] => Some(i32::from_le_bytes([a, b, c, d])),
        _ => None,
    }
}

/// An unsigned value of at most 32 bits, if the object exists.
#[inline(never)]
pub fn unsigned(ctx: &Ctx<'_>, index: u16, sub: u8) -> Option<u32> {
    ctx.read_u32(index, sub)
}

/// An unsigned value, or `default` if the object is missing.
#[inline(never)]
pub fn unsigned_or(ctx: &Ctx<'_>, index: u16, sub: u8, default: u32) -> u32 {
    unsigned(ctx, index, sub).unwrap_or(default)
}

/// Sets a value the profile owns (statusword, actual values) with the
/// standard's length for it; an object the device lacks is skipped.
#[inline(never)]
pub fn set(ctx: &mut Ctx<'_>, index: u16, len: usize, value: i32) {
    if let Some(bytes) = value.to_le_bytes().get(..len) {
        let _ = ctx.set_value(index, 0, bytes);
    }
}

/// [`set`] of an object [`Located`] found.
#[inline(never)]
pub fn set_at(ctx: &mut Ctx<'_>, at: EntryRef, len: usize, value: i32) {
    if let Some(bytes) = value.to_le_bytes().get(..len) {
        let _ = ctx.set_at(at, bytes);
    }
}

/// The objects the profile reads or writes with every frame, SYNC or
/// tick, found once at reset application: a dictionary search costs more
/// than a step of the state machine. All [`EntryRef::NONE`] (all zero
/// bits) until then; [`Located::at`] with one of the `Located` constants
/// ([`Located::CONTROLWORD`], …) names an object.
#[derive(Clone, Copy, Debug)]
pub struct Located([EntryRef; HOT.len()]);

/// The objects [`Located`] finds (sub 0 each), in the order of its constants.
const HOT: [u16; 12] = [
    index::CONTROLWORD,
    index::STATUSWORD,
    index::QUICK_STOP_OPTION,
    index::TARGET_VELOCITY,
    index::VL_TARGET_VELOCITY,
    index::POSITION_ACTUAL,
    index::VELOCITY_ACTUAL,
    index::TORQUE_ACTUAL,
    index::POSITION_DEMAND,
    index::VELOCITY_DEMAND,
    index::VL_VELOCITY_DEMAND,
    index::VL_VELOCITY_ACTUAL,
];

impl Located {
    /// Nothing found yet.
    pub const NONE: Located = Located([EntryRef::NONE; HOT.len()]);
    /// 0x6040.
    pub const CONTROLWORD: usize = 0;
    /// 0x6041.
    pub const STATUSWORD: usize = 1;
    /// 0x605A.
    pub const QUICK_STOP_OPTION: usize = 2;
    /// 0x60FF.
    pub const TARGET_VELOCITY: usize = 3;
    /// 0x6042.
    pub const VL_TARGET_VELOCITY: usize = 4;
    /// 0x6064, 0x606C, 0x6077, 0x6062, 0x606B: the actual values every mode shows, from here on.
    pub const ACTUALS: usize = 5;
    /// 0x6043, 0x6044 (vl), from here on.
    pub const VL_ACTUALS: usize = 10;

    /// The objects in the node's dictionary.
    // Out of line: it runs at reset application only.
    #[inline(never)]
    pub fn find(ctx: &Ctx<'_>) -> Located {
        let mut found = Located::NONE;
        for (at, &index) in found.0.iter_mut().zip(&HOT) {
            *at = ctx.locate(index, 0);
        }
        found
    }

    /// Object `i` (one of the constants): [`EntryRef::NONE`] if missing.
    pub fn at(&self, i: usize) -> EntryRef {
        self.0.get(i).copied().unwrap_or(EntryRef::NONE)
    }
}
