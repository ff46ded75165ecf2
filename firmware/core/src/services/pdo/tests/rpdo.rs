//! RPDOs (event-driven and synchronous, lengths, timeout, dummy entries)
//! and the synchronous window (0x1007).

use super::*;

// ---- RPDOs ----------------------------------------------------------------------------

#[test]
fn event_driven_rpdo_writes_at_once() {
    let mut node = Node::operational(ms(0));
    assert!(node.rx(ms(1), 0x201, &[0x34, 0x12, 0x56]));
    assert_eq!((node.get(0x2001, 0), node.get(0x2000, 0)), (vec![0x34, 0x12], vec![0x56]));
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
    assert!(!node.rx(ms(1), 0x301, &[1]), "RPDO2 maps nothing: disabled");
    assert!(!node.rx(ms(1), 0x202, &[1, 2, 3]));
    assert_eq!(node.events(), []);
}

#[test]
fn a_received_rpdo_names_the_tpdos_its_data_reaches_as_the_general_path_does() {
    // The node marks what `on_frame_reaching` returns; the general path
    // asked `reaches` for the RPDOs the frame reported as received.
    let mut node = Node::new();
    assert_eq!(node.pdos.on_frame_reaching(ms(0), 0x201, &[1, 2, 3], &mut node.image, &mut node.bus), None, "not Operational");
    node.pdos.enter_operational(ms(0));
    let check = |node: &mut Node, cob_id: u16, data: &[u8], want: Option<u32>| {
        let got = node.pdos.on_frame_reaching(ms(1), cob_id, data, &mut node.image, &mut node.bus);
        let received = node.events().iter().fold(0, |m, e| if let PdoEvent::Received(n) = e { m | 1 << n } else { m });
        assert_eq!(got, want, "{cob_id:#X} {data:?}");
        if got.is_some() {
            assert_eq!(got, Some(node.pdos.reaches(received)), "{cob_id:#X} {data:?}: as `reaches` of the received RPDOs");
        }
    };
    // RPDO1 writes 0x2000, which the event-driven TPDO1 maps.
    check(&mut node, 0x201, &[1, 2, 3], Some(0b1));
    // Too short: nothing written, nothing reached.
    check(&mut node, 0x201, &[1, 2], Some(0));
    check(&mut node, 0x202, &[1, 2, 3], None);
    // TPDO1 synchronous: no change detection, so RPDO1 reaches no TPDO.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 2, &[1]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    check(&mut node, 0x201, &[1, 2, 3], Some(0));
    // RPDO1 synchronous: its data waits for the SYNC.
    node.pdos.on_sync(&sync_at(ms(2), None), &mut node.image, &mut node.bus);
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()));
    check(&mut node, 0x201, &[4, 5, 6], Some(0));
}

#[test]
fn rpdo_length_errors() {
    let mut node = Node::operational(ms(0));
    // Shorter than mapped: not processed; each frame is an error (the node sends its EMCY 0x8210 once).
    assert!(node.rx(ms(1), 0x201, &[1, 2]));
    assert!(node.rx(ms(2), 0x201, &[]));
    assert_eq!(node.get(0x2001, 0), [0, 0]);
    assert_eq!(
        node.events(),
        [PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH }, PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH }]
    );
    // The right length ends it.
    assert!(node.rx(ms(3), 0x201, &[1, 2, 3]));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode(0x8210) }, PdoEvent::Received(0)]);
    // Longer: the mapped bytes are processed, EMCY 0x8220.
    assert!(node.rx(ms(4), 0x201, &[4, 5, 6, 7, 8, 9, 10, 11]));
    assert_eq!(node.get(0x2001, 0), [4, 5]);
    assert_eq!(node.get(0x2000, 0), [6]);
    assert!(node.rx(ms(5), 0x201, &[4, 5, 6, 7]));
    assert!(node.rx(ms(6), 0x201, &[7]));
    assert!(node.rx(ms(7), 0x201, &[1, 2, 3]));
    assert_eq!(
        node.events(),
        [
            PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH_EXCEEDED },
            PdoEvent::Received(0),
            PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH_EXCEEDED },
            PdoEvent::Received(0),
            PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode(0x8220) },
            PdoEvent::Error { rpdo: 0, code: EmcyCode(0x8210) },
            PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode(0x8210) },
            PdoEvent::Received(0),
        ]
    );
}

