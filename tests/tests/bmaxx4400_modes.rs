//! The Baumüller b maXX 4400 (seed 003), the rest of its modes and
//! positioning, as exact frames with time and the axis moving: interpolated
//! position as App. C describes it (60C0h-60C4h, M-L6237-6450: linear
//! interpolation, one record in 0x60C1 sub 1 taken on every SYNC, time period
//! 0x60C2 of 2, 4 or 8 ms) with the drive's position control −4 running the
//! same interpolation; the gear factor 0x604C (§4.4.6); the positioning EMCYs
//! 8600h with drive errors 196/197 (software limits, §4.4.3) and 200
//! (positioning without homing, §4.4.8). Decisions D58-D61 in
//! docs/devices/bmaxx4400.md; manual lines as "M-L" in the test names.

mod common;

use common::{Bench, abort, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

const ID: u8 = 4;
const SYNC: u16 = 0x080;
const RPDO2: u16 = 0x304;
const RPDO3: u16 = 0x404;
const TPDO3: u16 = 0x384;

fn i32_at(b: &mut Bmaxx, index: u16) -> i32 {
    let v = b.sdo_upload(ID, index, 0).expect("readable");
    i32::from_le_bytes([v[0], v[1], v[2], v[3]])
}

/// The ip set-up a PLC makes: RPDO3 = controlword + 0x60C1 sub 1, TPDO3 =
/// statusword + position demand 0x6062 on every SYNC (type 1); then
/// Operational and Operation enabled in `mode` (RPDO2) at 100-300 ms.
fn ip_ready(mode: i8) -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.map_pdo(ID, 0x1602, &[0x6040_0010, 0x60C1_0120]);
    b.map_pdo(ID, 0x1A02, &[0x6041_0010, 0x6062_0020]);
    assert_eq!(b.sdo_write(ID, 0x1802, 2, &[1]), ok_write(0x1802, 2));
    assert_eq!(b.sdo_write(ID, 0x6067, 0, &16u32.to_le_bytes()), ok_write(0x6067, 0), "position window");
    b.now = ms(10);
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, mode as u8]);
    }
    b.run_until(ms(400));
    b
}

/// At `t`: the record `target` with controlword `cw` (RPDO3), then a SYNC;
/// the TPDO3 the SYNC makes (statusword, position demand).
fn record_and_sync(b: &mut Bmaxx, t: u64, cw: u16, target: i32) -> (u16, i32) {
    b.run_until(ms(t));
    let [c0, c1] = cw.to_le_bytes();
    let [p0, p1, p2, p3] = target.to_le_bytes();
    b.rx(ms(t), RPDO3, &[c0, c1, p0, p1, p2, p3]);
    let out = b.rx(ms(t), SYNC, &[]);
    let tpdo: Vec<_> = out.iter().filter(|(id, _)| *id == TPDO3).collect();
    assert_eq!(tpdo.len(), 1, "one TPDO3 per SYNC at {t} ms: {out:x?}");
    let d = &tpdo[0].1;
    (u16::from_le_bytes([d[0], d[1]]), i32::from_le_bytes([d[2], d[3], d[4], d[5]]))
}

