//! TPDOs by transmission type (254/255, 0, 1..=240, 252/253), then what
//! a mapping may carry.

use super::*;

// ---- TPDO types 254/255: event-driven --------------------------------------------

#[test]
fn event_driven_tpdo_sends_on_entering_operational_and_on_each_change() {
    let mut node = Node::operational(ms(0));
    node.set(0x2002, 0, &0x0403_0201u32.to_le_bytes());
    node.set(0x2000, 0, &[0x05]);
    assert_eq!(node.pdos.deadline(), Some(0), "due at once");
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [1, 2, 3, 4, 5])]);
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    node.set(0x2000, 0, &[0x06]);
    node.poll(ms(2));
    tx!(node, [(0x181, [1, 2, 3, 4, 6])]);
    node.poll(ms(3));
    tx!(node, []);
}

#[test]
fn inhibit_time_delays_an_event_and_sends_the_latest_data() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &100u16.to_le_bytes()), Ok(()), "10 ms");
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[1]);
    assert_eq!(node.poll(ms(1)), Some(ms(10)));
    node.set(0x2000, 0, &[2]);
    assert_eq!(node.poll(us(9_999)), Some(ms(10)));
    tx!(node, []);
    assert_eq!(node.poll(ms(10)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 2])]);
    // A change undone within the inhibit time sends nothing.
    node.set(0x2000, 0, &[3]);
    node.poll(ms(12));
    node.set(0x2000, 0, &[2]);
    node.poll(ms(20));
    tx!(node, []);
}

#[test]
fn event_timer_sends_periodically_and_restarts_with_each_transmission() {
    let mut node = Node::new();
    assert_eq!(node.sdo(0x1800, 5, &100u16.to_le_bytes()), Ok(()), "writable while valid");
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), Some(ms(100)));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert_eq!(node.poll(ms(99)), Some(ms(100)));
    tx!(node, []);
    assert_eq!(node.poll(ms(100)), Some(ms(200)));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[9]);
    assert_eq!(node.poll(ms(130)), Some(ms(230)));
    tx!(node, [(0x181, [0, 0, 0, 0, 9])]);
    // A new event timer starts at the next poll.
    assert_eq!(node.sdo(0x1800, 5, &50u16.to_le_bytes()), Ok(()));
    assert_eq!(node.pdos.deadline(), Some(0));
    assert_eq!(node.poll(ms(140)), Some(ms(190)));
    assert_eq!(node.poll(ms(190)), Some(ms(240)));
    tx!(node, [(0x181, [0, 0, 0, 0, 9])]);
}

#[test]
fn an_event_timer_expiring_in_the_inhibit_time_waits_for_its_end() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &500u16.to_le_bytes()), Ok(()), "50 ms");
    assert_eq!(node.sdo(0x1800, 5, &20u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), Some(ms(20)));
    assert_eq!(node.poll(ms(20)), Some(ms(50)), "pending until the inhibit time ends");
    assert_eq!(node.poll(ms(50)), Some(ms(70)));
    assert_eq!(node.poll(ms(70)), Some(ms(100)));
    assert_eq!(node.poll(ms(100)), Some(ms(120)));
    assert_eq!(node.frames().len(), 3, "at 0, 50 and 100 ms");
}

#[test]
fn without_change_detection_only_the_timer_and_the_application_send() {
    let mut node = Node::operational(ms(0));
    node.pdos.set_change_detection(0, false);
    assert!(!node.pdos.tpdo(0).unwrap().change_detection());
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[1]);
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    assert!(node.pdos.trigger(0));
    assert_eq!(node.pdos.deadline(), Some(0));
    node.poll(ms(2));
    tx!(node, [(0x181, [0, 0, 0, 0, 1])]);
    assert!(!node.pdos.trigger(1), "TPDO2 is not valid");
    assert!(!node.pdos.trigger(5));
}

