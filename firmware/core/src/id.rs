//! Node-IDs and COB-IDs. CiA 301 v4.2 §7.3.3 (pre-defined connection set),
//! §7.3.5 (restricted CAN-IDs) and the COB-ID entries of the communication
//! objects (0x1005 SYNC, 0x1012 TIME, 0x1014 EMCY, 0x1200–0x12FF SDO,
//! 0x1400–0x15FF and 0x1800–0x19FF PDO).

/// A CANopen node-ID: 1..=127 (CiA 301 §7.3.3; 0 is the NMT broadcast
/// address, 128..=255 are not node-IDs, 255 means "unconfigured" in LSS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(u8);

impl NodeId {
    /// The node-ID `id`, if it is one (1..=127).
    pub const fn new(id: u8) -> Option<NodeId> {
        match id {
            1..=127 => Some(NodeId(id)),
            _ => None,
        }
    }

    /// The node-ID as a number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// Whether CiA 301 §7.3.5 (table "restricted CAN-IDs") reserves `can_id`,
/// so that no configurable COB-ID may use it: NMT and reserved 0x000–0x07F,
/// 0x101–0x180, the default SDO 0x581–0x5FF and 0x601–0x67F, 0x6E0–0x6FF,
/// NMT error control 0x701–0x77F and 0x780–0x7FF.
pub const fn is_restricted_can_id(can_id: u16) -> bool {
    matches!(can_id, 0x000..=0x07F | 0x101..=0x180 | 0x581..=0x5FF | 0x601..=0x67F | 0x6E0..=0x6FF | 0x701..=0x7FF)
}

/// A COB-ID entry as the communication objects store it (UNSIGNED32).
///
/// Bits 0..10 are the 11-bit CAN-ID and bit 29 ("frame") selects a 29-bit
/// CAN-ID, which this stack does not support; bits 11..28 then belong to the
/// 29-bit identifier. Bits 30 and 31 mean different things per object:
/// valid/RTR for PDOs, valid/dynamic for SDO, valid for EMCY, generate for
/// SYNC, consume/produce for TIME.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CobId(pub u32);

impl CobId {
    /// Bit 31 (PDO, SDO, EMCY: set = the object does not exist / is not valid).
    pub const BIT31: u32 = 1 << 31;
    /// Bit 30.
    pub const BIT30: u32 = 1 << 30;
    /// Bit 29 and bits 11..28: a 29-bit CAN-ID.
    pub const EXTENDED: u32 = 0x3FFF_F800 & !Self::BIT30;

    /// The 11-bit CAN-ID (bits 0..10).
    pub const fn can_id(self) -> u16 {
        (self.0 & 0x7FF) as u16
    }

    /// Bit 31 clear: the PDO, SDO or EMCY it configures exists.
    pub const fn is_valid(self) -> bool {
        self.0 & Self::BIT31 == 0
    }

    /// Whether bit 29 or any of bits 11..28 is set (29-bit identifiers are not supported).
    pub const fn is_extended(self) -> bool {
        self.0 & Self::EXTENDED != 0
    }

    /// Whether its CAN-ID is restricted (§7.3.5).
    pub const fn is_restricted(self) -> bool {
        is_restricted_can_id(self.can_id())
    }
}

/// What a download of one kind of COB-ID entry must pass (CiA 301
/// §7.5.2.5 SYNC, §7.5.2.13 TIME, §7.5.2.15 EMCY, §7.5.2.33 SDO,
/// §7.5.2.35/37 PDO): the rules as data, one [`CobRule::check`] for all.
/// When bits 30/31 put a COB-ID "in use" is a truth table over them: bit
/// n of a table (n = bits 31..30 of the value, 0..=3) set means "in use"
/// in that sense. One 16-bit word: the "used" table (bits 0..3), the
/// "fixed" table (bits 4..7), bit 30 reserved (bit 8), CAN-ID 0 refused
/// (bit 9); a constant a caller loads in one instruction, where the
/// six bytes of bools and pairs it had were passed by address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CobRule(u16);

/// Bit 31 clear (bits 31..30 = 0b00 or 0b01): in use (PDO, SDO, EMCY valid).
const VALID: u16 = 0b0011;
/// Never in use.
const NEVER: u16 = 0;
/// Bit 30 must be 0 too, besides bits 11..29 (no 29-bit CAN-IDs).
const BIT30_RESERVED: u16 = 1 << 8;
/// CAN-ID 0 is refused even while the COB-ID is not in use (EMCY).
const NO_ZERO: u16 = 1 << 9;

impl CobRule {
    /// The rule with these truth tables: `used` (in use, the CAN-ID may
    /// not be restricted, §7.3.5) and `fixed` (while the old and the new
    /// COB-ID are both in this sense in use, the CAN-ID may not change),
    /// and the flags.
    const fn new(used: u16, fixed: u16, flags: u16) -> CobRule {
        CobRule(used | fixed << 4 | flags)
    }