#[test]
fn m_l6237_ip_follows_the_records_of_every_sync_at_2_ms_and_reaches_the_last() {
    let mut b = ip_ready(7);
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![7]));
    // Bit 4 off: Operation enabled without ip active (bit 12 = 0), the axis stands.
    assert_eq!(record_and_sync(&mut b, 400, 0x000F, 0), (0x0637, 0));
    // Bit 4 on: ip active (bit 12). Records 1000 inc apart every 2 ms
    // (0x60C2 default 2 · 10^-3 s): 500,000 inc/s ≈ 458 min⁻¹. Each SYNC
    // shows the demand on the record of the SYNC before (one period behind).
    assert_eq!(record_and_sync(&mut b, 402, 0x001F, 0).0 & 0x1000, 0x1000, "ip mode active");
    for k in 1..=50 {
        let (status, demand) = record_and_sync(&mut b, 402 + 2 * k as u64, 0x001F, 1000 * k);
        // Target reached (bit 10) only while the demand stood on record 0 (SYNC 1).
        let reached = if k == 1 { 0x0400 } else { 0 };
        assert_eq!((status & 0x167F, demand), (0x1237 | reached, 1000 * (k - 1)), "SYNC {k}");
        if k == 40 {
            // Halfway between two SYNCs the demand is halfway between the records.
            b.run_until(ms(402 + 2 * k as u64 + 1));
            assert_eq!(i32_at(&mut b, 0x6062), 39_500);
            let rpm = i32_at(&mut b, 0x606C);
            assert!((440..=480).contains(&rpm), "the axis runs at the records' speed: {rpm} min⁻¹");
        }
    }
    // The master holds the last record: the axis settles on it, target reached.
    for k in 51..=150 {
        record_and_sync(&mut b, 402 + 2 * k as u64, 0x001F, 50_000);
    }
    let (status, demand) = record_and_sync(&mut b, 704, 0x001F, 50_000);
    assert_eq!((status, demand), (0x1637, 50_000), "target reached (bit 10), ip active (bit 12)");
    assert!((49_984..=50_016).contains(&i32_at(&mut b, 0x6064)), "within the position window");
    assert_eq!(i32_at(&mut b, 0x606C), 0);
    // Bit 4 off again: records are ignored, the axis stays.
    record_and_sync(&mut b, 706, 0x000F, 90_000);
    b.run_until(ms(800));
    assert_eq!(i32_at(&mut b, 0x6062), 50_000);
}

#[test]
fn m_l6237_a_halt_suspends_the_interpolation_and_brakes() {
    let mut b = ip_ready(7);
    assert_eq!(b.sdo_write(ID, 0x6084, 0, &65_536_000u32.to_le_bytes()), ok_write(0x6084, 0), "1000 rev/s²");
    record_and_sync(&mut b, 400, 0x001F, 0);
    for k in 1..=20 {
        record_and_sync(&mut b, 400 + 2 * k as u64, 0x001F, 1000 * k);
    }
    // Halt (bit 8) with 0x605D = 1 (slow down ramp): records are ignored, the demand brakes.
    assert_eq!(b.sdo_write(ID, 0x605D, 0, &1i16.to_le_bytes()), ok_write(0x605D, 0));
    let (_, at_halt) = record_and_sync(&mut b, 442, 0x011F, 21_000);
    for k in 22..=60 {
        record_and_sync(&mut b, 400 + 2 * k as u64, 0x011F, 1000 * k);
    }
    let (status, demand) = record_and_sync(&mut b, 522, 0x011F, 61_000);
    // 500,000 inc/s braked at 65,536,000 inc/s²: about 1,900 inc beyond where the halt came.
    assert!((at_halt + 1_500..=at_halt + 2_500).contains(&demand), "{at_halt} → {demand}");
    // 1000 rev/s² is twice what the motor can (500): the axis overshoots the demand and
    // the position loop brings it back; bit 10 waits until it stands (0x606C reads 0, D68).
    assert_eq!(status & 0x1400, 0x1000, "ip still enabled (bit 12), the axis still moving");
    assert!(i32_at(&mut b, 0x606C) < 0, "returning");
    let (status, _) = record_and_sync(&mut b, 600, 0x011F, 61_000);
    assert_eq!(status & 0x1400, 0x1400, "standing (bit 10), ip still enabled (bit 12)");
    assert_eq!(i32_at(&mut b, 0x606C), 0);
}

