//! The Sendix encoder on the bench with a shaft moved by hand.

use super::{Bench, F, ms};
use canopen_core::time::Duration;
use firmware::devices::sendix::{self, BenchSensor};
use hal_host::storage::MemStorage;

/// The Sendix (node 0x3F) on a hand-moved sensor.
pub type Encoder = Bench<sendix::od::Ram, sendix::App<BenchSensor>, MemStorage, 0, 3, 0>;

/// Steps per revolution of the M5868 (0x6501).
pub const STEPS: u64 = 0x4000;

/// Powers on at t = 0 with the shaft at `count` on a physical counter of
/// `range` steps (0: never wraps); the boot-up is checked.
pub fn encoder(storage: MemStorage, range: u64, count: u64) -> Encoder {
    let mut sensor = BenchSensor::new(range);
    sensor.shaft.set(count);
    let mut b = Bench::new(sendix::od::Ram::new(0x3F), sendix::App::with_sensor(sensor), storage, 0x3F);
    assert_eq!(b.at(ms(0)), [(0x73F, vec![0x00])]);
    b
}

/// Reads a value by SDO (expedited), as bytes.
pub fn read(b: &mut Encoder, index: u16, sub: u8) -> Vec<u8> {
    b.sdo_upload(0x3F, index, sub).expect("upload")
}

/// Reads a 32-bit value by SDO.
pub fn read_u32(b: &mut Encoder, index: u16, sub: u8) -> u32 {
    let v = read(b, index, sub);
    let mut a = [0u8; 4];
    a[..v.len()].copy_from_slice(&v);
    u32::from_le_bytes(a)
}

/// Moves the shaft to `count` and runs the node 2 ms later (one sensor
/// sample); returns what it sent.
pub fn move_to(b: &mut Encoder, count: u64) -> Vec<F> {
    b.node.app_mut().encoder.source.shaft.set(count);
    let t = b.now + Duration::from_millis(2);
    b.at(t)
}

/// Turns the shaft by `steps` and samples it 2 ms later.
pub fn turn(b: &mut Encoder, steps: i64) -> Vec<F> {
    b.node.app_mut().encoder.source.shaft.turn(steps);
    let t = b.now + Duration::from_millis(2);
    b.at(t)
}
