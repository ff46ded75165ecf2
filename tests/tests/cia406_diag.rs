//! CiA 406 diagnostics on the Sendix with exact frames: work-area state
//! bits 0x6400, alarms 0x6503 and warnings 0x6505 with the EMCY each raises
//! and the zero EMCY when it clears, the over-temperature EMCY of §5.8.2
//! with its 0x1029:02 reaction, and the operating time 0x6508.

mod common;

use canopen_core::profiles::cia406::SensorFault;
use common::sendix::{STEPS, encoder, move_to, read, read_u32};
use common::{ms, ok_write};
use firmware::devices::sendix::SensorTemperature;
use hal_host::storage::MemStorage;

#[test]
fn work_area_state_bits_seed_11_25() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    // §5.7.2: MUR 3600, TMR 36000, channel 1 from 1000 to 35000.
    assert_eq!(b.sdo_write(0x3F, 0x6002, 0, &36000u32.to_le_bytes()), ok_write(0x6002, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6001, 0, &3600u32.to_le_bytes()), ok_write(0x6001, 0));
    assert_eq!(b.sdo_write(0x3F, 0x6000, 0, &[0x04, 0x00]), ok_write(0x6000, 0));
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x01, 0x64, 0x01, 0xE8, 0x03, 0x00, 0x00]), [(0x5BF, ok_write(0x6401, 1))]);
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x02, 0x64, 0x01, 0xB8, 0x88, 0x00, 0x00]), [(0x5BF, ok_write(0x6402, 1))]);
    let at = |units: u64| (units * STEPS).div_ceil(3600);
    move_to(&mut b, at(500));
    assert_eq!(
        b.rx(b.now, 0x63F, &[0x40, 0x00, 0x64, 0x01, 0, 0, 0, 0]),
        [(0x5BF, vec![0x4F, 0x00, 0x64, 0x01, 0x04, 0, 0, 0])],
        "underflow"
    );
    move_to(&mut b, at(20000));
    assert_eq!(read(&mut b, 0x6400, 1), [0x00], "inside");
    move_to(&mut b, at(35500));
    assert_eq!(read(&mut b, 0x6400, 1), [0x02], "overflow");
    assert_eq!(read(&mut b, 0x6400, 2), [0x00], "channel 2 keeps its default limits 0..0x10000000");
}

#[test]
fn work_area_state_travels_in_a_tpdo() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x6401, 1, &1000u32.to_le_bytes()), ok_write(0x6401, 1));
    // TPDO3 = 0x6400:01 (8 bit), the mapping procedure in Pre-operational.
    assert_eq!(b.sdo_write(0x3F, 0x1802, 1, &0xC000_03BFu32.to_le_bytes()), ok_write(0x1802, 1));
    assert_eq!(b.sdo_write(0x3F, 0x1A02, 0, &[0]), ok_write(0x1A02, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1A02, 1, &0x6400_0108u32.to_le_bytes()), ok_write(0x1A02, 1));
    assert_eq!(b.sdo_write(0x3F, 0x1A02, 0, &[1]), ok_write(0x1A02, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1802, 1, &0x4000_03BFu32.to_le_bytes()), ok_write(0x1802, 1));
    let out = b.nmt(0x01, 0x3F);
    assert!(out.contains(&(0x3BF, vec![0x04])), "{out:x?}");
    let out = move_to(&mut b, 2000);
    assert!(out.contains(&(0x3BF, vec![0x00])), "{out:x?}");
}

#[test]
fn a_position_error_sets_alarm_bit_0_with_emcy_0x1000_l2696() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(read(&mut b, 0x6504, 0), [0x01, 0x80], "supported alarms");
    b.node.app_mut().encoder.source.shaft.set_fault(Some(SensorFault::Position));
    let out = b.run_until(ms(10));
    // §5.5.3: a position error sets bits 0 and 5 of the error register: 0x21.
    assert_eq!(out, [(ms(2), (0x0BF, vec![0x00, 0x10, 0x21, 0, 0, 0, 0, 0]))], "at the first sample");
    assert_eq!(read(&mut b, 0x6503, 0), [0x01, 0x00]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x21], "while it lasts");
    b.node.app_mut().encoder.source.shaft.set_fault(None);
    let out = b.run_until(ms(20));
    assert_eq!(out, [(ms(12), (0x0BF, vec![0; 8]))], "the zero EMCY when it clears");
    assert_eq!(read(&mut b, 0x6503, 0), [0x00, 0x00]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x00], "cleared after");
}