#[test]
fn m_l6336_time_period_4_ms_taken_when_sub_2_is_written_and_only_2_4_8_ms() {
    let mut b = ip_ready(7);
    // 4000 µs: sub 1 = 4, sub 2 = −3 (App. C's example); sub 1 alone is not taken.
    assert_eq!(b.sdo_write(ID, 0x60C2, 1, &[4]), ok_write(0x60C2, 1));
    record_and_sync(&mut b, 400, 0x001F, 0);
    record_and_sync(&mut b, 404, 0x001F, 4000);
    b.run_until(ms(405));
    assert_eq!(i32_at(&mut b, 0x6062), 2000, "2 ms period still: half-way after 1 ms");
    assert_eq!(b.sdo_write(ID, 0x60C2, 2, &[0xFD]), ok_write(0x60C2, 2));
    record_and_sync(&mut b, 408, 0x001F, 8000);
    b.run_until(ms(409));
    assert_eq!(i32_at(&mut b, 0x6062), 5000, "4 ms period: a quarter after 1 ms");
    b.run_until(ms(412));
    assert_eq!(i32_at(&mut b, 0x6062), 8000);
    // 3 ms, 1 ms and 16 ms are refused (0x06090030); the 4 ms stay.
    assert_eq!(b.sdo_write(ID, 0x60C2, 1, &[3]), ok_write(0x60C2, 1));
    assert_eq!(b.sdo_write(ID, 0x60C2, 2, &[0xFD]), abort(0x60C2, 2, 0x0609_0030));
    assert_eq!(b.sdo_write(ID, 0x60C2, 1, &[1]), ok_write(0x60C2, 1));
    assert_eq!(b.sdo_write(ID, 0x60C2, 2, &[0xFD]), abort(0x60C2, 2, 0x0609_0030));
    assert_eq!(b.sdo_write(ID, 0x60C2, 1, &[16]), ok_write(0x60C2, 1));
    assert_eq!(b.sdo_write(ID, 0x60C2, 2, &[0xFD]), abort(0x60C2, 2, 0x0609_0030));
    // 80 · 10^-4 s = 8 ms is allowed.
    assert_eq!(b.sdo_write(ID, 0x60C2, 1, &[80]), ok_write(0x60C2, 1));
    assert_eq!(b.sdo_write(ID, 0x60C2, 2, &[0xFC]), ok_write(0x60C2, 2));
    record_and_sync(&mut b, 420, 0x001F, 16_000);
    b.run_until(ms(422));
    assert_eq!(i32_at(&mut b, 0x6062), 10_000, "8 ms period: a quarter after 2 ms");
}

#[test]
fn m_l5293_position_control_minus_4_runs_the_interpolation_and_shows_minus_4() {
    let mut b = ip_ready(-4);
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![0xFC]));
    assert_eq!(b.sdo_upload(ID, 0x43E8, 0), Ok((-4i16).to_le_bytes().to_vec()), "P1000: drive mode −4");
    record_and_sync(&mut b, 400, 0x001F, 0);
    for k in 1..=10 {
        record_and_sync(&mut b, 400 + 2 * k as u64, 0x001F, 655 * k);
    }
    b.run_until(ms(600));
    assert!((6_534..=6_566).contains(&i32_at(&mut b, 0x6064)), "a tenth of a revolution");
}

#[test]
fn m_l6310_records_are_increments_whatever_the_user_units() {
    let mut b = ip_ready(7);
    // 36000 BE per revolution (§4.4.5): 0x60C1 still counts 65536 per revolution (y = x to P0369).
    assert_eq!(b.sdo_write(ID, 0x6092, 1, &36_000u32.to_le_bytes()), ok_write(0x6092, 1));
    record_and_sync(&mut b, 400, 0x001F, 0);
    record_and_sync(&mut b, 402, 0x001F, 65_536);
    b.run_until(ms(700));
    let inc = canopen_core::profiles::cia402::drive::Drive::position(&b.node.app().drive.drive);
    assert!((65_520..=65_552).contains(&inc), "one revolution: {inc}");
    assert!((35_990..=36_010).contains(&i32_at(&mut b, 0x6064)), "0x6064 in BE: 360.00°");
}

