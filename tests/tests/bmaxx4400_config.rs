//! The b maXX 4400's configuration word P0830 (0x433E, §4.3, M-L652-783;
//! D62 in docs/devices/bmaxx4400.md): bit 0 boot-up as DS 301 V3 (B2), bit 3
//! the zeroed default mapping with 0x6007 = 3, bit 4 the NMT state after a
//! life guarding event. Node 1, as in the manual's frames. The card reads
//! P0830 at start-up ("nach Speichern und Neustart"); P0830 is not stored
//! over CANopen, so the tests write it and reset communication.

mod common;

use common::{Bench, F, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

const ID: u8 = 1;
const P0830: u16 = 0x433E;

/// Powered on at 0 ms with the V4 boot-up (B1, M-L674-679: `701 [1] 00`).
fn powered() -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    assert_eq!(b.at(ms(0)), [(0x701, vec![0x00])]);
    b.now = ms(10);
    b
}

/// P0830 = `word`, then NMT reset communication at 20 ms: what the node sends.
fn configured(b: &mut Bmaxx, word: u16) -> Vec<F> {
    assert_eq!(b.sdo_write(ID, P0830, 0, &word.to_le_bytes()), ok_write(P0830, 0));
    b.now = ms(20);
    b.nmt(0x82, ID)
}

#[test]
fn b2_m_l683_p0830_bit_0_boots_up_as_ds301_v3() {
    let mut b = powered();
    // "ID = 80hex + Node-ID, DLC = 0 und anschließend ID = 80hex + Node-ID, DLC = 8
    // Byte 0-7 mit den Daten = 0 aufgefüllt (Reset des Error Registers)".
    assert_eq!(configured(&mut b, 0x0001), [(0x081, vec![]), (0x081, vec![0; 8])]);
    // Pre-operational as after any boot-up: guarding answers 7F (B4).
    assert_eq!(b.rtr(ms(30), 0x701), [(0x701, vec![0x7F])]);
    // Bit 0 clear again: the V4 boot-up (B1).
    assert_eq!(configured(&mut b, 0x0000), [(0x701, vec![0x00])]);
}

/// Operational, guarded every 100 ms with life time factor 2 from the RTR at
/// 100 ms; no RTR after it: the life guarding event at 300 ms. The frames
/// up to 400 ms, then what an RTR there brings.
fn guarding_lost(word: u16) -> (Vec<F>, Vec<F>) {
    let mut b = powered();
    configured(&mut b, word);
    assert_eq!(b.sdo_write(ID, 0x100C, 0, &100u16.to_le_bytes()), ok_write(0x100C, 0));
    assert_eq!(b.sdo_write(ID, 0x100D, 0, &[2]), ok_write(0x100D, 0));
    b.now = ms(50);
    b.nmt(0x01, ID);
    assert_eq!(b.rtr(ms(100), 0x701), [(0x701, vec![0x05])], "Operational, toggle 0 (B4)");
    let lost = b.run_until(ms(400)).into_iter().map(|(_, f)| f).collect();
    (lost, b.rtr(ms(400), 0x701))
}

