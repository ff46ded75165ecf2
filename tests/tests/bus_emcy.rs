//! EMCY after a bus-off, on the virtual bus at 1 Mbit/s. CiA 301 v4.2
//! §7.2.7 (EMCY, code 0x8140 "recovered from bus off"); ISO 11898-1
//! §12.1.4 (fault confinement).
//!
//! The board reports what its CAN controller saw through
//! `Node::controller_event` (here the test plays that board glue), and the
//! core raises the EMCY (`tests/tests/controller_events.rs` has every
//! event). The frames the node queued while bus-off stay in its mailboxes
//! and leave, in order, as soon as it is back.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::{ControllerEvent, NoApplication};
use common::net::{Net, bits, us};
use hal_host::bus::{BitRate, CRC_ERROR_DETECT_BITS, ERROR_FRAME_BITS, ErrorState, INTERMISSION_BITS, frame_bits};
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::master::UploadMode;
use hal_host::storage::MemStorage;

type Interop = Node<NoApplication, MemStorage>;

#[test]
fn heartbeat_waits_out_bus_off_and_the_board_raises_emcy_0x8140() {
    let mut net = Net::new("heartbeat_waits_out_bus_off_and_the_board_raises_emcy_0x8140", BitRate::MBIT_1);
    let m = net.add_master();
    let a = net.add_node(Interop::new(Ram::new(1), NoApplication, MemStorage::new(4096), 1, us(0)));
    net.run_until(us(1000));
    // Heartbeat every 100 ms from the download's receipt at 1117 µs.
    net.configure(m, 1, 0x1017, 0, &100u16.to_le_bytes());
    net.run_until(us(101_000));

    // A broken transceiver: every frame of node 1 fails its CRC check.
    let port = a.port;
    let fault = net.bus().corrupt_where(move |p, _| p == port);
    // The heartbeat of 101 117 µs is destroyed 3 bits after its CRC
    // sequence (46 bits after SOF), then an error frame and intermission:
    // an attempt every 66 µs, each adding 8 to the TEC.
    let heartbeat = CanFrame::standard(0x701, &[0x7F]).unwrap();
    let to_error = u64::from(frame_bits(&heartbeat).stuffed() + CRC_ERROR_DETECT_BITS);
    let attempt = to_error + u64::from(ERROR_FRAME_BITS + INTERMISSION_BITS);
    assert_eq!((to_error, attempt), (49, 66));
    let error = |n: u64| 101_117 + to_error + (n - 1) * attempt;
    // TEC 128 after the 16th error: error-passive.
    net.run_until(us(error(16) - 1));
    assert_eq!((net.bus().error_state(port), net.bus().error_counters(port)), (Some(ErrorState::Active), Some((120, 0))));
    net.run_until(us(error(16)));
    assert_eq!(net.bus().error_state(port), Some(ErrorState::Passive));
    // TEC 256 after the 32nd: bus-off, at 103 212 µs. The disturbance ends.
    let bus_off = error(32);
    assert_eq!(bus_off, 103_212);
    net.run_until(us(bus_off - 1));
    assert_eq!(net.bus().error_state(port), Some(ErrorState::Passive));
    net.run_until(us(bus_off));
    assert_eq!(net.bus().error_state(port), Some(ErrorState::BusOff));
    assert!(net.bus().remove_fault(fault));

    // Recovery: 128 × 11 recessive bits from the end of the 6-bit error flag.
    let recovered = bus_off + 6 + 128 * 11;
    net.run_until(us(recovered - 1));
    assert_eq!(net.bus().error_state(port), Some(ErrorState::BusOff));
    net.run_until(us(recovered));
    assert_eq!((net.bus().error_state(port), net.bus().error_counters(port)), (Some(ErrorState::Active), Some((0, 0))));
    // The board glue reports the recovery.
    net.node_mut::<Interop>(a).controller_event(ControllerEvent::BusOffRecovered, us(recovered));
    net.run_until(us(110_000));

    // The heartbeat, already in a mailbox, goes first; the EMCY follows
    // with error register 0x11 (generic + communication) and the count of
    // recoveries (1).
    let (hb_eof, _) = bits(0x701, &[0x7F]);
    let (emcy_eof, _) = bits(0x081, &[0x40, 0x81, 0x11, 1, 0, 0, 0, 0]);
    assert_eq!(recovered + hb_eof, 104_682);
    assert_eq!(104_682 + 3 + emcy_eof, 104_804);
    let expected = "\
(0000000000.104682) vcan0 701#7F
(0000000000.104804) vcan0 081#4081110100000000
";
    assert_eq!(net.candump_since(us(101_000)), expected);
    let stats = net.bus().stats();
    assert_eq!((stats.error_frames, net.bus().port_stats(port).unwrap().bus_off_count), (32, 1));
    assert_eq!(
        net.sdo_upload(m, 1, 0x1003, 1, UploadMode::ExpeditedOrSegmented),
        Ok(0x0001_8140u32.to_le_bytes().to_vec()),
        "code, and the low half of the count"
    );
}