#[test]
fn m_l940_gear_factor_0x604c_10_to_5_doubles_the_motor_speed_of_0x60ff() {
    let mut b = ip_ready(3);
    // §4.4.6's example: numerator 10, denominator 5: 100 min⁻¹ at the object is 200 at the motor.
    assert_eq!(b.sdo_write(ID, 0x604C, 1, &10i32.to_le_bytes()), ok_write(0x604C, 1));
    assert_eq!(b.sdo_write(ID, 0x604C, 2, &5i32.to_le_bytes()), ok_write(0x604C, 2));
    // 30 min⁻¹ through RPDO4 (6040 + 60FF): the motor turns at 60 min⁻¹, one revolution a second.
    let v = 30i32.to_le_bytes();
    b.rx(ms(400), 0x504, &[0x0F, 0x00, v[0], v[1], v[2], v[3]]);
    b.run_until(ms(700));
    assert_eq!(i32_at(&mut b, 0x606C), 30, "0x606C in the object's units");
    assert_eq!(i32_at(&mut b, 0x606B), 30);
    let p = i32_at(&mut b, 0x6064);
    b.run_until(ms(1700));
    let moved = i32_at(&mut b, 0x6064) - p;
    assert!((65_000..=66_100).contains(&moved), "one motor revolution in a second: {moved}");
    // A negative factor turns the other way; a zero denominator and ±33000 overrun are refused.
    assert_eq!(b.sdo_write(ID, 0x604C, 1, &(-10i32).to_le_bytes()), ok_write(0x604C, 1));
    b.run_until(ms(2000));
    assert_eq!(i32_at(&mut b, 0x606C), 30, "-30 min⁻¹ at the motor read back through -10/5");
    assert!(canopen_core::profiles::cia402::drive::Drive::velocity(&b.node.app().drive.drive) < 0, "turning backwards");
    assert_eq!(b.sdo_write(ID, 0x604C, 2, &0i32.to_le_bytes()), abort(0x604C, 2, 0x0609_0030));
    assert_eq!(b.sdo_write(ID, 0x604C, 1, &33_001i32.to_le_bytes()), abort(0x604C, 1, 0x0609_0031));
    assert_eq!(b.sdo_write(ID, 0x604C, 2, &(-33_001i32).to_le_bytes()), abort(0x604C, 2, 0x0609_0032));
}

#[test]
fn m_l940_gear_factor_0x604c_applies_to_the_vl_objects_6042_6043_6044_and_their_ramp() {
    let mut b = ip_ready(2);
    assert_eq!(b.sdo_write(ID, 0x604C, 1, &10i32.to_le_bytes()), ok_write(0x604C, 1));
    assert_eq!(b.sdo_write(ID, 0x604C, 2, &5i32.to_le_bytes()), ok_write(0x604C, 2));
    // §4.4.6 lists 6042h, 6043h, 6048h among the objects the factor scales: a ramp of
    // 60 per second in the object's units, then 30 min⁻¹ (INTEGER16) by SDO at 400 ms.
    assert_eq!(b.sdo_write(ID, 0x6048, 1, &60u32.to_le_bytes()), ok_write(0x6048, 1));
    assert_eq!(b.sdo_write(ID, 0x6048, 2, &1u16.to_le_bytes()), ok_write(0x6048, 2));
    b.run_until(ms(400));
    assert_eq!(b.sdo_write(ID, 0x6042, 0, &30i16.to_le_bytes()), ok_write(0x6042, 0));
    b.run_until(ms(650));
    let demand = b.sdo_upload(ID, 0x6043, 0).map(|v| i16::from_le_bytes([v[0], v[1]]));
    assert_eq!(demand, Ok(15), "half-way up the ramp after 250 ms, in the object's units");
    b.run_until(ms(1200));
    assert_eq!(b.sdo_upload(ID, 0x6044, 0), Ok(30i16.to_le_bytes().to_vec()), "0x6044 in the object's units");
    assert_eq!(b.sdo_upload(ID, 0x6043, 0), Ok(30i16.to_le_bytes().to_vec()));
    // The motor turns at 60 min⁻¹: one revolution (65536 increments) a second.
    let p = i32_at(&mut b, 0x6064);
    b.run_until(ms(2200));
    let moved = i32_at(&mut b, 0x6064) - p;
    assert!((65_000..=66_100).contains(&moved), "one motor revolution in a second: {moved}");
    // A negative factor turns the motor the other way; 0x6044 reads 30 through it.
    assert_eq!(b.sdo_write(ID, 0x604C, 1, &(-10i32).to_le_bytes()), ok_write(0x604C, 1));
    b.run_until(ms(4000));
    assert_eq!(b.sdo_upload(ID, 0x6044, 0), Ok(30i16.to_le_bytes().to_vec()));
    let p = i32_at(&mut b, 0x6064);
    b.run_until(ms(5000));
    let moved = i32_at(&mut b, 0x6064) - p;
    assert!((-66_100..=-65_000).contains(&moved), "one revolution backwards: {moved}");
}