#[test]
fn synchronous_rpdo_is_written_on_the_next_sync() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()), "the type may change while valid");
    assert!(node.rx(ms(1), 0x201, &[1, 0, 2]));
    assert!(node.rx(ms(2), 0x201, &[3, 0, 4]));
    assert!(node.pdos.rpdo(0).unwrap().has_buffered());
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0], vec![]));
    node.sync(sync_at(ms(10), None));
    assert_eq!((node.get(0x2001, 0), node.get(0x2000, 0)), (vec![3, 0], vec![4]), "the last one");
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
    node.sync(sync_at(ms(20), None));
    assert_eq!(node.events(), []);
}

#[test]
fn configure_forgets_raised_errors_but_keeps_change_detection() {
    let mut node = Node::operational(ms(0));
    node.pdos.set_change_detection(0, false);
    assert!(node.rx(ms(1), 0x201, &[1]));
    assert_eq!(node.events(), [PdoEvent::Error { rpdo: 0, code: EmcyCode(0x8210) }]);
    assert_eq!(node.pdos.configure(&DICT, &node.image), Ok(()));
    node.pdos.enter_operational(ms(2));
    assert!(node.rx(ms(3), 0x201, &[1, 2, 3]));
    assert_eq!(node.events(), [PdoEvent::Received(0)], "no 0x8210 to clear after reset communication");
    assert!(!node.pdos.tpdo(0).unwrap().change_detection());
}

#[test]
fn rpdo_timeout_is_armed_by_the_first_rpdo() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 5, &50u16.to_le_bytes()), Ok(()));
    assert_eq!(node.poll(ms(1000)), None, "not armed before the first RPDO");
    node.frames();
    assert!(node.rx(ms(1000), 0x201, &[0, 0, 0]));
    node.events();
    assert_eq!(node.pdos.deadline(), Some(ms(1050)));
    assert!(node.rx(ms(1020), 0x201, &[0, 0, 0]));
    assert_eq!(node.poll(ms(1069)), Some(ms(1070)));
    node.events();
    assert_eq!(node.poll(ms(1070)), None);
    assert_eq!(node.events(), [PdoEvent::Error { rpdo: 0, code: EmcyCode::RPDO_TIMEOUT }]);
    assert_eq!(node.poll(ms(2000)), None);
    assert_eq!(node.events(), [], "raised once");
    assert!(node.rx(ms(2100), 0x201, &[0, 0, 0]));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode(0x8250) }, PdoEvent::Received(0)]);
    assert_eq!(node.pdos.deadline(), Some(ms(2150)));
    // A too-short RPDO does not count as received.
    assert!(node.rx(ms(2140), 0x201, &[0]));
    assert_eq!(node.pdos.deadline(), Some(ms(2150)));
}

#[test]
fn dummy_entries_skip_bytes_of_an_rpdo() {
    // CiA 310 case 3.33.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    for (sub, entry) in [(1, 0x2000_0008u32), (2, 0x0006_0010), (3, 0x0001_0008), (4, 0x2001_0010)] {
        assert_eq!(node.sdo32(0x1600, sub, entry), Ok(()));
    }
    assert_eq!(node.sdo(0x1600, 0, &[4]), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x201), Ok(()));
    assert!(node.rx(ms(1), 0x201, &[0xAA, 0xFF, 0xFF, 0xFF, 0x34, 0x12]));
    assert_eq!((node.get(0x2000, 0), node.get(0x2001, 0)), (vec![0xAA], vec![0x34, 0x12]));
}

// ---- The synchronous window (0x1007) ---------------------------------------------------

#[test]
fn synchronous_rpdos_after_the_window_are_discarded() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 2, &[0]), Ok(()));
    let window = |at| SyncEvent { at, counter: None, window_end: Far::after(at, 2000) };
    node.sync(window(ms(10)));
    assert!(node.rx(ms(12), 0x201, &[1, 0, 1]), "inside the window");
    node.sync(window(ms(20)));
    assert_eq!(node.get(0x2000, 0), [1]);
    assert!(node.rx(us(22_001), 0x201, &[2, 0, 2]), "after it");
    node.sync(window(ms(30)));
    assert_eq!(node.get(0x2000, 0), [1]);
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
}