#[test]
fn m_l733_p0830_bit_4_clear_a_life_guarding_event_leaves_the_state() {
    // Bit 4 = 0, "Standard": "CANopen State wechselt nicht nach PRE-OPERATIONAL sondern
    // bleibt im aktuellen Zustand". EMCY 8130h; the next RTR finds it Operational (85: toggle 1).
    let (lost, answer) = guarding_lost(0x0000);
    assert_eq!(lost, [(0x081, vec![0x30, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    // Guarding resumed: "error reset" (B17), then the answer.
    assert_eq!(answer, [(0x081, vec![0; 8]), (0x701, vec![0x85])]);
}

#[test]
fn m_l736_p0830_bit_4_set_a_life_guarding_event_enters_pre_operational() {
    // Bit 4 = 1: "wie bisher, CANopen State wechselt immer nach PRE-OPERATIONAL".
    let (lost, answer) = guarding_lost(0x0010);
    assert_eq!(lost, [(0x081, vec![0x30, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(answer, [(0x081, vec![0; 8]), (0x701, vec![0xFF])], "Pre-operational, toggle 1 (B4)");
}

/// (index, sub) as an unsigned value.
fn value(b: &mut Bmaxx, index: u16, sub: u8) -> u32 {
    let v = b.sdo_upload(ID, index, sub).expect("readable");
    v.iter().rev().fold(0, |acc, byte| acc << 8 | u32::from(*byte))
}

#[test]
fn m_l713_p0830_bit_3_zeroes_the_default_mapping_and_sets_0x6007_to_3() {
    let mut b = powered();
    assert_eq!(value(&mut b, 0x1600, 1), 0x6040_0010, "DSP 402 default mapping first");
    // "Default Mapping bei dem alle FBO Objekte auf Null gesetzt werden, Triggertypen bleiben
    // nach DSP 402 auf Default. FBO 6007hex Node Guarding-Reaktion wird dann auf 3 gesetzt."
    assert_eq!(configured(&mut b, 0x0008), [(0x701, vec![0x00])]);
    for index in [0x1600, 0x1601, 0x1602, 0x1603, 0x1A00, 0x1A01, 0x1A02, 0x1A03] {
        assert_eq!(value(&mut b, index, 0), 0, "{index:x} sub 0");
        assert_eq!(value(&mut b, index, 1), 0, "{index:x} sub 1");
        assert_eq!(value(&mut b, index, 2), 0, "{index:x} sub 2");
    }
    assert_eq!(value(&mut b, 0x1800, 2), 0xFF, "TPDO1 transmission type as DSP 402");
    assert_eq!(value(&mut b, 0x1802, 2), 0xFE, "TPDO3 transmission type as DSP 402");
    assert_eq!(value(&mut b, 0x6007, 0), 3);
    // Operational: no PDO leaves and an RPDO1 frame moves nothing (no mapping).
    b.now = ms(30);
    assert_eq!(b.nmt(0x01, ID), []);
    assert_eq!(b.rx(ms(40), 0x201, &[0x06, 0x00]), []);
    assert_eq!(value(&mut b, 0x6040, 0), 0);
    // The master maps what it needs: RPDO1 = 0x6040 again takes effect.
    b.now = ms(50);
    b.nmt(0x80, ID);
    assert_eq!(b.sdo_write(ID, 0x1600, 1, &0x6040_0010u32.to_le_bytes()), ok_write(0x1600, 1));
    assert_eq!(b.sdo_write(ID, 0x1600, 0, &[1]), ok_write(0x1600, 0));
    b.nmt(0x01, ID);
    b.rx(ms(60), 0x201, &[0x06, 0x00]);
    assert_eq!(value(&mut b, 0x6040, 0), 6);
}

#[test]
fn m_l713_p0830_bit_3_leaves_a_stored_mapping() {
    let mut b = powered();
    // RPDO1 = 0x6040 + 0x6060 stored with 0x1010 sub 2 ("save", Pre-operational).
    assert_eq!(b.sdo_write(ID, 0x1600, 2, &0x6060_0008u32.to_le_bytes()), ok_write(0x1600, 2));
    assert_eq!(b.sdo_write(ID, 0x1600, 0, &[2]), ok_write(0x1600, 0));
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    assert_eq!(configured(&mut b, 0x0008), [(0x701, vec![0x00])]);
    assert_eq!(value(&mut b, 0x1600, 0), 2);
    assert_eq!(value(&mut b, 0x1600, 2), 0x6060_0008);
    assert_eq!(value(&mut b, 0x1A00, 0), 1, "the stored set's TPDO1 (the default it was stored with)");
    assert_eq!(value(&mut b, 0x6007, 0), 3, "0x6007 = 3 with bit 3 all the same");
    // Without bit 3 nothing changes.
    assert_eq!(configured(&mut b, 0x0000), [(0x701, vec![0x00])]);
    assert_eq!(value(&mut b, 0x1600, 0), 2);
}
