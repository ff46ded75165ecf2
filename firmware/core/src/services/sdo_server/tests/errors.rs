//! Aborts, protocol errors, timeouts, malformed frames, TX back-pressure.

use super::*;

// ---------------------------------------------------------------------------
// Aborts and protocol errors
// ---------------------------------------------------------------------------

#[test]
fn unknown_command_specifier_is_aborted_and_counted() {
    // CCT 2.7.
    let mut t = Sdo::new();
    t.x(ms(0), "E0 00 10 00 00 00 00 00", "80 00 10 00 01 00 04 05");
    assert_eq!(t.server.malformed(), 1);
    // A request that fits no transfer in progress.
    t.x(ms(1), "60 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05");
    t.x(ms(1), "A1 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05");
    // During a transfer: the abort names the transfer's object.
    t.x(ms(2), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.x(ms(3), "F0 17 10 00 00 00 00 00", "80 10 20 00 01 00 04 05");
    t.done(ms(3));
    assert_eq!(t.server.malformed(), 2);
}

#[test]
fn a_request_of_another_transfer_is_refused_for_the_one_in_progress() {
    // Each request outside an initiate belongs to one kind of transfer:
    // during another kind it ends that transfer with 0x05040001 for its
    // object, while idle it is refused for no object.
    let others = [
        (
            "40 10 20 00 00 00 00 00",
            "41 10 20 00 78 00 00 00",
            ["00 41 42 43 44 45 46 47", "C1 00 00 00 00 00 00 00", "A3 00 00 00 00 00 00 00"],
        ),
        (
            "21 10 20 00 78 00 00 00",
            "60 10 20 00 00 00 00 00",
            ["60 00 00 00 00 00 00 00", "C1 00 00 00 00 00 00 00", "A2 01 05 00 00 00 00 00"],
        ),
        (
            "A4 10 20 00 7F 00 00 00",
            "C6 10 20 00 78 00 00 00",
            ["00 41 42 43 44 45 46 47", "60 00 00 00 00 00 00 00", "C1 00 00 00 00 00 00 00"],
        ),
    ];
    for (initiate, answer, requests) in others {
        for request in requests {
            let mut t = Sdo::new();
            t.x(ms(0), initiate, answer);
            t.x(ms(1), request, "80 10 20 00 01 00 04 05");
            t.done(ms(1));
            t.x(ms(2), request, "80 00 00 00 01 00 04 05");
            t.done(ms(2));
            assert_eq!(t.server.malformed(), 0, "{request}");
        }
    }
    // A block download waiting for its end request takes nothing else.
    for request in ["00 41 42 43 44 45 46 47", "60 00 00 00 00 00 00 00", "A1 00 00 00 00 00 00 00"] {
        let mut t = Sdo::new();
        t.x(ms(0), "C6 10 20 00 02 00 00 00", "A4 10 20 00 13 00 00 00");
        t.x(ms(1), "81 61 62 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
        t.x(ms(2), request, "80 10 20 00 01 00 04 05");
        t.done(ms(2));
    }
}

#[test]
fn abort_from_the_client_ends_the_transfer_silently() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.rx(ms(1), "80 10 20 00 00 00 04 05");
    t.done(ms(1));
    // An abort with nothing in progress is ignored as well.
    t.rx(ms(2), "80 00 00 00 00 00 00 08");
    t.done(ms(2));
}

#[test]
fn a_new_initiate_while_busy_replaces_the_transfer() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.x(ms(1), "60 00 00 00 00 00 00 00", "00 41 42 43 44 45 46 47");
    // The client gives up and reads 0x1000: answered, the old upload is gone.
    t.x(ms(2), "40 00 10 00 00 00 00 00", "43 00 10 00 92 01 02 00");
    t.x(ms(3), "70 00 00 00 00 00 00 00", "80 00 00 00 01 00 04 05");
    // Likewise from a block upload (not from a block download sub-block,
    // whose frames are all segments).
    t.x(ms(4), "A4 10 20 00 7F 00 00 00", "C6 10 20 00 78 00 00 00");
    t.x(ms(5), "21 17 10 00 02 00 00 00", "60 17 10 00 00 00 00 00");
    t.x(ms(6), "0B 10 00 00 00 00 00 00", "20 00 00 00 00 00 00 00");
    t.done(ms(6));
    assert_eq!(t.value(0x1017, 0), [0x10, 0x00]);
}

