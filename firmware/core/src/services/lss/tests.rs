//! LSS slave: every service in both states with its exact answer, the
//! Sendix manual's sequence (seed 002 §5.7.6), and fastscan finding three
//! unconfigured slaves on one bus.

use super::*;
use crate::wire::lss::{AddressPart, LssRequest};

const ADDR: [u32; 4] = [0x13, 0x5868_2001, 0x66, 0x0001_E240];
/// Bits of the CiA 305 table the slave supports: 1M, 500k, 250k, 125k, 50k, 20k, 10k.
const RATES: u16 = 0b1_1101_1101;

fn req(r: LssRequest) -> [u8; 8] {
    r.emit()
}

fn send(s: &mut LssSlave, frame: [u8; 8]) -> LssAction {
    s.on_request(&frame)
}

fn ans(bytes: [u8; 8]) -> LssAction {
    let [cs, a, b, c, d, rest @ ..] = bytes;
    assert_eq!(rest, [0; 3], "an LSS answer's bytes 5-7 are 0");
    LssAction::Answer(LssAnswer { cs, data: u32::from_le_bytes([a, b, c, d]) })
}

// ---- The Sendix manual's sequence -----------------------------------------------

#[test]
fn sendix_manual_sequence() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    assert_eq!(send(&mut s, [0x04, 0x01, 0, 0, 0, 0, 0, 0]), LssAction::None);
    assert_eq!(s.mode(), Mode::Configuration);
    assert_eq!(send(&mut s, [0x5E, 0, 0, 0, 0, 0, 0, 0]), ans([0x5E, 0x3F, 0, 0, 0, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x11, 0x2A, 0, 0, 0, 0, 0, 0]), ans([0x11, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x13, 0x00, 0x04, 0, 0, 0, 0, 0]), ans([0x13, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x17, 0, 0, 0, 0, 0, 0, 0]), LssAction::Store { node_id: 0x2A, bit_rate: 4 });
    assert_eq!(LssSlave::store_result(true), [0x17, 0, 0, 0, 0, 0, 0, 0]);
    // Byte 2 of the manual's final frame is reserved and ignored.
    assert_eq!(send(&mut s, [0x04, 0x00, 0x04, 0, 0, 0, 0, 0]), LssAction::None);
    assert_eq!(s.mode(), Mode::Waiting);
    // Pending until reset communication (CiA 305 §5.2.2).
    assert_eq!(s.active_node_id(), 0x3F);
    assert_eq!(s.reset_communication(), 0x2A);
}

#[test]
fn configuration_error_codes() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    send(&mut s, req(LssRequest::SwitchGlobal(true)));
    for bad in [0x00, 0x80, 0xFE] {
        assert_eq!(send(&mut s, [0x11, bad, 0, 0, 0, 0, 0, 0]), ans([0x11, 1, 0, 0, 0, 0, 0, 0]), "node-id {bad:#x}");
    }
    assert_eq!(send(&mut s, [0x11, 0xFF, 0, 0, 0, 0, 0, 0]), ans([0x11, 0, 0, 0, 0, 0, 0, 0]), "0xFF = unconfigured");
    // Index 5 is reserved, 1 (800k) is not supported here, 9 is outside the table, table 1 is not the CiA table.
    for (table, index) in [(0, 5), (0, 1), (0, 9), (1, 0)] {
        assert_eq!(send(&mut s, [0x13, table, index, 0, 0, 0, 0, 0]), ans([0x13, 1, 0, 0, 0, 0, 0, 0]));
    }
    assert_eq!(LssSlave::store_result(false), [0x17, 2, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn configuration_services_are_ignored_while_waiting() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    for frame in [
        [0x11, 0x05, 0, 0, 0, 0, 0, 0],
        [0x13, 0, 3, 0, 0, 0, 0, 0],
        [0x15, 0x64, 0, 0, 0, 0, 0, 0],
        [0x17, 0, 0, 0, 0, 0, 0, 0],
        [0x5A, 0, 0, 0, 0, 0, 0, 0],
        [0x5E, 0, 0, 0, 0, 0, 0, 0],
        [0x4C, 0, 0, 0, 0, 0, 0, 0],
    ] {
        assert_eq!(send(&mut s, frame), LssAction::None, "{frame:02X?}");
    }
    assert_eq!(s.pending_node_id(), 0x3F);
}

#[test]
fn inquire_every_address_part() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    send(&mut s, req(LssRequest::SwitchGlobal(true)));
    assert_eq!(send(&mut s, [0x5A, 0, 0, 0, 0, 0, 0, 0]), ans([0x5A, 0x13, 0, 0, 0, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x5B, 0, 0, 0, 0, 0, 0, 0]), ans([0x5B, 0x01, 0x20, 0x68, 0x58, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x5C, 0, 0, 0, 0, 0, 0, 0]), ans([0x5C, 0x66, 0, 0, 0, 0, 0, 0]));
    assert_eq!(send(&mut s, [0x5D, 0, 0, 0, 0, 0, 0, 0]), ans([0x5D, 0x40, 0xE2, 0x01, 0, 0, 0, 0]));
}

