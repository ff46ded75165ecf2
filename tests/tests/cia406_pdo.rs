//! CiA 406 process data on the Sendix, in virtual time: TPDO1 on the
//! cyclic timer 0x6200, TPDO2 with the position sampled at its SYNC, TPDO3
//! with the speed 0x6030 over the integration time 0x6031:02, and the
//! overspeed warning with its EMCY.

mod common;

use canopen_core::time::Instant;
use common::sendix::{Encoder, STEPS, encoder, move_to, read};
use common::{F, ms, ok_write};
use hal_host::storage::MemStorage;

fn on(frames: &[(Instant, F)], cob_id: u16) -> Vec<(u64, Vec<u8>)> {
    frames.iter().filter(|(_, f)| f.0 == cob_id).map(|(t, f)| (t.as_micros() / 1000, f.1.clone())).collect()
}

#[test]
fn cyclic_timer_sends_tpdo1_every_10_ms_s13_s18() {
    let mut b = encoder(MemStorage::new(4096), 0, 19642);
    assert_eq!(b.rx(ms(1), 0x63F, &[0x2B, 0x00, 0x62, 0x00, 0x0A, 0x00, 0x00, 0x00]), [(0x5BF, ok_write(0x6200, 0))]);
    b.nmt(0x01, 0x3F);
    let out = b.run_until(ms(41));
    let pos = vec![0xBA, 0x4C, 0x00, 0x00];
    assert_eq!(on(&out, 0x1BF), [(11, pos.clone()), (21, pos.clone()), (31, pos.clone()), (41, pos)], "the trace's frame every 10 ms");
    // Writing 0 stops it (and 0x1800:05 follows).
    assert_eq!(b.sdo_write(0x3F, 0x6200, 0, &[0, 0]), ok_write(0x6200, 0));
    assert_eq!(read(&mut b, 0x1800, 5), [0, 0]);
    assert_eq!(on(&b.run_until(ms(100)), 0x1BF), []);
}

#[test]
fn tpdo1_without_a_timer_goes_on_each_change_l839() {
    let mut b = encoder(MemStorage::new(4096), 0, 5);
    let started = b.nmt(0x01, 0x3F);
    assert!(started.contains(&(0x1BF, vec![5, 0, 0, 0])), "once on entering Operational: {started:x?}");
    let out = b.run_until(ms(10));
    assert_eq!(on(&out, 0x1BF), [], "then only on change");
    let sent = move_to(&mut b, 6);
    assert!(sent.contains(&(0x1BF, vec![6, 0, 0, 0])), "{sent:x?}");
}

#[test]
fn a_sync_tpdo_carries_the_position_sampled_at_that_sync_s14() {
    let mut b = encoder(MemStorage::new(4096), 0, 100);
    b.nmt(0x01, 0x3F);
    b.run_until(ms(5));
    // The shaft moves between two samples; the SYNC comes before the next one.
    b.node.app_mut().encoder.source.shaft.set(19642);
    let out = b.rx(ms(5), 0x080, &[]);
    assert!(out.contains(&(0x2BF, vec![0xBA, 0x4C, 0x00, 0x00])), "the position at the SYNC: {out:x?}");
    assert_eq!(out.iter().filter(|f| f.0 == 0x2BF).count(), 1, "exactly one TPDO2 per SYNC (TT 1)");
    // TT 3: one every third SYNC.
    b.nmt(0x80, 0x3F);
    assert_eq!(b.sdo_write(0x3F, 0x1801, 2, &[3]), ok_write(0x1801, 2));
    b.nmt(0x01, 0x3F);
    let mut t = 6;
    let mut tpdo2 = Vec::new();
    for _ in 0..6 {
        t += 1;
        let out = b.rx(ms(t), 0x080, &[]);
        tpdo2.push(out.iter().filter(|f| f.0 == 0x2BF).count());
    }
    assert_eq!(tpdo2, [0, 0, 1, 0, 0, 1]);
}