#[test]
fn errors_of_the_application_pass_through_as_abort_codes() {
    let codes = [
        (AbortCode::UnsupportedAccess, "00 00 01 06"),
        (AbortCode::NoObject, "00 00 02 06"),
        (AbortCode::NoSubIndex, "11 00 09 06"),
        (AbortCode::WriteOnly, "01 00 01 06"),
        (AbortCode::ReadOnly, "02 00 01 06"),
        (AbortCode::ParameterIncompatible, "43 00 04 06"),
        (AbortCode::InternalIncompatible, "47 00 04 06"),
        (AbortCode::Hardware, "00 00 06 06"),
        (AbortCode::LengthMismatch, "10 00 07 06"),
        (AbortCode::LengthTooHigh, "12 00 07 06"),
        (AbortCode::LengthTooLow, "13 00 07 06"),
        (AbortCode::InvalidValue, "30 00 09 06"),
        (AbortCode::ValueTooHigh, "31 00 09 06"),
        (AbortCode::ValueTooLow, "32 00 09 06"),
        (AbortCode::MaxBelowMin, "36 00 09 06"),
        (AbortCode::NoResource, "23 00 0A 06"),
        (AbortCode::General, "00 00 00 08"),
        (AbortCode::CannotStore, "20 00 00 08"),
        (AbortCode::LocalControl, "21 00 00 08"),
        (AbortCode::DeviceState, "22 00 00 08"),
        (AbortCode::NoDictionary, "23 00 00 08"),
        (AbortCode::NoData, "24 00 00 08"),
    ];
    let mut t = Sdo::new();
    for (code, bytes) in codes {
        // Expedited download.
        t.write_error = Some(code);
        t.x(ms(0), "23 04 20 00 01 02 03 04", &format!("80 04 20 00 {bytes}"));
        // Segmented download, at its last segment.
        t.x(ms(0), "21 04 20 00 04 00 00 00", "60 04 20 00 00 00 00 00");
        t.x(ms(0), "07 01 02 03 04 00 00 00", &format!("80 04 20 00 {bytes}"));
        t.write_error = None;
        // Expedited upload and a segmented upload in progress.
        t.read_error = Some(code);
        t.x(ms(0), "40 04 20 00 00 00 00 00", &format!("80 04 20 00 {bytes}"));
        t.read_error = None;
        t.x(ms(0), "40 11 20 00 00 00 00 00", "41 11 20 00 0A 00 00 00");
        t.read_error = Some(code);
        t.x(ms(0), "60 00 00 00 00 00 00 00", &format!("80 11 20 00 {bytes}"));
        t.read_error = None;
    }
    t.done(ms(0));
    assert_eq!(t.image, DEFAULTS);
}

#[test]
fn every_abort_code_the_server_itself_produces() {
    // The others come from the dictionary (see the pass-through test above).
    let mut t = Test::<16>::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.x(ms(0), "70 00 00 00 00 00 00 00", "80 10 20 00 00 00 03 05"); // toggle bit not alternated
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.poll(ms(1000));
    t.tx("80 10 20 00 00 00 04 05"); // SDO protocol timed out
    t.x(ms(1000), "E5 10 20 00 00 00 00 00", "80 10 20 00 01 00 04 05"); // command specifier not valid or unknown
    t.x(ms(1000), "A4 10 20 00 80 00 00 00", "80 10 20 00 02 00 04 05"); // invalid block size
    t.x(ms(1000), "C6 17 10 00 02 00 00 00", "A4 17 10 00 03 00 00 00");
    t.x(ms(1000), "04 D0 07 00 00 00 00 00", "80 17 10 00 03 00 04 05"); // invalid sequence number
    t.x(ms(1000), "C6 17 10 00 02 00 00 00", "A4 17 10 00 03 00 00 00");
    t.x(ms(1000), "81 D0 07 00 00 00 00 00", "A2 01 02 00 00 00 00 00");
    t.x(ms(1000), "D5 00 00 00 00 00 00 00", "80 17 10 00 04 00 04 05"); // CRC error
    t.x(ms(1000), "21 10 20 00 11 00 00 00", "80 10 20 00 05 00 04 05"); // out of memory
    t.x(ms(1000), "21 11 20 00 03 00 00 00", "60 11 20 00 00 00 00 00");
    t.x(ms(1000), "07 01 02 03 04 00 00 00", "80 11 20 00 12 00 07 06"); // more data than the size indicated
    t.x(ms(1000), "21 11 20 00 03 00 00 00", "60 11 20 00 00 00 00 00");
    t.x(ms(1000), "0B 01 02 00 00 00 00 00", "80 11 20 00 13 00 07 06"); // less data than the size indicated
    t.done(ms(1000));
    assert_eq!(t.image, DEFAULTS);
}