#[test]
fn a_refused_synchronous_tpdo_is_retried_only_inside_the_window() {
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 1);
    node.poll(ms(0));
    node.frames();
    let window = |at| SyncEvent { at, counter: None, window_end: Far::after(at, 2000) };
    node.bus.refuse = true;
    node.sync(window(ms(10)));
    node.bus.refuse = false;
    assert_eq!(node.poll(ms(11)), None);
    tx!(node, [(0x281, [0])]);
    node.bus.refuse = true;
    node.sync(window(ms(20)));
    node.bus.refuse = false;
    node.poll(us(22_001));
    node.poll(ms(25));
    tx!(node, []);
}

// ---- The plain frame's path --------------------------------------------------------------

/// A frame as the node takes it: the plain path if it is the plain frame, the general one otherwise.
fn rx_plain_first(node: &mut Node, now: At, cob_id: u16, data: &[u8]) -> Option<u32> {
    if let Some((n, reached)) = node.pdos.on_plain_frame(cob_id, data, &mut node.image) {
        node.bus.received(n);
        return Some(reached);
    }
    node.pdos.on_frame_reaching(now, cob_id, data, &mut node.image, &mut node.bus)
}

#[test]
fn the_plain_path_follows_the_cob_id_the_type_the_timer_the_mapping_and_the_errors() {
    let mut node = Node::operational(ms(0));
    let rx = |node: &mut Node, cob_id: u16, data: &[u8]| rx_plain_first(node, ms(1), cob_id, data);
    assert_eq!(rx(&mut node, 0x201, &[1, 2, 3]), Some(0b1));
    assert_eq!((node.get(0x2001, 0), node.get(0x2000, 0), node.events()), (vec![1, 2], vec![3], vec![PdoEvent::Received(0)]));
    // Invalid (bit 31): no RPDO takes the frame.
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert_eq!(rx(&mut node, 0x201, &[4, 5, 6]), None);
    // Valid on another CAN-ID: only that one.
    assert_eq!(node.sdo32(0x1400, 1, 0x202), Ok(()));
    assert_eq!(rx(&mut node, 0x201, &[4, 5, 6]), None);
    assert_eq!(rx(&mut node, 0x202, &[4, 5, 6]), Some(0b1));
    assert_eq!((node.get(0x2001, 0), node.events()), (vec![4, 5], vec![PdoEvent::Received(0)]));
    // Too short: nothing written, EMCY 0x8210 with each frame, until a frame of the right length.
    assert_eq!(rx(&mut node, 0x202, &[7, 8]), Some(0));
    assert_eq!(rx(&mut node, 0x202, &[7, 8]), Some(0));
    assert_eq!(node.get(0x2001, 0), [4, 5]);
    let short = PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH };
    assert_eq!(node.events(), [short, short]);
    assert_eq!(rx(&mut node, 0x202, &[7, 8, 9]), Some(0b1));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode::PDO_LENGTH }, PdoEvent::Received(0)]);
    assert_eq!(rx(&mut node, 0x202, &[7, 8, 9]), Some(0b1));
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
    // A new mapping (0x2000 alone): a 1-byte frame is the right one, 3 bytes are too many.
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0202), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    assert_eq!(node.sdo32(0x1600, 1, 0x2000_0008), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[1]), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x202), Ok(()));
    assert_eq!(rx(&mut node, 0x202, &[0x11]), Some(0b1));
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0x11], vec![PdoEvent::Received(0)]));
    assert_eq!(rx(&mut node, 0x202, &[0x22, 0, 0]), Some(0b1));
    let long = PdoEvent::Error { rpdo: 0, code: EmcyCode::PDO_LENGTH_EXCEEDED };
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0x22], vec![long, PdoEvent::Received(0)]));
    assert_eq!(rx(&mut node, 0x202, &[0x33]), Some(0b1));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: EmcyCode::PDO_LENGTH_EXCEEDED }, PdoEvent::Received(0)]);
    // Mapping count 0 disables the RPDO while its frame arrives.
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0202), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x202), Ok(()));
    assert_eq!(rx(&mut node, 0x202, &[0x44]), None);
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0x33], vec![]));
    // Back to one entry; an event timer: the frame starts it (the general path).
    assert_eq!(node.sdo(0x1600, 0, &[1]), Err(AbortCode::UnsupportedAccess), "only while invalid");
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0202), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[1]), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x202), Ok(()));
    assert_eq!(node.sdo(0x1400, 5, &10u16.to_le_bytes()), Ok(()));
    assert_eq!(rx(&mut node, 0x202, &[0x55]), Some(0b1));
    assert_eq!(node.pdos.rpdos[0].timeout_at(), Some(ms(11)));
    // Synchronous: the data waits for the SYNC.
    assert_eq!(node.sdo(0x1400, 5, &0u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()));
    node.events();
    assert_eq!(rx(&mut node, 0x202, &[0x66]), Some(0));
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0x55], vec![]));
    node.sync(sync_at(ms(2), None));
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0x66], vec![PdoEvent::Received(0)]));
}