#[test]
fn rules_that_never_switch_keep_change_detection_on() {
    /// A node's rules: nothing turns change detection off (a call of
    /// `set_change_detection` with them does not compile).
    struct Fixed;
    impl TpdoRules for Fixed {
        const TYPE_254: bool = false;
        const TYPE_255_WITH_TIMER: bool = false;
        const SWITCHES_CHANGE_DETECTION: bool = false;
    }
    let mut node = Node::<Fixed>::started(ms(0));
    assert!(node.pdos.tpdo(0).unwrap().change_detection());
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[1]);
    node.poll(ms(1));
    tx!(node, [(0x181, [0, 0, 0, 0, 1])]);
}

#[test]
fn an_event_timer_written_while_valid_makes_type_255_timer_only_where_the_device_says_so() {
    /// The Sendix's reading.
    struct Timer255;
    impl TpdoRules for Timer255 {
        const TYPE_254: bool = false;
        const TYPE_255_WITH_TIMER: bool = true;
        const SWITCHES_CHANGE_DETECTION: bool = true;
    }
    let mut node = Node::<Timer255>::started(ms(0));
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    // Without an event timer a change sends.
    node.set(0x2000, 0, &[1]);
    node.poll(ms(1));
    tx!(node, [(0x181, [0, 0, 0, 0, 1])]);
    // 100 ms, written while the TPDO is valid (no restart): timer-only from now on.
    assert_eq!(node.sdo(0x1800, 5, &100u16.to_le_bytes()), Ok(()));
    node.set(0x2000, 0, &[2]);
    node.poll(ms(2));
    tx!(node, []);
    node.poll(ms(102));
    tx!(node, [(0x181, [0, 0, 0, 0, 2])]);
    // Back to 0: a change sends again.
    assert_eq!(node.sdo(0x1800, 5, &0u16.to_le_bytes()), Ok(()));
    node.set(0x2000, 0, &[3]);
    node.poll(ms(103));
    tx!(node, [(0x181, [0, 0, 0, 0, 3])]);
}

#[test]
fn a_refused_frame_is_retried_at_the_next_poll() {
    let mut node = Node::operational(ms(0));
    node.bus.refuse = true;
    assert_eq!(node.poll(ms(0)), None, "no deadline: no spinning on a full queue");
    node.bus.refuse = false;
    node.poll(ms(1));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
}

#[test]
fn a_refused_frame_is_retried_by_a_poll_that_marks_other_tpdos_only() {
    // The poll itself looks for TPDOs waiting to retry: the node marks only
    // the TPDOs a write reached.
    let mut node = Node::operational(ms(0));
    node.bus.refuse = true;
    assert_eq!(node.pdos.poll_changed(ms(0), 0, &node.image, &mut node.bus), None);
    node.bus.refuse = false;
    node.pdos.poll_changed(ms(1), 0b10, &node.image, &mut node.bus);
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.pdos.poll_changed(ms(2), 0b10, &node.image, &mut node.bus);
    tx!(node, []);
}

#[test]
fn rtr_on_an_event_driven_tpdo_sends_the_current_data() {
    // CiA 310 case 3.3.
    let mut node = Node::operational(ms(0));
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(node.rtr(ms(5), 0x181));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(!node.rtr(ms(5), 0x182), "not a TPDO");
    // COB-ID bit 30: no RTR.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Ok(()));
    node.poll(ms(6));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(!node.rtr(ms(7), 0x181));
    tx!(node, []);
}

// ---- TPDO type 0: synchronous acyclic ---------------------------------------------

#[test]
fn acyclic_synchronous_tpdo_sends_on_the_sync_after_an_event() {
    // CiA 310 cases 3.7, 3.13.
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 0);
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.sync(sync_at(ms(10), None));
    tx!(node, [(0x281, [0])]);
    node.sync(sync_at(ms(20), None));
    tx!(node, []);
    node.set(0x2000, 0, &[7]);
    node.poll(ms(25));
    tx!(node, [(0x181, [0, 0, 0, 0, 7])]);
    node.sync(sync_at(ms(30), None));
    tx!(node, [(0x281, [7])]);
    assert!(node.pdos.trigger(1));
    node.poll(ms(31));
    tx!(node, []);
    node.sync(sync_at(ms(40), None));
    tx!(node, [(0x281, [7])]);
    node.sync(sync_at(ms(50), None));
    tx!(node, []);
}