const RPDO1: u16 = 0x204;
const EMCY: u16 = 0x084;

/// The EMCY frames among `out`.
fn emcys(out: &[(u16, Vec<u8>)]) -> Vec<Vec<u8>> {
    out.iter().filter(|(id, _)| *id == EMCY).map(|(_, d)| d.clone()).collect()
}

/// Operation enabled in pp after a homing on the current position (method 35) at 100-320 ms.
fn pp_homed() -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    assert_eq!(b.sdo_write(ID, 0x6098, 0, &[35]), ok_write(0x6098, 0));
    for (t, cw, mode) in [(100, 0x06u8, 6u8), (200, 0x07, 6), (300, 0x0F, 6), (310, 0x1F, 6), (320, 0x0F, 1)] {
        let out = b.rx(ms(t), RPDO2, &[cw, 0, mode]);
        assert_eq!(emcys(&out), Vec::<Vec<u8>>::new(), "{t} ms");
    }
    b
}

#[test]
fn m_l856_a_target_beyond_software_limit_2_is_emcy_8600_drive_error_197_and_no_motion() {
    let mut b = pp_homed();
    assert_eq!(b.sdo_write(ID, 0x607D, 1, &(-100_000i32).to_le_bytes()), ok_write(0x607D, 1));
    assert_eq!(b.sdo_write(ID, 0x607D, 2, &100_000i32.to_le_bytes()), ok_write(0x607D, 2));
    // 0x605A = 2: the drive brakes on the quick stop ramp ("Verhalten über 605Ahex einstellbar").
    assert_eq!(b.sdo_write(ID, 0x605A, 0, &2i16.to_le_bytes()), ok_write(0x605A, 0));
    let t = 200_000i32.to_le_bytes();
    let out = b.rx(ms(400), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    // EMCY 8600h, the error register as the core derives it (as for 8611h in B16), drive
    // error 00C5h (197) in bytes 3-4.
    assert_eq!(emcys(&out), [vec![0x00, 0x86, 0x11, 0x00, 0xC5, 0, 0, 0]]);
    b.run_until(ms(600));
    assert_eq!(b.sdo_upload(ID, 0x6041, 0).map(|v| v[0] & 0x4F), Ok(0x08), "Fault");
    assert_eq!(i32_at(&mut b, 0x6064), 0, "no motion");
    // Fault reset (RPDO1): "no error"; the next target inside the limits moves.
    let out = b.rx(ms(600), RPDO1, &[0x80, 0x00]);
    assert_eq!(emcys(&out), [vec![0; 8]]);
    for (t, cw) in [(610, 0x06u8), (620, 0x07), (630, 0x0F)] {
        b.rx(ms(t), RPDO1, &[cw, 0]);
    }
    // Below limit 1: drive error 00C4h (196).
    let t = (-150_000i32).to_le_bytes();
    let out = b.rx(ms(700), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    assert_eq!(emcys(&out), [vec![0x00, 0x86, 0x11, 0x00, 0xC4, 0, 0, 0]]);
    b.rx(ms(800), RPDO1, &[0x80, 0x00]);
    for (t, cw) in [(810, 0x06u8), (820, 0x07), (830, 0x0F)] {
        b.rx(ms(t), RPDO1, &[cw, 0]);
    }
    let t = 65_536i32.to_le_bytes();
    let out = b.rx(ms(900), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    assert_eq!(emcys(&out), Vec::<Vec<u8>>::new());
    b.rx(ms(910), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
    b.run_until(ms(2500));
    assert!((65_520..=65_552).contains(&i32_at(&mut b, 0x6064)), "one revolution");
}

#[test]
fn m_l1002_positioning_without_homing_is_emcy_8600_drive_error_200_until_homed_and_acknowledged() {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    b.rx(ms(100), RPDO2, &[0x06, 0, 1]);
    b.rx(ms(200), RPDO2, &[0x07, 0, 1]);
    // Enabled in pp without a homing since power-on: EMCY 8600h, drive error 00C8h (200), once.
    let out = b.rx(ms(300), RPDO2, &[0x0F, 0, 1]);
    assert_eq!(emcys(&out), [vec![0x00, 0x86, 0x11, 0x00, 0xC8, 0, 0, 0]]);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x02]), "Operation enabled: the drive holds its position");
    // A set-point is not taken (no acknowledge, no motion, no second EMCY).
    let t = 65_536i32.to_le_bytes();
    let out = b.rx(ms(400), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    assert_eq!(emcys(&out), Vec::<Vec<u8>>::new());
    b.run_until(ms(600));
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x06]), "standing on its position, no set-point acknowledge (bit 12)");
    assert_eq!(i32_at(&mut b, 0x6064), 0);
    // A fault reset before homing does not acknowledge it.
    let out = b.rx(ms(600), RPDO1, &[0x8F, 0x00]);
    assert_eq!(emcys(&out), Vec::<Vec<u8>>::new());
    // Homing on the current position (hm, method 35), back to pp, fault reset: "no error".
    assert_eq!(b.sdo_write(ID, 0x6098, 0, &[35]), ok_write(0x6098, 0));
    b.rx(ms(700), RPDO2, &[0x0F, 0, 6]);
    b.rx(ms(710), RPDO2, &[0x1F, 0, 6]);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x16]), "homing attained");
    b.rx(ms(720), RPDO2, &[0x0F, 0, 1]);
    let out = b.rx(ms(730), RPDO1, &[0x8F, 0x00]);
    assert_eq!(emcys(&out), [vec![0; 8]]);
    // Now the set-point moves the axis.
    b.rx(ms(740), RPDO1, &[0x0F, 0x00]);
    b.rx(ms(750), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    b.rx(ms(760), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
    b.run_until(ms(2500));
    assert!((65_520..=65_552).contains(&i32_at(&mut b, 0x6064)), "one revolution");
}

#[test]
fn m_l1074_other_positioning_modes_than_p0601_9_need_no_homing() {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    assert_eq!(b.sdo_write(ID, 0x4259, 0, &10i16.to_le_bytes()), ok_write(0x4259, 0));
    let mut emcy = Vec::new();
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        emcy.extend(emcys(&b.rx(ms(t), RPDO2, &[cw, 0, 1])));
    }
    let t = 65_536i32.to_le_bytes();
    emcy.extend(emcys(&b.rx(ms(400), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]])));
    b.rx(ms(410), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
    b.run_until(ms(2000));
    assert_eq!(emcy, Vec::<Vec<u8>>::new());
    assert!((65_520..=65_552).contains(&i32_at(&mut b, 0x6064)), "one revolution");
}

