//! CiA 402 power drive system state machine on the EC5000 (the first
//! device running the profile): every transition from every state with the
//! exact controlword in (RPDO1: 0x6040, 0x6060, 0x6081) and the exact
//! statusword out in the change-of-state TPDO (TPDO2: 0x6041, 0x6064).

mod common;

use common::{Bench, ms};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
const RPDO1: u16 = 0x205;
const RPDO3: u16 = 0x405;
const TPDO2: u16 = 0x285;

type Ec5000 = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

/// Statusword values (bit 9 remote, bit 4 voltage enabled with the DC link up).
const SWITCH_ON_DISABLED: u16 = 0x0250;
const READY_TO_SWITCH_ON: u16 = 0x0231;
const SWITCHED_ON: u16 = 0x0233;
/// At the transition; one tick later pv at standstill with target 0 adds
/// bit 10 target reached and bit 12 speed = 0 (0x1637, see `pv_target_reached_one_tick_after_enable`).
const OPERATION_ENABLED: u16 = 0x0237;
const QUICK_STOP_ACTIVE: u16 = 0x0617;
const FAULT: u16 = 0x0218;

/// Boot, Operational at t = 10 ms; returns the bench at t = 10 ms, the
/// start-of-Operational TPDOs drained.
fn operational() -> Ec5000 {
    let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    b.now = ms(10);
    b.nmt(0x01, ID);
    b
}

/// The statusword TPDO2 sends after a controlword at `t` (RPDO1, pv mode 3, 0x6081 = 0).
fn command(b: &mut Ec5000, t: u64, controlword: u16) -> Vec<u16> {
    let [lo, hi] = controlword.to_le_bytes();
    b.rx(ms(t), RPDO1, &[lo, hi, 3, 0, 0, 0, 0])
        .into_iter()
        .filter(|(id, _)| *id == TPDO2)
        .map(|(_, d)| u16::from_le_bytes([d[0], d[1]]))
        .collect()
}

fn statusword(b: &mut Ec5000) -> u16 {
    let v = b.sdo_upload(ID, 0x6041, 0).expect("0x6041");
    u16::from_le_bytes([v[0], v[1]])
}

/// Each step 200 ms after the last (TPDO2 inhibit time 100 ms): the
/// statusword TPDO2 sends at once, and what follows within 100 ms.
fn walk(b: &mut Ec5000, start: u64, steps: &[(u16, Option<u16>, Option<u16>)]) -> u64 {
    let mut t = start;
    for (i, (cw, at_once, then)) in steps.iter().enumerate() {
        t += 200;
        let out = command(b, t, *cw);
        assert_eq!(out, at_once.iter().copied().collect::<Vec<_>>(), "step {i}: controlword {cw:#06x}");
        let later: Vec<(u64, u16)> = b
            .run_until(ms(t + 100))
            .into_iter()
            .filter(|(_, (id, _))| *id == TPDO2)
            .map(|(at, (_, d))| (at.as_micros() / 1000 - t, u16::from_le_bytes([d[0], d[1]])))
            .collect();
        assert_eq!(later.into_iter().map(|(_, w)| w).collect::<Vec<_>>(), then.iter().copied().collect::<Vec<_>>(), "step {i} after");
    }
    t
}

/// Enabled in pv at rest: bit 10 target reached and bit 12 speed = 0 after the first tick.
const ENABLED_AT_REST: u16 = 0x1637;

/// Transitions 2, 3 and 4, from Switch on disabled to Operation enabled.
const ON: [(u16, Option<u16>, Option<u16>); 3] =
    [(0x0006, Some(READY_TO_SWITCH_ON), None), (0x0007, Some(SWITCHED_ON), None), (0x000F, Some(OPERATION_ENABLED), Some(ENABLED_AT_REST))];

#[test]
fn power_on_reaches_switch_on_disabled_transitions_0_and_1() {
    let mut b = operational();
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED);
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![3]), "pv, the EC5000's default mode");
}

#[test]
fn enable_and_disable_transitions_2_3_4_5_6_7() {
    let mut b = operational();
    walk(
        &mut b,
        0,
        &[
            (0x0006, Some(READY_TO_SWITCH_ON), None),                 // 2
            (0x0007, Some(SWITCHED_ON), None),                        // 3
            (0x000F, Some(OPERATION_ENABLED), Some(ENABLED_AT_REST)), // 4
            (0x0007, None, Some(SWITCHED_ON)),                        // 5 (0x605C default: slow down ramp; stopped one tick later)
            (0x0006, Some(READY_TO_SWITCH_ON), None),                 // 6
            (0x0000, Some(SWITCH_ON_DISABLED), None),                 // 7 (disable voltage)
            (0x0006, Some(READY_TO_SWITCH_ON), None),                 // 2
            (0x0002, Some(SWITCH_ON_DISABLED), None),                 // 7 (quick stop)
        ],
    );
}

