//! The EC5000's monitoring values 0x2200 (D49) and traffic lights
//! 0x2210/0x2211 (D50), read by SDO while the roller runs in virtual time.

mod common;

use canopen_core::axis::Injected;
use common::{Bench, ms};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
const RPDO1: u16 = 0x205;
const RPDO3: u16 = 0x405;

type Ec5000 = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

/// Operational at 10 ms, Operation enabled in pv at rest by 700 ms.
fn enabled() -> Ec5000 {
    let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06), (300, 0x07), (500, 0x0F)] {
        b.rx(ms(t), RPDO1, &[cw, 0, 3, 0, 0, 0, 0]);
    }
    b.run_until(ms(700));
    b
}

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
    b.node.app_mut().drive.drive.axis.set_ambient(40);
    b.run_until(ms(900));
    b.node.app_mut().drive.drive.axis.set_ambient(-5);
    b.run_until(ms(1100));
    b.node.app_mut().drive.drive.axis.set_ambient(30);
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
    b.node.app_mut().drive.drive.axis.set_ambient(95);
    b.run_until(ms(900));
    assert_eq!(lights(&mut b), [1, 0, 1]);
    // The over-temperature fault: red.
    b.node.app_mut().drive.drive.axis.inject(Injected::OverTemperature);
    b.run_until(ms(1100));
    assert_eq!(lights(&mut b)[0], 2);
    // The DC link collapses: power red.
    b.node.app_mut().drive.drive.axis.inject(Injected::UnderVoltage);
    b.run_until(ms(1300));
    assert_eq!(lights(&mut b)[1], 2);
    // Cooled and powered again: temperature and power green; 0x1003 cleared: green.
    b.node.app_mut().drive.drive.axis.remove(Injected::OverTemperature);
    b.node.app_mut().drive.drive.axis.remove(Injected::UnderVoltage);
    b.node.app_mut().drive.drive.axis.set_ambient(25);
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
        b.node.app_mut().drive.drive.axis.set_ambient(95);
        b.run_until(ms(800 + 200 * i));
        b.node.app_mut().drive.drive.axis.set_ambient(25);
        b.run_until(ms(900 + 200 * i));
    }
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![8]));
    assert_eq!(b.sdo_upload(ID, 0x2211, 3), Ok(vec![2]));
}
