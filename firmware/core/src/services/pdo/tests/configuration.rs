//! Configuration from the dictionary, the NMT states, reset communication.

use super::map::Slot;
use super::*;

// ---- Configuration -------------------------------------------------------------

#[test]
fn configure_caches_the_records_and_resolves_the_mappings() {
    let node = Node::new();
    let r1 = node.pdos.rpdo(0).unwrap();
    assert_eq!((r1.cob_id(), r1.params().transmission_type, r1.mapping().map(Mapping::len)), (Some(0x201), 255, Some(3)));
    let mapping = r1.mapping().unwrap();
    assert_eq!(
        [mapping.object(0).map(|(_, s)| s), mapping.object(1).map(|(_, s)| s), mapping.object(2).map(|(_, s)| s)],
        [Some(Slot { source: map::Source::Ram(143), len: 2 }), Some(Slot { source: map::Source::Ram(142), len: 1 }), None]
    );
    // Valid, but nothing mapped: disabled.
    let r2 = node.pdos.rpdo(1).unwrap();
    assert_eq!((r2.params().valid(), r2.cob_id(), r2.mapping().map(Mapping::len)), (true, None, Some(0)));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
    assert_eq!(node.pdos.tpdo(1).unwrap().cob_id(), None, "invalid");
    assert!(node.pdos.rpdo(2).is_none());
    assert!(!node.pdos.is_operational());
}

#[test]
fn a_mapping_that_does_not_resolve_silences_its_pdo() {
    let mut image = DEFAULTS;
    image[77..81].copy_from_slice(&0x2003_0010u32.to_le_bytes());
    let mut pdos: Pdos<2, 2> = Pdos::default();
    assert_eq!(pdos.configure(&DICT, &image), Err(MappingError { index: 0x1A00, code: AbortCode::NotMappable }));
    assert_eq!(pdos.tpdo(0).unwrap().cob_id(), None);
    assert!(pdos.tpdo(0).unwrap().mapping().is_none(), "no mapping to speak of (an empty one is sub 0 = 0)");
    assert_eq!(pdos.rpdo(0).unwrap().cob_id(), Some(0x201), "the others are configured");
    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    assert_eq!(pdos.poll(ms(0), &image, &mut bus), None);
    assert!(bus.frames.is_empty());
}

#[test]
fn nothing_runs_outside_operational() {
    let mut node = Node::new();
    assert!(!node.rx(ms(0), 0x201, &[1, 2, 3]));
    assert!(!node.rtr(ms(0), 0x181));
    node.sync(sync_at(ms(0), None));
    assert_eq!((node.poll(ms(0)), node.pdos.deadline()), (None, None));
    node.pdos.enter_operational(ms(1));
    node.pdos.stop();
    assert_eq!(node.poll(ms(2)), None);
    assert!(!node.rx(ms(2), 0x201, &[1, 2, 3]));
    tx!(node, []);
    assert_eq!(node.get(0x2000, 0), [0]);
}

#[test]
fn reset_communication_restores_the_defaults() {
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(0, &[0x2004_0040], 0x182, 1);
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x182));
    DICT.reset_communication(&mut node.image, 1);
    assert_eq!(node.pdos.configure(&DICT, &node.image), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
    assert_eq!(node.pdos.tpdo(0).unwrap().mapping().map(Mapping::len), Some(5));
    assert!(!node.pdos.is_operational());
}

/// A mapping record the dictionary lacks is no error (the PDO is silent);
/// one without sub 0 is 0x06020000 at configuration.
#[test]
fn a_missing_mapping_record_is_no_error_and_one_without_sub_0_is() {
    use crate::od::{Attr, DataType, Entry};
    static ENTRIES: [Entry; 3] = [
        Entry::new(0x1800, 1, DataType::Unsigned32, Attr::READ, 4, 0),
        Entry::new(0x1801, 1, DataType::Unsigned32, Attr::READ, 4, 4),
        Entry::new(0x1A01, 1, DataType::Unsigned32, Attr::READ, 4, 8),
    ];
    static IMAGE: [u8; 12] = [0x81, 1, 0, 0, 0x82, 1, 0, 0, 0x10, 0, 0, 0x20];
    static ONLY: Dictionary = Dictionary::comm_only(&ENTRIES, &IMAGE);
    let mut pdos: Pdos<0, 1> = Pdos::default();
    assert_eq!(pdos.configure(&ONLY, &IMAGE), Ok(()), "no 0x1A00");
    assert!(pdos.tpdo(0).unwrap().mapping().is_none());
    assert_eq!(pdos.tpdo(0).unwrap().cob_id(), None);
    let mut pdos: Pdos<0, 2> = Pdos::default();
    assert_eq!(pdos.configure(&ONLY, &IMAGE), Err(MappingError { index: 0x1A01, code: AbortCode::NoObject }), "0x1A01 without sub 0");
    assert_eq!(pdos.tpdo(1).unwrap().cob_id(), None);
}
