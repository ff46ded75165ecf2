//! The EC5000's monitoring values 0x2200 (D49, D67) and traffic lights
//! 0x2210/0x2211 (D50, D68), read by SDO while the roller runs in virtual time.

mod common;

use canopen_core::axis::Injected;
use canopen_core::services::store;
use common::ec5000::*;
use common::ms;
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

fn u32_of(b: &mut Ec5000, index: u16, sub: u8) -> u32 {
    let v = b.sdo_upload(ID, index, sub).expect("upload");
    v.iter().rev().fold(0, |acc, byte| acc << 8 | u32::from(*byte))
}

fn i16_of(b: &mut Ec5000, sub: u8) -> i16 {
    let v = b.sdo_upload(ID, 0x2200, sub).expect("upload");
    i16::from_le_bytes([v[0], v[1]])
}

#[test]
fn uptime_working_time_start_stops_and_rotations() {
    let mut b = enabled();
    assert_eq!([u32_of(&mut b, 0x2200, 1), u32_of(&mut b, 0x2200, 2), u32_of(&mut b, 0x2200, 9)], [0, 0, 0], "at rest");
    // 100 mm/s for two seconds, then 0: one start, 220 mm with the ramps =
    // 25.2 motor revolutions at 469.6 inc/mm and 4096 inc/rev (D41).
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 100, 0, 0, 0]);
    b.run_until(ms(3000));
    b.rx(ms(3000), RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    b.run_until(ms(3500));
    assert_eq!(u32_of(&mut b, 0x2200, 1), 1, "one start");
    assert_eq!(u32_of(&mut b, 0x2200, 2), 2, "the roller turned for two seconds (and the ramps)");
    assert_eq!(b.sdo_upload(ID, 0x6064, 0), Ok(vec![220, 0, 0, 0]));
    assert_eq!(u32_of(&mut b, 0x2200, 9), 25, "motor revolutions");
    b.run_until(ms(4000));
    b.rx(ms(4000), RPDO3, &[0x0F, 0, 0x9C, 0xFF, 0xFF, 0xFF]);
    b.run_until(ms(4500));
    b.rx(ms(4500), RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    b.run_until(ms(10_200));
    assert_eq!(u32_of(&mut b, 0x2200, 1), 2, "the second start (backwards)");
    assert_eq!(u32_of(&mut b, 0x2200, 3), 10, "uptime [s] since power-on");
}

#[test]
fn quick_stops_are_counted() {
    let mut b = enabled();
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 100, 0, 0, 0]);
    b.run_until(ms(1500));
    b.rx(ms(1500), RPDO3, &[0x0B, 0, 100, 0, 0, 0]);
    b.run_until(ms(2000));
    assert_eq!(b.sdo_upload(ID, 0x2200, 7), Ok(vec![1, 0]));
    for (t, cw) in [(2100, 0x06), (2300, 0x0F), (2500, 0x0B)] {
        b.rx(ms(t), RPDO3, &[cw, 0, 0, 0, 0, 0]);
    }
    b.run_until(ms(2700));
    assert_eq!(b.sdo_upload(ID, 0x2200, 7), Ok(vec![2, 0]));
}

#[test]
fn temperatures_actual_lowest_and_highest() {
    let mut b = enabled();
    assert_eq!([i16_of(&mut b, 4), i16_of(&mut b, 5), i16_of(&mut b, 6)], [25, 25, 25]);
    roller(&mut b).axis.set_ambient(40);
    b.run_until(ms(900));
    roller(&mut b).axis.set_ambient(-5);
    b.run_until(ms(1100));
    roller(&mut b).axis.set_ambient(30);
    b.run_until(ms(1300));
    assert_eq!([i16_of(&mut b, 4), i16_of(&mut b, 5), i16_of(&mut b, 6)], [-5, 40, 30]);
}

