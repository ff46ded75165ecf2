//! The option codes 0x605B-0x605E with the deceleration each implies (CiA
//! 402-2 §6.3: 1 slow down ramp 0x6084, 2 quick stop ramp 0x6085, 3 the
//! drive's current limit, 0 the drive function off at once), measured on
//! the axis of the b maXX 4400 (the one drive whose dictionary has all of
//! them) in profile velocity: 0x606C over virtual time. Its speeds are
//! min⁻¹ (docs/devices/bmaxx4400.md D57); its decelerations increments per
//! second squared (1 BE = 1 increment, D50).

mod common;

use common::bmaxx4400::{Bmaxx, ID, SPEED, controlword, powered, turn};
use common::{ms, ok_write};

/// Node 2 in pv at 600 min⁻¹ from 0 to 200 ms (acceleration 100 revolutions/s²: 0.1 s),
/// with `option` = `code`. The clock stands at 200 ms.
fn turning(option: u16, code: i16) -> Bmaxx {
    let mut b = powered();
    turn(&mut b, &[(option, 0, &code.to_le_bytes())]);
    assert_eq!(speed(&mut b), SPEED);
    b
}

fn speed(b: &mut Bmaxx) -> i32 {
    let v = b.sdo_upload(ID, 0x606C, 0).expect("0x606C");
    i32::from_le_bytes([v[0], v[1], v[2], v[3]])
}

fn state(b: &mut Bmaxx) -> u16 {
    let v = b.sdo_upload(ID, 0x6041, 0).expect("0x6041");
    u16::from_le_bytes([v[0], v[1]]) & 0x6F
}

const OPERATION_ENABLED: u16 = 0x27;
const SWITCHED_ON: u16 = 0x23;
const SWITCH_ON_DISABLED: u16 = 0x40;
const FAULT_REACTION_ACTIVE: u16 = 0x0F;
const FAULT: u16 = 0x08;

/// 0x606C at `t` ms.
fn at(b: &mut Bmaxx, t: u64) -> i32 {
    b.run_until(ms(t));
    speed(b)
}

/// Within one millisecond of a ramp of `per_s` min⁻¹ per second (the profile's tick).
#[track_caller]
fn near(actual: i32, expected: i32, per_s: i32) {
    let tolerance = per_s / 1000 + 1;
    assert!((actual - expected).abs() <= tolerance, "{actual} min⁻¹, expected {expected} ± {tolerance}");
}

/// The first millisecond from `from` on at which the state is `wanted`.
fn when(b: &mut Bmaxx, from: u64, wanted: u16) -> u64 {
    (from..from + 2000)
        .find(|&t| {
            b.run_until(ms(t));
            state(b) == wanted
        })
        .expect("state reached")
}

// The transitions that wait for the stop (5 with 0x605C 1, 12 after a quick stop, 14
// after the fault reaction) complete when the demand stands and 0x606C reads 0 min⁻¹
// (docs/firmware.md "Standstill"): after a small overshoot the position loop brings the
// axis back at 1-3 min⁻¹ for up to 45 ms (the exact frames are in cia402_standstill.rs).
// `SETTLE` allows that.
const SETTLE: u64 = 50;

#[test]
fn halt_option_0x605d_1_slow_down_ramp_2_quick_stop_ramp_3_current_limit() {
    // 1: 0x6084, half the speed after 0.5 s, standstill after 1 s, still Operation enabled.
    let mut b = turning(0x605D, 1);
    controlword(&mut b, 0x010F);
    near(at(&mut b, 700), SPEED / 2, 600);
    assert_eq!(at(&mut b, 1210), 0);
    assert_eq!(state(&mut b), OPERATION_ENABLED);
    // 2: 0x6085, half after 0.1 s, standstill after 0.2 s.
    let mut b = turning(0x605D, 2);
    controlword(&mut b, 0x010F);
    near(at(&mut b, 300), SPEED / 2, 3000);
    assert_eq!(at(&mut b, 450), 0);
    // 3: the drive's limit (500 revolutions/s²: 0.02 s; the axis overshoots a little).
    let mut b = turning(0x605D, 3);
    controlword(&mut b, 0x010F);
    near(at(&mut b, 210), SPEED / 2, 30_000);
    assert!(at(&mut b, 230) <= 0, "stopped within 0.03 s");
    assert_eq!(at(&mut b, 340), 0);
    // Releasing the halt turns the axis again.
    controlword(&mut b, 0x000F);
    assert_eq!(at(&mut b, 600), SPEED);
}

#[test]
fn disable_operation_option_0x605c_1_brakes_before_transition_5_0_switches_off_at_once() {
    // 1: Operation enabled while braking on 0x6084, then Switched on.
    let mut b = turning(0x605C, 1);
    controlword(&mut b, 0x0007);
    near(at(&mut b, 700), SPEED / 2, 600);
    assert_eq!(state(&mut b), OPERATION_ENABLED, "still braking");
    assert_eq!(at(&mut b, 1210), 0);
    assert!(when(&mut b, 1210, SWITCHED_ON) <= 1200 + SETTLE);
    // 0: the drive function off at once: Switched on, the motor coasts (not on 0x6084).
    let mut b = turning(0x605C, 0);
    controlword(&mut b, 0x0007);
    assert!(when(&mut b, 200, SWITCHED_ON) <= 201);
    assert!(at(&mut b, 290) < 500, "coasting, not the slow down ramp's 545 min⁻¹");
}