// ---------------------------------------------------------------------------
// Timeouts
// ---------------------------------------------------------------------------

#[test]
fn timeout_aborts_at_exactly_the_timeout() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    assert_eq!(t.poll(999_999), Some(ms(1000)));
    t.none();
    assert_eq!(t.poll(ms(1000)), None);
    t.tx("80 10 20 00 00 00 04 05");
    t.done(ms(1000));
}

#[test]
fn timeout_restarts_with_every_frame_and_can_be_set() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.x(ms(600), "60 00 00 00 00 00 00 00", "00 41 42 43 44 45 46 47");
    assert_eq!(t.poll(ms(1599)), Some(ms(1600)));
    t.none();
    t.server.set_timeout(Duration::from_millis(50));
    t.x(ms(1599), "70 00 00 00 00 00 00 00", "10 48 49 4A 4B 4C 4D 4E");
    assert_eq!(t.poll(ms(1648)), Some(ms(1649)));
    assert_eq!(t.poll(ms(1649)), None);
    t.tx("80 10 20 00 00 00 04 05");
    t.done(ms(1649));
}

#[test]
fn a_zero_timeout_is_1_us_and_a_long_one_stops_at_the_longest_span() {
    let mut t = Sdo::new();
    t.server.set_timeout(Duration::ZERO);
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    assert_eq!(t.poll(ms(0)), Some(1));
    assert_eq!(t.poll(1), None);
    t.tx("80 10 20 00 00 00 04 05");
    t.done(1);
    let longest = crate::time::MAX_SPAN;
    t.server.set_timeout(Duration::from_secs(86_400));
    t.x(ms(10), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    assert_eq!(t.poll(ms(10)), Some(ms(10) + longest));
    t.server.set_timeout(Duration::from_micros(u64::from(longest)));
    t.x(ms(20), "60 00 00 00 00 00 00 00", "00 41 42 43 44 45 46 47");
    assert_eq!(t.poll(ms(20)), Some(ms(20) + longest));
    assert_eq!(t.poll(ms(20) + longest), None);
    t.tx("80 10 20 00 00 00 04 05");
    t.done(ms(20) + longest);
}

#[test]
fn timeout_found_by_a_late_frame_answers_only_once() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    // No poll: the segment request itself arrives at the deadline.
    t.x(ms(1000), "60 00 00 00 00 00 00 00", "80 10 20 00 00 00 04 05");
    t.done(ms(1000));
    // A late initiate is still served after the abort.
    t.x(ms(2000), "21 17 10 00 02 00 00 00", "60 17 10 00 00 00 00 00");
    t.rx(ms(3000), "40 00 10 00 00 00 00 00");
    t.tx("80 17 10 00 00 00 04 05");
    t.tx("43 00 10 00 92 01 02 00");
    t.done(ms(3000));
}

#[test]
fn timeout_in_block_transfers() {
    let mut t = Sdo::new();
    // Download: the last segment of the block never comes.
    t.x(ms(0), "C6 10 20 00 78 00 00 00", "A4 10 20 00 13 00 00 00");
    t.rx(ms(10), "01 61 62 63 64 65 66 67");
    assert_eq!(t.poll(ms(10)), Some(ms(1010)));
    assert_eq!(t.poll(ms(1010)), None);
    t.tx("80 10 20 00 00 00 04 05");
    // Upload: the ack never comes; timed from the last segment sent.
    t.x(ms(2000), "A4 08 10 00 7F 00 00 00", "C6 08 10 00 06 00 00 00");
    t.rx(ms(2001), "A3 00 00 00 00 00 00 00");
    assert_eq!(t.poll(ms(2005)), Some(ms(3005)));
    t.tx("81 64 65 76 69 63 65 00");
    assert_eq!(t.poll(ms(3004)), Some(ms(3005)));
    t.none();
    t.poll(ms(3005));
    t.tx("80 08 10 00 00 00 04 05");
    t.done(ms(3005));
}

