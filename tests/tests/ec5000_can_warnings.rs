//! The EC5000's CAN warnings (M §9.2, L1737-1743; D63): 0xFFD0 "Communication
//! Warning CAN bus" for a bus-off recovery, 0xFFD1 "Warning CAN overrun
//! (objects lost)" for frames lost in either direction, 0xFFD2 "Warning CAN in
//! passive mode" while the controller is error passive, 0xFFD3 "Warning
//! CANopen protocol" for an NMT command or heartbeat message the node cannot
//! parse. Class W: no fault reaction, nothing to acknowledge ("Warnungen
//! müssen nicht quittiert werden", §5.2); each clears by itself, with
//! "error reset" once no error is left. Exact EMCY frames at exact times,
//! the roller enabled in pv at rest.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::ControllerEvent;
use common::ec5000::*;
use common::ms;

/// Error register 0x91: generic, communication (CiA 301 bit 4: "overrun,
/// error state") and manufacturer-specific (the 0xFFxx code).
const REGISTER: u8 = 0x91;
const ERROR_RESET: [u8; 8] = [0; 8];

/// Reports `event` to the node at `t` ms; the EMCY frames it sends then.
fn report(b: &mut Ec5000, t: u64, event: ControllerEvent) -> Vec<Vec<u8>> {
    b.run_until(ms(t));
    b.node.controller_event(event, ms(t));
    b.at(ms(t)).into_iter().filter(|(id, _)| *id == EMCY).map(|(_, d)| d).collect()
}

/// A frame to the node at `t` ms; the EMCY frames it sends then.
fn receive(b: &mut Ec5000, t: u64, cob_id: u16, data: &[u8]) -> Vec<Vec<u8>> {
    b.run_until(ms(t));
    b.rx(ms(t), cob_id, data).into_iter().filter(|(id, _)| *id == EMCY).map(|(_, d)| d).collect()
}

#[test]
fn m_l1737_a_bus_off_recovery_is_warning_0xffd0_for_a_quiet_second() {
    let mut b = enabled();
    // Bytes 3-6: recoveries since power-on (the core's count, D54's manufacturer bytes).
    assert_eq!(report(&mut b, 1000, ControllerEvent::BusOffRecovered), [vec![0xD0, 0xFF, REGISTER, 1, 0, 0, 0, 0]]);
    // TPDO1 carries the error register (byte 3) beside the statusword: at once,
    // and again when "error reset" clears it 1 s after the recovery.
    assert_eq!(
        frames(&mut b, 1000, 1500),
        [
            (0, TPDO1, vec![0x37, 0x16, 3, REGISTER, 25, 0, 0, 0]),
            (1000, EMCY, ERROR_RESET.to_vec()),
            (1001, TPDO1, vec![0x37, 0x16, 3, 0, 25, 0, 0, 0])
        ]
    );
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0xD0, 0xFF, 1, 0]), "history: the code, then bytes 3-4");
    // A warning: the drive stayed enabled (0x6007 = 0), statusword 0x1637 throughout.
    assert_eq!(statusword(&mut b), 0x1637);
    // The next one counts on.
    assert_eq!(report(&mut b, 3000, ControllerEvent::BusOffRecovered), [vec![0xD0, 0xFF, REGISTER, 2, 0, 0, 0, 0]]);
}

#[test]
fn m_l1739_lost_frames_are_warning_0xffd1_until_none_is_lost_for_a_second() {
    let mut b = enabled();
    // Received frames lost: bytes 3-6 the count so far, byte 7 = 0 (receive).
    assert_eq!(report(&mut b, 1000, ControllerEvent::RxOverrun { lost: 3 }), [vec![0xD1, 0xFF, REGISTER, 3, 0, 0, 0, 0]]);
    // Active already: nothing new, but held a second from this loss.
    assert_eq!(report(&mut b, 1500, ControllerEvent::RxOverrun { lost: 2 }), Vec::<Vec<u8>>::new());
    assert_eq!(emcy(&mut b, 1500, 1500), [(1000, ERROR_RESET.to_vec())], "at 2500 ms");
    assert_eq!(report(&mut b, 3100, ControllerEvent::RxOverrun { lost: 1 }), [vec![0xD1, 0xFF, REGISTER, 6, 0, 0, 0, 0]]);
}

