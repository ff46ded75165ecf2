//! SDO downloads of the PDO parameter records: the CiA 301 mapping
//! procedure with every abort code, then the communication parameters.

use super::*;
use crate::id::is_restricted_can_id;

// ---- The mapping procedure (SDO) ------------------------------------------------------

#[test]
fn the_cia301_mapping_procedure() {
    // CiA 310 cases 3.22, 3.24.
    let mut node = Node::operational(ms(0));
    node.poll(ms(0));
    node.frames();
    // While the PDO is valid, the mapping is locked.
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Err(AbortCode::UnsupportedAccess));
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Err(AbortCode::UnsupportedAccess));
    // 1. Invalidate. 2. Disable the mapping. 3. Write the entries. 4. Enable. 5. Validate.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Err(AbortCode::UnsupportedAccess), "sub 0 is not 0");
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 1, 0x2008_0220), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 2, 0x2008_0110), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[2]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.set(0x2008, 2, &[1, 2, 3, 4]);
    node.set(0x2008, 1, &[5, 6]);
    node.poll(ms(2));
    tx!(node, [(0x181, [1, 2, 3, 4, 5, 6])]);
    assert_eq!(node.get(0x1A00, 0), [2]);
    assert_eq!(node.get(0x1A00, 1), 0x2008_0220u32.to_le_bytes());
}

#[test]
fn mapping_entry_downloads_and_their_abort_codes() {
    // CiA 310 cases 3.25–3.32.
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    let before = node.image;
    let cases: [(u16, u32, AbortCode); 14] = [
        (0x1A00, 0x3000_0008, AbortCode::NoObject),
        (0x1A00, 0x2008_0310, AbortCode::NoSubIndex),
        (0x1A00, 0x2003_0010, AbortCode::NotMappable),           // PDOMapping=0 (3.32)
        (0x1600, 0x2003_0010, AbortCode::NotMappable),           // (3.29)
        (0x1A00, 0x2001_0010, AbortCode::NotMappable),           // rww into a TPDO (3.31)
        (0x1600, 0x2002_0020, AbortCode::NotMappable),           // ro into an RPDO (3.28)
        (0x1600, 0x2005_0020, AbortCode::NotMappable),           // a constant into an RPDO
        (0x1A00, 0x2007_0000, AbortCode::NotMappable),           // DOMAIN
        (0x1A00, 0x0005_0008, AbortCode::NotMappable),           // dummy in a TPDO
        (0x1A00, 0x2001_0008, AbortCode::NotMappable),           // direction before length
        (0x1A00, 0x2002_0010, AbortCode::ParameterIncompatible), // 16 of 32 bits
        (0x1A00, 0x2000_0004, AbortCode::ParameterIncompatible), // bit mapping
        (0x1600, 0x0006_0008, AbortCode::ParameterIncompatible), // dummy of the wrong size
        (0x1A00, 0x2006_0050, AbortCode::PdoTooLong),            // 80 bits (3.26)
    ];
    for (index, entry, code) in cases {
        assert_eq!(node.sdo32(index, 1, entry), Err(code), "{index:#06X} ← {entry:#010X}");
    }
    assert_eq!(node.image, before, "nothing written");
    // Too many bytes in all (3.26) and too many objects (3.25).
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 2, 0x2000_0008), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[2]), Err(AbortCode::PdoTooLong));
    // The dictionary's limit on sub 0 (0..=8 here) answers first, as in the
    // node (tests/conformance_pdo.rs has a count of 9 without a limit: 0x06040042).
    assert_eq!(node.sdo(0x1A00, 0, &[9]), Err(AbortCode::ValueTooHigh));
    assert_eq!(node.sdo(0x1601, 0, &[3]), Err(AbortCode::PdoTooLong), "the record has 2 entries");
    assert_eq!(node.get(0x1A00, 0), [0]);
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Ok(()));
    // Length and existence checks of the download itself.
    assert_eq!(node.sdo(0x1A00, 1, &[0, 0]), Err(AbortCode::LengthTooLow));
    assert_eq!(node.sdo(0x1A00, 0, &[1, 0]), Err(AbortCode::LengthTooHigh));
    assert_eq!(node.sdo32(0x1A00, 9, 0), Err(AbortCode::NoSubIndex));
    assert_eq!(node.sdo(0x1800, 0, &[6]), Err(AbortCode::ReadOnly));
}

