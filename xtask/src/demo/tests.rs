//! The demo's own arithmetic and formatting; the script itself runs in `cargo xtask test`.

use super::*;
use canopen_core::frame::CanFrame;
use hal_host::decode::EXIT_ID;

fn rx(ms: u64, id: u16, data: &[u8]) -> LoggedFrame {
    LoggedFrame { at: Duration::from_millis(ms), direction: Direction::Received, frame: CanFrame::standard(id, data).unwrap() }
}

#[test]
fn heartbeat_intervals_skip_state_changes_restarts_and_boot_up() {
    let log = [
        rx(0, 0x77F, &[0x00]),
        rx(100, 0x77F, &[0x7F]),
        rx(210, 0x77F, &[0x7F]),
        rx(215, 0x1FF, &[0; 8]),
        // State change: an early heartbeat, not a period.
        rx(250, 0x77F, &[0x05]),
        rx(350, 0x77F, &[0x05]),
        // Another node.
        rx(360, 0x701, &[0x05]),
        rx(470, 0x77F, &[0x05]),
        // Position 8 is a restart (NMT command sent there).
        LoggedFrame { direction: Direction::Sent, ..rx(480, 0x000, &[0x01, 0x7F]) },
        rx(490, 0x77F, &[0x05]),
        rx(590, 0x77F, &[0x05]),
    ];
    assert_eq!(heartbeat_intervals(&log, 0x77F, &[8]), [110.0, 100.0, 120.0, 100.0]);
    assert_eq!(heartbeat_intervals(&log, 0x77F, &[]), [110.0, 100.0, 120.0, 20.0, 100.0]);
    assert_eq!(stats(&[110.0, 100.0, 120.0, 100.0]), (107.5, 100.0, 120.0));
    assert_eq!(stats(&[]), (0.0, 0.0, 0.0));
}

#[test]
fn trace_lines_in_candump_columns() {
    let plain = Style { on: false };
    let sdo = LoggedFrame { direction: Direction::Sent, ..rx(14, 0x67F, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]) };
    assert_eq!(
        trace_line(&sdo, "SDO upload request 0x1000:00 Device type", plain),
        "   0.014  ->       67F  [8]  40 00 10 00 00 00 00 00  SDO upload request 0x1000:00 Device type"
    );
    let exit = LoggedFrame {
        at: Duration::from_micros(3_274_400),
        direction: Direction::Sent,
        frame: CanFrame::extended(EXIT_ID, b"EXIT\x00").unwrap(),
    };
    assert_eq!(
        trace_line(&exit, "QEMU exit request (status 0)", plain),
        "   3.274  ->  1FFFFFFF  [5]  45 58 49 54 00           QEMU exit request (status 0)"
    );
    let guard = LoggedFrame { direction: Direction::Sent, frame: CanFrame::remote(0x77F, 1).unwrap(), ..sdo };
    assert_eq!(trace_line(&guard, "", plain), "   0.014  ->       77F  [1]  remote request           ");
    // Colours only when asked for; aborts and EMCY in red.
    let coloured = trace_line(&rx(1, 0x5FF, &[0x80, 0, 0x20, 0, 0, 0, 2, 6]), "SDO abort", Style { on: true });
    assert!(coloured.contains("\x1b[32m<-\x1b[0m") && coloured.ends_with("\x1b[31mSDO abort\x1b[0m"), "{coloured:?}");
}

#[test]
fn statusword_state_names_follow_cia_402_state_coding() {
    assert_eq!(pds_state(0x0250), "Switch on disabled");
    assert_eq!(pds_state(0x0231), "Ready to switch on");
    assert_eq!(pds_state(0x0233), "Switched on");
    assert_eq!(pds_state(0x1637), "Operation enabled");
    assert_eq!(pds_state(0x0617), "Quick stop active");
    assert_eq!(pds_state(0x021F), "Fault reaction active");
    assert_eq!(pds_state(0x0218), "Fault");
    assert_eq!(pds_state(0x0000), "Not ready to switch on");
}

#[test]
fn node_id_is_for_the_ec5000_demo_only() {
    let args = |device: &str, node_id| DemoArgs { connect: Some("127.0.0.1:1".into()), node_id, device: Some(device.into()) };
    assert!(args("ec5000", Some(5)).check().is_ok());
    assert!(args("sendix", None).check().is_ok());
    for device in ["sendix", "unitek-ds"] {
        let e = args(device, Some(5)).check().err().map(|e| (e.exit_code(), e.to_string()));
        assert!(e.as_ref().is_some_and(|(code, text)| *code == 2 && text.contains("is for the EC5000 demo")), "{device}: {e:?}");
    }
}

/// A bus where no node answers (a wrong node-id or address): the demo stops
/// after the boot-up it waited for, not after every step's waits (minutes).
#[test]
fn a_node_that_sends_no_boot_up_stops_the_demo() {
    let (server, _channels) = hal_host::slcan::SlcanServer::bind("127.0.0.1:0").expect("bind");
    let ec5000 = DemoArgs { connect: Some(server.local_addr().to_string()), node_id: Some(5), device: None };
    let sendix = DemoArgs { device: Some("sendix".into()), node_id: None, connect: ec5000.connect.clone() };
    let start = Instant::now();
    // Both at once on the one bus, each an adapter of its own: neither node is there.
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(|| demo(&ec5000));
        let b = s.spawn(|| demo(&sendix));
        (a.join().expect("ec5000 demo"), b.join().expect("sendix demo"))
    });
    assert!(a.as_ref().is_err_and(|e| e.contains("node 5 sent no boot-up")), "{a:?}");
    assert!(b.as_ref().is_err_and(|e| e.contains("node 63 sent no boot-up")), "{b:?}");
    assert!(start.elapsed() < BOOT_WAIT_CONNECTED + Duration::from_secs(3), "{:?}", start.elapsed());
}
