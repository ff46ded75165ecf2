//! SDO downloads of the PDO parameter records: the communication records
//! through [`CommParams`]' rules, the mapping records by the mapping
//! procedure of CiA 301 §7.5.2.36 (the decisions are listed in the module
//! docs of [`super`]).

use super::config::{Change, Config};
use super::map::{Direction, Mapping};
use super::rpdo::Rpdo;
use super::tpdo::Tpdo;
use super::{Pdos, TpdoRules};
use crate::abort::AbortCode;
use crate::od::{Dictionary, Entry, index, le_u32, object, precheck, store_checked, sub_entry, value_u32};
use crate::wire::pdo_mapping::MappingEntry;

impl<const R: usize, const T: usize, P: TpdoRules> Pdos<R, T, P> {
    /// An SDO download of (index, sub): `None` if it is not a parameter of
    /// one of these PDOs, else the outcome. On success the PDO uses the
    /// value and the image holds it.
    pub fn write_object(&mut self, index: u16, sub: u8, data: &[u8], dict: &Dictionary, image: &mut [u8]) -> Option<Result<(), AbortCode>> {
        self.write_object_with(index, sub, data, dict, image, false)
    }

    /// [`Pdos::write_object`], with `rewrite` for a device whose manual
    /// lets a valid PDO change: mapping entries are written while sub 0 is
    /// not 0 (each entry checked as it is written; the PDO takes the new
    /// mapping when sub 0 is written or at [`Pdos::reload_mappings`]), and
    /// the COB-ID may move while valid.
    pub fn write_object_with(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        dict: &Dictionary,
        image: &mut [u8],
        rewrite: bool,
    ) -> Option<Result<(), AbortCode>> {
        self.settled = false;
        let result = self.write_parameter(index, sub, data, None, dict, image, rewrite);
        self.parameters_changed();
        Some(result?.and_then(|entry| store_checked(image, entry, data)).map(|_| ()))
    }

    /// [`Pdos::write_object_with`] of an `entry` the caller found and
    /// checked as [`precheck`] does (the node's SDO router), but for the
    /// store: the PDO takes the value, and the caller stores it when this
    /// is `Ok` (its tail for every kind of object, so that the PDOs' rules
    /// have no store of their own). A record of a PDO this node lacks is `Ok`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn write_checked(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        entry: &'static Entry,
        dict: &Dictionary,
        image: &[u8],
        rewrite: bool,
    ) -> Result<(), AbortCode> {
        self.settled = false;
        // A record of a PDO this node lacks changes none.
        let Some(result) = self.write_parameter(index, sub, data, Some(entry), dict, image, rewrite) else { return Ok(()) };
        self.parameters_changed();
        result.map(|_| ())
    }

    /// PDO `n`'s configuration (0-based) in `direction`, if there is that PDO.
    // Left to the inliner since round 16 (was out of line so that the
    // download's path is one for both directions): −8 B on the references.
    pub(super) fn config_mut(&mut self, direction: Direction, n: usize) -> Option<&mut Config> {
        match direction {
            Direction::Receive => Some(&mut self.rpdos.get_mut(n)?.config),
            Direction::Transmit => Some(&mut self.tpdos.get_mut(n)?.config),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn write_parameter(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        entry: Option<&'static Entry>,
        dict: &Dictionary,
        image: &[u8],
        rewrite: bool,
    ) -> Option<Result<&'static Entry, AbortCode>> {
        // The same rules for both directions: only the PDO's reaction differs.
        // On success, the entry for the caller to store the value in (the
        // PDO's rules read the image as it was).
        let (direction, base) = match index {
            index::RPDO_COMMUNICATION_PARAMETER..=index::RPDO_MAPPING_PARAMETER_LAST => {
                (Direction::Receive, index::RPDO_COMMUNICATION_PARAMETER)
            }
            index::TPDO_COMMUNICATION_PARAMETER..=index::TPDO_MAPPING_PARAMETER_LAST => {
                (Direction::Transmit, index::TPDO_COMMUNICATION_PARAMETER)
            }
            _ => return None,
        };
        let offset = index.wrapping_sub(base);
        let is_mapping = offset >= index::RPDO_MAPPING_PARAMETER - index::RPDO_COMMUNICATION_PARAMETER;
        let n = usize::from(offset % (index::RPDO_MAPPING_PARAMETER - index::RPDO_COMMUNICATION_PARAMETER));
        // One path for both directions on the PDO's configuration; only the reaction differs.
        // With PDOs of one kind only, the path is one already: no call.
        let config = if R == 0 || T == 0 {
            match direction {
                Direction::Receive => &mut self.rpdos.get_mut(n)?.config,
                Direction::Transmit => &mut self.tpdos.get_mut(n)?.config,
            }
        } else {
            self.config_mut(direction, n)?
        };
        let entry = match entry {
            Some(entry) => entry,
            None => match precheck::<true>(dict, index, sub, data) {
                Ok(entry) => entry,
                Err(code) => return Some(Err(code)),
            },
        };
        // As a number, once for both kinds of record: the precheck held
        // `data` to the entry's length (an UNSIGNED8, 16 or 32), and a
        // number compares in fewer bytes than a slice.
        let value = le_u32(data);
        let change = match write_config(config, is_mapping, direction, entry, index, sub, value, dict, image, rewrite) {
            Ok(change) => change,
            Err(code) => return Some(Err(code)),
        };
        if Self::ACT_IN_WALK {
            // `parameters_changed`, which follows, acts on it.
            config.change = change;
            return Some(Ok(entry));
        }
        match (direction, change) {
            (_, Change::None) => {}
            (Direction::Receive, Change::Restart) => self.rpdos.get_mut(n).map_or((), Rpdo::restart),
            (Direction::Receive, Change::Timer) => self.rpdos.get_mut(n).map_or((), Rpdo::disarm_timer),
            (Direction::Transmit, Change::Restart) => self.tpdos.get_mut(n).map_or((), |t| t.restart::<P>(None)),
            (Direction::Transmit, Change::Timer) => self.tpdos.get_mut(n).map_or((), Tpdo::rearm_timer),
        }
        Some(Ok(entry))
    }
}

