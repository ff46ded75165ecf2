//! The EC5000's fixed PDOs (M §7, L885-1249; D7, D11-D15) as a PLC sees them:
//! the mappings as printed, TPDO1/TPDO2 on change at most every 100 ms
//! (inhibit time) and at least every 2000 ms (event timer), TPDO3 on SYNC,
//! PDO4 silent while unmapped; and the 0x6007 reactions 0-3 (M §5.2,
//! L611-626; D44) on a heartbeat loss, with the frames and their times.

mod common;

use common::ec5000::*;
use common::ms;

fn u32_of(b: &mut Ec5000, index: u16, sub: u8) -> u32 {
    let v = b.sdo_upload(ID, index, sub).expect("upload");
    v.iter().rev().fold(0, |acc, byte| acc << 8 | u32::from(*byte))
}

#[test]
fn l944_l1156_the_mappings_and_timing_parameters_as_printed() {
    let mut b = enabled();
    // RPDO1-3 (D7: three and two entries), TPDO1-3; PDO4 empty.
    let map = |b: &mut Ec5000, index: u16| {
        let n = value(b, index, 0) as u8;
        (1..=n).map(|sub| u32_of(b, index, sub)).collect::<Vec<_>>()
    };
    assert_eq!(map(&mut b, 0x1600), [0x6040_0010, 0x6060_0008, 0x6081_0020]);
    assert_eq!(map(&mut b, 0x1601), [0x6040_0010, 0x607A_0020]);
    assert_eq!(map(&mut b, 0x1602), [0x6040_0010, 0x60FF_0020]);
    assert_eq!(map(&mut b, 0x1603), []);
    assert_eq!(map(&mut b, 0x1A00), [0x6041_0010, 0x6061_0008, 0x1001_0008, 0x2200_0610, 0x6077_0010]);
    assert_eq!(map(&mut b, 0x1A01), [0x6041_0010, 0x6064_0020]);
    assert_eq!(map(&mut b, 0x1A02), [0x6041_0010, 0x606C_0020]);
    assert_eq!(map(&mut b, 0x1A03), []);
    // Transmission type, inhibit time [100 µs] and event timer [ms] of TPDO1-4 (L1062-1152).
    for (n, tt) in [(0, 255), (1, 255), (2, 1), (3, 255)] {
        assert_eq!([2, 3, 5].map(|sub| u32_of(&mut b, 0x1800 + n, sub)), [tt, 1000, 2000], "TPDO{}", n + 1);
    }
    // PDO1-3 are static (D11): entries read-only, sub 0 constant.
    assert_eq!(b.sdo_download(ID, 0x1A00, 1, &0x6041_0010u32.to_le_bytes()), Err(0x0601_0002));
    assert_eq!(b.sdo_download(ID, 0x1600, 0, &[0]), Err(0x0601_0002));
}

#[test]
fn l1066_tpdo1_tpdo2_every_2000_ms_on_change_after_100_ms_and_tpdo3_on_sync() {
    let mut b = enabled();
    // At rest nothing changes: the event timers send TPDO1 and TPDO2 every 2 s.
    let at_rest = (TPDO1, vec![0x37, 0x16, 3, 0, 25, 0, 0, 0]);
    let at_rest2 = (TPDO2, vec![0x37, 0x16, 0, 0, 0, 0]);
    assert_eq!(
        frames(&mut b, 700, 4500),
        [
            (1900, at_rest.0, at_rest.1.clone()),
            (1900, at_rest2.0, at_rest2.1.clone()),
            (3900, at_rest.0, at_rest.1),
            (3900, at_rest2.0, at_rest2.1)
        ]
    );
    // Moving, 0x6064 and 0x6077 change every tick: TPDO1/TPDO2 go out at
    // once and then every 100 ms (the inhibit time), TPDO3 not at all.
    pv(&mut b, 5200, 0x0F, 100);
    assert_eq!(
        frames(&mut b, 5200, 300),
        [
            (1, TPDO1, vec![0x37, 0x02, 3, 0, 25, 0, 0x1A, 0x04]),
            (1, TPDO2, vec![0x37, 0x02, 0, 0, 0, 0]),
            (101, TPDO1, vec![0x37, 0x06, 3, 0, 25, 0, 0x2C, 0]),
            (101, TPDO2, vec![0x37, 0x06, 8, 0, 0, 0]),
            (201, TPDO1, vec![0x37, 0x06, 3, 0, 25, 0, 0x33, 0]),
            (201, TPDO2, vec![0x37, 0x06, 18, 0, 0, 0]),
        ]
    );
    // TPDO3 (transmission type 1): the statusword and 100 mm/s at each SYNC; TPDO4 is never sent.
    // (Between the TPDO2s of 5500 and 5600 ms.)
    b.run_until(ms(5550));
    assert_eq!(b.rx(ms(5550), 0x080, &[]), [(TPDO3, vec![0x37, 0x06, 100, 0, 0, 0])]);
    assert_eq!(b.rx(ms(5560), 0x080, &[]), [(TPDO3, vec![0x37, 0x06, 100, 0, 0, 0])]);
    // RPDO4 (0x505) maps nothing: ignored.
    assert_eq!(b.rx(ms(5570), 0x505, &[0x00, 0x00]), []);
    assert_eq!(value(&mut b, 0x606C, 0), 100);
}