#[test]
fn enabling_a_mapping_checks_the_stored_entries() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    node.set(0x1A00, 1, &0x3000_0008u32.to_le_bytes()); // as a bad stored parameter set could hold
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Err(AbortCode::NoObject));
    assert_eq!(node.sdo32(0x1A00, 1, 0), Ok(()), "clearing an entry is always possible");
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Err(AbortCode::NoObject), "index 0 does not exist");
}

#[test]
fn writing_back_current_values_is_accepted() {
    // CiA 310 case 4.9: read every rw object and write it back.
    let mut node = Node::operational(ms(0));
    for (index, sub) in
        [(0x1A00, 0), (0x1A00, 1), (0x1A00, 8), (0x1800, 1), (0x1800, 2), (0x1800, 3), (0x1800, 6), (0x1600, 0), (0x1400, 1)]
    {
        let value = node.get(index, sub);
        assert_eq!(node.sdo(index, sub, &value), Ok(()), "{index:#06X} sub {sub}");
    }
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
}

#[test]
fn a_read_only_cob_id_lets_sub0_open_the_mapping() {
    // docs/devices/ec5000.md decision 13: RPDO2's COB-ID is ro and valid.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1401, 1, 0x8000_0301), Err(AbortCode::ReadOnly));
    assert_eq!(node.sdo32(0x1601, 1, 0x2000_0008), Ok(()));
    assert_eq!(node.sdo(0x1601, 0, &[1]), Ok(()));
    assert_eq!(node.pdos.rpdo(1).unwrap().cob_id(), Some(0x301));
    assert_eq!(node.sdo32(0x1601, 1, 0x2008_0110), Err(AbortCode::UnsupportedAccess), "sub 0 is not 0");
    assert!(node.rx(ms(1), 0x301, &[0x42]));
    node.sync(sync_at(ms(2), None));
    assert_eq!(node.get(0x2000, 0), [0x42]);
    assert_eq!(node.sdo(0x1601, 0, &[0]), Ok(()));
    assert!(!node.rx(ms(3), 0x301, &[0x43]), "disabled again");
}

// ---- Communication parameter downloads ------------------------------------------------

#[test]
fn cob_id_downloads() {
    let mut node = Node::operational(ms(0));
    let w = |node: &mut Node, v: u32| node.sdo32(0x1800, 1, v);
    assert_eq!(w(&mut node, 0x182), Err(AbortCode::InvalidValue), "the CAN-ID of a valid PDO");
    assert_eq!(w(&mut node, 0x8000_0182), Ok(()), "invalidate and move at once");
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), None);
    assert_eq!(w(&mut node, 0x2000_0182), Err(AbortCode::InvalidValue), "29-bit frame");
    assert_eq!(w(&mut node, 0x0004_0182), Err(AbortCode::InvalidValue), "bits 11..28");
    for restricted in [0x000u32, 0x07F, 0x101, 0x180, 0x5FF, 0x601, 0x6E0, 0x701, 0x7FF] {
        assert_eq!(w(&mut node, restricted), Err(AbortCode::InvalidValue), "{restricted:#X}");
    }
    assert_eq!(w(&mut node, 0x8000_0701), Ok(()), "an invalid COB-ID may hold anything");
    assert_eq!(w(&mut node, 0x4000_0182), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x182));
    assert!(!node.pdos.tpdo(0).unwrap().params().rtr_allowed());
    assert_eq!(node.get(0x1800, 1), 0x4000_0182u32.to_le_bytes());
    assert_eq!(node.sdo(0x1800, 1, &[0x82, 0x01]), Err(AbortCode::LengthTooLow));
}