/// Operation enabled in `mode` (RPDO2) at 100-300 ms, without a homing.
fn enabled_in(mode: u8) -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, mode]);
    }
    b
}

/// The EMCY frames with their time [ms] up to `until`.
fn emcys_until(b: &mut Bmaxx, until: u64) -> Vec<(u64, Vec<u8>)> {
    b.run_until(ms(until)).into_iter().filter(|(_, (id, _))| *id == EMCY).map(|(t, (_, d))| (t.as_micros() / 1000, d)).collect()
}

#[test]
fn m_l876_running_onto_a_hardware_limit_switch_is_emcy_8600_drive_error_198_or_199() {
    // pv (−3, speed control) at 3000 min⁻¹ from 300 ms: the positive switch sits 100
    // revolutions out (D65), reached 2.05 s later (0.1 s ramp, then 50 revolutions a second).
    let mut b = enabled_in(0xFD);
    // 0x605A = 2: the drive brakes on the quick stop ramp, as for the software limits.
    assert_eq!(b.sdo_write(ID, 0x605A, 0, &2i16.to_le_bytes()), ok_write(0x605A, 0));
    assert_eq!(b.sdo_write(ID, 0x60FF, 0, &3000i32.to_le_bytes()), ok_write(0x60FF, 0));
    b.run_until(ms(2000));
    // "Fehlerauslösung bei Fahrt in Hardware-Endschalter": EMCY 8600h, drive error 199 (00C7h).
    assert_eq!(emcys_until(&mut b, 3000), [(2350, vec![0x00, 0x86, 0x11, 0x00, 0xC7, 0, 0, 0])]);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0).map(|v| v[0] & 0x4F), Ok(0x08), "Fault");
    assert!(i32_at(&mut b, 0x6064) >= 100 * 65536, "on the switch");
    assert_eq!(i32_at(&mut b, 0x606C), 0, "stopped on the quick stop ramp");
    // Fault reset, enabled again, out of the switch at −600 min⁻¹: no new error.
    b.rx(ms(6000), RPDO2, &[0x80, 0, 0xFD]);
    assert_eq!(b.sdo_write(ID, 0x60FF, 0, &(-600i32).to_le_bytes()), ok_write(0x60FF, 0));
    for (t, cw) in [(6010, 0x06u8), (6020, 0x07), (6030, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, 0xFD]);
    }
    assert_eq!(emcys_until(&mut b, 8000), []);
    assert!(i32_at(&mut b, 0x6064) < 100 * 65536, "off the switch");
    // The other way, the negative switch: drive error 198 (00C6h).
    assert_eq!(b.sdo_write(ID, 0x60FF, 0, &(-3000i32).to_le_bytes()), ok_write(0x60FF, 0));
    let emcy = emcys_until(&mut b, 13_000);
    assert_eq!(emcy.iter().map(|(_, d)| d.clone()).collect::<Vec<_>>(), [vec![0x00, 0x86, 0x11, 0x00, 0xC6, 0, 0, 0]]);
}