#[test]
fn health_traffic_lights() {
    let mut b = enabled();
    let lights = |b: &mut Ec5000| [1, 2, 3].map(|sub| b.sdo_upload(ID, 0x2211, sub).expect("0x2211")[0]);
    assert_eq!(lights(&mut b), [0, 0, 0], "all green");
    assert_eq!(b.sdo_upload(ID, 0x2210, 0), Ok(vec![0]), "lifetime green");
    // The temperature warning: temperature yellow; one error in 0x1003: yellow.
    roller(&mut b).axis.set_ambient(95);
    b.run_until(ms(900));
    assert_eq!(lights(&mut b), [1, 0, 1]);
    // The over-temperature fault: red.
    roller(&mut b).axis.inject(Injected::OverTemperature);
    b.run_until(ms(1100));
    assert_eq!(lights(&mut b)[0], 2);
    // The DC link collapses: power red.
    roller(&mut b).axis.inject(Injected::UnderVoltage);
    b.run_until(ms(1300));
    assert_eq!(lights(&mut b)[1], 2);
    // Cooled and powered again: temperature and power green; 0x1003 cleared: green.
    roller(&mut b).axis.remove(Injected::OverTemperature);
    roller(&mut b).axis.remove(Injected::UnderVoltage);
    roller(&mut b).axis.set_ambient(25);
    b.run_until(ms(1500));
    assert_eq!(lights(&mut b)[..2], [2, 0], "temperature red until the fault is reset");
    b.rx(ms(1500), RPDO1, &[0x00, 0, 3, 0, 0, 0, 0]);
    b.rx(ms(1510), RPDO1, &[0x80, 0, 3, 0, 0, 0, 0]);
    b.sdo_download(ID, 0x1003, 0, &[0]).expect("clear the history");
    b.run_until(ms(1700));
    assert_eq!(lights(&mut b), [0, 0, 0]);
}

#[test]
fn a_full_error_history_is_red() {
    let mut b = enabled();
    // Eight warnings raised and cleared: 0x1003 full.
    for i in 0..8u64 {
        roller(&mut b).axis.set_ambient(95);
        b.run_until(ms(800 + 200 * i));
        roller(&mut b).axis.set_ambient(25);
        b.run_until(ms(900 + 200 * i));
    }
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![8]));
    assert_eq!(b.sdo_upload(ID, 0x2211, 3), Ok(vec![2]));
}

/// The remanent counters (D55): 0x2200 sub 1, 2, 4, 5, 7, 9.
fn counters(b: &mut Ec5000) -> [u32; 6] {
    [1, 2, 4, 5, 7, 9].map(|sub| u32_of(b, 0x2200, sub))
}

/// Two seconds at 100 mm/s and a quick stop in a 40 °C hall, then Switch on
/// disabled at 25 °C by 4000 ms: one start, 2 s working, 25 motor revolutions.
fn worked() -> Ec5000 {
    let mut b = enabled();
    roller(&mut b).axis.set_ambient(40);
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 100, 0, 0, 0]);
    b.run_until(ms(3000));
    b.rx(ms(3000), RPDO3, &[0x0B, 0, 100, 0, 0, 0]);
    b.run_until(ms(3500));
    roller(&mut b).axis.set_ambient(25);
    b.rx(ms(3500), RPDO3, &[0x00, 0, 0, 0, 0, 0]);
    b.run_until(ms(4000));
    assert_eq!(counters(&mut b), [1, 2, 25, 40, 1, 25]);
    b
}

/// Powers the roller on again on the storage `b` left, Operation enabled by 700 ms.
fn power_cycled(b: &mut Ec5000) -> Ec5000 {
    let mut storage = b.node.storage_mut().clone();
    storage.power_on();
    enabled_on(storage)
}

#[test]
fn l634_the_counters_are_stored_when_the_dc_link_collapses_and_survive_the_power_off() {
    let mut b = worked();
    let steps = b.node.storage_mut().steps();
    roller(&mut b).axis.inject(Injected::UnderVoltage);
    b.run_until(ms(4200));
    assert!(b.node.storage_mut().steps() > steps, "stored");
    let mut b = power_cycled(&mut b);
    assert_eq!(counters(&mut b), [1, 2, 25, 40, 1, 25], "as before the power-off");
    assert_eq!(u32_of(&mut b, 0x2200, 3), 0, "the uptime counts from power-on");
    // Counting goes on from there.
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 100, 0, 0, 0]);
    b.run_until(ms(3000));
    assert_eq!(counters(&mut b)[..2], [2, 4]);
}

#[test]
fn l634_without_a_warning_the_counters_of_the_last_8_hours_are_lost() {
    let mut b = worked();
    // Nothing stored yet: a power cut now starts from zero.
    assert_eq!(counters(&mut power_cycled(&mut b)), [0, 0, 25, 25, 0, 0]);
    // Every 8 hours of uptime the changed counters are stored.
    let steps = b.node.storage_mut().steps();
    b.run_until(ms(8 * 3600 * 1000 - 1000));
    assert_eq!(b.node.storage_mut().steps(), steps, "not before 8 h");
    b.run_until(ms(8 * 3600 * 1000 + 200));
    assert!(b.node.storage_mut().steps() > steps, "at 8 h");
    assert_eq!(counters(&mut power_cycled(&mut b)), [1, 2, 25, 40, 1, 25]);
}

