//! The b maXX 4400's configuration word P0830 (0x433E, §4.3, M-L652-783;
//! D62 in docs/devices/bmaxx4400.md): bit 0 boot-up as DS 301 V3 (B2), bit 4
//! the NMT state after a life guarding event. Node 1, as in the manual's frames. The card reads
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
