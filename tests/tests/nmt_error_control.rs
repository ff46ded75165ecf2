//! NMT, boot-up, heartbeat producer and consumer, node and life guarding,
//! EMCY with the error register and history, store/restore: exact frames at
//! exact times on a real device dictionary (EC5000: CiA 301 + 402, and the
//! b maXX 4400 for guarding). CiA 301 v4.2 §7.2.8, §7.2.7, §7.5.2.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::services::nmt::NmtState;
use canopen_core::wire::emcy::EmcyCode;
use common::{Bench, abort, ms, ok_write};
use firmware::devices::{bmaxx4400, ec5000};
use hal_host::storage::MemStorage;

type Ec5000 = Bench<ec5000::od::Ram, NoApplication, MemStorage, 4, 4, 1>;

fn ec5000(id: u8) -> Ec5000 {
    Bench::new(ec5000::od::Ram::new(id), NoApplication, MemStorage::new(2048), id)
}

// ---- Boot-up and NMT states -------------------------------------------------

#[test]
fn boots_up_into_pre_operational_with_the_boot_up_frame() {
    let mut b = ec5000(5);
    assert_eq!(b.node.state(), NmtState::Initialising);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.at(ms(1000)), []);
}

#[test]
fn every_nmt_command_addressed_and_broadcast() {
    let mut b = ec5000(5);
    b.at(ms(0));
    // Entering Operational sends the event-driven TPDOs once (TPDO1 statusword/mode/velocity, TPDO3).
    assert_eq!(b.rx(ms(1), 0x000, &[0x01, 0x05]), [(0x185, vec![0, 0, 3, 0, 0, 0, 0, 0]), (0x285, vec![0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.node.state(), NmtState::Operational);
    assert_eq!(b.rx(ms(2), 0x000, &[0x02, 0x06]), [], "other node");
    assert_eq!(b.node.state(), NmtState::Operational);
    assert_eq!(b.rx(ms(3), 0x000, &[0x02, 0x00]), []);
    assert_eq!(b.node.state(), NmtState::Stopped);
    assert_eq!(b.rx(ms(4), 0x000, &[0x80, 0x05]), []);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.rx(ms(5), 0x000, &[0x82, 0x00]), [(0x705, vec![0x00])], "reset communication boots up again");
    assert_eq!(b.rx(ms(6), 0x000, &[0x81, 0x05]), [(0x705, vec![0x00])], "reset node too");
    assert_eq!(b.node.state(), NmtState::PreOperational);
}

#[test]
fn sdo_is_not_served_in_stopped() {
    let mut b = ec5000(5);
    b.at(ms(0));
    b.rx(ms(1), 0x000, &[0x02, 0x05]);
    assert_eq!(b.rx(ms(2), 0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), []);
    b.rx(ms(3), 0x000, &[0x80, 0x05]);
    assert_eq!(b.rx(ms(4), 0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [(0x585, vec![0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x42, 0x00])]);
}

#[test]
fn malformed_nmt_and_heartbeat_frames_are_counted_and_ignored() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.rx(ms(1), 0x000, &[0x01]), []);
    assert_eq!(b.rx(ms(2), 0x000, &[0x07, 0x05]), []);
    assert_eq!(b.rx(ms(3), 0x703, &[0x05, 0x00]), []);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.node.counters().malformed, 3);
}

// ---- Heartbeat producer -----------------------------------------------------

#[test]
fn heartbeat_producer_follows_0x1017_and_the_state() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.sdo_write(5, 0x1017, 0, &100u16.to_le_bytes()), ok_write(0x1017, 0));
    let beats = b.run_until(ms(350));
    assert_eq!(beats, [(ms(100), (0x705, vec![0x7F])), (ms(200), (0x705, vec![0x7F])), (ms(300), (0x705, vec![0x7F]))]);
    b.rx(ms(350), 0x000, &[0x01, 0x05]);
    assert_eq!(b.run_until(ms(400)), [(ms(400), (0x705, vec![0x05]))]);
    b.rx(ms(450), 0x000, &[0x02, 0x05]);
    assert_eq!(b.run_until(ms(500)), [(ms(500), (0x705, vec![0x04]))]);
    // Reset communication restores 0x1017 = 0: no more heartbeats.
    b.rx(ms(510), 0x000, &[0x82, 0x05]);
    assert!(b.run_until(ms(2000)).is_empty());
}

