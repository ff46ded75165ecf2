//! The communication parameter record of a PDO (0x1400+n, 0x1800+n) as
//! the PDOs cache it, and the rules an SDO download of one of its
//! sub-indices must pass (CiA 301 §7.5.2.35, §7.5.2.37; the decisions are
//! listed in the module docs of [`super`]).

use super::map::Direction;
use crate::abort::AbortCode;
use crate::id::CobRule;
use crate::od::{Dictionary, object, value_u32};
use crate::time::{ms_span, span_100us};

/// COB-ID bit 31: the PDO does not exist (is not valid).
pub const COB_ID_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: no RTR allowed on this PDO.
pub const COB_ID_NO_RTR: u32 = 1 << 30;

/// The communication parameter record of one PDO (0x1400+n or 0x1800+n) as cached.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommParams {
    /// Sub 1: COB-ID (bit 31 = not valid, bit 30 = no RTR, bits 0..10 = CAN-ID).
    pub cob_id: u32,
    /// Sub 2: transmission type.
    pub transmission_type: u8,
    /// Sub 3: inhibit time in 100 µs (0 if the record has no sub 3).
    pub inhibit_time_100us: u16,
    /// Sub 5: event timer in ms (0 if the record has no sub 5).
    pub event_timer_ms: u16,
    /// Sub 6: SYNC start value (0 if the record has no sub 6).
    pub sync_start: u8,
}

impl Default for CommParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl CommParams {
    /// A record without sub-indices: an invalid PDO of type 254.
    pub const DEFAULT: CommParams =
        CommParams { cob_id: COB_ID_INVALID, transmission_type: 254, inhibit_time_100us: 0, event_timer_ms: 0, sync_start: 0 };

    /// All zero bits, for the PDOs before their first configuration (which
    /// their empty mapping keeps silent); not a record anyone wrote.
    pub(super) const UNCONFIGURED: CommParams =
        CommParams { cob_id: 0, transmission_type: 0, inhibit_time_100us: 0, event_timer_ms: 0, sync_start: 0 };

    /// Reads record `index` (0x1400+n or 0x1800+n): two binary searches. A
    /// record without sub 1 is an invalid PDO; a missing sub 2 reads as 254.
    pub fn read(dict: &Dictionary, image: &[u8], index: u16) -> CommParams {
        let mut params = CommParams::UNCONFIGURED;
        params.read_record(dict, image, index);
        params
    }

    /// Becomes [`CommParams::read`] of record `index`, in place, and returns
    /// whether sub 1 can be written at all: one pass over the record's
    /// entries rather than a search per sub-index. From
    /// [`CommParams::UNCONFIGURED`] (the caller's, cleared): only the two
    /// fields whose default is not 0 are set first.
    pub(super) fn read_record(&mut self, dict: &Dictionary, image: &[u8], index: u16) -> bool {
        (self.cob_id, self.transmission_type) = (CommParams::DEFAULT.cob_id, CommParams::DEFAULT.transmission_type);
        let mut cob_id_writable = false;
        for entry in object(dict, index) {
            let value = value_u32(dict, image, entry);
            match entry.sub {
                1 => (self.cob_id, cob_id_writable) = (value, entry.writable()),
                2 => self.transmission_type = value as u8,
                3 => self.inhibit_time_100us = value as u16,
                5 => self.event_timer_ms = value as u16,
                6 => self.sync_start = value as u8,
                _ => {}
            }
        }
        cob_id_writable
    }

    /// Bit 31 clear: the PDO exists.
    pub const fn valid(&self) -> bool {
        self.cob_id & COB_ID_INVALID == 0
    }

    /// Bit 30 clear: RTRs are allowed.
    pub const fn rtr_allowed(&self) -> bool {
        self.cob_id & COB_ID_NO_RTR == 0
    }

    /// The 11-bit CAN-ID.
    pub const fn can_id(&self) -> u16 {
        (self.cob_id & 0x7FF) as u16
    }

    /// Types 0..=240 work with the SYNC.
    pub const fn is_synchronous(&self) -> bool {
        self.transmission_type <= 240
    }

    /// Sub 3 in µs.
    pub const fn inhibit_time(&self) -> u32 {
        span_100us(self.inhibit_time_100us)
    }

    /// Sub 5 in µs.
    pub const fn event_timer(&self) -> u32 {
        ms_span(self.event_timer_ms)
    }

    /// Applies an SDO download of sub-index `sub` (already checked for
    /// length) and returns the new record, or the abort code CiA 301 gives.
    /// With `rewrite`, the CAN-ID may change while the PDO stays valid
    /// (a device whose manual allows it, [`Pdos::write_object_with`]).
    pub(super) fn with(self, direction: Direction, sub: u8, value: u32, rewrite: bool) -> Result<CommParams, AbortCode> {
        let mut new = self;
        match sub {
            1 => new.cob_id = value,
            2 => new.transmission_type = value as u8,
            3 => new.inhibit_time_100us = value as u16,
            5 => new.event_timer_ms = value as u16,
            6 => new.sync_start = value as u8,
            _ => {}
        }
        // Every rule broken is 0x06090030: one test of them all.
        let transmit = direction == Direction::Transmit;
        let rtr_only = matches!(new.transmission_type, 252 | 253) && !new.rtr_allowed();
        let refused = match sub {
            1 => {
                let rule = if rewrite { CobRule::MOVABLE } else { CobRule::VALID };
                rule.check(Some(self.cob_id), value, u16::MAX).is_err()
            }
            // 241..=251 reserved, 252/253 too for an RPDO.
            2 => (241..=if transmit { 251 } else { 253 }).contains(&new.transmission_type),
            // The inhibit time and the SYNC start value change only while the PDO is not valid.
            3 => self.valid() && new.inhibit_time_100us != self.inhibit_time_100us,
            6 => new.sync_start > 240 || (self.valid() && new.sync_start != self.sync_start),
            _ => false,
        };
        // RTR-only types need RTRs: a TPDO's type (an RPDO's 252/253 are
        // refused above) or its valid COB-ID; one test for both subs.
        let refused = refused || (transmit && rtr_only && (sub == 2 || (sub == 1 && new.valid())));
        if refused {
            return Err(AbortCode::InvalidValue);
        }
        Ok(new)
    }
}