/// An SDO download into PDO record (index, sub), a mapping record if
/// `is_mapping`, applied to the PDO's `config` (the caller stores the value).
#[allow(clippy::too_many_arguments)]
fn write_config(
    config: &mut Config,
    is_mapping: bool,
    direction: Direction,
    entry: &'static Entry,
    index: u16,
    sub: u8,
    value: u32,
    dict: &Dictionary,
    image: &[u8],
    rewrite: bool,
) -> Result<Change, AbortCode> {
    let params = config.params;
    if is_mapping {
        let locked = params.valid() && config.cob_id_writable && !rewrite;
        let mut mapping = Mapping::EMPTY;
        if !write_map(locked, rewrite, direction, entry, index, sub, value, dict, image, &mut mapping)? {
            return Ok(Change::None);
        }
        (config.mapping, config.unresolved) = (mapping, false);
        return Ok(Change::Restart);
    }
    let new = params.with(direction, sub, value, rewrite)?;
    config.params = new;
    Ok(if (params.cob_id, params.transmission_type) != (new.cob_id, new.transmission_type) {
        Change::Restart
    } else if params.event_timer_ms != new.event_timer_ms {
        Change::Timer
    } else {
        Change::None
    })
}

/// An SDO download into a mapping record; `true` when sub 0 was written
/// and `new` (an empty mapping) holds the mapping it resolved (an entry
/// is checked in its first slot).
#[allow(clippy::too_many_arguments)]
fn write_map(
    locked: bool,
    rewrite: bool,
    direction: Direction,
    entry: &'static Entry,
    index: u16,
    sub: u8,
    value: u32,
    dict: &Dictionary,
    image: &[u8],
    new: &mut Mapping,
) -> Result<bool, AbortCode> {
    // One call for both tests (the compiler laid out one per test).
    let current = value_u32(dict, image, entry);
    if (locked || sub != 0) && current == value {
        // Writing back the current value changes nothing and is allowed
        // (sub 0 of an open mapping is always resolved again).
        return Ok(false);
    }
    if locked {
        return Err(AbortCode::UnsupportedAccess);
    }
    let record = object(dict, index);
    let resolved = if sub == 0 {
        new.resolve(dict, image, record, value, direction)?;
        true
    } else {
        let count = sub_entry(record, 0).map_or(0, |e| value_u32(dict, image, e));
        if count != 0 && !rewrite {
            return Err(AbortCode::UnsupportedAccess);
        }
        if value != 0 {
            new.check_entry(dict, MappingEntry::from_u32(value), direction)?;
        }
        false
    };
    Ok(resolved)
}
