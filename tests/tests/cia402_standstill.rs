//! The end of a stop that waits for the axis (CiA 402-2 §6: transitions 5
//! and 8 on a ramp, 12 after a quick stop, 14 after the fault reaction;
//! halt's and quick stop's target reached, bit 10): the axis stands when
//! the velocity actual value reads within the velocity threshold 0x606F (0:
//! reads 0) for 0x6070 ms, CiA 402's "speed = 0" of pv, in the unit the
//! object uses (docs/firmware.md "Standstill", docs/devices/bmaxx4400.md
//! D68). Measured on the b maXX 4400 (every option code in its dictionary;
//! 0x606C in min⁻¹): TPDO3 carries the statusword and 0x606C at a SYNC
//! every millisecond, and the statusword changes in the frame in which
//! 0x606C first reads standstill, not when the position loop has settled
//! the last increment about 0.2 s later. vl (0x6044 reads 0) is in
//! `cia402_vl_ramp_times.rs`.

mod common;

use common::bmaxx4400::{Bmaxx, ID, controlword, powered, turn};
use common::{ms, ok_write};

const SYNC: u16 = 0x080;
const TPDO3: u16 = 0x382;
const TPDO4: u16 = 0x482;

const OPERATION_ENABLED: u16 = 0x0237;
const SWITCHED_ON: u16 = 0x0233;
const READY_TO_SWITCH_ON: u16 = 0x0231;
const QUICK_STOP_ACTIVE: u16 = 0x0217;
const SWITCH_ON_DISABLED: u16 = 0x0250;
const FAULT_REACTION_ACTIVE: u16 = 0x021F;
const FAULT: u16 = 0x0218;
/// Statusword bit 10, target reached.
const TARGET_REACHED: u16 = 0x0400;

/// Node 2 in pv at 600 min⁻¹, 0x6084 slow down ramp 10 revolutions/s²
/// (600 min⁻¹ to 0 in 1 s), 0x6085 quick stop 50 revolutions/s² (0.2 s),
/// `settings` written first; on every SYNC TPDO3 = statusword + 0x606C,
/// TPDO4 = 0x606B. Operation enabled at 10 ms; the clock at 200 ms.
fn turning(settings: &[(u16, u8, &[u8])]) -> Bmaxx {
    let mut b = powered();
    b.map_pdo(ID, 0x1A02, &[0x6041_0010, 0x606C_0020]);
    b.map_pdo(ID, 0x1A03, &[0x606B_0020]);
    for pdo in [0x1802, 0x1803] {
        assert_eq!(b.sdo_write(ID, pdo, 2, &[1]), ok_write(pdo, 2));
    }
    turn(&mut b, settings);
    b
}

/// One SYNC's frames: (ms, statusword, 0x606C, 0x606B).
type Frame = (u64, u16, i32, i32);

/// A little-endian INTEGER32.
fn i32_of(bytes: &[u8]) -> i32 {
    i32::from_le_bytes(bytes.try_into().expect("4 bytes"))
}

/// TPDO3 and TPDO4 at a SYNC every millisecond up to `to` ms.
fn trace(b: &mut Bmaxx, to: u64) -> Vec<Frame> {
    let from = b.now.as_micros() / 1000 + 1;
    let mut frames = Vec::new();
    for t in from..=to {
        // TPDO1 and TPDO2 (the default mapping, event-driven) are not looked at.
        let out: Vec<_> = b.rx(ms(t), SYNC, &[]).into_iter().filter(|(id, _)| [TPDO3, TPDO4].contains(id)).collect();
        let [(TPDO3, status), (TPDO4, demand)] = &out[..] else { panic!("at {t} ms: {out:x?}") };
        frames.push((t, u16::from_le_bytes([status[0], status[1]]), i32_of(&status[2..]), i32_of(demand)));
    }
    frames
}

/// The stop completes in the first frame that shows the demand at rest (0)
/// and the axis within the standstill window (|actual| ≤ `threshold`): that
/// frame shows `done`, the one before it `before`. Returns its time.
#[track_caller]
fn changes_at_standstill(frames: &[Frame], before: u16, done: impl Fn(u16) -> bool, threshold: i32) -> u64 {
    let standstill = |f: &Frame| f.3 == 0 && f.2.abs() <= threshold;
    // The first few frames: the stop has only begun.
    let i = frames.iter().skip(5).position(standstill).expect("the axis stands") + 5;
    let ((t0, previous, ..), (t, status, velocity, _)) = (frames[i - 1], frames[i]);
    assert!(done(status), "at {t} ms: {status:#06x}, 0x606C = {velocity}: the stop has not completed");
    assert_eq!(previous, before, "at {t0} ms: {previous:#06x}: the stop completed a frame earlier");
    t
}

#[test]
fn transition_5_disable_operation_0x605c_1_ends_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605C, 0, &1i16.to_le_bytes())]);
    controlword(&mut b, 0x0007);
    let frames = trace(&mut b, 1500);
    // 600 min⁻¹ at 10 revolutions/s² from 200 ms.
    let t = changes_at_standstill(&frames, OPERATION_ENABLED, |s| s == SWITCHED_ON, 0);
    // The demand stands at 1201 ms; the axis, 1 min⁻¹ past it, reads 0 again at 1206 ms.
    assert_eq!(t, 1206, "Switched on");
    assert_eq!(frames.iter().find(|f| f.0 == t).unwrap().1, SWITCHED_ON);
}