// ---------------------------------------------------------------------------
// Malformed frames, a full TX queue, reset
// ---------------------------------------------------------------------------

#[test]
fn frames_without_8_bytes_are_counted_and_ignored() {
    let mut t = Sdo::new();
    let read = hex("40 00 10 00 00 00 00 00");
    for len in 0..8 {
        t.rx_bytes(ms(0), &read[..len]);
    }
    t.rx_bytes(ms(0), &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0, 0]);
    t.done(ms(0));
    assert_eq!(t.server.malformed(), 9);
    // In a block download sub-block too, without disturbing it.
    t.x(ms(1), "C6 17 10 00 02 00 00 00", "A4 17 10 00 13 00 00 00");
    t.rx(ms(2), "81 D0 07");
    t.none();
    t.rx_bytes(ms(2), &[0x81, 0xD0, 0x07, 0, 0, 0, 0, 0, 0]); // 9 bytes, and none
    t.none();
    t.rx_bytes(ms(2), &[]);
    t.none();
    t.x(ms(3), "81 D0 07 00 00 00 00 00", "A2 01 12 00 00 00 00 00");
    t.rx(ms(4), "D5 C0 65 00 00 00 00");
    t.none();
    t.x(ms(5), "D5 C0 65 00 00 00 00 00", "A1 00 00 00 00 00 00 00");
    t.done(ms(5));
    assert_eq!(t.value(0x1017, 0), [0xD0, 0x07]);
    assert_eq!(t.server.malformed(), 13);
}

#[test]
fn a_response_the_tx_queue_refuses_goes_out_on_the_next_poll() {
    let mut t = Sdo::new();
    t.bus.room = 0;
    t.rx(ms(0), "40 00 10 00 00 00 00 00");
    t.none();
    assert!(!t.server.is_idle());
    assert_eq!(t.poll(ms(1)), Some(ms(1)));
    t.none();
    t.bus.room = usize::MAX;
    assert_eq!(t.poll(ms(2)), None);
    t.tx("43 00 10 00 92 01 02 00");
    t.done(ms(2));
    // A timeout abort waits for room the same way.
    t.x(ms(10), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.bus.room = 0;
    assert_eq!(t.poll(ms(1010)), Some(ms(1010)));
    t.bus.room = usize::MAX;
    assert_eq!(t.poll(ms(1011)), None);
    t.tx("80 10 20 00 00 00 04 05");
    t.done(ms(1011));
}

#[test]
fn reset_drops_the_transfer_silently() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.server.reset();
    t.done(ms(0));
    assert_eq!(t.poll(ms(5000)), None);
    t.none();
}

#[test]
fn without_block_transfer_its_requests_are_unknown_commands() {
    // A node without block SDO (`block` false, as ds301-lean): each block
    // request is refused with 0x05040001 and counted, for its own object
    // if it would start a transfer, else for none; a segment request of no
    // transfer is refused for no object and not counted.
    for quick in [false, true] {
        let mut servers: SdoServers<128, 1> = SdoServers::new();
        let mut image = DEFAULTS;
        let mut bus = Bus { frames: VecDeque::new(), room: usize::MAX };
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image: &mut image }, read_error: None, write_error: None };
        let exchanges = [
            ("A0 18 10 01 7F 00 00 00", "80 18 10 01 01 00 04 05", 1),
            ("A3 18 10 01 00 00 00 00", "80 00 00 00 01 00 04 05", 2),
            ("C2 18 10 01 04 00 00 00", "80 18 10 01 01 00 04 05", 3),
            ("C1 18 10 01 00 00 00 00", "80 00 00 00 01 00 04 05", 4),
            ("00 18 10 01 00 00 00 00", "80 00 00 00 01 00 04 05", 4),
            ("60 18 10 01 00 00 00 00", "80 00 00 00 01 00 04 05", 4),
            ("E0 18 10 01 00 00 00 00", "80 18 10 01 01 00 04 05", 5),
        ];
        for (request, response, malformed) in exchanges {
            servers.on_request_with(0, ms(0), &hex(request), false, quick, &mut od, &mut bus);
            assert_eq!(bus.frames.drain(..).map(|f| show(&f)).collect::<Vec<_>>(), [show(&hex(response))], "{request}");
            assert_eq!(servers.malformed(0), malformed, "{request}");
        }
        assert!(servers.is_idle(0));
    }
}