#[test]
fn shutdown_option_0x605b_0_switches_off_at_once() {
    let mut b = turning(0x605B, 0);
    controlword(&mut b, 0x0006);
    assert!(when(&mut b, 200, 0x21) <= 201, "Ready to switch on at once");
    assert!(at(&mut b, 290) < 500, "coasting, not the slow down ramp's 545 min⁻¹");
}

#[test]
fn quick_stop_option_0x605a_2_quick_stop_ramp_then_switch_on_disabled_5_stays() {
    let mut b = turning(0x605A, 2);
    controlword(&mut b, 0x000B);
    near(at(&mut b, 300), SPEED / 2, 3000);
    assert_eq!(state(&mut b), 0x07, "Quick stop active while braking");
    assert!(when(&mut b, 300, SWITCH_ON_DISABLED) <= 400 + SETTLE);
    assert_eq!(speed(&mut b), 0);
    // 5: slow down ramp, then stays in Quick stop active.
    let mut b = turning(0x605A, 5);
    controlword(&mut b, 0x000B);
    near(at(&mut b, 700), SPEED / 2, 600);
    assert_eq!(at(&mut b, 1210), 0);
    assert_eq!(at(&mut b, 1600), 0);
    assert_eq!(state(&mut b), 0x07, "Quick stop active");
}

#[test]
fn fault_reaction_option_0x605e_1_and_2_brake_on_a_guarding_loss_with_0x6007_1() {
    for (code, half, stopped) in [(1i16, 800u64, 1300u64), (2, 400, 500)] {
        let mut b = turning(0x605E, code);
        // 0x6007 = 1: a communication error is a fault with the reaction 0x605E. Guarding:
        // 100 ms, life time factor 1, one RTR at 200 ms; lost at 300 ms.
        assert_eq!(b.sdo_write(ID, 0x6007, 0, &1i16.to_le_bytes()), ok_write(0x6007, 0));
        assert_eq!(b.sdo_write(ID, 0x100C, 0, &100u16.to_le_bytes()), ok_write(0x100C, 0));
        assert_eq!(b.sdo_write(ID, 0x100D, 0, &[1]), ok_write(0x100D, 0));
        b.rtr(ms(200), 0x702);
        let lost = when(&mut b, 200, FAULT_REACTION_ACTIVE);
        assert!((300..=301).contains(&lost), "guarding lost at {lost} ms");
        near(at(&mut b, half), SPEED / 2, if code == 1 { 600 } else { 3000 });
        assert!(at(&mut b, stopped + 10).abs() <= 3, "0x605E = {code}: stopped");
        assert!(when(&mut b, stopped + 10, FAULT) <= stopped + SETTLE, "0x605E = {code}");
        assert_eq!(speed(&mut b), 0);
    }
}

#[test]
fn m_l5130_bmaxx_shutdown_and_disable_operation_minus_1_quick_stop_ramp_minus_2_current_limit() {
    // 0x605B = −1 "Rücklauf an Schnellhaltrampe": transition 8 after the quick stop ramp.
    let mut b = turning(0x605B, -1);
    assert_eq!(b.sdo_upload(ID, 0x605B, 0), Ok(vec![0xFF, 0xFF]), "reads back −1");
    controlword(&mut b, 0x0006);
    near(at(&mut b, 300), SPEED / 2, 3000);
    assert_eq!(state(&mut b), OPERATION_ENABLED, "braking");
    assert!(when(&mut b, 300, 0x21) <= 400 + SETTLE, "then Ready to switch on");
    assert_eq!(b.sdo_upload(ID, 0x605B, 0), Ok(vec![0xFF, 0xFF]), "still −1");
    // 0x605C = −2 "Rücklauf an Stromgrenze": transition 5 after a stop at the drive's limit.
    let mut b = turning(0x605C, -2);
    controlword(&mut b, 0x0007);
    near(at(&mut b, 210), SPEED / 2, 30_000);
    assert!(when(&mut b, 210, SWITCHED_ON) <= 220 + SETTLE);
    // 0x605C = −1: the quick stop ramp.
    let mut b = turning(0x605C, -1);
    controlword(&mut b, 0x0007);
    near(at(&mut b, 300), SPEED / 2, 3000);
}

#[test]
fn m_l5040_bmaxx_option_codes_take_the_values_of_their_tables() {
    let mut b = powered();
    for (index, refused) in
        [(0x6007u16, [-1i16, 4]), (0x605A, [-1, 9]), (0x605B, [-3, 2]), (0x605C, [-3, 2]), (0x605D, [-1, 4]), (0x605E, [-1, 4])]
    {
        for value in refused {
            assert_eq!(b.sdo_write(ID, index, 0, &value.to_le_bytes()), common::abort(index, 0, 0x0609_0030), "{index:#x} = {value}");
        }
    }
    for (index, value) in [(0x6007u16, 3i16), (0x605A, 8), (0x605B, -2), (0x605C, 1), (0x605D, 3), (0x605E, 0)] {
        assert_eq!(b.sdo_write(ID, index, 0, &value.to_le_bytes()), ok_write(index, 0), "{index:#x} = {value}");
    }
}