// ---- TPDO types 1..=240: synchronous cyclic ---------------------------------------

#[test]
fn cyclic_synchronous_tpdo_sends_every_nth_sync() {
    // CiA 310 cases 3.6, 3.12, 6.3.
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 3);
    assert_eq!(node.sdo(0x1801, 5, &10u16.to_le_bytes()), Ok(()), "no effect on a synchronous PDO");
    let mut sent = Vec::new();
    for i in 1..=7u8 {
        node.set(0x2000, 0, &[i]);
        node.sync(sync_at(ms(u32::from(i) * 10), None));
        assert_eq!(node.poll(ms(u32::from(i) * 10 + 5)), None);
        sent.extend(node.frames().into_iter().filter(|(id, _)| *id == 0x281));
    }
    assert_eq!(sent, vec![(0x281, vec![3]), (0x281, vec![6])]);
    assert!(!node.pdos.trigger(1), "type 3 has no application event");
    assert!(!node.rtr(ms(100), 0x281), "nor RTR");
}

#[test]
fn a_sync_reaches_the_tpdos_that_are_synchronous_and_valid_at_that_moment() {
    // The PDOs keep a mask of their synchronous TPDOs: every download of a
    // type or COB-ID must reach it.
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 1);
    node.set(0x2000, 0, &[7]);
    node.sync(sync_at(ms(10), None));
    tx!(node, [(0x281, [7])]);
    assert_eq!(node.sdo(0x1801, 2, &[254]), Ok(()));
    node.sync(sync_at(ms(20), None));
    tx!(node, []);
    assert_eq!(node.sdo(0x1801, 2, &[1]), Ok(()));
    node.sync(sync_at(ms(30), None));
    tx!(node, [(0x281, [7])]);
    assert_eq!(node.sdo32(0x1801, 1, 0x8000_0281), Ok(()));
    node.sync(sync_at(ms(40), None));
    tx!(node, []);
    assert_eq!(node.sdo32(0x1801, 1, 0x281), Ok(()));
    node.sync(sync_at(ms(50), None));
    tx!(node, [(0x281, [7])]);
}

#[test]
fn sync_start_value_makes_the_matching_sync_the_first() {
    // CiA 310 cases 3.8, 3.14: 0x1019 > 0 and sub 6 = 5.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 2);
    let mut sent = Vec::new();
    for (i, counter) in [3u8, 4, 5, 6, 7, 8, 9, 10, 1, 2].into_iter().enumerate() {
        node.set(0x2000, 0, &[counter]);
        node.sync(sync_at(ms(i as u32), Some(counter)));
        sent.extend(node.frames().into_iter().filter(|(id, _)| *id == 0x281).map(|(_, d)| d[0]));
    }
    assert_eq!(sent, [6, 8, 10, 2]);
    // Type 1: the start SYNC itself sends.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 1);
    node.frames();
    for counter in [3u8, 4, 5, 6] {
        node.set(0x2000, 0, &[counter]);
        node.sync(sync_at(ms(1), Some(counter)));
    }
    tx!(node, [(0x281, [5]), (0x281, [6])]);
}

#[test]
fn sync_start_value_is_ignored_without_a_sync_counter() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 2);
    node.frames();
    for i in 1..=4 {
        node.sync(sync_at(ms(i), None));
    }
    tx!(node, [(0x281, [0]), (0x281, [0])]);
}

// ---- TPDO types 252/253: RTR only -------------------------------------------------

#[test]
fn rtr_only_synchronous_tpdo_sends_the_sample_of_the_last_sync() {
    // CiA 310 case 3.15.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()), "TPDO1 quiet");
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 252);
    node.set(0x2000, 0, &[1]);
    assert!(node.rtr(ms(1), 0x281), "no sample yet: the current data");
    tx!(node, [(0x281, [1])]);
    node.set(0x2000, 0, &[2]);
    node.sync(sync_at(ms(10), None));
    tx!(node, []);
    node.set(0x2000, 0, &[3]);
    assert_eq!(node.poll(ms(11)), None);
    assert!(node.rtr(ms(12), 0x281));
    tx!(node, [(0x281, [2])]);
}