#[test]
fn restoring_the_parameters_keeps_the_counters() {
    let mut b = worked();
    roller(&mut b).axis.inject(Injected::UnderVoltage);
    b.run_until(ms(4200));
    b.sdo_download(ID, 0x4231, 1, &100i16.to_le_bytes()).expect("0x4231");
    b.sdo_download(ID, 0x1010, 1, b"save").expect("save");
    // 0x1011 sub 1 "load": the parameters return to their defaults at the next
    // start, the roller's life counters stay.
    b.sdo_download(ID, 0x1011, 1, b"load").expect("load");
    let mut b = power_cycled(&mut b);
    assert_eq!(b.sdo_upload(ID, 0x4231, 1), Ok(95i16.to_le_bytes().to_vec()), "the default threshold");
    assert_eq!(counters(&mut b), [1, 2, 25, 40, 1, 25]);
}

#[test]
fn l653_the_power_average_is_the_mean_mechanical_power_of_each_hour_d67() {
    let mut b = enabled();
    // 436 mm/s (the rated 3,000 min⁻¹) against a load of 900 ‰: 950 ‰ of
    // the rated torque with the friction, 19 W of 0x4048's 20 W.
    roller(&mut b).axis.set_load(-900);
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 0xB4, 0x01, 0, 0]);
    b.run_until(ms(2000));
    assert_eq!([value(&mut b, 0x606C, 0), value(&mut b, 0x6077, 0)], [436, 950]);
    assert_eq!(b.sdo_upload(ID, 0x4048, 0), Ok(vec![20]));
    // For 3 minutes, then at rest and switched off: 0.95 Wh in the first
    // hour of uptime (the ramps add less than 1 J).
    b.run_until(ms(1000 + 180_000));
    roller(&mut b).axis.set_load(0);
    b.rx(ms(1000 + 180_000), RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    b.run_until(ms(1000 + 180_500));
    b.rx(ms(1000 + 180_500), RPDO3, &[0x06, 0, 0, 0, 0, 0]);
    b.run_until(ms(3_599_900));
    assert_eq!(b.sdo_upload(ID, 0x2200, 8), Ok(vec![0]), "not before the first hour is over");
    b.run_until(ms(3_600_000));
    assert_eq!(b.sdo_upload(ID, 0x2200, 8), Ok(vec![1]), "0.95 W on average, rounded");
    b.run_until(ms(7_200_000));
    assert_eq!(b.sdo_upload(ID, 0x2200, 8), Ok(vec![0]), "an hour at rest");
}

/// A roller whose stored counters (D55) say it turned `revolutions` motor
/// revolutions in its life, powered on and Operation enabled by 700 ms.
fn aged(revolutions: u32) -> Ec5000 {
    let dict = &ec5000::od::DICTIONARY;
    let mut image = vec![0; dict.defaults.len];
    dict.defaults.read(0, &mut image);
    dict.reset_application(&mut image, ID);
    dict.reset_communication(&mut image, ID);
    dict.write_unchecked(&mut image, 0x2200, 9, &revolutions.to_le_bytes()).expect("0x2200 sub 9");
    let mut storage = MemStorage::new(4096);
    store::save_objects(dict, &image, ID, &mut storage, 0x2200, 0x2200).expect("the counters");
    enabled_on(storage)
}

#[test]
fn the_lifetime_light_turns_yellow_at_90_percent_of_3_6e9_motor_revolutions_d68() {
    // 25 revolutions short of 3.24e9: green, until two seconds at 100 mm/s
    // (25.2 revolutions, as above) make the roller's life 90 % used.
    let mut b = aged(3_240_000_000 - 25);
    assert_eq!(b.sdo_upload(ID, 0x2210, 0), Ok(vec![0]), "green");
    b.rx(ms(1000), RPDO3, &[0x0F, 0, 100, 0, 0, 0]);
    b.run_until(ms(2900));
    assert_eq!(u32_of(&mut b, 0x2200, 9), 3_239_999_998);
    assert_eq!(b.sdo_upload(ID, 0x2210, 0), Ok(vec![0]), "still green");
    b.run_until(ms(3000));
    b.rx(ms(3000), RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    b.run_until(ms(3500));
    assert_eq!(u32_of(&mut b, 0x2200, 9), 3_240_000_000);
    assert_eq!(b.sdo_upload(ID, 0x2210, 0), Ok(vec![1]), "yellow");
    // Yellow from the start on a roller that old; never red (the manual's
    // legend for 0x2210 is "0=grün; 1=gelb").
    let mut b = aged(u32::MAX);
    assert_eq!(b.sdo_upload(ID, 0x2210, 0), Ok(vec![1]));
    assert_eq!(b.sdo_upload(ID, 0x2211, 1), Ok(vec![0]), "the health lights are not the lifetime's");
}
