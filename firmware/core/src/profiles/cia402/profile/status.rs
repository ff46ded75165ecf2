//! What the profile shows: the statusword, the actual values, the factor
//! group and the supported modes from the dictionary.

use super::{Cia402, Config};
use crate::node::Ctx;
use crate::profiles::cia402::controlword as cw;
use crate::profiles::cia402::drive::Drive;
use crate::profiles::cia402::fsa::PdsState;
use crate::profiles::cia402::hm::Phase;
use crate::profiles::cia402::objects::{self, Located, index, signed, unsigned, unsigned_or};
use crate::profiles::cia402::units::{self, Units};
use crate::profiles::cia402::{mode, statusword as sw};

impl<D: Drive> Cia402<D> {
    // ---- objects -------------------------------------------------------------------

    pub(super) fn statusword(&self) -> u16 {
        let s = &self.s;
        let mut word = s.state.statusword();
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
            let standing = s.demand.velocity_q == 0;
            // Halt and quick stop: target reached once the axis stands (CiA 402-2: "velocity 0").
            let stopped = standing && s.speed_zero;
            let (reached, bit12, bit13) = match s.mode {
                mode::PP => (s.reached, s.pp.acknowledge, s.following),
                mode::PV => (s.reached, s.speed_zero, false),
                mode::VL => (s.reached, false, false),
                mode::IP => (s.reached, self.ip_active(), false),
                // CiA 402-2 homing status: bits 13, 12, 10 (000 in progress, 001
                // interrupted or not started, 011 attained, 10x error moving or standing).
                mode::HM => (
                    s.hm.phase == Phase::Attained || (matches!(s.hm.phase, Phase::Idle | Phase::Error) && standing),
                    s.hm.phase == Phase::Attained,
                    s.hm.phase == Phase::Error,
                ),
                _ => (false, false, false),
            };
            // Halted (halt, quick stop): bit 10 tells the axis stands, not that the mode's
            // target is reached (CiA 402-2: "axis decelerates" / "axis has velocity 0");
            // homing has its own coding of bits 13, 12, 10.
            let target_reached = if halted && s.mode != mode::HM { stopped } else { reached || (halted && stopped) };
            if target_reached {
                word |= sw::TARGET_REACHED;
            }
            if bit12 {
                word |= sw::BIT12;
            }
            if bit13 {
                word |= sw::BIT13;
            }
        }
        self.drive.status_bits(word)
    }

    /// Writes 0x6041 if it changed (the node then checks the TPDOs that map it).
    pub(super) fn publish(&mut self, ctx: &mut Ctx<'_>) {
        let word = self.statusword();
        if word != self.s.statusword {
            self.s.statusword = word;
            ctx.set_slot(self.s.status_out, u32::from(word));
        }
    }

    /// The actual values in user units.
    pub(super) fn actuals(&mut self, ctx: &mut Ctx<'_>) {
        let u = &self.s.units;
        let d = &self.drive;
        if self.s.mode == mode::VL {
            let rpm = |inc: i32| {
                let v = u.vl_to_user.apply(i64::from(inc));
                units::negate(v, u.velocity_negative).clamp(-32768, 32767) as i32
            };
            let at = |i: usize| self.s.at.at(Located::VL_ACTUALS.saturating_add(i));
            objects::set_at(ctx, at(0), 2, rpm(self.s.demand.velocity()));
            objects::set_at(ctx, at(1), 2, rpm(d.velocity()));
        }
        let at = |i: usize| self.s.at.at(Located::ACTUALS.saturating_add(i));
        objects::set_at(ctx, at(0), 4, u.position_to_user(d.position()));
        objects::set_at(ctx, at(1), 4, u.velocity_to_user(i64::from(d.velocity())));
        objects::set_at(ctx, at(2), 2, i32::from(d.torque()));
        objects::set_at(ctx, at(3), 4, u.position_to_user(self.s.demand.position()));
        objects::set_at(ctx, at(4), 4, u.velocity_to_user(i64::from(self.s.demand.velocity())));
    }
}

/// The factor group from the dictionary (missing objects: 1:1).
pub(super) fn units(ctx: &Ctx<'_>, config: &Config) -> Units {
    let pair = |index| (unsigned_or(ctx, index, 1, 0), unsigned_or(ctx, index, 2, 0));
    let gear = match pair(index::GEAR_RATIO) {
        (0, _) | (_, 0) => (1, 1),
        g => g,
    };
    let feed = match pair(index::FEED_CONSTANT) {
        (0, _) | (_, 0) => (config.increments_per_rev, 1),
        f => f,
    };
    let units = Units::new(config.increments_per_rev, gear, feed, unsigned_or(ctx, index::POLARITY, 0, 0) as u8);
    match (signed(ctx, index::VL_DIMENSION_FACTOR, 1), signed(ctx, index::VL_DIMENSION_FACTOR, 2)) {
        (Some(numerator), Some(denominator)) => units.with_vl_dimension(config.increments_per_rev, numerator, denominator),
        _ => units,
    }
}

/// The modes this dictionary supports: 0x6502 (if present) and the objects
/// each mode needs.
pub(super) fn supported_modes(ctx: &Ctx<'_>) -> u32 {
    let has = |index| ctx.read(index, 0).is_ok() || ctx.read_u32(index, 1).is_some();
    let mut modes = 0;
    for (m, object) in [
        (mode::PP, index::TARGET_POSITION),
        (mode::VL, index::VL_TARGET_VELOCITY),
        (mode::PV, index::TARGET_VELOCITY),
        (mode::HM, index::HOMING_METHOD),
        (mode::IP, index::INTERPOLATION_DATA_RECORD),
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