#[test]
fn activate_bit_timing_uses_the_pending_rate() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    send(&mut s, req(LssRequest::SwitchGlobal(true)));
    send(&mut s, [0x13, 0, 4, 0, 0, 0, 0, 0]);
    assert_eq!(send(&mut s, [0x15, 0xF4, 0x01, 0, 0, 0, 0, 0]), LssAction::ActivateBitTiming { delay_ms: 500, index: 4 });
    // The pending rate is kept: a second activation switches to it again.
    assert_eq!(send(&mut s, [0x15, 0x0A, 0x00, 0, 0, 0, 0, 0]), LssAction::ActivateBitTiming { delay_ms: 10, index: 4 });
}

#[test]
fn malformed_is_what_parse_refuses() {
    for b0 in 0..=255u8 {
        for b1 in 0..=3u8 {
            let f = [b0, b1, 7, 8, 9, 10, 11, 12];
            for mode in [Mode::Waiting, Mode::Configuration] {
                let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
                s.mode = mode;
                let malformed = s.on_request(&f) == LssAction::Malformed;
                assert_eq!(malformed, LssRequest::parse(&f).is_err(), "{b0:#04x} {b1} {mode:?}");
            }
        }
    }
}

#[test]
fn a_malformed_frame_does_not_break_a_selective_sequence() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    let parts = [AddressPart::Vendor, AddressPart::Product, AddressPart::Revision, AddressPart::Serial];
    let mut last = LssAction::None;
    for (p, v) in parts.iter().zip(ADDR) {
        assert_eq!(s.on_request(&[0x99, 0, 0, 0, 0, 0, 0, 0]), LssAction::Malformed);
        last = s.on_request(&LssRequest::SwitchSelective(*p, v).emit());
    }
    assert_eq!(last, ans([0x44, 0, 0, 0, 0, 0, 0, 0]));
    // A request in between ends the sequence.
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    for (p, v) in parts.iter().zip(ADDR) {
        assert_eq!(s.on_request(&[0x5A, 0, 0, 0, 0, 0, 0, 0]), LssAction::None);
        last = s.on_request(&LssRequest::SwitchSelective(*p, v).emit());
    }
    assert_eq!(last, LssAction::None);
}

// ---- Switch state selective ---------------------------------------------------------

#[test]
fn switch_state_selective_needs_the_whole_address_in_order() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    let parts = [AddressPart::Vendor, AddressPart::Product, AddressPart::Revision, AddressPart::Serial];
    // Wrong serial: no answer, still waiting.
    for (p, v) in parts.iter().zip([ADDR[0], ADDR[1], ADDR[2], 7]) {
        assert_eq!(s.on_request(&LssRequest::SwitchSelective(*p, v).emit()), LssAction::None);
    }
    assert_eq!(s.mode(), Mode::Waiting);
    // Out of order: starts over.
    s.on_request(&LssRequest::SwitchSelective(AddressPart::Product, ADDR[1]).emit());
    assert_eq!(s.mode(), Mode::Waiting);
    let mut last = LssAction::None;
    for (p, v) in parts.iter().zip(ADDR) {
        last = s.on_request(&LssRequest::SwitchSelective(*p, v).emit());
    }
    assert_eq!(last, ans([0x44, 0, 0, 0, 0, 0, 0, 0]));
    assert_eq!(s.mode(), Mode::Configuration);
}

