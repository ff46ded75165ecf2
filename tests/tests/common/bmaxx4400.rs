//! The b maXX 4400 (node 2) on the bench, set up by SDO as a PLC does: what
//! the CiA 402 stop and ramp tests start from (the drive whose dictionary
//! has every option code 0x605A-0x605E), [`turn`] in profile velocity. Its speeds
//! are min⁻¹ (docs/devices/bmaxx4400.md D57), its accelerations increments
//! per second squared (1 BE = 1 increment, D50).

use super::{Bench, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

/// The b maXX 4400 on the bench.
pub type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

/// Its node-id.
pub const ID: u8 = 2;
/// 600 min⁻¹: 10 revolutions a second, 655,360 increments a second.
pub const SPEED: i32 = 600;
/// 0x6084 profile deceleration: 10 revolutions/s², from 600 min⁻¹ to 0 in 1 s.
pub const SLOW_DOWN: u32 = 655_360;
/// 0x6085 quick stop deceleration: 50 revolutions/s², from 600 min⁻¹ to 0 in 0.2 s.
pub const QUICK_STOP: u32 = 3_276_800;

/// Node 2 powered on at 0 ms, the clock at 10 ms, Pre-operational: the
/// test configures what it needs (its PDOs) before [`turn`].
pub fn powered() -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    b.now = ms(10);
    b
}

/// By SDO: 0x6083 acceleration 100 revolutions/s² (0.1 s to [`SPEED`]),
/// 0x6084 [`SLOW_DOWN`], 0x6085 [`QUICK_STOP`], then `settings`, pv (0x6060
/// = 3) at 0x60FF = [`SPEED`]; NMT start and Operation enabled (controlword
/// 6, 7, 0x0F). The clock stands at 200 ms.
pub fn turn(b: &mut Bmaxx, settings: &[(u16, u8, &[u8])]) {
    for (index, value) in [(0x6083u16, 6_553_600u32), (0x6084, SLOW_DOWN), (0x6085, QUICK_STOP)] {
        assert_eq!(b.sdo_write(ID, index, 0, &value.to_le_bytes()), ok_write(index, 0));
    }
    for &(index, sub, value) in settings {
        assert_eq!(b.sdo_write(ID, index, sub, value), ok_write(index, sub), "{index:#x}");
    }
    assert_eq!(b.sdo_write(ID, 0x6060, 0, &[3]), ok_write(0x6060, 0));
    assert_eq!(b.sdo_write(ID, 0x60FF, 0, &SPEED.to_le_bytes()), ok_write(0x60FF, 0));
    b.nmt(0x01, ID);
    for cw in [0x06u16, 0x07, 0x0F] {
        controlword(b, cw);
    }
    b.run_until(ms(200));
}

/// The controlword by SDO (answers and TPDOs ignored).
pub fn controlword(b: &mut Bmaxx, cw: u16) {
    let [lo, hi] = cw.to_le_bytes();
    let out = b.rx(b.now, 0x600 + u16::from(ID), &[0x2B, 0x40, 0x60, 0x00, lo, hi, 0, 0]);
    assert!(out.contains(&(0x580 + u16::from(ID), ok_write(0x6040, 0))), "{out:x?}");
}