#[test]
fn a_tpdo_turned_from_252_to_253_forgets_its_sample() {
    // 252 and 253 answer an RTR on one path: the sample of the last SYNC,
    // else the data now. A new type starts the PDO over, sample included,
    // so 253 sends the data now, not what 252 sampled.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()), "TPDO1 quiet");
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 252);
    node.set(0x2000, 0, &[1]);
    node.sync(sync_at(ms(1), None));
    node.set(0x2000, 0, &[2]);
    assert!(node.rtr(ms(2), 0x281));
    tx!(node, [(0x281, [1])]);
    assert_eq!(node.sdo(0x1801, 2, &[253]), Ok(()));
    assert!(node.rtr(ms(3), 0x281));
    tx!(node, [(0x281, [2])]);
}

#[test]
fn rtr_only_event_driven_tpdo_sends_fresh_data_on_each_rtr() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()), "TPDO1 quiet");
    node.remap_tpdo(1, &[0x2000_0008, 0x2008_0110], 0x281, 253);
    node.set(0x2008, 1, &(-2i16).to_le_bytes());
    node.sync(sync_at(ms(1), None));
    assert_eq!(node.poll(ms(2)), None);
    tx!(node, []);
    assert!(node.rtr(ms(3), 0x281));
    node.set(0x2000, 0, &[4]);
    assert!(node.rtr(ms(4), 0x281));
    tx!(node, [(0x281, [0, 0xFE, 0xFF]), (0x281, [4, 0xFE, 0xFF])]);
}

// ---- Mapped sources ----------------------------------------------------------------

#[test]
fn a_tpdo_carries_constants_and_64_bit_values() {
    let mut node = Node::operational(ms(0));
    node.set(0x2004, 0, &0x0807_0605_0403_0201u64.to_le_bytes());
    node.remap_tpdo(1, &[0x2004_0040], 0x281, 254);
    node.remap_tpdo(0, &[0x2005_0020, 0x2000_0008], 0x181, 254);
    node.poll(ms(0));
    let mut frames = node.frames();
    frames.sort();
    assert_eq!(frames, vec![(0x181, vec![0x78, 0x56, 0x34, 0x12, 0]), (0x281, vec![1, 2, 3, 4, 5, 6, 7, 8])]);
}

#[test]
fn a_mapping_is_built_over_whatever_a_buffer_held_zeros_past_its_length() {
    // A queue slot holds an older frame's bytes: every byte past the mapping's length becomes 0.
    let mut node = Node::operational(ms(0));
    node.set(0x2008, 1, &[0xCD, 0xAB]);
    node.set(0x2000, 0, &[0x42]);
    for (entries, want_len, want) in [
        (&[0x2005_0020, 0x2000_0008][..], 5, [0x78, 0x56, 0x34, 0x12, 0x42, 0, 0, 0]),
        (&[0x2000_0008, 0x2008_0110, 0x2005_0020][..], 7, [0x42, 0xCD, 0xAB, 0x78, 0x56, 0x34, 0x12, 0]),
        (&[0x2000_0008][..], 1, [0x42, 0, 0, 0, 0, 0, 0, 0]),
    ] {
        node.remap_tpdo(0, entries, 0x181, 254);
        let mapping = node.pdos.tpdo(0).and_then(Tpdo::mapping).expect("resolved");
        let mut out = [0xAA; 8];
        let len = mapping.build(&node.image, &mut out);
        assert_eq!((len, out), (want_len, want), "{entries:08X?}");
    }
}