#[test]
fn m_l1739_frames_the_transmit_queue_refused_are_warning_0xffd1_too() {
    let mut b = enabled();
    b.run_until(ms(1000));
    // 40 SYNCs with no frame taken off the node: TPDO3 (synchronous) each time,
    // more than the transmit queue holds.
    let mut refused = 0;
    for i in 0..40 {
        let t = ms(1000) + canopen_core::time::Duration::from_micros(i * 100);
        b.node.on_frame(t, &CanFrame::standard(0x080, &[]).expect("SYNC"));
        b.node.process(t);
        // The process that first found frames refused raised the warning.
        if refused == 0 {
            refused = b.node.tx_overflows();
        }
    }
    assert!(refused > 0, "the queue overflowed");
    assert_eq!(b.at(ms(1004)).len(), 32, "a full queue of TPDO3s");
    // Then the warning (bytes 3-6: frames refused, byte 7 = 1: transmit), and
    // "error reset" once the queue has drained.
    let [r0, r1, r2, r3] = refused.to_le_bytes();
    assert_eq!(emcy(&mut b, 1004, 10), [(0, vec![0xD1, 0xFF, REGISTER, r0, r1, r2, r3, 1]), (0, ERROR_RESET.to_vec())]);
}

#[test]
fn m_l1741_error_passive_is_warning_0xffd2_while_it_lasts() {
    let mut b = enabled();
    assert_eq!(report(&mut b, 1000, ControllerEvent::ErrorPassive), [vec![0xD2, 0xFF, REGISTER, 0, 0, 0, 0, 0]]);
    assert_eq!(report(&mut b, 1100, ControllerEvent::ErrorPassive), Vec::<Vec<u8>>::new(), "still the same warning");
    assert_eq!(emcy(&mut b, 1100, 3000), [], "a state: no time limit");
    assert_eq!(report(&mut b, 5000, ControllerEvent::ErrorActive), [ERROR_RESET.to_vec()]);
}

#[test]
fn m_l1743_a_broken_nmt_or_heartbeat_frame_is_warning_0xffd3_for_a_quiet_second() {
    let mut b = enabled();
    // NMT with one byte (CiA 301: two), counted and ignored: the node stays Operational.
    assert_eq!(receive(&mut b, 1000, 0x000, &[0x02]), [vec![0xD3, 0xFF, REGISTER, 0, 0, 0, 0, 0]]);
    assert_eq!(b.node.counters().malformed, 1);
    // A heartbeat of node 1 with two bytes, and one with an unknown state (0x01): held on.
    assert_eq!(receive(&mut b, 1400, 0x701, &[0x05, 0x00]), Vec::<Vec<u8>>::new());
    assert_eq!(receive(&mut b, 1500, 0x701, &[0x01]), Vec::<Vec<u8>>::new());
    assert_eq!(emcy(&mut b, 1500, 1500), [(1000, ERROR_RESET.to_vec())], "at 2500 ms");
    // A good NMT command and heartbeat are no warning.
    assert_eq!(receive(&mut b, 3000, 0x701, &[0x05]), Vec::<Vec<u8>>::new());
    assert_eq!(receive(&mut b, 3100, 0x000, &[0x01, 0x00]), Vec::<Vec<u8>>::new());
    assert_eq!(statusword(&mut b) & 0x6F, 0x27, "Operation enabled throughout");
}

#[test]
fn the_warnings_stack_and_error_reset_follows_the_last() {
    let mut b = enabled();
    assert_eq!(report(&mut b, 1000, ControllerEvent::ErrorPassive), [vec![0xD2, 0xFF, REGISTER, 0, 0, 0, 0, 0]]);
    assert_eq!(report(&mut b, 1200, ControllerEvent::RxOverrun { lost: 1 }), [vec![0xD1, 0xFF, REGISTER, 1, 0, 0, 0, 0]]);
    // The overrun clears at 2200 ms while error passive lasts: no "error reset" yet.
    assert_eq!(emcy(&mut b, 1200, 1800), []);
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![REGISTER]));
    assert_eq!(report(&mut b, 3000, ControllerEvent::ErrorActive), [ERROR_RESET.to_vec()]);
}

#[test]
fn m_l1741_an_rpdo_too_long_is_0x8210_like_one_too_short_d64() {
    // RPDO3 maps 0x6040 and 0x60FF: 6 bytes. The manual's one code for a PDO
    // of the wrong length, "PDO not processed, length error", in place of
    // CiA 301's 0x8220 for a long one (D64); byte 3 is the RPDO's number.
    let mut long = enabled();
    let sent = receive(&mut long, 1000, RPDO3, &[0x0F, 0, 0, 0, 0, 0, 0xAA, 0xBB]);
    let mut short = enabled();
    assert_eq!(sent, receive(&mut short, 1000, RPDO3, &[0x0F, 0, 0]));
    // Error register 0x11: generic and communication.
    assert_eq!(sent, [vec![0x10, 0x82, 0x11, 3, 0, 0, 0, 0]]);
    // The right length ends it in both: "error reset" or the next error's frame.
    let ended = receive(&mut long, 2000, RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    assert_eq!(ended, receive(&mut short, 2000, RPDO3, &[0x0F, 0, 0, 0, 0, 0]));
}