// ---- Identify ----------------------------------------------------------------------

#[test]
fn identify_remote_slave_answers_inside_the_range() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    let bounds = |rev: (u32, u32), ser: (u32, u32)| [ADDR[0], ADDR[1], rev.0, rev.1, ser.0, ser.1];
    for (k, v) in bounds((0, 0x100), (0x1_0000, 0x2_0000)).into_iter().enumerate() {
        let a = s.on_request(&LssRequest::IdentifyRemote(k as u8, v).emit());
        assert_eq!(a, if k == 5 { ans([0x4F, 0, 0, 0, 0, 0, 0, 0]) } else { LssAction::None });
    }
    for (k, v) in bounds((0x67, 0x100), (0, u32::MAX)).into_iter().enumerate() {
        assert_eq!(s.on_request(&LssRequest::IdentifyRemote(k as u8, v).emit()), LssAction::None, "revision below the range");
    }
}

#[test]
fn identify_remote_slave_checks_the_bounds_since_the_vendor_id() {
    let mut s = LssSlave::new(ADDR, 0x3F, 3, RATES);
    let send_bound = |s: &mut LssSlave, k: u8, v: u32| s.on_request(&LssRequest::IdentifyRemote(k, v).emit());
    // Without a vendor-id no check has started: no answer.
    for (k, v) in [(1, ADDR[1]), (2, 0), (3, u32::MAX), (4, 0)] {
        assert_eq!(send_bound(&mut s, k, v), LssAction::None);
    }
    assert_eq!(send_bound(&mut s, 5, u32::MAX), LssAction::None, "no vendor-id");
    // A wrong product code fails the check; repeating it right does not mend it (as CANopenNode).
    send_bound(&mut s, 0, ADDR[0]);
    send_bound(&mut s, 1, ADDR[1] + 1);
    for (k, v) in [(1, ADDR[1]), (2, 0), (3, u32::MAX), (4, 0)] {
        send_bound(&mut s, k, v);
    }
    assert_eq!(send_bound(&mut s, 5, u32::MAX), LssAction::None, "a failed bound since the vendor-id");
    // The next vendor-id starts over; bounds equal to the address are inside.
    for (k, v) in [(0, ADDR[0]), (1, ADDR[1]), (2, ADDR[2]), (3, ADDR[2]), (4, ADDR[3])] {
        send_bound(&mut s, k, v);
    }
    assert_eq!(send_bound(&mut s, 5, ADDR[3]), ans([0x4F, 0, 0, 0, 0, 0, 0, 0]));
    // Serial number above the high bound.
    for (k, v) in [(0, ADDR[0]), (1, ADDR[1]), (2, 0), (3, u32::MAX), (4, 0)] {
        send_bound(&mut s, k, v);
    }
    assert_eq!(send_bound(&mut s, 5, ADDR[3] - 1), LssAction::None, "serial number above the range");
}

#[test]
fn identify_non_configured_and_starting_an_unconfigured_node() {
    let mut configured = LssSlave::new(ADDR, 0x3F, 3, RATES);
    assert_eq!(configured.on_request(&LssRequest::IdentifyNonConfigured.emit()), LssAction::None);
    let mut s = LssSlave::new(ADDR, UNCONFIGURED, 3, RATES);
    assert_eq!(s.on_request(&LssRequest::IdentifyNonConfigured.emit()), ans([0x50, 0, 0, 0, 0, 0, 0, 0]));
    s.on_request(&LssRequest::SwitchGlobal(true).emit());
    assert_eq!(s.on_request(&LssRequest::InquireNodeId.emit()), ans([0x5E, 0xFF, 0, 0, 0, 0, 0, 0]));
    s.on_request(&LssRequest::ConfigureNodeId(0x20).emit());
    assert_eq!(s.on_request(&LssRequest::SwitchGlobal(false).emit()), LssAction::Start(0x20));
    assert_eq!(s.active_node_id(), 0x20);
    assert_eq!(s.on_request(&LssRequest::IdentifyNonConfigured.emit()), LssAction::None);
}