#[test]
fn the_plain_path_answers_as_the_general_path_does() {
    // Two nodes driven alike at random (frames of every length on the
    // RPDOs' and other COB-IDs, the RPDO's COB-ID, type, event timer and
    // mapping rewritten, SYNCs with a window, polls that time out): every
    // frame of one goes through `on_plain_frame` where it is the plain one
    // (as the node takes it), of the other through the general path alone. The
    // answers, the events, the images and the PDOs' state must stay equal.
    let (mut a, mut b) = (Node::operational(ms(0)), Node::operational(ms(0)));
    let (mut t, mut seed, mut plain) = (0u32, 0x9E37_79B9u32, 0);
    let mappings: [&[u32]; 4] = [&[0x2001_0010, 0x2000_0008], &[0x2000_0008], &[0x2004_0040], &[0x2000_0008, 0x0005_0008, 0x2008_0220]];
    for step in 0..20_000 {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        t += seed % 4000;
        let now = us(t);
        let arg = seed >> 8;
        for node in [&mut a, &mut b] {
            match seed % 64 {
                0 => {
                    let cob = if arg & 3 == 0 { 0x8000_0201 } else { 0x201 + (arg >> 2 & 1) };
                    let _ = node.sdo32(0x1400, 1, cob);
                }
                1 => {
                    let _ = node.sdo(0x1400, 2, &[[255, 254, 255, 1][(arg & 3) as usize]]);
                }
                2 => {
                    let _ = node.sdo(0x1400, 5, &[0u16, 0, 0, 20][(arg & 3) as usize].to_le_bytes());
                }
                3 => {
                    let entries = mappings[(arg & 3) as usize];
                    let cob = u32::from_le_bytes(node.get(0x1400, 1).try_into().unwrap());
                    let _ = node.sdo32(0x1400, 1, cob | COB_ID_INVALID);
                    let _ = node.sdo(0x1600, 0, &[0]);
                    for (sub, &entry) in (1u8..).zip(entries) {
                        let _ = node.sdo32(0x1600, sub, entry);
                    }
                    let _ = node.sdo(0x1600, 0, &[if arg & 4 == 0 { entries.len() as u8 } else { 0 }]);
                    let _ = node.sdo32(0x1400, 1, cob);
                }
                4 => {
                    let window_end = if arg & 1 == 0 { Far::after(now, u64::from(arg >> 1 & 0xFFF)) } else { Far::NEVER };
                    node.sync(SyncEvent { at: now, counter: None, window_end });
                }
                5 => {
                    node.poll(now);
                }
                _ => {}
            }
        }
        if seed % 64 >= 6 {
            let cob_id = [0x201, 0x202, 0x201, 0x301, 0x202, 0x181, 0x201, 0x202][(arg & 7) as usize];
            // Mostly the length RPDO1 maps.
            let mapped = a.pdos.rpdo(0).and_then(Rpdo::mapping).map_or(0, Mapping::len);
            let len = if arg & 0x30 != 0 { mapped } else { (arg >> 6) as usize % 10 };
            let data: Vec<u8> = (0..len.min(8)).map(|i| (arg >> i) as u8 ^ step as u8).collect();
            let data = if len == 9 { vec![0u8; 12] } else { data };
            plain += usize::from(a.pdos.rx_keys.contains(&frame_key(cob_id, data.len())));
            let got_a = rx_plain_first(&mut a, now, cob_id, &data);
            let got_b = b.pdos.on_frame_reaching(now, cob_id, &data, &mut b.image, &mut b.bus);
            assert_eq!(got_a, got_b, "step {step}: {cob_id:#X} {data:?}");
        }
        assert_eq!(a.events(), b.events(), "step {step}");
        assert_eq!(a.image, b.image, "step {step}");
        assert_eq!(format!("{:?}", a.pdos), format!("{:?}", b.pdos), "step {step}");
    }
    assert!(plain > 500, "the plain path was taken {plain} times");
}
