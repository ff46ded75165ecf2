//! Downloads into the communication area (0x1000–0x1FFF) as a table and
//! one interpreter: [`Kind::of`] says what an object is, the interpreter
//! checks the value by its kind's rule (a [`CobRule`], a range, the
//! heartbeat consumers' duplicates), stores it once into the entry the
//! precheck found, and lets the service that owns it take the new value
//! ([`Services::apply`]). The PDO records keep their own service's rules
//! ([`Services::write_pdo`]). The SYNC objects' rules read their old values
//! from the image, which the SYNC service took them from.
//!
//! Abort codes (CiA 301 §7.5.2): every broken rule is 0x06090030, but a
//! second heartbeat consumer for one node is 0x06040043 (§7.5.2.17), a COB-ID
//! of the wrong length 0x0607001x, and a mapping write on a device that
//! allows it only in Pre-operational 0x08000022.

use crate::abort::AbortCode;
use crate::id::CobRule;
use crate::od::index;
use crate::od::{Entry, le_u32, store_checked, u32_exact, value_u32};
use crate::services::nmt::NmtState;

use super::app::Ctx;
use super::router::Follow;

/// What a download into one communication object checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// No rule of its own: stored.
    Plain,
    /// A one-byte value of at most the row's `arg` (0x1029 sub 1.., an SDO
    /// server's client node-ID).
    AtMost,
    /// A COB-ID: its rule is `RULES[arg]`; the default SDO server's
    /// (0x1200) keeps its pre-defined, otherwise restricted, CAN-IDs.
    CobId,
    /// 0x1016 sub 1..: no second entry for a node (0x06040043).
    Consumer,
    /// 0x1003 sub 0: only 0, which clears the history.
    History,
    /// 0x1019: 0 or 2..=240, set only while no SYNC is produced
    /// (0x1006 = 0; else 0x08000022).
    Overflow,
    /// 0x1400–0x1BFF: the PDOs' rules.
    Pdo,
}

/// One row of the table: objects `first..=last`, their sub-indices
/// `subs.0..=subs.1`, the kind and its argument. Rows as data, not a
/// `match`: the search is one loop of 8-byte rows, where the match was a
/// tree of comparisons (round 14: ds301 −152 B, ds301-lean −12 B, every
/// device −36..−40 B or equal).
struct Row {
    first: u16,
    last: u16,
    subs: (u8, u8),
    kind: Kind,
    arg: u8,
}

impl Row {
    const fn new(first: u16, last: u16, subs: (u8, u8), kind: Kind, arg: u8) -> Row {
        Row { first, last, subs, kind, arg }
    }
}

/// Every sub-index; from sub-index 1.
const ALL: (u8, u8) = (0, u8::MAX);
const FROM_1: (u8, u8) = (1, u8::MAX);

/// The COB-ID rules by the rows' `arg`.
const RULES: [CobRule; 4] = [CobRule::SYNC, CobRule::TIME, CobRule::EMCY, CobRule::VALID];

/// The table: the objects with a rule of their own, none of them
/// overlapping (the first row that holds an object is its kind).
const TABLE: [Row; 10] = [
    // The PDOs first: their records take most of a configuration's writes
    // (a mapping's download found on the first row, not the tenth).
    Row::new(index::RPDO_COMMUNICATION_PARAMETER, index::TPDO_MAPPING_PARAMETER_LAST, ALL, Kind::Pdo, 0),
    Row::new(index::PRE_DEFINED_ERROR_FIELD, index::PRE_DEFINED_ERROR_FIELD, ALL, Kind::History, 0),
    Row::new(index::COB_ID_SYNC, index::COB_ID_SYNC, ALL, Kind::CobId, 0),
    Row::new(index::COB_ID_TIME_STAMP, index::COB_ID_TIME_STAMP, (0, 0), Kind::CobId, 1),
    Row::new(index::COB_ID_EMCY, index::COB_ID_EMCY, (0, 0), Kind::CobId, 2),
    Row::new(index::CONSUMER_HEARTBEAT_TIME, index::CONSUMER_HEARTBEAT_TIME, FROM_1, Kind::Consumer, 0),
    Row::new(index::SYNCHRONOUS_COUNTER_OVERFLOW, index::SYNCHRONOUS_COUNTER_OVERFLOW, ALL, Kind::Overflow, 0),
    Row::new(index::ERROR_BEHAVIOUR, index::ERROR_BEHAVIOUR, FROM_1, Kind::AtMost, 2),
    Row::new(index::SDO_SERVER_PARAMETER, index::SDO_SERVER_PARAMETER_LAST, (1, 2), Kind::CobId, 3),
    Row::new(index::SDO_SERVER_PARAMETER, index::SDO_SERVER_PARAMETER_LAST, (3, 3), Kind::AtMost, 127),
];