// ---- Fastscan ----------------------------------------------------------------------

/// The master's side of fastscan (CiA 305 §5.5) against slaves on one bus:
/// the master sees an answer if any slave answers.
fn fastscan(slaves: &mut [LssSlave]) -> Option<[u32; 4]> {
    let mut ask = |id: u32, bit: u8, sub: u8, next: u8| {
        let r = LssRequest::Fastscan { id, bit_checked: bit, sub, next };
        slaves.iter_mut().map(|s| s.on_request(&r.emit())).filter(|a| *a != LssAction::None).count() > 0
    };
    if !ask(0, 0x80, 0, 0) {
        return None;
    }
    let mut found = [0u32; 4];
    for sub in 0..4u8 {
        let mut id = 0u32;
        for bit in (0..32u8).rev() {
            // Nobody answers "bits above and this bit 0": the bit is 1.
            if !ask(id, bit, sub, sub) {
                id |= 1 << bit;
            }
        }
        assert!(ask(id, 0, sub, (sub + 1) % 4), "confirmation");
        found[usize::from(sub)] = id;
    }
    Some(found)
}

#[test]
fn fastscan_finds_three_unconfigured_slaves_one_by_one() {
    let serials = [0x0000_0005, 0x8000_0000, 0x1234_5678];
    let mut slaves: Vec<LssSlave> = serials.iter().map(|&sn| LssSlave::new([0x13, 0x42, 0x1, sn], UNCONFIGURED, 3, RATES)).collect();
    let mut assigned = Vec::new();
    for node_id in [10u8, 11, 12] {
        let found = fastscan(&mut slaves).expect("an unconfigured slave answers");
        let s = slaves.iter_mut().find(|s| s.mode() == Mode::Configuration).expect("the found slave is configuring");
        assert_eq!(s.address, found);
        assert_eq!(s.on_request(&LssRequest::ConfigureNodeId(node_id).emit()), ans([0x11, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(s.on_request(&LssRequest::SwitchGlobal(false).emit()), LssAction::Start(node_id));
        assigned.push((found[3], node_id));
    }
    assert_eq!(fastscan(&mut slaves), None, "no unconfigured slave is left");
    assigned.sort();
    // The lowest address answers first: each scan ends at the smallest serial left.
    assert_eq!(assigned, [(0x0000_0005, 10), (0x1234_5678, 11), (0x8000_0000, 12)]);
}

#[test]
fn fastscan_ignores_bad_parameters_and_configured_slaves() {
    let mut s = LssSlave::new(ADDR, UNCONFIGURED, 3, RATES);
    for (bit, sub, next) in [(32, 0, 0), (0, 4, 0), (0, 0, 4), (31, 1, 1)] {
        assert_eq!(s.on_request(&LssRequest::Fastscan { id: 0, bit_checked: bit, sub, next }.emit()), LssAction::None);
    }
    let mut c = LssSlave::new(ADDR, 5, 3, RATES);
    assert_eq!(c.on_request(&LssRequest::Fastscan { id: 0, bit_checked: 0x80, sub: 0, next: 0 }.emit()), LssAction::None);
}

#[test]
fn power_on_is_a_new_slave_with_the_address_kept() {
    // The node's unpowered slave, its address then set from 0x1018 as the reset does.
    let mut s = LssSlave::new([0; 4], 0, 0, 0);
    *s.address_mut() = ADDR;
    s.power_on(0x3F, 3, RATES);
    assert_eq!(s, LssSlave::new(ADDR, 0x3F, 3, RATES));
    // Unconfigured, no rate stored.
    let mut u = LssSlave::new([0; 4], 0, 0, 0);
    u.power_on(UNCONFIGURED, 0xFF, RATES);
    assert_eq!(u, LssSlave::new([0; 4], UNCONFIGURED, 0xFF, RATES));
}