#[test]
fn a_stored_heartbeat_time_restarts_one_period_after_each_boot_up() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.sdo_write(5, 0x1017, 0, &100u16.to_le_bytes()), ok_write(0x1017, 0));
    assert_eq!(b.sdo_write(5, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    let beats = b.run_until(ms(250));
    assert_eq!(beats, [(ms(100), (0x705, vec![0x7F])), (ms(200), (0x705, vec![0x7F]))]);
    // Reset communication keeps the stored 0x1017; the period starts over at the boot-up, not on the old grid.
    assert_eq!(b.rx(ms(250), 0x000, &[0x82, 0x05]), [(0x705, vec![0x00])]);
    let beats = b.run_until(ms(460));
    assert_eq!(beats, [(ms(350), (0x705, vec![0x7F])), (ms(450), (0x705, vec![0x7F]))]);
    // The same after reset node, with a heartbeat time written since (not stored): the stored one counts.
    assert_eq!(b.sdo_write(5, 0x1017, 0, &40u16.to_le_bytes()), ok_write(0x1017, 0));
    assert_eq!(b.run_until(ms(500)), [(ms(500), (0x705, vec![0x7F]))]);
    assert_eq!(b.rx(ms(505), 0x000, &[0x81, 0x05]), [(0x705, vec![0x00])]);
    assert_eq!(b.run_until(ms(700)), [(ms(605), (0x705, vec![0x7F]))]);
}

// ---- Heartbeat consumer ------------------------------------------------------

#[test]
fn heartbeat_consumer_times_out_with_emcy_history_and_error_behaviour() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.sdo_write(5, 0x1016, 1, &0x0003_0064u32.to_le_bytes()), ok_write(0x1016, 1));
    b.rx(ms(1), 0x000, &[0x01, 0x05]);
    assert!(b.run_until(ms(1000)).is_empty(), "not armed before the first heartbeat");
    assert_eq!(b.rx(ms(1000), 0x703, &[0x05]), []);
    assert!(b.run_until(ms(1099)).is_empty());
    assert_eq!(b.run_until(ms(1100)), [(ms(1100), (0x085, vec![0x30, 0x81, 0x11, 0x03, 0, 0, 0, 0]))]);
    // 0x1029 sub 1 = 0: a communication error takes an Operational node to Pre-operational.
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.sdo_read(5, 0x1001, 0), [0x4F, 0x01, 0x10, 0x00, 0x11, 0, 0, 0]);
    assert_eq!(b.sdo_read(5, 0x1003, 0), [0x4F, 0x03, 0x10, 0x00, 0x01, 0, 0, 0]);
    assert_eq!(b.sdo_read(5, 0x1003, 1), [0x43, 0x03, 0x10, 0x01, 0x30, 0x81, 0x03, 0x00]);
    // Writing 0 clears the history; anything else is refused.
    assert_eq!(b.sdo_write(5, 0x1003, 0, &[1]), abort(0x1003, 0, 0x0609_0030));
    assert_eq!(b.sdo_write(5, 0x1003, 0, &[0]), ok_write(0x1003, 0));
    assert_eq!(b.sdo_read(5, 0x1003, 0), [0x4F, 0x03, 0x10, 0x00, 0x00, 0, 0, 0]);
}

#[test]
fn a_second_entry_for_the_same_node_is_refused() {
    let mut b =
        Bench::<agile_od::Ram, NoApplication, MemStorage, 3, 3, 3>::new(agile_od::Ram::new(2), NoApplication, MemStorage::new(4096), 2);
    b.at(ms(0));
    assert_eq!(b.sdo_write(2, 0x1016, 1, &0x0003_0064u32.to_le_bytes()), ok_write(0x1016, 1));
    assert_eq!(b.sdo_write(2, 0x1016, 2, &0x0003_00C8u32.to_le_bytes()), abort(0x1016, 2, 0x0604_0043));
    assert_eq!(b.sdo_write(2, 0x1016, 2, &0x0004_00C8u32.to_le_bytes()), ok_write(0x1016, 2));
}