impl Kind {
    /// The table: (index, sub) to its kind and the row's argument.
    fn of(index: u16, sub: u8) -> (Kind, u8) {
        for row in &TABLE {
            if (row.first..=row.last).contains(&index) && (row.subs.0..=row.subs.1).contains(&sub) {
                return (row.kind, row.arg);
            }
        }
        (Kind::Plain, 0)
    }
}

/// Whether PDO record `index` (0x1400–0x1BFF) is a mapping (0x1600–0x17FF,
/// 0x1A00–0x1BFF): bit 9 set, where the communication records have it clear.
const fn is_mapping(index: u16) -> bool {
    index & 0x200 != 0
}

impl Ctx<'_> {
    /// A checked write of (index, sub), whose `entry` passed [`Ctx::precheck`]:
    /// the object's kind applies its rules, the service that owns it its value.
    /// Not 0x1010/0x1011: their callers choose whether the node stores
    /// ([`Ctx::store_command`]), so that a node without storage links none of it.
    /// `rewrite`: the device's [`super::ServiceOptions::pdo_rewrite_while_valid`],
    /// passed by a caller that knows it as a constant (the SDO path), so
    /// that a device without it links none of its rules.
    pub(super) fn route_write(&mut self, index: u16, sub: u8, data: &[u8], entry: &'static Entry, rewrite: bool) -> Result<(), AbortCode> {
        if index >= index::MANUFACTURER_SPECIFIC {
            return self.write_plain(entry, data);
        }
        // The node reads the SDO servers and rebuilds its acceptance list
        // after any download to a communication object, taken or refused
        // (one store of the four flags): both only act on what changed (a
        // server whose COB-IDs moved, a list whose identifiers did).
        self.effects.follow = Follow { sdo_changed: true, consumed_changed: true, written: true, services: true };
        self.write_comm(index, sub, data, entry, rewrite)
    }

    /// The interpreter: check by kind, store, apply.
    fn write_comm(&mut self, index: u16, sub: u8, data: &[u8], entry: &'static Entry, rewrite: bool) -> Result<(), AbortCode> {
        let (dict, now, node_id) = (self.dict, self.now, self.hook.node_id);
        let (kind, arg) = Kind::of(index, sub);
        match kind {
            Kind::Plain => {}
            Kind::AtMost => {
                if matches!(data, [v] if *v > arg) {
                    return Err(AbortCode::InvalidValue);
                }
            }
            Kind::CobId | Kind::Consumer => {
                let new = u32_exact(data)?;
                if kind == Kind::Consumer {
                    // sub ≥ 1: the kind's.
                    #[allow(clippy::arithmetic_side_effects)]
                    if self.services.consumer_conflicts(usize::from(sub) - 1, new) {
                        return Err(AbortCode::ParameterIncompatible);
                    }
                } else {
                    // The pre-defined CAN-IDs of the default server: 0x600 + node-ID
                    // (sub 1) or 0x580 + node-ID, below 0x700.
                    #[allow(clippy::arithmetic_side_effects)]
                    let own = if index != index::SDO_SERVER_PARAMETER {
                        u16::MAX
                    } else {
                        u16::from(node_id) + if sub == 1 { 0x600 } else { 0x580 }
                    };
                    // A COB-ID entry is 4 bytes (the precheck matched the data's
                    // length): its old value, if an SDO could read it.
                    let old = entry.readable().then(|| value_u32(dict, self.image, entry));
                    // Every CobId row's `arg` names one of the four rules: the
                    // test `the_table_gives_every_object_its_kind` pins each row.
                    if let Some(rule) = RULES.get(usize::from(arg)) {
                        rule.check(old, new, own)?;
                    }
                }
            }
            Kind::History => {
                // The precheck found the entry writable.
                if sub != 0 {
                    return Err(AbortCode::ReadOnly);
                }
                // CiA 301 §7.5.2.4: only 0 may be written, and it clears the history.
                return match data {
                    [0] => {
                        super::comm::clear_history(dict, self.image);
                        Ok(())
                    }
                    [_] => Err(AbortCode::InvalidValue),
                    [] => Err(AbortCode::LengthTooLow),
                    _ => Err(AbortCode::LengthTooHigh),
                };
            }
            Kind::Overflow => {
                let period = || super::comm::u32_of(dict, self.image, index::COMMUNICATION_CYCLE_PERIOD, 0, 0);
                crate::services::sync::overflow_rule(le_u32(data), period)?;
            }
            Kind::Pdo => {
                let operational = self.state == NmtState::Operational;
                if rewrite && operational && is_mapping(index) {
                    // The manual's order: mappings change in Pre-operational only.
                    return Err(AbortCode::DeviceState);
                }
                // In Operational a COB-ID follows CiA 301 (it moves only while the PDO is not valid).
                // The PDO's rules; the store below, as every kind's. It cannot
                // refuse what the PDO took: a PDO record is never a DOMAIN and a
                // writable entry lies in the image, as od-gen lays them out.
                self.services.write_pdo(index, sub, data, entry, dict, self.image, rewrite && !operational)?;
            }
        }
        store_checked(self.image, entry, data)?;
        self.services.apply(index, sub, le_u32(data), now);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table says what the `match` it replaced said, for every
    /// (index, sub) of the communication area.
    #[test]
    fn the_table_gives_every_object_its_kind() {
        fn by_match(index: u16, sub: u8) -> (Kind, u8) {
            match (index, sub) {
                (index::PRE_DEFINED_ERROR_FIELD, _) => (Kind::History, 0),
                (index::COB_ID_SYNC, _) => (Kind::CobId, 0),
                (index::SYNCHRONOUS_COUNTER_OVERFLOW, _) => (Kind::Overflow, 0),
                (index::COB_ID_TIME_STAMP, 0) => (Kind::CobId, 1),
                (index::COB_ID_EMCY, 0) => (Kind::CobId, 2),
                (index::CONSUMER_HEARTBEAT_TIME, 1..) => (Kind::Consumer, 0),
                (index::ERROR_BEHAVIOUR, 1..) => (Kind::AtMost, 2),
                (index::SDO_SERVER_PARAMETER..=index::SDO_SERVER_PARAMETER_LAST, 1 | 2) => (Kind::CobId, 3),
                (index::SDO_SERVER_PARAMETER..=index::SDO_SERVER_PARAMETER_LAST, 3) => (Kind::AtMost, 127),
                (index::RPDO_COMMUNICATION_PARAMETER..=index::TPDO_MAPPING_PARAMETER_LAST, _) => (Kind::Pdo, 0),
                _ => (Kind::Plain, 0),
            }
        }
        for index in 0x1000..=0x1FFF {
            for sub in 0..=u8::MAX {
                assert_eq!(Kind::of(index, sub), by_match(index, sub), "{index:#06X} sub {sub}");
            }
        }
        assert_eq!(RULES.map(|r| r == CobRule::VALID), [false, false, false, true]);
        assert_eq!([RULES[0], RULES[1], RULES[2]], [CobRule::SYNC, CobRule::TIME, CobRule::EMCY]);
    }
}