#[test]
fn m_l1002_homing_methods_17_and_18_find_the_hardware_limit_switches() {
    // hm, method 17 (negative limit switch) at 3,276,800 BE/s (50 revolutions a second),
    // leaving it at 65,536 BE/s; its edge is home, 0x607C = 1000. No EMCY: the switch is
    // the homing's target.
    let mut b = enabled_in(6);
    assert_eq!(b.sdo_write(ID, 0x6098, 0, &[17]), ok_write(0x6098, 0));
    assert_eq!(b.sdo_write(ID, 0x6099, 1, &3_276_800u32.to_le_bytes()), ok_write(0x6099, 1));
    assert_eq!(b.sdo_write(ID, 0x6099, 2, &65_536u32.to_le_bytes()), ok_write(0x6099, 2));
    assert_eq!(b.sdo_write(ID, 0x607C, 0, &1000i32.to_le_bytes()), ok_write(0x607C, 0));
    b.rx(ms(400), RPDO2, &[0x1F, 0, 6]);
    assert_eq!(emcys_until(&mut b, 5000), []);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x16]), "homing attained (bits 12, 10)");
    // Home is the edge; the axis stops from the zero speed 4 increments past it.
    assert_eq!(i32_at(&mut b, 0x6064), 1004, "home");
    // Method 18 (positive switch), then pp takes set-points: the CANopen positioning mode's homing.
    assert_eq!(b.sdo_write(ID, 0x6098, 0, &[18]), ok_write(0x6098, 0));
    b.rx(ms(5000), RPDO2, &[0x0F, 0, 6]);
    b.rx(ms(5010), RPDO2, &[0x1F, 0, 6]);
    assert_eq!(emcys_until(&mut b, 12_000), []);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x16]), "homing attained");
    assert_eq!(i32_at(&mut b, 0x6064), 999, "home; the axis stops from the zero speed one increment short");
    b.rx(ms(12_000), RPDO2, &[0x0F, 0, 1]);
    let t = 65_536i32.to_le_bytes();
    assert_eq!(emcys(&b.rx(ms(12_010), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]])), Vec::<Vec<u8>>::new());
    b.rx(ms(12_020), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
    b.run_until(ms(20_000));
    assert!((65_520..=65_552).contains(&i32_at(&mut b, 0x6064)), "one revolution from home");
}

