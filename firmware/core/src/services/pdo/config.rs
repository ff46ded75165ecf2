//! What an RPDO and a TPDO have alike: the communication record as
//! cached, the resolved mapping and whether sub 1 can be written. One
//! type, so that configuring a PDO and the SDO downloads of its records are
//! one code path for both directions; only the PDO's reaction differs.

use super::map::{Direction, Mapping};
use super::{CommParams, MappingError, nth};
use crate::od::Dictionary;

/// Communication record minus mapping record: 0x1400 − 0x1600, 0x1800 − 0x1A00.
const MAPPING_OFFSET: u16 = 0x200;

/// A PDO's configuration (0x1400+n and 0x1600+n, or 0x1800+n and 0x1A00+n).
// In this order (`repr(C)`): the parameters and the flags, then the
// mapping (its count and length first), so that the paths reach what they
// test with 2-byte thumbv7m instructions (see [`super::tpdo::Tpdo`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Config {
    pub(super) params: CommParams,
    /// The configured mapping did not resolve (`mapping` is empty).
    pub(super) unresolved: bool,
    /// Whether sub 1 (COB-ID) is writable: if not, the mapping is changed with sub 0 alone.
    pub(super) cob_id_writable: bool,
    /// What a download or a configuration changed that the PDO has yet to
    /// act on (see `Pdos::ACT_IN_WALK`); [`Change::None`] but in between.
    pub(super) change: Change,
    /// The mapping; empty (the PDO is silent) when the configured one does
    /// not resolve. Not an `Option`: every path that uses the mapping
    /// would check it, where an empty mapping already keeps the PDO off.
    pub(super) mapping: Mapping,
}

/// What a download changed in a PDO's configuration: the PDO's reaction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum Change {
    /// Nothing the PDO acts on. First: all zero bits.
    #[default]
    None,
    /// The COB-ID, the type or the mapping: the PDO starts over.
    Restart,
    /// The event timer alone: it starts again.
    Timer,
}

impl Config {
    /// Before the first configuration: all zero bits ([`crate::node`]), an
    /// empty mapping, so the PDO does nothing.
    pub(super) const UNCONFIGURED: Config = Config {
        params: CommParams::UNCONFIGURED,
        mapping: Mapping::EMPTY,
        unresolved: false,
        cob_id_writable: false,
        change: Change::None,
    };

    /// A dictionary without the PDO's records: an invalid PDO of type 254.
    pub(super) const DEFAULT: Config =
        Config { params: CommParams::DEFAULT, mapping: Mapping::EMPTY, unresolved: true, cob_id_writable: false, change: Change::None };

    /// The CAN-ID the PDO uses: `Some` when the COB-ID is valid and a
    /// non-empty mapping resolved (a mapping of sub 0 = 0 disables the PDO).
    pub(super) fn cob_id(&self) -> Option<u16> {
        (self.params.valid() && !self.mapping.is_empty()).then(|| self.params.can_id())
    }

    /// Reads communication record `comm` (0x1400+n or 0x1800+n) and its
    /// mapping record from the image into a configuration that is
    /// [`Config::UNCONFIGURED`] (the caller's PDO's, cleared): a
    /// mapping the dictionary lacks, or one that does not resolve, leaves
    /// the mapping empty and `unresolved`; the second is returned. The
    /// mapping is resolved in place (a mapping returned by value was copied
    /// twice on its way into the PDO).
    // Left to the inliner: since round 15 one loop configures both kinds.
    pub(super) fn read(&mut self, dict: &Dictionary, image: &[u8], comm: u16, direction: Direction) -> Option<MappingError> {
        self.cob_id_writable = self.params.read_record(dict, image, comm);
        let index = nth(comm, MAPPING_OFFSET);
        let Err(code) = self.mapping.read_record(dict, image, index, direction) else { return None };
        // The failed resolution left an empty mapping (`Mapping::resolve`).
        self.unresolved = true;
        // A record the dictionary lacks is no error.
        code.map(|code| MappingError { index, code })
    }
}