#[test]
fn a_multiturn_error_sends_0x5051_with_the_manual_bytes_l3689() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    b.node.app_mut().encoder.source.shaft.set_fault(Some(SensorFault::Multiturn));
    let out = b.run_until(ms(10));
    // §5.8.1: 0x5051 "Error Multiturn", bytes 03 05; the position is lost: 0x6503 bit 0, 0x1001 = 0x21.
    assert_eq!(out, [(ms(2), (0x0BF, vec![0x51, 0x50, 0x21, 0x03, 0x05, 0, 0, 0]))]);
    assert_eq!(read(&mut b, 0x6503, 0), [0x01, 0x00]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x21]);
    // The sensor stops answering: its EMCY goes out before 0x5051 clears, with no "error reset" between.
    b.node.app_mut().encoder.source.shaft.set_fault(Some(SensorFault::Sync));
    let out = b.run_until(ms(20));
    assert_eq!(out, [(ms(12), (0x0BF, vec![0x00, 0xFF, 0xA1, 0x13, 0x05, 0, 0, 0]))], "0x5051 still active: 0xA1");
    assert_eq!(read(&mut b, 0x6503, 0), [0x00, 0x80]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x81], "0x5051 cleared, 0xFF00 active");
    b.node.app_mut().encoder.source.shaft.set_fault(None);
    let out = b.run_until(ms(30));
    assert_eq!(out, [(ms(22), (0x0BF, vec![0; 8]))]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x00]);
}

#[test]
fn a_sensor_sync_failure_sends_0xff00_with_the_manual_bytes_l3682() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    b.node.app_mut().encoder.source.shaft.set_fault(Some(SensorFault::Sync));
    let out = b.run_until(ms(10));
    // §5.8.1: 0xFF00, manufacturer bytes 13 05 00 00 00; error register generic + manufacturer.
    assert_eq!(out.iter().map(|(_, f)| f.clone()).collect::<Vec<_>>(), [(0x0BF, vec![0x00, 0xFF, 0x81, 0x13, 0x05, 0, 0, 0])]);
    assert_eq!(read(&mut b, 0x6503, 0), [0x00, 0x80], "device error");
}

fn hot() -> SensorTemperature {
    // The §5.8.2 example: 22 °C (0x56) against an upper limit of 16 °C (0x50).
    SensorTemperature { tenths: 220, low: 0x20, high: 0x50, version: 0x2E }
}

#[test]
fn over_temperature_sends_the_manual_frame_s20_l3699() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(read(&mut b, 0x2150, 0), 259i16.to_le_bytes(), "room temperature, 0.1 °C");
    b.nmt(0x01, 0x3F);
    b.run_until(ms(500));
    b.node.app_mut().encoder.source.temperature = hot();
    let out = b.run_until(ms(1500));
    let emcy: Vec<_> = out.iter().filter(|(_, f)| f.0 == 0x0BF).map(|(t, f)| (t.as_micros() / 1000, f.1.clone())).collect();
    assert_eq!(emcy, [(1000, vec![0x00, 0x42, 0x09, 0x80, 0x56, 0x20, 0x50, 0x2E])]);
    assert_eq!(read(&mut b, 0x1001, 0), [0x09]);
    assert_eq!(read(&mut b, 0x6505, 0), [0x00, 0x40], "warning bit 14");
    assert_eq!(b.node.state(), canopen_core::services::nmt::NmtState::Operational, "0x1029:02 = 1 (default): no change");
    b.node.app_mut().encoder.source.temperature.tenths = 100;
    let out = b.run_until(ms(2500));
    assert!(out.iter().any(|(_, f)| *f == (0x0BF, vec![0; 8])), "cleared: {out:x?}");
}

#[test]
fn over_temperature_follows_0x1029_sub_2_l2003() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(b.sdo_write(0x3F, 0x1029, 2, &[0]), ok_write(0x1029, 2));
    b.nmt(0x01, 0x3F);
    b.node.app_mut().encoder.source.temperature = hot();
    b.run_until(ms(1000));
    assert_eq!(b.node.state(), canopen_core::services::nmt::NmtState::PreOperational, "0: to Pre-operational");
    assert_eq!(b.sdo_write(0x3F, 0x1029, 2, &[2]), ok_write(0x1029, 2));
    b.node.app_mut().encoder.source.temperature.tenths = 100;
    b.run_until(ms(2000));
    b.nmt(0x01, 0x3F);
    b.node.app_mut().encoder.source.temperature = hot();
    b.run_until(ms(3000));
    assert_eq!(b.node.state(), canopen_core::services::nmt::NmtState::Stopped, "2: to Stopped");
}