#[test]
fn m_l1081_p0601_4_takes_every_target_as_relative_whatever_controlword_bit_6() {
    // "Relativ, positive und negativ (Wert 4): … keine Umschaltung 'absolut/relativ' über das
    // Steuerwort": two set-points of one revolution with bit 6 clear move two revolutions.
    // (P0601 ≠ 9: no homing required, D61.)
    let mut b = enabled_in(1);
    assert_eq!(b.sdo_write(ID, 0x4259, 0, &4i16.to_le_bytes()), ok_write(0x4259, 0));
    let t = 65_536i32.to_le_bytes();
    for (start, expected) in [(400u64, 65_536i32), (2500, 131_072)] {
        assert_eq!(emcys(&b.rx(ms(start), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]])), Vec::<Vec<u8>>::new());
        b.rx(ms(start + 10), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
        b.run_until(ms(start + 2000));
        let at = i32_at(&mut b, 0x6064);
        assert!((expected - 16..=expected + 16).contains(&at), "{at} after the set-point at {start} ms");
    }
    // P0601 = 10 ("Absolut relativ"): bit 6 clear is absolute again, the axis goes back to one revolution.
    assert_eq!(b.sdo_write(ID, 0x4259, 0, &10i16.to_le_bytes()), ok_write(0x4259, 0));
    b.rx(ms(4600), RPDO3, &[0x1F, 0x00, t[0], t[1], t[2], t[3]]);
    b.rx(ms(4610), RPDO3, &[0x0F, 0x00, t[0], t[1], t[2], t[3]]);
    b.run_until(ms(6600));
    assert!((65_520..=65_552).contains(&i32_at(&mut b, 0x6064)), "absolute with P0601 = 10");
}

#[test]
fn m_l1060_the_cards_start_sets_p0601_to_9_unless_p1190_bit_9() {
    // "In P1190 mit Bit 9 ist es möglich das automatische Einstellen des Modus 'Absolut /
    // Relativ CANopen' während der Init Phase der CANopen Optionskarte zu deaktivieren".
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    let p0601 = |b: &mut Bmaxx| b.sdo_upload(ID, 0x4259, 0).expect("P0601");
    for (p1190, after_reset) in [(0x0000u16, 9i16), (0x0200, 4)] {
        assert_eq!(b.sdo_write(ID, 0x44A6, 0, &p1190.to_le_bytes()), ok_write(0x44A6, 0));
        assert_eq!(b.sdo_write(ID, 0x4259, 0, &4i16.to_le_bytes()), ok_write(0x4259, 0));
        assert_eq!(b.nmt(0x82, ID), [(0x704, vec![0x00])]);
        assert_eq!(p0601(&mut b), after_reset.to_le_bytes().to_vec(), "P1190 = {p1190:04X}h");
    }
}

/// D51: an unused 0x6060 value (0, 5) that an RPDO carries keeps the mode, as the SDO write's
/// refusal 0x06090030 does: the drive keeps running pv and 0x6060/0x6061 read 3.
#[test]
fn m_l5241_an_unused_mode_by_rpdo2_keeps_the_mode_as_the_sdo_refusal_does() {
    let mut b = enabled_in(3);
    b.run_until(ms(400));
    assert_eq!(b.sdo_write(ID, 0x6060, 0, &[0]), abort(0x6060, 0, 0x0609_0030));
    for (t, unused) in [(500, 0u8), (600, 5)] {
        b.rx(ms(t), RPDO2, &[0x0F, 0, unused]);
        b.run_until(ms(t + 50));
        assert_eq!(b.sdo_upload(ID, 0x6060, 0), Ok(vec![3]), "0x6060 after {unused} by RPDO2");
        assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![3]), "0x6061 after {unused} by RPDO2");
    }
    // A used value by RPDO2 still switches: −3 runs pv and shows 3, 0x6060 reads −3.
    b.rx(ms(700), RPDO2, &[0x0F, 0, 0xFD]);
    b.run_until(ms(750));
    assert_eq!(b.sdo_upload(ID, 0x6060, 0), Ok(vec![0xFD]));
    b.rx(ms(800), RPDO2, &[0x0F, 0, 0]);
    b.run_until(ms(850));
    assert_eq!(b.sdo_upload(ID, 0x6060, 0), Ok(vec![0xFD]), "−3 kept");
    assert_eq!(b.sdo_upload(ID, 0x6061, 0), Ok(vec![3]));
}