#[test]
fn transmission_type_downloads() {
    let mut node = Node::new();
    for (index, tt, ok) in
        [(0x1800, 241, false), (0x1800, 251, false), (0x1800, 252, true), (0x1800, 253, true), (0x1800, 0, true), (0x1800, 240, true)]
    {
        assert_eq!(node.sdo(index, 2, &[tt]).is_ok(), ok, "TPDO type {tt}");
    }
    for (tt, ok) in [(241u8, false), (252, false), (253, false), (254, true), (0, true)] {
        assert_eq!(node.sdo(0x1400, 2, &[tt]).is_ok(), ok, "RPDO type {tt}");
    }
    assert_eq!(node.sdo(0x1400, 2, &[252]), Err(AbortCode::InvalidValue));
    // RTR-only types and COB-ID bit 30 exclude each other.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Ok(()), "type 240");
    assert_eq!(node.sdo(0x1800, 2, &[252]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 2, &[253]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 2, &[253]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Err(AbortCode::InvalidValue));
    // The COB-ID's rule holds for a valid PDO only; the type's whether valid or not.
    assert_eq!(node.sdo32(0x1800, 1, 0xC000_0181), Ok(()), "not valid: no RTR beside type 253");
    assert_eq!(node.sdo(0x1800, 2, &[252]), Err(AbortCode::InvalidValue), "not valid, no RTR: no RTR-only type");
    assert_eq!(node.sdo(0x1800, 2, &[254]), Ok(()));
}

/// A TPDO configured from an image in the state the downloads refuse (type
/// 253 with COB-ID bit 30 "no RTR", valid): the RTR rule refuses only sub 2
/// and a valid sub 1; the other subs follow their own rules.
#[test]
fn the_rtr_rule_holds_for_sub_1_and_2_only() {
    let mut node = Node::new();
    node.set(0x1800, 1, &0x4000_0181u32.to_le_bytes());
    node.set(0x1800, 2, &[253]);
    assert_eq!(node.pdos.configure(&DICT, &node.image), Ok(()));
    assert_eq!(node.sdo(0x1800, 5, &100u16.to_le_bytes()), Ok(()), "event timer");
    assert_eq!(node.sdo(0x1800, 2, &[253]), Err(AbortCode::InvalidValue), "the same type again");
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Err(AbortCode::InvalidValue), "the same COB-ID again");
    assert_eq!(node.sdo32(0x1800, 1, 0xC000_0181), Ok(()), "not valid");
    assert_eq!(node.sdo(0x1800, 3, &10u16.to_le_bytes()), Ok(()), "inhibit time, not valid");
    assert_eq!(node.sdo(0x1800, 6, &[3]), Ok(()), "SYNC start value, not valid");
    assert_eq!(node.sdo(0x1800, 2, &[254]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Ok(()), "type 254 with no RTR");
    // An RPDO's RTR-only types are reserved: refused whatever bit 30 says.
    assert_eq!(node.sdo32(0x1400, 1, 0xC000_0201), Ok(()));
    assert_eq!(node.sdo(0x1400, 2, &[253]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo32(0x1400, 1, 0x4000_0201), Ok(()), "an RPDO's bit 30 alone");
}

#[test]
fn inhibit_time_and_sync_start_change_only_while_invalid() {
    let mut node = Node::new();
    // While valid, the values they hold may be written again.
    for sub in [3, 6] {
        let held = node.get(0x1800, sub);
        assert_eq!(node.sdo(0x1800, sub, &held), Ok(()), "sub {sub} rewritten");
    }
    assert_eq!(node.sdo(0x1800, 3, &10u16.to_le_bytes()), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 6, &[5]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 6, &[241]), Err(AbortCode::InvalidValue), "out of range too");
    assert_eq!(node.sdo(0x1400, 3, &10u16.to_le_bytes()), Err(AbortCode::InvalidValue), "RPDO sub 3 too");
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &10u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo(0x1800, 6, &[241]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 6, &[240]), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().params().inhibit_time(), 1000);
    assert_eq!(node.pdos.tpdo(0).unwrap().params().sync_start, 240);
    assert_eq!(node.sdo(0x1801, 4, &[0]), Err(AbortCode::NoSubIndex), "sub 4 is reserved");
}

