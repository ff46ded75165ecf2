//! CiA 406 position 0x6004 on the Sendix with exact SDO frames: scaling
//! (0x6000 bits 0 and 2, MUR 0x6001, TMR 0x6002), the wrap of a
//! non-binary range across the physical counter's wrap, MUR ≤ TMR, and
//! the preset 0x6003 with its offset 0x6509 over a power cycle.

mod common;

use common::sendix::{STEPS, encoder, move_to, read, read_u32, turn};
use common::{abort, ms, ok_write};
use hal_host::storage::MemStorage;

const SCALING: [u8; 2] = [0x04, 0x00];

#[test]
fn scaling_off_the_position_is_the_raw_count_trace_l3599() {
    let mut b = encoder(MemStorage::new(4096), 0, 19642);
    // The manual's trace position 0x4CBA, read as a master reads it.
    assert_eq!(b.rx(ms(1), 0x63F, &[0x40, 0x04, 0x60, 0x00, 0, 0, 0, 0]), [(0x5BF, vec![0x43, 0x04, 0x60, 0x00, 0xBA, 0x4C, 0x00, 0x00])]);
    assert_eq!(read(&mut b, 0x600C, 0), [0xBA, 0x4C, 0, 0]);
    assert_eq!(read(&mut b, 0x600B, 0), [0xBA, 0x4C, 0, 0, 0, 0, 0, 0]);
    move_to(&mut b, 19643);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 19643, "the position follows the shaft");
}

#[test]
fn binary_scaling_wraps_at_tmr_seed_11_21() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &0x1000u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &0x10000u32.to_le_bytes()), ok_write(0x6002, 0));
    // 0x1000 units per 0x4000 steps: a quarter turn is 0x400 units.
    for quarter in 1..=64u64 {
        turn(&mut b, (STEPS / 4) as i64);
        assert_eq!(read_u32(&mut b, 0x6004, 0), ((quarter * 0x400) % 0x10000) as u32, "after {quarter} quarter turns");
    }
    turn(&mut b, -1);
    assert_eq!(read(&mut b, 0x6004, 0), [0xFF, 0xFF, 0, 0], "one step back from 0 is 0xFFFF");
    assert_eq!(read(&mut b, 0x6500, 0), SCALING, "0x6500 mirrors 0x6000");
}

#[test]
fn tmr_zero_means_two_to_the_32() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &[0, 0, 0, 0]), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &0x4000u32.to_le_bytes()), ok_write(0x6001, 0));
    turn(&mut b, -1);
    assert_eq!(read(&mut b, 0x6004, 0), [0xFF, 0xFF, 0xFF, 0xFF]);
}

/// §5.7.2: MUR 3600, TMR 36000 (ten turns). The physical counter wraps
/// after 7 turns, which 10 does not divide: the position runs on.
#[test]
fn a_non_binary_range_does_not_jump_when_the_turn_counter_wraps_l2946() {
    let range = 7 * STEPS;
    let mut b = encoder(MemStorage::new(4096), range, 0);
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x02, 0x60, 0x00, 0xA0, 0x8C, 0x00, 0x00]), [(0x5BF, ok_write(0x6002, 0))]);
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x01, 0x60, 0x00, 0x10, 0x0E, 0x00, 0x00]), [(0x5BF, ok_write(0x6001, 0))]);
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    // 30 turns forward in quarter turns: 900 units each, modulo 36000.
    for quarter in 1..=120u64 {
        turn(&mut b, (STEPS / 4) as i64);
        assert_eq!(read_u32(&mut b, 0x6004, 0), ((quarter * 900) % 36000) as u32, "after {quarter} quarter turns");
    }
    // And back 30 turns, across the wrap the other way.
    for quarter in (0..120u64).rev() {
        turn(&mut b, -((STEPS / 4) as i64));
        assert_eq!(read_u32(&mut b, 0x6004, 0), ((quarter * 900) % 36000) as u32, "back at {quarter} quarter turns");
    }
}

#[test]
fn the_code_sequence_counts_down_clockwise_s2() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &36000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3600u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x05, 0x00]), ok_write(0x6000, 0));
    turn(&mut b, STEPS as i64);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 36000 - 3600, "one turn clockwise, counting down");
}

#[test]
fn mur_above_tmr_is_refused_and_the_old_value_kept_seed_11_23() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &0x10000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &0x1000u32.to_le_bytes()), ok_write(0x6001, 0));
    // TMR 0x800 < MUR 0x1000: 0x06040043 (the manual names no code, D16).
    assert_eq!(
        b.rx(ms(1), 0x63F, &[0x23, 0x02, 0x60, 0x00, 0x00, 0x08, 0x00, 0x00]),
        [(0x5BF, vec![0x80, 0x02, 0x60, 0x00, 0x43, 0x00, 0x04, 0x06])]
    );
    assert_eq!(read_u32(&mut b, 0x6002, 0), 0x10000, "the old TMR stays");
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &3u32.to_le_bytes()), abort(0x6002, 0, 0x0609_0030));
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &0x1000u32.to_le_bytes()), ok_write(0x6002, 0), "MUR = TMR: one turn");
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &0x2000u32.to_le_bytes()), abort(0x6001, 0, 0x0604_0043));
    assert_eq!(read_u32(&mut b, 0x6001, 0), 0x1000, "the old MUR stays");
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3u32.to_le_bytes()), abort(0x6001, 0, 0x0609_0032), "below 4");
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &0x4001u32.to_le_bytes()), abort(0x6001, 0, 0x0609_0031), "above 0x6501");
}

