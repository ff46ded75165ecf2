//! EMCY 0x6310 "Loss of parameters" on the EC5000 (M §9.1 L1682, D66): the
//! parameters saved by a firmware whose dictionary layout differs (before
//! an update) are refused, so the drive starts on its defaults, in Fault
//! with 0x6310, until a fault reset acknowledges it; a save or a restore of
//! the defaults writes a set of this layout and ends it.

mod common;

use canopen_core::od::Dictionary;
use canopen_core::services::store::{self, Scope};
use common::ec5000::*;
use common::{Bench, F, ms, ok_write};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

/// What the firmware before the update saved (0x4231 sub 1 = 100 °C and the
/// other parameters), under the layout id of another dictionary.
fn saved_by_the_old_firmware() -> MemStorage {
    let dict = &ec5000::od::DICTIONARY;
    let old = Dictionary { layout_id: dict.layout_id ^ 1, ..*dict };
    let mut image = vec![0; dict.defaults.len];
    dict.defaults.read(0, &mut image);
    dict.reset_application(&mut image, ID);
    dict.reset_communication(&mut image, ID);
    old.write(&mut image, 0x4231, 1, &100i16.to_le_bytes()).expect("0x4231");
    let mut storage = MemStorage::new(4096);
    store::save(&old, &image, ID, &mut storage, Scope::All).expect("the old set");
    storage
}

/// The roller powered on at t = 0 with `storage`, and what it sends in its
/// first 10 ms (at t = 0).
fn powered_on(storage: MemStorage) -> (Ec5000, Vec<F>) {
    let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, storage, ID);
    let out = b.run_until(ms(10)).into_iter().map(|(t, f)| {
        assert_eq!(t, ms(0), "{f:x?}");
        f
    });
    let out = out.collect();
    (b, out)
}

/// The roller powered on again on the storage `b` left.
fn power_cycled(b: &mut Ec5000) -> (Ec5000, Vec<F>) {
    let mut storage = b.node.storage_mut().clone();
    storage.power_on();
    powered_on(storage)
}

const BOOT_UP: (u16, [u8; 1]) = (0x705, [0]);
/// 0x6310, error register 0x21 (generic + device profile, the core's bits
/// for a 0x6xxx code), no manufacturer bytes (D54).
const LOSS: [u8; 8] = [0x10, 0x63, 0x21, 0, 0, 0, 0, 0];

#[test]
fn l1682_a_set_of_another_layout_is_emcy_0x6310_and_a_fault_until_reset() {
    let (mut b, out) = powered_on(saved_by_the_old_firmware());
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec()), (EMCY, LOSS.to_vec())]);
    assert_eq!(statusword(&mut b), 0x0218, "Fault (remote, voltage enabled)");
    assert_eq!(b.sdo_upload(ID, 0x4231, 1), Ok(vec![95, 0]), "the default, not the refused set's 100");
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0x10, 0x63, 0, 0]));
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0x21]));
    // The fault reset (controlword bit 7 rising): "error reset" (the EMCY
    // first: its identifier wins the bus), Switch on disabled.
    b.sdo_download(ID, 0x6040, 0, &[0, 0]).expect("0x6040");
    let out = b.rx(ms(100), 0x605, &[0x2B, 0x40, 0x60, 0, 0x80, 0, 0, 0]);
    assert_eq!(out, [(EMCY, vec![0; 8]), (0x585, ok_write(0x6040, 0))]);
    assert_eq!(statusword(&mut b), 0x0250, "Switch on disabled");
    assert_eq!(b.run_until(ms(1000)), []);
}

#[test]
fn the_loss_is_reported_at_every_start_until_a_save() {
    let (mut b, _) = powered_on(saved_by_the_old_firmware());
    // Power-on again, and NMT reset node: still the defaults, still 0x6310.
    let (mut b, out) = power_cycled(&mut b);
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec()), (EMCY, LOSS.to_vec())]);
    let mut out = b.nmt(0x81, ID);
    out.extend(b.run_until(ms(10)).into_iter().map(|(_, f)| f));
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec()), (EMCY, LOSS.to_vec())]);
    // 0x1010 sub 1 "save": the set of this layout holds the defaults now.
    b.sdo_download(ID, 0x1010, 1, b"save").expect("save");
    let (mut b, out) = power_cycled(&mut b);
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec())], "no loss: the saved set is loaded");
    assert_eq!(statusword(&mut b), 0x0250, "Switch on disabled");
    assert_eq!(b.sdo_upload(ID, 0x1001, 0), Ok(vec![0]));
}

#[test]
fn restoring_the_defaults_ends_the_loss_too() {
    let (mut b, _) = powered_on(saved_by_the_old_firmware());
    b.sdo_download(ID, 0x1011, 1, b"load").expect("load");
    let (mut b, out) = power_cycled(&mut b);
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec())]);
    assert_eq!(b.sdo_upload(ID, 0x4231, 1), Ok(vec![95, 0]));
}

#[test]
fn a_set_of_this_layout_is_no_loss() {
    let mut b = enabled();
    b.sdo_download(ID, 0x4231, 1, &100i16.to_le_bytes()).expect("0x4231");
    b.sdo_download(ID, 0x1010, 1, b"save").expect("save");
    let (mut b, out) = power_cycled(&mut b);
    assert_eq!(out, [(BOOT_UP.0, BOOT_UP.1.to_vec())]);
    assert_eq!(b.sdo_upload(ID, 0x4231, 1), Ok(vec![100, 0]));
}