#[test]
fn transitions_8_9_10_11_12_16() {
    let mut b = operational();
    let mut t = walk(&mut b, 0, &ON);
    t = walk(&mut b, t, &[(0x0006, Some(READY_TO_SWITCH_ON), None)]); // 8
    t = walk(&mut b, t, &ON[1..]);
    t = walk(&mut b, t, &[(0x0000, Some(SWITCH_ON_DISABLED), None)]); // 9
    t = walk(&mut b, t, &ON[..2]);
    t = walk(&mut b, t, &[(0x0000, Some(SWITCH_ON_DISABLED), None)]); // 10 (disable voltage)
    t = walk(&mut b, t, &ON[..2]);
    t = walk(&mut b, t, &[(0x000B, Some(SWITCH_ON_DISABLED), None)]); // 10 (quick stop)
    t = walk(&mut b, t, &ON);
    // 11, and at rest the quick stop (0x605A missing: option 2) ends in 12 at once.
    let out = command(&mut b, t + 200, 0x000B);
    assert_eq!(out, [QUICK_STOP_ACTIVE | 0x1000], "11 (pv bit 12: speed = 0)");
    b.run_until(ms(t + 400));
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED, "12 after the stop");
    // Not reachable without 0x605A = 5..8: 16 (enable operation in Quick stop active).
    assert_eq!(command(&mut b, t + 600, 0x000F), Vec::<u16>::new());
}

#[test]
fn commands_that_are_no_transition_change_nothing() {
    let mut b = operational();
    // Switch on and enable operation from Switch on disabled: no transition.
    let t = walk(&mut b, 0, &[(0x0007, None, None), (0x000F, None, None), (0x0002, None, None)]);
    assert_eq!(statusword(&mut b), SWITCH_ON_DISABLED);
    // Ready to switch on: 0x000F is switch on + enable operation: 3 then 4.
    walk(&mut b, t, &[(0x0006, Some(READY_TO_SWITCH_ON), None), (0x000F, Some(OPERATION_ENABLED), Some(ENABLED_AT_REST))]);
}

#[test]
fn fault_reaction_fault_and_reset_transitions_13_14_15() {
    let mut b = operational();
    let t = walk(&mut b, 0, &ON);
    b.node.app_mut().drive.drive.axis.inject(canopen_core::axis::Injected::UnderVoltage);
    let out = b.run_until(ms(t + 300));
    // 13 and 14: the drive lost its power stage, so no ramp: Fault at once,
    // EMCY 0x3220 with error register 0x05 (generic + voltage).
    let emcy: Vec<_> = out.iter().filter(|(_, (id, _))| *id == 0x085).map(|(_, (_, d))| d.clone()).collect();
    assert_eq!(emcy, [vec![0x20, 0x32, 0x05, 0, 0, 0, 0, 0]]);
    // Bit 4 off: the DC link is down.
    assert_eq!(statusword(&mut b), FAULT & !0x0010);
    // Fault reset while the cause persists: stays in Fault.
    assert_eq!(command(&mut b, t + 500, 0x0080), Vec::<u16>::new());
    b.node.app_mut().drive.drive.axis.remove(canopen_core::axis::Injected::UnderVoltage);
    command(&mut b, t + 700, 0x0000);
    // 15 on the rising edge; the EMCY "error reset" follows.
    let out = b.rx(ms(t + 900), RPDO1, &[0x80, 0x00, 3, 0, 0, 0, 0]);
    assert!(out.contains(&(0x085, vec![0, 0, 0, 0, 0, 0, 0, 0])), "{out:x?}");
    assert!(out.contains(&(TPDO2, vec![0x50, 0x02, 0, 0, 0, 0])), "{out:x?}");
}

#[test]
fn change_of_state_tpdo_leaves_in_the_same_process_as_the_rpdo() {
    let mut b = operational();
    // RPDO3 (0x6040 + 0x60FF): shutdown → TPDO2 with 0x0231 at the same instant.
    let out = b.rx(ms(300), RPDO3, &[0x06, 0x00, 0, 0, 0, 0]);
    // TPDO1 (0x6041, 0x6061, 0x1001, 0x2200 sub 6, 0x6077) and TPDO2 (0x6041, 0x6064) both map it.
    // 0x2200 sub 6: the roller at 25 °C ambient (D49).
    assert_eq!(out, [(0x185, vec![0x31, 0x02, 3, 0, 25, 0, 0, 0]), (TPDO2, vec![0x31, 0x02, 0, 0, 0, 0])]);
}

#[test]
fn pv_target_reached_one_tick_after_enable() {
    let mut b = operational();
    let t = walk(&mut b, 0, &ON);
    // walk ran 100 ms further: the window (0x606E missing: one tick) has held.
    assert_eq!(b.run_until(ms(t + 150)), []);
    assert_eq!(statusword(&mut b), 0x1637);
}

/// The end of time is input too (a board's clock, the fuzzer): the
/// profile's timers saturate there instead of overflowing.
#[test]
fn the_profile_runs_at_the_end_of_time() {
    let mut b = operational();
    let end = canopen_core::time::Instant::from_micros(u64::MAX - 500);
    let [lo, hi] = 0x000Fu16.to_le_bytes();
    for controlword in [0x0006u16, 0x0007, 0x000F] {
        let [lo, hi] = controlword.to_le_bytes();
        b.rx(end, RPDO1, &[lo, hi, 3, 0, 0, 0, 0]);
    }
    b.rx(end, RPDO1, &[lo, hi, 3, 0x10, 0, 0, 0]);
    assert!(b.node.process(end).is_some_and(|d| d >= end), "a deadline no earlier than now");
    let last = canopen_core::time::Instant::from_micros(u64::MAX);
    b.at(last);
    let answer = b.rx(last, 0x600 + u16::from(ID), &[0x40, 0x41, 0x60, 0, 0, 0, 0, 0]);
    let sdo = answer.iter().find(|(id, _)| *id == 0x580 + u16::from(ID)).expect("an SDO answer");
    assert_eq!(u16::from_le_bytes([sdo.1[4], sdo.1[5]]) & 0x6F, 0x27, "still Operation enabled");
}