/// 0x6007 = `code`, a heartbeat consumer for node 1 (100 ms) that keeps the
/// node Operational when it times out (0x1029 sub 1 = 1, so the TPDOs show
/// the reaction); the roller at 100 mm/s from 800 ms, node 1's heartbeat
/// once at 1000 ms, then none: the frames of the next 400 ms.
fn heartbeat_lost(code: i16) -> (Ec5000, Vec<(u64, u16, Vec<u8>)>) {
    let mut b = enabled();
    b.sdo_download(ID, 0x6007, 0, &code.to_le_bytes()).expect("0x6007");
    b.sdo_download(ID, 0x1016, 1, &0x0001_0064u32.to_le_bytes()).expect("0x1016");
    b.sdo_download(ID, 0x1029, 1, &[1]).expect("0x1029");
    pv(&mut b, 800, 0x0F, 100);
    b.rx(ms(1000), 0x701, &[0x05]);
    let out = frames(&mut b, 1000, 400);
    (b, out)
}

/// EMCY 0x8130 heartbeat (node 1), error register 0x11.
fn heartbeat_emcy() -> (u64, u16, Vec<u8>) {
    (100, EMCY, vec![0x30, 0x81, 0x11, 1, 0, 0, 0, 0])
}

fn tpdo2(statusword: u16, mm: u8) -> Vec<u8> {
    let [lo, hi] = statusword.to_le_bytes();
    vec![lo, hi, mm, 0, 0, 0]
}

#[test]
fn l621_0x6007_0_no_action() {
    let (mut b, out) = heartbeat_lost(0);
    assert_eq!(out[0], heartbeat_emcy());
    assert!(out.iter().filter(|(_, id, _)| *id == TPDO2).all(|(_, _, d)| d[..2] == [0x37, 0x06]), "{out:x?}");
    assert_eq!(value(&mut b, 0x606C, 0), 100, "runs on");
}

#[test]
fn l622_0x6007_1_fault_signal() {
    // The fault reaction (quick stop ramp), then Fault; 0x8130 is already active, so one EMCY.
    let (_, out) = heartbeat_lost(1);
    assert_eq!(
        out,
        [
            heartbeat_emcy(),
            (100, TPDO1, vec![0x1F, 0x02, 3, 0, 25, 0, 0x34, 0]),
            (100, TPDO2, tpdo2(0x021F, 28)),
            (200, TPDO1, vec![0x18, 0x02, 3, 0x11, 25, 0, 0, 0]),
            (200, TPDO2, tpdo2(0x0218, 30)),
        ]
    );
}

#[test]
fn l623_0x6007_2_disable_voltage() {
    // Switch on disabled at once: the power stage off, the roller coasts on.
    let (_, out) = heartbeat_lost(2);
    let positions: Vec<_> = out.iter().filter(|(_, id, _)| *id == TPDO2).map(|(t, _, d)| (*t, d[0], d[2])).collect();
    assert_eq!(out[0], heartbeat_emcy());
    assert_eq!(positions, [(100, 0x50, 28), (200, 0x50, 36), (300, 0x50, 42), (400, 0x50, 46)]);
}

#[test]
fn l624_0x6007_3_quick_stop() {
    // Quick stop active on the quick stop ramp (2.3 mm from 100 mm/s), then Switch on disabled.
    // Bit 10 is clear while the roller brakes (CiA 402: "axis decelerates", docs/firmware.md
    // "Standstill"; it showed the pv target reached before).
    let (_, out) = heartbeat_lost(3);
    assert_eq!(
        out,
        [
            heartbeat_emcy(),
            (100, TPDO1, vec![0x17, 0x02, 3, 0, 25, 0, 0x34, 0]),
            (100, TPDO2, tpdo2(0x0217, 28)),
            (200, TPDO1, vec![0x50, 0x02, 3, 0x11, 25, 0, 0, 0]),
            (200, TPDO2, tpdo2(0x0250, 30)),
        ]
    );
}