use firmware::devices::agile::od as agile_od;

// ---- Node and life guarding ---------------------------------------------------

#[test]
fn node_guarding_toggles_and_life_guarding_expires() {
    type Bm = Bench<bmaxx4400::od::Ram, NoApplication, MemStorage, 4, 4, 0>;
    let mut b: Bm = Bench::new(bmaxx4400::od::Ram::new(7), NoApplication, MemStorage::new(4096), 7);
    assert_eq!(b.at(ms(0)), [(0x707, vec![0x00])]);
    assert_eq!(b.sdo_write(7, 0x100C, 0, &100u16.to_le_bytes()), ok_write(0x100C, 0));
    assert_eq!(b.sdo_write(7, 0x100D, 0, &[3]), ok_write(0x100D, 0));
    assert_eq!(b.rtr(ms(10), 0x707), [(0x707, vec![0x7F])]);
    assert_eq!(b.rtr(ms(110), 0x707), [(0x707, vec![0xFF])]);
    b.rx(ms(120), 0x000, &[0x01, 0x07]);
    assert_eq!(b.rtr(ms(210), 0x707), [(0x707, vec![0x05])]);
    assert!(b.run_until(ms(509)).is_empty());
    let expired = b.run_until(ms(510));
    assert_eq!(expired, [(ms(510), (0x087, vec![0x30, 0x81, 0x11, 0x00, 0, 0, 0, 0]))]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
}

// ---- Store and restore ---------------------------------------------------------

#[test]
fn save_keeps_parameters_over_reset_and_load_restores_defaults() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.sdo_write(5, 0x1017, 0, &250u16.to_le_bytes()), ok_write(0x1017, 0));
    assert_eq!(b.sdo_write(5, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.sdo_read(5, 0x1010, 1), [0x43, 0x10, 0x10, 0x01, 0x01, 0, 0, 0], "read-back: saves on command");
    assert_eq!(b.sdo_write(5, 0x1010, 1, b"evas"), abort(0x1010, 1, 0x0800_0020));
    b.rx(ms(10), 0x000, &[0x81, 0x05]);
    assert_eq!(b.sdo_read(5, 0x1017, 0), [0x4B, 0x17, 0x10, 0x00, 250, 0, 0, 0]);
    assert_eq!(b.sdo_write(5, 0x1011, 1, b"load"), ok_write(0x1011, 1));
    assert_eq!(b.sdo_write(5, 0x1011, 1, b"daol"), abort(0x1011, 1, 0x0800_0020));
    b.rx(ms(20), 0x000, &[0x81, 0x05]);
    assert_eq!(b.sdo_read(5, 0x1017, 0), [0x4B, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
}

#[test]
fn emcy_cob_id_changes_only_while_emcy_is_off() {
    let mut b = ec5000(5);
    b.at(ms(0));
    assert_eq!(b.sdo_write(5, 0x1014, 0, &0x0000_0090u32.to_le_bytes()), abort(0x1014, 0, 0x0609_0030));
    assert_eq!(b.sdo_write(5, 0x1014, 0, &0x8000_0085u32.to_le_bytes()), ok_write(0x1014, 0));
    assert_eq!(b.sdo_write(5, 0x1014, 0, &0x0000_0090u32.to_le_bytes()), ok_write(0x1014, 0));
    b.node.raise_error(EmcyCode(0x5000), [0; 5]);
    assert_eq!(b.at(ms(1)), [(0x090, vec![0x00, 0x50, 0x01, 0, 0, 0, 0, 0])]);
    b.node.clear_error(EmcyCode(0x5000));
    assert_eq!(b.at(ms(2)), [(0x090, vec![0, 0, 0, 0, 0, 0, 0, 0])]);
}