#[test]
fn a_preset_that_cannot_be_stored_raises_warning_bit_15_and_emcy_0x5200_l2750() {
    // A storage too small for a parameter set.
    let mut b = encoder(MemStorage::new(16), 0, 0);
    let out = b.rx(ms(1), 0x63F, &[0x23, 0x03, 0x60, 0x00, 0x10, 0x00, 0x00, 0x00]);
    // The failed store fails the write too (0x08000020 for a set that does not fit), but the position moved.
    assert_eq!(out, [(0x0BF, vec![0x00, 0x52, 0x01, 0, 0, 0, 0, 0]), (0x5BF, common::abort(0x6003, 0, 0x0800_0020))]);
    assert_eq!(read(&mut b, 0x6505, 0), [0x00, 0x80]);
    assert_eq!(read_u32(&mut b, 0x6004, 0), 0x10, "the preset still applies");
}

#[test]
fn a_preset_the_memory_fails_to_store_sends_0x5000_with_the_manual_bytes_l3688() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    // The flash stops taking writes (a power cut to the memory alone, as far as the node can tell).
    b.node.storage_mut().cut_after(0);
    let out = b.rx(ms(1), 0x63F, &[0x23, 0x03, 0x60, 0x00, 0x10, 0x00, 0x00, 0x00]);
    // §5.8.1: 0x5000 "Internal Memory Error NVM", bytes E1 01, then warning bit 15's 0x5200 (§5.5.45).
    assert_eq!(
        out,
        [
            (0x0BF, vec![0x00, 0x50, 0x01, 0xE1, 0x01, 0, 0, 0]),
            (0x0BF, vec![0x00, 0x52, 0x01, 0, 0, 0, 0, 0]),
            (0x5BF, common::abort(0x6003, 0, 0x0606_0000)),
        ]
    );
    assert_eq!(read(&mut b, 0x6505, 0), [0x00, 0x80]);
}

fn hours(tenths: u64) -> canopen_core::time::Instant {
    ms(tenths * 360_000)
}

#[test]
fn operating_time_counts_tenths_of_an_hour_and_on_after_a_power_cycle() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    assert_eq!(read_u32(&mut b, 0x6508, 0), 0);
    b.at(ms(359_999));
    assert_eq!(read_u32(&mut b, 0x6508, 0), 0);
    b.at(hours(2));
    assert_eq!(read_u32(&mut b, 0x6508, 0), 2);
    let steps = b.node.storage_mut().steps();
    b.at(hours(9));
    assert_eq!(b.node.storage_mut().steps(), steps, "nothing stored within the first hour");
    b.at(hours(10));
    assert!(b.node.storage_mut().steps() > steps, "stored at one hour");
    b.at(hours(13));
    assert_eq!(read_u32(&mut b, 0x6508, 0), 13);
    // Power cycle 1.3 h after power-on: the hour stored counts on.
    let storage = b.node.storage_mut().clone();
    let mut b = encoder(storage, 0, 0);
    assert_eq!(read_u32(&mut b, 0x6508, 0), 10);
    b.at(hours(1));
    assert_eq!(read_u32(&mut b, 0x6508, 0), 11);
    // An NMT reset node keeps counting from power-on, not from what is stored.
    b.at(hours(5));
    b.nmt(0x81, 0x3F);
    assert_eq!(read_u32(&mut b, 0x6508, 0), 15);
}

#[test]
fn a_restore_of_the_defaults_does_not_zero_the_operating_time() {
    let mut b = encoder(MemStorage::new(4096), 0, 0);
    b.at(hours(12));
    assert_eq!(b.sdo_write(0x3F, 0x1011, 1, &0x6461_6F6Cu32.to_le_bytes()), ok_write(0x1011, 1));
    b.nmt(0x81, 0x3F);
    assert_eq!(read_u32(&mut b, 0x6508, 0), 12, "the count goes on after the reset");
    assert_eq!(read(&mut b, 0x6000, 0), [0, 0]);
    // Nothing stored holds it now: it is stored again within the hour.
    b.at(hours(13));
    let storage = b.node.storage_mut().clone();
    let mut b = encoder(storage, 0, 0);
    assert_eq!(read_u32(&mut b, 0x6508, 0), 13);
}

#[test]
fn the_raw_position_crc_follows_the_raw_position_l2366() {
    let mut b = encoder(MemStorage::new(4096), 0, 19642);
    let crc = firmware::devices::sendix::crc16(&19642u32.to_le_bytes());
    assert_eq!(read(&mut b, 0x2162, 0), crc.to_le_bytes());
    move_to(&mut b, 1);
    assert_eq!(read(&mut b, 0x2162, 0), firmware::devices::sendix::crc16(&[1, 0, 0, 0]).to_le_bytes());
    // The catalogued check values of the same polynomial (CRC-16/CCITT-FALSE, XMODEM) over "123456789".
    assert_eq!(firmware::devices::sendix::crc16_ccitt(0xFFFF, b"123456789"), 0x29B1);
    assert_eq!(firmware::devices::sendix::crc16_ccitt(0x0000, b"123456789"), 0x31C3);
    assert_eq!(firmware::devices::sendix::crc16(b"123456789"), 0x5E86);
}