/// Turns the shaft at `steps_per_ms` (a fraction allowed: the count is
/// rounded from the time) for `duration` ms, sampling every 2 ms.
fn drive(b: &mut Encoder, steps_per_s: i64, until: u64) -> Vec<(Instant, F)> {
    let start = b.now.as_micros() / 1000;
    let base = b.node.app().encoder.source.shaft.get() as i64;
    let mut out = Vec::new();
    let mut t = start;
    while t < until {
        t += 2;
        let count = base + steps_per_s * (t - start) as i64 / 1000;
        b.node.app_mut().encoder.source.shaft.set(count as u64);
        out.extend(b.run_until(ms(t)));
    }
    out
}

#[test]
fn speed_in_units_per_second_over_100_ms_seed_11_29() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    // Units per second (bit 12), integration time 100 ms (the default).
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x00, 0x10]), ok_write(0x6000, 0));
    assert_eq!(read(&mut b, 0x6031, 2), [100, 0]);
    b.nmt(0x01, 0x3F);
    let out = drive(&mut b, 10_000, 300);
    let speed = on(&out, 0x3BF);
    assert_eq!(speed.last().map(|s| s.1.clone()), Some(vec![0x10, 0x27, 0x00, 0x00]), "10000 units/s on TPDO3: {speed:?}");
    assert_eq!(read(&mut b, 0x6030, 1), [0x10, 0x27, 0, 0]);
    let out = drive(&mut b, -10_000, 600);
    assert_eq!(on(&out, 0x3BF).last().map(|s| s.1.clone()), Some((-10_000i32).to_le_bytes().to_vec()), "negative backwards");
}

#[test]
fn speed_in_rpm_with_the_gear_factor() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6031, 2, &1000i16.to_le_bytes()), ok_write(0x6031, 2));
    drive(&mut b, STEPS as i64, 2100);
    assert_eq!(read(&mut b, 0x6030, 1), 60i32.to_le_bytes(), "one turn per second");
    assert_eq!(b.sdo_write(0x3F, 0x6031, 3, &3i16.to_le_bytes()), ok_write(0x6031, 3));
    assert_eq!(b.sdo_write(0x3F, 0x6031, 4, &2i16.to_le_bytes()), ok_write(0x6031, 4));
    drive(&mut b, STEPS as i64, 4100);
    assert_eq!(read(&mut b, 0x6030, 1), 90i32.to_le_bytes(), "× C1 / C2");
    assert_eq!(b.sdo_write(0x3F, 0x6031, 2, &4i16.to_le_bytes()), common::abort(0x6031, 2, 0x0609_0032), "below 5 ms");
}

#[test]
fn acceleration_follows_the_change_of_speed() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x00, 0x10]), ok_write(0x6000, 0));
    drive(&mut b, 10_000, 200);
    drive(&mut b, 20_000, 300);
    // +10000 units/s within one 100 ms gate: 100000 units/s².
    assert_eq!(read(&mut b, 0x6040, 1), 100_000i32.to_le_bytes());
}

#[test]
fn overspeed_sets_warning_bit_0_and_emcy_0x4200_once_l2572() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    // 250 turns per second: 15000 rpm, above the 12000 of the manual.
    let out = drive(&mut b, 250 * STEPS as i64, 300);
    assert_eq!(on(&out, 0x0BF), [(100, vec![0x00, 0x42, 0x09, 0, 0, 0, 0, 0])], "one EMCY while it lasts");
    assert_eq!(read(&mut b, 0x6505, 0), [0x01, 0x00]);
    let out = drive(&mut b, 0, 600);
    assert_eq!(on(&out, 0x0BF), [(400, vec![0; 8])], "the zero EMCY when it clears");
    assert_eq!(read(&mut b, 0x6505, 0), [0x00, 0x00]);
}

#[test]
fn the_event_timer_of_tpdo3_is_500_ms_s11() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.rx(ms(1), 0x63F, &[0x2B, 0x02, 0x18, 0x05, 0xF4, 0x01, 0x00, 0x00]), [(0x5BF, ok_write(0x1802, 5))]);
    b.nmt(0x01, 0x3F);
    let out = b.run_until(ms(1600));
    let times: Vec<u64> = on(&out, 0x3BF).into_iter().map(|(t, _)| t).collect();
    assert_eq!(times, [501, 1001, 1501], "speed 0 every 500 ms");
}