    /// 0x1005: bit 31 "do not care", bit 30 produce; a restricted CAN-ID is
    /// refused even for a consumer; a producer's CAN-ID is fixed.
    pub const SYNC: CobRule = CobRule::new(0b1111, 0b1010, 0);
    /// 0x1012: bit 31 consume, bit 30 produce; the CAN-ID may change in use.
    pub const TIME: CobRule = CobRule::new(0b1110, NEVER, 0);
    /// 0x1014: bit 31 off, bit 30 reserved, never CAN-ID 0.
    pub const EMCY: CobRule = CobRule::new(VALID, VALID, BIT30_RESERVED | NO_ZERO);
    /// 0x1200+ sub 1/2, 0x1400+ and 0x1800+ sub 1: bit 31 not valid, bit 30
    /// dynamic (SDO) or no RTR (PDO).
    pub const VALID: CobRule = CobRule::new(VALID, VALID, 0);
    /// [`CobRule::VALID`] for a device whose manual lets a valid PDO move.
    pub const MOVABLE: CobRule = CobRule::new(VALID, NEVER, 0);

    /// Checks `new` against the entry's `old` value (`None`: none to keep),
    /// `own` a restricted CAN-ID this entry may still use (the default SDO
    /// server's own; else any value above 0x7FF). 0x06090030 if it fails.
    // Out of line: one copy for the six kinds of COB-ID.
    #[inline(never)]
    pub fn check(self, old: Option<u32>, new: u32, own: u16) -> Result<(), crate::abort::AbortCode> {
        let rule = u32::from(self.0);
        // The table's bit for bits 31..30 of `v`.
        let on = |table: u32, v: u32| (table >> (v >> 30)) & 1 != 0;
        let (used, fixed) = (rule, rule >> 4);
        let can_id = CobId(new).can_id();
        let reserved = if self.0 & BIT30_RESERVED != 0 { CobId::EXTENDED | CobId::BIT30 } else { CobId::EXTENDED };
        // One rule at a time, each refusing alone: branches, where the
        // whole condition at once was worked out without (LLVM's selects).
        if new & reserved != 0 || (self.0 & NO_ZERO != 0 && can_id == 0) {
            return Err(crate::abort::AbortCode::InvalidValue);
        }
        if old.is_some_and(|old| on(fixed, old) && on(fixed, new) && (old ^ new) & 0x7FF != 0) {
            return Err(crate::abort::AbortCode::InvalidValue);
        }
        if on(used, new) && can_id != own && is_restricted_can_id(can_id) {
            return Err(crate::abort::AbortCode::InvalidValue);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_ids_are_1_to_127() {
        assert_eq!(NodeId::new(0), None);
        assert_eq!(NodeId::new(1).map(NodeId::get), Some(1));
        assert_eq!(NodeId::new(127).map(NodeId::get), Some(127));
        assert_eq!(NodeId::new(128), None);
        assert_eq!(NodeId::new(255), None);
    }

    #[test]
    fn restricted_can_ids_follow_cia301_table_34() {
        let restricted = [0x000, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701, 0x77F, 0x780, 0x7FF];
        let allowed = [0x080, 0x0FF, 0x100, 0x181, 0x580, 0x600, 0x680, 0x6DF, 0x700];
        assert!(restricted.iter().all(|&id| is_restricted_can_id(id)));
        assert!(allowed.iter().all(|&id| !is_restricted_can_id(id)));
    }

    #[test]
    fn cob_rules_as_each_object_has_them() {
        use crate::abort::AbortCode::InvalidValue;
        let none = u16::MAX;
        // (rule, old, new, own, refused)
        let cases = [
            (CobRule::EMCY, Some(0x84), 0x85, none, true),
            (CobRule::EMCY, Some(0x8000_0084), 0x85, none, false),
            (CobRule::EMCY, None, 0x4000_0085, none, true),
            (CobRule::EMCY, None, 0x8000_0000, none, true),
            (CobRule::EMCY, None, 0x8000_0701, none, false),
            (CobRule::TIME, Some(0x8000_0100), 0xC000_0290, none, false),
            (CobRule::TIME, None, 0x0000_0701, none, false),
            (CobRule::TIME, None, 0x4000_0701, none, true),
            (CobRule::SYNC, Some(0x4000_0080), 0x4000_0081, none, true),
            (CobRule::SYNC, Some(0x4000_0080), 0x0000_0081, none, false),
            (CobRule::SYNC, Some(0x80), 0x8000_0701, none, true),
            (CobRule::VALID, Some(0x8000_0000), 0x604, 0x604, false),
            (CobRule::VALID, Some(0x8000_0000), 0x604, none, true),
            (CobRule::VALID, Some(0x4000_0201), 0x4000_0202, none, true),
            (CobRule::MOVABLE, Some(0x4000_0201), 0x4000_0202, none, false),
            (CobRule::VALID, None, 0x2000_0201, none, true),
        ];
        for (rule, old, new, own, refused) in cases {
            assert_eq!(rule.check(old, new, own), if refused { Err(InvalidValue) } else { Ok(()) }, "{rule:?} {old:?} -> {new:#X}");
        }
    }

    /// The truth tables say what the (mask, off) pairs and flags they
    /// replaced said (round 14), for every rule on a grid of values.
    #[test]
    fn cob_rules_as_tables_decide_as_the_pairs_did() {
        use crate::abort::AbortCode::InvalidValue;
        // (bit30 reserved, no zero, used, fixed) as before.
        fn by_pairs(
            (bit30_reserved, no_zero, used, fixed): (bool, bool, (u8, u8), (u8, u8)),
            old: Option<u32>,
            new: u32,
            own: u16,
        ) -> bool {
            let on = |(mask, off): (u8, u8), v: u32| (v >> 24) as u8 & mask != off;
            let can_id = CobId(new).can_id();
            let restricted = is_restricted_can_id(can_id) && can_id != own;
            let reserved = if bit30_reserved { CobId::EXTENDED | CobId::BIT30 } else { CobId::EXTENDED };
            let moves = old.is_some_and(|old| on(fixed, old) && on(fixed, new) && (old ^ new) & 0x7FF != 0);
            new & reserved != 0 || (no_zero && can_id == 0) || (on(used, new) && restricted) || moves
        }
        let (valid, never) = ((0x80, 0x80), (0, 0));
        let rules = [
            (CobRule::SYNC, (false, false, (0, 1), (0x40, 0))),
            (CobRule::TIME, (false, false, (0xC0, 0), never)),
            (CobRule::EMCY, (true, true, valid, valid)),
            (CobRule::VALID, (false, false, valid, valid)),
            (CobRule::MOVABLE, (false, false, valid, never)),
        ];
        let ids = [0, 1, 0x7F, 0x80, 0x100, 0x101, 0x181, 0x580, 0x581, 0x600, 0x601, 0x604, 0x67F, 0x6E0, 0x700, 0x701, 0x7FF];
        let mut values = std::vec::Vec::new();
        for top in 0..4u32 {
            for high in [0, 0x800, 0x2000_0000] {
                for id in ids {
                    values.push(top << 30 | high | id);
                }
            }
        }
        for (rule, pairs) in rules {
            for own in [u16::MAX, 0x604] {
                for &new in &values {
                    for old in core::iter::once(None).chain(values.iter().copied().map(Some)) {
                        let want = if by_pairs(pairs, old, new, own) { Err(InvalidValue) } else { Ok(()) };
                        assert_eq!(rule.check(old, new, own), want, "{rule:?} {old:?} -> {new:#X} own {own:#X}");
                    }
                }
            }
        }
    }

    #[test]
    fn cob_id_fields() {
        let c = CobId(0xC000_0185);
        assert_eq!((c.can_id(), c.is_valid(), c.is_extended(), c.is_restricted()), (0x185, false, false, false));
        assert!(CobId(0x2000_0185).is_extended());
        assert!(CobId(0x0000_0985).is_extended());
        assert!(!CobId(0x4000_0185).is_extended());
        assert!(CobId(0x0000_0701).is_restricted());
    }
}