#[test]
fn transition_8_shutdown_0x605b_1_ends_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605B, 0, &1i16.to_le_bytes())]);
    controlword(&mut b, 0x0006);
    let frames = trace(&mut b, 1500);
    let t = changes_at_standstill(&frames, OPERATION_ENABLED, |s| s == READY_TO_SWITCH_ON, 0);
    assert_eq!(t, 1206, "Ready to switch on");
}

#[test]
fn transition_12_after_a_quick_stop_0x605a_2_ends_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605A, 0, &2i16.to_le_bytes())]);
    controlword(&mut b, 0x000B);
    let frames = trace(&mut b, 700);
    assert_eq!(frames[0].1, QUICK_STOP_ACTIVE, "braking in Quick stop active");
    // 600 min⁻¹ at 50 revolutions/s²: the demand stands at 400 ms; the axis, 3 min⁻¹
    // past it, comes back at 1-3 min⁻¹ and reads 0 at 445 ms (it took 0.2 s more before).
    let t = changes_at_standstill(&frames, QUICK_STOP_ACTIVE, |s| s == SWITCH_ON_DISABLED, 0);
    assert_eq!(t, 445, "Switch on disabled");
}

#[test]
fn quick_stop_0x605a_6_stays_and_shows_target_reached_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605A, 0, &6i16.to_le_bytes())]);
    controlword(&mut b, 0x000B);
    let frames = trace(&mut b, 700);
    // Standing: target reached (bit 10) and, in pv, speed = 0 (bit 12).
    let standing = QUICK_STOP_ACTIVE | TARGET_REACHED | 0x1000;
    let t = changes_at_standstill(&frames, QUICK_STOP_ACTIVE, |s| s == standing, 0);
    assert_eq!(t, 445, "standing");
    assert!(frames.iter().filter(|f| f.0 > t).all(|f| f.1 == standing), "stays");
}

#[test]
fn transition_14_after_the_fault_reaction_0x605e_2_ends_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605E, 0, &2i16.to_le_bytes()), (0x6007, 0, &1i16.to_le_bytes())]);
    // Guarding every 100 ms, life time factor 1: one RTR at 200 ms, lost at 300 ms.
    assert_eq!(b.sdo_write(ID, 0x100C, 0, &100u16.to_le_bytes()), ok_write(0x100C, 0));
    assert_eq!(b.sdo_write(ID, 0x100D, 0, &[1]), ok_write(0x100D, 0));
    b.rtr(ms(200), 0x700 + u16::from(ID));
    let frames = trace(&mut b, 800);
    let reacting = frames.iter().find(|f| f.1 & 0x6F == FAULT_REACTION_ACTIVE & 0x6F).expect("fault reaction").0;
    assert!((300..=302).contains(&reacting), "guarding lost at {reacting} ms");
    let t = changes_at_standstill(&frames, FAULT_REACTION_ACTIVE, |s| s == FAULT, 0);
    // The quick stop ramp from 300 ms: the demand stands at 500 ms, the axis as in transition 12.
    assert_eq!(t, 545, "Fault");
}

#[test]
fn halt_0x605d_1_target_reached_in_the_frame_0x606c_reads_0() {
    let mut b = turning(&[(0x605D, 0, &1i16.to_le_bytes())]);
    controlword(&mut b, 0x010F);
    let frames = trace(&mut b, 1500);
    let t = changes_at_standstill(&frames, OPERATION_ENABLED, |s| s == OPERATION_ENABLED | TARGET_REACHED | 0x1000, 0);
    assert_eq!(t, 1206, "target reached");
    // pv speed = 0 (bit 12) with it: the same window.
    assert_eq!(frames.iter().find(|f| f.0 == t).unwrap().1, OPERATION_ENABLED | TARGET_REACHED | 0x1000);
}

#[test]
fn velocity_threshold_0x606f_20_min_ends_the_stop_with_the_demand_while_0x606c_reads_20_or_less() {
    // 0x606F in 0x606C's unit (min⁻¹, D57): the axis is within 20 min⁻¹ some 30 ms before the
    // demand stands; the transition waits for the demand and not for 0x606C = 0.
    let mut b = turning(&[(0x605C, 0, &1i16.to_le_bytes()), (0x606F, 0, &20u16.to_le_bytes())]);
    controlword(&mut b, 0x0007);
    let frames = trace(&mut b, 1500);
    let t = changes_at_standstill(&frames, OPERATION_ENABLED | 0x1000, |s| s == SWITCHED_ON, 20);
    let velocity = frames.iter().find(|f| f.0 == t).unwrap().2;
    assert!(velocity != 0 && velocity.abs() <= 20, "at {t} ms 0x606C = {velocity} min⁻¹: within 0x606F, not yet 0");
    assert_eq!(t, 1201, "with the demand");
}
