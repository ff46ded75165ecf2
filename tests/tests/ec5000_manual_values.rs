//! The EC5000 manual's value vectors that no other test reads as frames
//! (device-review §1.4: the manual prints no byte-level frames, only
//! values): device type 0x420192 (M-L692), the version 0x67FE =
//! 00030100h (M-L1649), the revision 0x1018 sub 3 = 0x00010001, and the SI
//! units 0x60A8-0x60AA "FDh 01h 00h 00h" / "FDh 01h 03h 00h" / "FDh 01h 57h
//! 00h" (mm, mm/s, mm/s², M-L1562-1591), which are fixed (min = max =
//! default). Exact SDO frames on node 5.

mod common;

use common::ec5000::{Ec5000, ID};
use common::{Bench, abort, ms};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

fn node() -> Ec5000 {
    let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    b
}

#[track_caller]
fn read(b: &mut Ec5000, index: u16, sub: u8, value: [u8; 4]) {
    let [lo, hi] = index.to_le_bytes();
    let [v0, v1, v2, v3] = value;
    assert_eq!(b.rx(b.now, 0x605, &[0x40, lo, hi, sub, 0, 0, 0, 0]), [(0x585, vec![0x43, lo, hi, sub, v0, v1, v2, v3])]);
}

#[test]
fn l692_l1649_device_type_version_and_revision() {
    let mut b = node();
    read(&mut b, 0x1000, 0, 0x0042_0192u32.to_le_bytes());
    read(&mut b, 0x67FE, 0, 0x0003_0100u32.to_le_bytes());
    read(&mut b, 0x1018, 3, 0x0001_0001u32.to_le_bytes());
}

#[test]
fn l1562_si_units_millimetre_per_second_and_per_second_squared_are_fixed() {
    let mut b = node();
    // The manual prints the most significant byte first: FD (milli) 01 (metre) 00/03/57 (—, s, s²) 00.
    read(&mut b, 0x60A8, 0, [0x00, 0x00, 0x01, 0xFD]);
    read(&mut b, 0x60A9, 0, [0x00, 0x03, 0x01, 0xFD]);
    read(&mut b, 0x60AA, 0, [0x00, 0x57, 0x01, 0xFD]);
    // Min = max = default: metres (prefix 0) are refused, the same value is taken.
    assert_eq!(b.sdo_write(ID, 0x60A8, 0, &0x0001_0000u32.to_le_bytes()), abort(0x60A8, 0, 0x0609_0032));
    assert_eq!(b.sdo_write(ID, 0x60A9, 0, &0xFD01_0300u32.to_le_bytes()), common::ok_write(0x60A9, 0));
}