#[test]
fn other_objects_are_not_pdo_parameters() {
    let mut node = Node::new();
    for index in [0x1005, 0x13FF, 0x1402, 0x1602, 0x1802, 0x1A02, 0x1C00, 0x2000] {
        assert_eq!(node.pdos.write_object(index, 1, &[0; 4], &DICT, &mut node.image), None, "{index:#06X}");
    }
    // A PDO this node has, but the dictionary lacks.
    let mut big: Pdos<3, 3> = Pdos::default();
    assert_eq!(big.configure(&DICT, &DEFAULTS), Ok(()));
    assert_eq!(big.rpdo(2).unwrap().cob_id(), None);
    assert_eq!(big.write_object(0x1402, 1, &[0; 4], &DICT, &mut node.image), Some(Err(AbortCode::NoObject)));
}

#[test]
fn restricted_can_ids_follow_cia301() {
    let allowed = [0x080u16, 0x100, 0x181, 0x1FF, 0x200, 0x580, 0x600, 0x680, 0x6DF, 0x700];
    assert!(allowed.iter().all(|&id| !is_restricted_can_id(id)));
    let restricted = [0x000u16, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701, 0x77F, 0x780, 0x7FF];
    assert!(restricted.iter().all(|&id| is_restricted_can_id(id)));
}

#[test]
fn the_deadline_a_poll_settled_follows_every_later_change() {
    // `deadline` answers from the last poll until a PDO changes: each change must be seen.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 5, &50u16.to_le_bytes()), Ok(()));
    node.poll(ms(1));
    node.frames();
    assert_eq!(node.poll(ms(2)), None);
    assert!(node.rx(ms(1000), 0x201, &[0, 0, 0]));
    node.events();
    assert_eq!(node.pdos.deadline(), Some(ms(1050)), "an RPDO arms its timer");
    assert_eq!(node.poll(ms(1010)), Some(ms(1050)));
    assert_eq!(node.sdo(0x1400, 5, &80u16.to_le_bytes()), Ok(()));
    assert_eq!(node.pdos.deadline(), None, "a new event timer waits for the next RPDO");
    assert_eq!(node.poll(ms(1020)), None);
    node.pdos.enter_operational(ms(1030));
    assert_eq!(node.pdos.deadline(), Some(0), "event-driven TPDOs go out at once");
}

#[test]
fn a_download_restarts_a_pdo_only_when_its_cob_id_type_or_mapping_changed() {
    let mut node = Node::operational(ms(0));
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    // TPDO1 (type 255): the same COB-ID and type again, a new event timer
    // (rearmed only): no restart, so no new initial event.
    let ty = node.get(0x1800, 2);
    assert_eq!(ty, [255]);
    assert_eq!(node.sdo(0x1800, 2, &ty), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    assert_eq!(node.sdo(0x1800, 5, &100u16.to_le_bytes()), Ok(()));
    node.poll(ms(1));
    tx!(node, []);
    // Another event-driven type: restarted, its initial event sent.
    assert_eq!(node.sdo(0x1800, 2, &[254]), Ok(()));
    node.poll(ms(2));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    // RPDO1 synchronous: a new event timer keeps the data waiting for the SYNC ...
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()));
    assert!(node.rx(ms(3), 0x201, &[1, 0, 2]));
    assert_eq!(node.sdo(0x1400, 5, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()));
    assert!(node.pdos.rpdo(0).unwrap().has_buffered(), "no restart");
    // ... another type (or COB-ID, or mapping) drops it.
    assert_eq!(node.sdo(0x1400, 2, &[2]), Ok(()));
    assert!(!node.pdos.rpdo(0).unwrap().has_buffered(), "restarted");
    assert!(node.rx(ms(4), 0x201, &[1, 0, 2]));
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert!(!node.pdos.rpdo(0).unwrap().has_buffered(), "restarted");
    let count = node.get(0x1600, 0);
    assert_eq!(node.sdo32(0x1400, 1, 0x201), Ok(()));
    assert!(node.rx(ms(5), 0x201, &[1, 0, 2]));
    assert!(node.pdos.rpdo(0).unwrap().has_buffered());
    assert_eq!(node.sdo(0x1600, 0, &[0]), Err(AbortCode::UnsupportedAccess), "valid: the mapping is locked");
    assert_eq!(node.sdo(0x1600, 0, &count), Ok(()), "written back");
    assert!(node.pdos.rpdo(0).unwrap().has_buffered(), "written back: no restart");
}