#[test]
fn an_rpdo_reaches_only_the_event_driven_tpdos_that_map_what_it_writes() {
    // RPDO1 writes 0x2001 and 0x2000; TPDO1 (event-driven) maps 0x2002 and 0x2000.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.pdos.reaches(0b1), 0b1);
    assert_eq!(node.pdos.reaches(0), 0);
    // 0x2003 (offset 149, 2 bytes) is in no TPDO; 0x2002 (145, 4 bytes) in TPDO1, also its last byte.
    assert_eq!(node.pdos.tpdos_mapping(149, 2), 0);
    assert_eq!((node.pdos.tpdos_mapping(145, 4), node.pdos.tpdos_mapping(148, 1)), (0b1, 0b1));
    // TPDO1 no longer maps 0x2000: RPDO1 cannot change it.
    node.remap_tpdo(0, &[0x2002_0020], 0x181, 255);
    assert_eq!(node.pdos.reaches(0b1), 0);
    // A synchronous TPDO does not look for changes: it reaches nothing either.
    node.remap_tpdo(0, &[0x2000_0008], 0x181, 1);
    assert_eq!((node.pdos.reaches(0b1), node.pdos.tpdos_mapping(142, 1)), (0, 0));
    node.remap_tpdo(0, &[0x2000_0008], 0x181, 254);
    assert_eq!(node.pdos.reaches(0b1), 0b1);
}

#[test]
fn the_tpdos_a_write_reaches_follow_a_new_mapping() {
    // 0x2002 (offset 145, 4 bytes) is in TPDO1; asked again, the answer is remembered.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.pdos.tpdos_mapping(145, 4), 0b1);
    assert_eq!(node.pdos.tpdos_mapping(145, 4), 0b1);
    // A new mapping: the same bytes reach what maps them now.
    node.remap_tpdo(0, &[0x2000_0008], 0x181, 255);
    assert_eq!(node.pdos.tpdos_mapping(145, 4), 0);
    node.remap_tpdo(1, &[0x2002_0020], 0x281, 255);
    assert_eq!(node.pdos.tpdos_mapping(145, 4), 0b10);
}

#[test]
fn a_poll_for_other_tpdos_leaves_a_changed_one_for_its_own_turn() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2002, 0, &[1, 2, 3, 4]);
    // Told that only TPDO2 may have changed, TPDO1 does not look.
    node.pdos.poll_changed(ms(1), 0b10, &node.image, &mut node.bus);
    tx!(node, []);
    node.pdos.poll_changed(ms(2), 0b1, &node.image, &mut node.bus);
    tx!(node, [(0x181, [1, 2, 3, 4, 0])]);
}

#[test]
fn the_deadline_a_poll_returns_is_the_one_a_walk_over_every_pdo_finds() {
    // The poll folds each PDO's deadline as it visits it (a TPDO it polls
    // is asked again after its poll); a walk after the poll, as
    // `Pdos::deadline` does when not settled, must find the same. Two
    // event-driven TPDOs with event timers (TPDO1 also with an inhibit
    // time) and an RPDO with an event timer, driven at random.
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &20u16.to_le_bytes()), Ok(()), "2 ms");
    assert_eq!(node.sdo(0x1800, 5, &7u16.to_le_bytes()), Ok(()), "7 ms");
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 255);
    assert_eq!(node.sdo(0x1801, 5, &3u16.to_le_bytes()), Ok(()), "3 ms");
    assert_eq!(node.sdo(0x1400, 5, &10u16.to_le_bytes()), Ok(()), "RPDO1: 10 ms");
    node.pdos.enter_operational(ms(0));
    let (mut t, mut seed, mut polls, mut sent) = (0u32, 0x2545_F491u32, 0, 0);
    for _ in 0..3000 {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        t += seed % 1500;
        match (seed >> 12) % 6 {
            0 => node.set(0x2000, 0, &[(seed >> 20) as u8 & 3]),
            1 => node.set(0x2002, 0, &(seed >> 20 & 1).to_le_bytes()),
            2 => assert!(node.rx(us(t), 0x201, &[1, 2, 3])),
            3 => node.bus.refuse = (seed >> 20) % 4 == 0,
            _ => {
                let marked = (seed >> 20) & 0b11;
                let returned = node.pdos.poll_changed(us(t), marked, &node.image, &mut node.bus);
                assert_eq!(returned, deadline_of(node.pdos.walk()), "poll at {t} µs, TPDOs {marked:#b} marked");
                assert_eq!(node.pdos.deadline(), returned);
                polls += 1;
            }
        }
        sent += node.frames().len();
        node.events();
    }
    assert!(polls > 800 && sent > 300, "{polls} polls, {sent} frames");
}