#[test]
fn a_preset_sets_the_position_at_once_and_survives_a_power_cycle_seed_11_24() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &36000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3600u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1010, 3, b"save"), ok_write(0x1010, 3));
    // Shaft at 12345 units: 12345 × 16384 / 3600 steps (rounded up, so the floor is 12345).
    let count = (12345 * STEPS).div_ceil(3600);
    move_to(&mut b, count);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 12345);
    assert_eq!(b.rx(b.now, 0x63F, &[0x23, 0x03, 0x60, 0x00, 0xE8, 0x03, 0x00, 0x00]), [(0x5BF, ok_write(0x6003, 0))]);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 1000, "the preset at once");
    assert_eq!(read_u32(&mut b, 0x6509, 0), (1000 + 36000 - 12345) as u32, "the offset 0x6509");
    turn(&mut b, STEPS as i64);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 4600, "and the shaft moves on from it");
    // Out of range: 36000 is not below TMR.
    assert_eq!(
        b.rx(b.now, 0x63F, &[0x23, 0x03, 0x60, 0x00, 0xA0, 0x8C, 0x00, 0x00]),
        [(0x5BF, vec![0x80, 0x03, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06])]
    );
    assert_eq!(read_u32(&mut b, 0x6004, 0), 4600, "unchanged by the refused preset");
    // Power cycle, no 0x1010 after the preset: the same shaft position shows 4600 again.
    let storage = b.node.storage_mut().clone();
    let mut again = encoder(storage, 0, count + STEPS);
    assert_eq!(read_u32(&mut again, 0x6004, 0), 4600, "the preset offset was stored");
    assert_eq!(read_u32(&mut again, 0x6003, 0), 1000);
}

#[test]
fn a_preset_without_scaling_counts_on_from_the_preset_s13() {
    let mut b = encoder(MemStorage::new(4096), 0, 19642);
    // §5.7.1 writes preset 0 with sub 00.
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00]), [(0x5BF, ok_write(0x6003, 0))]);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 0);
    turn(&mut b, -100);
    assert_eq!(read_u32(&mut b, 0x6004, 0), u32::MAX - 99, "below 0 wraps at 2^32");
}

/// D40: a preset below the position (a negative offset) with scaling off,
/// then MUR 3600 / TMR 36000: the preset point keeps the preset's value,
/// and the position is the preset plus the movement since, in the new
/// units (it showed 18015-like jumps when the offset kept its number,
/// wrapped from 2^32 into 36000).
#[test]
fn a_scaling_change_after_a_preset_keeps_the_preset_point() {
    let mut b = encoder(MemStorage::new(4096), 0, 20000);
    assert_eq!(b.sdo_write(0x3F, 0x6003, 0, &1000u32.to_le_bytes()), ok_write(0x6003, 0));
    assert_eq!(read_u32(&mut b, 0x6509, 0), (-19000i32) as u32, "offset -19000");
    // A quarter turn on: 1000 + 4096 steps.
    turn(&mut b, (STEPS / 4) as i64);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 5096);
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &36000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3600u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(read_u32(&mut b, 0x6004, 0), 5096, "scaling still off: nothing moved");
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    // The quarter turn since the preset is 900 units now.
    assert_eq!(read_u32(&mut b, 0x6004, 0), 1900);
    turn(&mut b, -((STEPS / 4) as i64));
    assert_eq!(read_u32(&mut b, 0x6004, 0), 1000, "back at the preset point: the preset");
    turn(&mut b, -(STEPS as i64));
    assert_eq!(read_u32(&mut b, 0x6004, 0), 36000 - 2600, "a turn below it wraps at TMR");
    // Saved with the scaling: the same after a power cycle.
    assert_eq!(b.sdo_write(0x3F, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    let storage = b.node.storage_mut().clone();
    let mut again = encoder(storage, 0, 20000 - STEPS);
    assert_eq!(read_u32(&mut again, 0x6004, 0), 36000 - 2600);
    // Scaling off again: the preset point shows 1000 once more, in steps.
    assert_eq!(again.sdo_write(0x3F, 0x6000, 0, &[0, 0]), ok_write(0x6000, 0));
    assert_eq!(read_u32(&mut again, 0x6004, 0), 1000u32.wrapping_sub(STEPS as u32));
}

#[test]
fn the_offset_follows_a_physical_wrap_over_a_power_cycle() {
    let range = 7 * STEPS;
    let mut b = encoder(MemStorage::new(4096), range, 6 * STEPS);
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &36000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3600u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &SCALING), ok_write(0x6000, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(read_u32(&mut b, 0x6004, 0), 21600);
    // Two turns forward: the counter wraps from 6 turns to 1.
    turn(&mut b, STEPS as i64);
    turn(&mut b, STEPS as i64);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 28800);
    let storage = b.node.storage_mut().clone();
    let mut again = encoder(storage, range, STEPS);
    assert_eq!(read_u32(&mut again, 0x6004, 0), 28800, "no jump after the power cycle either");
}
