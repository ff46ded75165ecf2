//! CiA CANopen Conformance Test Tool 3.0.3.10, "testing other" cases
//! 8.1–8.10 (store/restore, restricted CAN-IDs), NMT state cases 9.1–9.4 and
//! NMT transition cases 10.1–10.4 (`/work/shared/notes/cia-notes.md`,
//! appendix A), as exact frames on the interop fixture (node 4).
//! CiA 301 v4.2 §7.5.2.13–14 (0x1010/0x1011), §7.3.5 (restricted CAN-IDs),
//! §7.3.2 (NMT state machine, figure 48).
//!
//! Cases: 8.9 does not apply: it needs 0x1020 (verify configuration),
//! which no dictionary here has. The other cases apply; 8.1/8.2, 8.5/8.6
//! store (sub 1 all, sub 2 communication), 8.3/8.4, 8.7/8.8 restore.

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use canopen_core::services::nmt::NmtState;
use common::{Bench, F, abort, ms, ok_write};
use embedded_can::Frame;
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 4;
const BOOT_UP: (u16, [u8; 1]) = (0x704, [0x00]);

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn interop() -> Interop {
    let mut b = Bench::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [boot_up()]);
    b
}

fn boot_up() -> F {
    (BOOT_UP.0, BOOT_UP.1.to_vec())
}

const TPDO1: [u8; 7] = [0x11, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44];

/// Changes a communication parameter (0x1017) and an application one (0x2000).
fn change_parameters(b: &mut Interop) {
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &500u16.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x2000, 0, &[0x99]), Ok(()));
}

fn parameters(b: &mut Interop) -> (Vec<u8>, Vec<u8>) {
    (b.sdo_upload(ID, 0x1017, 0).unwrap(), b.sdo_upload(ID, 0x2000, 0).unwrap())
}

const CHANGED: ([u8; 2], [u8; 1]) = ([0xF4, 0x01], [0x99]);
const DEFAULT: ([u8; 2], [u8; 1]) = ([0, 0], [0x11]);

fn is(v: (Vec<u8>, Vec<u8>), expected: ([u8; 2], [u8; 1])) -> bool {
    v.0 == expected.0 && v.1 == expected.1
}

// ---- Store and restore ------------------------------------------------------------

#[test]
fn cct_8_1_store_all_parameters() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1010, 1), [0x43, 0x10, 0x10, 0x01, 0x01, 0, 0, 0], "bit 0: saves on command");
    change_parameters(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert!(is(parameters(&mut b), CHANGED));
}

/// The size a segmented download announces is checked at its initiate: the
/// 0x1010/0x1011 signature is 4 bytes whatever the entry holds, and their
/// sub 0 is refused only after the length; other objects are refused as
/// read-only before the length is looked at.
#[test]
fn a_store_commands_announced_size_is_checked_before_its_sub_0() {
    announced_sizes_are_checked(interop());
    // Without block SDO (and without SDO hooks) the node runs these checks
    // out of line (`download_check_apart`): the same abort codes.
    let mut b: Bench<_, _, _, 4, 4, 4> = Bench::new(NoBlock(interop::Ram::new(ID)), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [boot_up()]);
    announced_sizes_are_checked(b);
}

common::with_services! {
    /// The interop dictionary without block SDO, as `ds301-lean`'s.
    NoBlock(interop::Ram) { block_sdo: false }
}

fn announced_sizes_are_checked<O: ObjectDictionary>(mut b: Bench<O, NoApplication, MemStorage, 4, 4, 4>) {
    let initiate = |index: u16, sub: u8, size: u32| {
        let [lo, hi] = index.to_le_bytes();
        let [s0, s1, s2, s3] = size.to_le_bytes();
        [0x21, lo, hi, sub, s0, s1, s2, s3]
    };
    for (index, sub, size, code) in [
        (0x1010, 1, 5, 0x0607_0012),
        (0x1010, 1, 3, 0x0607_0013),
        (0x1011, 4, 0, 0x0607_0013),
        (0x1010, 0, 5, 0x0607_0012),
        (0x1010, 0, 4, 0x0601_0002),
        (0x1011, 0, 4, 0x0601_0002),
        (0x1011, 5, 4, 0x0609_0011),
        (0x1000, 0, 5, 0x0601_0002),
        (0x1017, 0, 3, 0x0607_0012),
        (0x1017, 0, 1, 0x0607_0013),
    ] {
        let out = b.rx(b.now, 0x604, &initiate(index, sub, size));
        assert_eq!(out, [(0x584, abort(index, sub, code))], "{index:#06X} sub {sub}, {size} bytes");
    }
    assert_eq!(b.rx(b.now, 0x604, &initiate(0x1010, 1, 4)), [(0x584, ok_write(0x1010, 1))]);
    // The one segment: 3 bytes unused, the last one.
    let mut segment = [0x07, 0, 0, 0, 0, 0, 0, 0];
    segment[1..5].copy_from_slice(b"save");
    assert_eq!(b.rx(b.now, 0x604, &segment), [(0x584, vec![0x20, 0, 0, 0, 0, 0, 0, 0])]);
}

#[test]
fn cct_8_2_store_with_a_wrong_signature_is_refused() {
    let mut b = interop();
    change_parameters(&mut b);
    for wrong in [b"wron", b"evas", b"SAVE"] {
        assert_eq!(b.sdo_write(ID, 0x1010, 1, wrong), abort(0x1010, 1, 0x0800_0020));
    }
    assert_eq!(b.sdo_write(ID, 0x1010, 0, &[4]), abort(0x1010, 0, 0x0601_0002));
    assert_eq!(b.sdo_write(ID, 0x1010, 5, b"save"), abort(0x1010, 5, 0x0609_0011));
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert!(is(parameters(&mut b), DEFAULT), "nothing was stored");
}

#[test]
fn cct_8_3_restore_with_signature_wron_is_refused() {
    let mut b = interop();
    assert_eq!(b.sdo_read(ID, 0x1011, 1), [0x43, 0x11, 0x10, 0x01, 0x01, 0, 0, 0], "bit 0: restores on command");
    assert_eq!(b.sdo_write(ID, 0x1011, 1, b"wron"), abort(0x1011, 1, 0x0800_0020));
}

#[test]
fn cct_8_4_restore_with_signature_daol_is_refused() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.sdo_write(ID, 0x1011, 1, b"daol"), abort(0x1011, 1, 0x0800_0020));
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert!(is(parameters(&mut b), CHANGED), "still the stored set");
    // "load": the defaults are valid from the next reset on.
    assert_eq!(b.sdo_write(ID, 0x1011, 1, b"load"), ok_write(0x1011, 1));
    assert!(is(parameters(&mut b), CHANGED), "not before the reset");
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert!(is(parameters(&mut b), DEFAULT));
}

#[test]
fn cct_8_5_store_communication_parameters() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"save"), ok_write(0x1010, 2));
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    let (comm, app) = parameters(&mut b);
    assert_eq!((comm, app), (CHANGED.0.to_vec(), DEFAULT.1.to_vec()), "only the communication area was stored");
}

#[test]
fn cct_8_6_store_communication_parameters_with_a_wrong_signature() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"wron"), abort(0x1010, 2, 0x0800_0020));
    assert_eq!(b.sdo_write(ID, 0x1010, 2, b"evas"), abort(0x1010, 2, 0x0800_0020));
    assert_eq!(b.nmt(0x82, ID), [boot_up()]);
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0, 0]));
}

#[test]
fn cct_8_7_restore_communication_parameters_with_signature_wron() {
    let mut b = interop();
    assert_eq!(b.sdo_write(ID, 0x1011, 2, b"wron"), abort(0x1011, 2, 0x0800_0020));
}

#[test]
fn cct_8_8_restore_communication_parameters_with_signature_daol() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.sdo_write(ID, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.sdo_write(ID, 0x1011, 2, b"daol"), abort(0x1011, 2, 0x0800_0020));
    // "load" on sub 2 restores the communication area only, at reset communication.
    assert_eq!(b.sdo_write(ID, 0x1011, 2, b"load"), ok_write(0x1011, 2));
    assert_eq!(b.nmt(0x82, ID), [boot_up()]);
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    let (comm, app) = parameters(&mut b);
    assert_eq!((comm, app), (DEFAULT.0.to_vec(), CHANGED.1.to_vec()));
}

/// CiA 301 §7.3.5, table 34, written out again (not taken from the node).
fn restricted() -> impl Iterator<Item = u32> {
    (0x000..=0x07F).chain(0x101..=0x180).chain(0x581..=0x5FF).chain(0x601..=0x67F).chain(0x6E0..=0x6FF).chain(0x701..=0x7FF)
}

#[test]
fn cct_8_10_restricted_can_ids_are_refused() {
    let mut b = interop();
    let w = |b: &mut Interop, index: u16, sub: u8, v: u32| b.sdo_download(ID, index, sub, &v.to_le_bytes());
    // Every object starts out not valid (or off), so only the CAN-ID can be at fault.
    assert_eq!(w(&mut b, 0x1400, 1, 0x8000_0204), Ok(()));
    assert_eq!(w(&mut b, 0x1800, 1, 0xC000_0184), Ok(()));
    assert_eq!(w(&mut b, 0x1014, 0, 0x8000_0084), Ok(()));
    let objects: [(u16, u8, u32); 7] = [
        (0x1400, 1, 0),           // RPDO, valid
        (0x1800, 1, 0x4000_0000), // TPDO, valid, no RTR
        (0x1014, 0, 0),           // EMCY, valid
        (0x1005, 0, 0),           // SYNC consumer
        (0x1012, 0, 0x8000_0000), // TIME consumer
        (0x1201, 1, 0),           // SDO server 2, client → server, valid
        (0x1201, 2, 0),           // SDO server 2, server → client, valid
    ];
    for (index, sub, flags) in objects {
        let before = b.sdo_upload(ID, index, sub).unwrap();
        for can_id in restricted() {
            assert_eq!(w(&mut b, index, sub, flags | can_id), Err(0x0609_0030), "{index:04X}:{sub} {can_id:03X}");
        }
        assert_eq!(b.sdo_upload(ID, index, sub), Ok(before), "{index:04X}:{sub} unchanged");
        // The free CAN-IDs at the edges of the restricted ranges are accepted.
        for can_id in [0x081, 0x100, 0x181, 0x580, 0x600, 0x680, 0x6DF, 0x700] {
            assert_eq!(w(&mut b, index, sub, flags | can_id), Ok(()), "{index:04X}:{sub} {can_id:03X}");
            if flags & 0x8000_0000 == 0 && index != 0x1005 {
                // Not valid again before the next CAN-ID: it may change only then.
                assert_eq!(w(&mut b, index, sub, 0x8000_0000 | flags | can_id), Ok(()));
            }
        }
    }
}

// ---- NMT states --------------------------------------------------------------------

#[test]
fn cct_9_1_boot_up_and_default_parameters() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert!(is(parameters(&mut b), DEFAULT));
    assert_eq!(b.run_until(ms(5000)), [], "0x1017 = 0: no heartbeat");
}

#[test]
fn cct_9_2_pre_operational() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(b.run_until(ms(100)), [(ms(100), (0x704, vec![0x7F]))]);
    // SDO and SYNC yes, PDO no: neither TPDOs on SYNC nor RPDOs.
    assert_eq!(b.rx(ms(110), 0x080, &[]), []);
    assert_eq!(b.rx(ms(120), 0x304, &[0x55, 0x66, 0x77]), []);
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x11]), "the RPDO was not processed");
    assert_eq!(b.rtr(ms(130), 0x184), []);
    // EMCY yes: a SYNC with a counter the node does not expect is an error it reports.
    assert_eq!(b.sdo_download(ID, 0x1019, 0, &[4]), Ok(()));
    assert_eq!(b.rx(ms(140), 0x080, &[]), [(0x084, vec![0x40, 0x82, 0x11, 0, 0, 0, 0, 0])]);
}

#[test]
fn cct_9_3_operational() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(b.nmt(0x01, ID), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.node.state(), NmtState::Operational);
    assert_eq!(b.run_until(ms(100)), [(ms(100), (0x704, vec![0x05]))]);
    assert_eq!(b.rx(ms(110), 0x304, &[0x55, 0x66, 0x77]), [(0x184, vec![0x55, 0x66, 0x77, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(b.rx(ms(120), 0x080, &[]).len(), 1, "TPDO2 on SYNC");
    assert_eq!(b.sdo_upload(ID, 0x2001, 0), Ok(vec![0x66, 0x77]), "SDO still served");
}

#[test]
fn cct_9_4_stopped() {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    b.nmt(0x01, ID);
    assert_eq!(b.nmt(0x02, ID), []);
    assert_eq!(b.node.state(), NmtState::Stopped);
    assert_eq!(b.run_until(ms(100)), [(ms(100), (0x704, vec![0x04]))], "heartbeat goes on");
    assert_eq!(b.rx(ms(110), 0x604, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [], "no SDO");
    assert_eq!(b.rx(ms(120), 0x304, &[0x55, 0x66, 0x77]), [], "no PDO");
    assert_eq!(b.rx(ms(130), 0x080, &[]), [], "no synchronous PDO");
    assert_eq!(b.rtr(ms(140), 0x184), []);
    assert_eq!(b.rx(ms(150), 0x080, &[1, 2]), [], "no EMCY");
    // NMT still works.
    assert_eq!(b.nmt(0x80, ID), []);
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x11]), "the RPDO in Stopped was ignored");
}

// ---- NMT transitions -----------------------------------------------------------------

#[test]
fn cct_10_1_reset_node_and_reset_communication() {
    let mut b = interop();
    change_parameters(&mut b);
    b.nmt(0x01, ID);
    // Reset communication: 0x1000–0x1FFF to defaults, the application area kept.
    assert_eq!(b.nmt(0x82, ID), [boot_up()]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    let (comm, app) = parameters(&mut b);
    assert_eq!((comm, app), (DEFAULT.0.to_vec(), CHANGED.1.to_vec()));
    // Reset node: everything to defaults.
    change_parameters(&mut b);
    b.nmt(0x02, ID);
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert!(is(parameters(&mut b), DEFAULT));
    // Broadcast (node-ID 0) too; another node's reset is not ours.
    assert_eq!(b.nmt(0x81, 0), [boot_up()]);
    assert_eq!(b.nmt(0x81, 5), []);
    assert_eq!(b.nmt(0x82, 5), []);
}

#[test]
fn cct_10_2_enter_pre_operational() {
    let mut b = interop();
    for from in [0x01, 0x02] {
        b.nmt(from, ID);
        assert_eq!(b.nmt(0x80, ID), []);
        assert_eq!(b.node.state(), NmtState::PreOperational);
    }
    b.nmt(0x01, 0);
    assert_eq!(b.nmt(0x80, 0), [], "broadcast");
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.nmt(0x80, ID), [], "already there");
}

#[test]
fn cct_10_3_start_remote_node() {
    let mut b = interop();
    assert_eq!(b.nmt(0x01, 5), [], "another node");
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.nmt(0x01, ID), [(0x184, TPDO1.to_vec())]);
    assert_eq!(b.nmt(0x01, ID), [], "already Operational: nothing sent again");
    b.nmt(0x02, ID);
    assert_eq!(b.nmt(0x01, 0), [(0x184, TPDO1.to_vec())], "from Stopped, broadcast");
    assert_eq!(b.node.state(), NmtState::Operational);
}

#[test]
fn cct_10_4_stop_remote_node() {
    let mut b = interop();
    assert_eq!(b.nmt(0x02, ID), []);
    assert_eq!(b.node.state(), NmtState::Stopped);
    b.nmt(0x01, ID);
    assert_eq!(b.nmt(0x02, 0), []);
    assert_eq!(b.node.state(), NmtState::Stopped);
    // Malformed NMT frames are ignored.
    assert_eq!(b.rx(ms(1), 0x000, &[0x01]), []);
    assert_eq!(b.rx(ms(2), 0x000, &[0x01, ID, 0]), []);
    assert_eq!(b.rx(ms(3), 0x000, &[0x03, ID]), []);
    assert_eq!(b.node.state(), NmtState::Stopped);
}

common::with_services! {
    /// The interop dictionary linked without storage (`Services::storage`
    /// off), as the `ds301-lean` size reference does with CANopenNode's
    /// profile: 0x1010/0x1011 stay in the dictionary, but nothing can be stored.
    NoStorage(interop::Ram) { storage: false }
}

#[test]
fn a_node_without_storage_refuses_save_and_restore_and_writes_nothing() {
    let mut b: Bench<_, _, _, 4, 4, 4> = Bench::new(NoStorage(interop::Ram::new(ID)), NoApplication, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [boot_up()]);
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &500u16.to_le_bytes()), Ok(()));
    // "save" and "load": 0x08000020, the data cannot be stored; an unknown sub-index stays 0x06090011.
    assert_eq!(b.sdo_download(ID, 0x1010, 1, b"save"), Err(0x0800_0020));
    assert_eq!(b.sdo_download(ID, 0x1011, 1, b"load"), Err(0x0800_0020));
    assert_eq!(b.sdo_download(ID, 0x1010, 9, b"save"), Err(0x0609_0011));
    assert!(b.node.storage_mut().region(0).is_some_and(|r| r.iter().all(|&x| x == 0xFF)), "region 0 erased");
    assert!(b.node.storage_mut().region(1).is_some_and(|r| r.iter().all(|&x| x == 0xFF)), "region 1 erased");
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0, 0]), "the default after reset node");
}

/// One received frame, no `process`.
fn deliver(b: &mut Interop, t: u64, cob_id: u16, data: &[u8]) {
    b.node.on_frame(ms(t), &CanFrame::standard(cob_id, data).expect("valid frame"));
}

#[test]
fn reset_node_with_a_stored_set_takes_a_stage_per_process_and_boots_up_after_the_last() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.sdo_download(ID, 0x1010, 1, b"save"), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x2000, 0, &[0x55]), Ok(()));
    deliver(&mut b, 10, 0x000, &[0x81, ID]);
    assert!(b.node.resetting());
    assert_eq!(b.node.state(), NmtState::Initialising);
    let mut stages = 0;
    while b.node.resetting() {
        // Each call before the last asks to be called again at once and sends nothing.
        assert_eq!(b.node.transmit(), None, "nothing before the reset is complete (stage {stages})");
        let deadline = b.node.process(ms(10));
        stages += 1;
        if b.node.resetting() {
            assert_eq!(deadline, Some(ms(10)), "stage {stages}");
            // The node is Initialising: an SDO request meanwhile is ignored, not answered.
            let ignored = b.node.counters().ignored;
            deliver(&mut b, 10, 0x604, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
            assert_eq!(b.node.counters().ignored, ignored + 1, "stage {stages}");
        }
    }
    // Find the stored set, the application part, the communication part
    // (defaults, then its stored values) and the services, RPDOs, TPDOs and the rest.
    assert_eq!(stages, 5);
    assert_eq!(b.node.transmit().map(|f| (f.cob_id(), f.data().to_vec())), Some((Some(0x704), vec![0x00])), "the boot-up, last");
    assert_eq!(b.node.transmit(), None);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert!(is(parameters(&mut b), CHANGED), "both parts loaded from the stored set");
}

#[test]
fn an_nmt_command_during_a_reset_is_ignored_as_while_initialising() {
    let mut b = interop();
    deliver(&mut b, 10, 0x000, &[0x82, ID]);
    b.node.process(ms(10));
    assert!(b.node.resetting());
    // Start and reset node before the boot-up: the NMT state machine ignores both (CiA 301 §7.3.2.2.1).
    deliver(&mut b, 10, 0x000, &[0x01, ID]);
    deliver(&mut b, 10, 0x000, &[0x81, 0]);
    assert!(b.node.resetting(), "the reset goes on");
    assert_eq!(b.at(ms(10)), [boot_up()]);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.at(ms(20)), [], "one reset, one boot-up");
}

/// The error history is a record of what happened since the last reset, not
/// a parameter: a set saved while it holds errors brings none of them back
/// (CiA 301 §7.5.2.5). Before, od-gen stored 0x1003 sub 0 as any writable
/// value, and a reset showed "one error" with an empty entry under it. The
/// saved parameter still comes back.
#[test]
fn a_saved_set_does_not_bring_back_the_error_history() {
    let mut b = interop();
    change_parameters(&mut b);
    assert_eq!(b.nmt(0x01, ID), [(0x184, vec![0x99, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44])]);
    // RPDO1 too short: EMCY 0x8210, one entry in the history.
    assert_eq!(b.rx(ms(10), 0x204, &[0x01, 0x02]), [(0x084, vec![0x10, 0x82, 0x11, 0x01, 0, 0, 0, 0])]);
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![1]));
    assert_eq!(b.sdo_download(ID, 0x1010, 1, b"save"), Ok(()));
    assert_eq!(b.nmt(0x81, ID), [boot_up()]);
    assert_eq!(b.sdo_read(ID, 0x1003, 0), [0x4F, 0x03, 0x10, 0x00, 0x00, 0, 0, 0], "no error after the reset");
    assert_eq!(b.sdo_read(ID, 0x1001, 0), [0x4F, 0x01, 0x10, 0x00, 0x00, 0, 0, 0]);
    assert!(is(parameters(&mut b), CHANGED));
}

// ---- NMT startup (0x1F80) -----------------------------------------------------------

/// 0x1F80 saved with `value`, then NMT reset communication: the node's state
/// once its boot-up has left.
fn state_after_reset_with_startup(value: u32) -> NmtState {
    let mut b = interop();
    assert_eq!(b.sdo_download(ID, 0x1F80, 0, &value.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1010, 2, b"save"), Ok(()));
    assert_eq!(b.nmt(0x82, ID), [boot_up()]);
    // Started: its event-driven TPDO goes out once (Pre-operational: nothing).
    let started = b.at(ms(1)) == [(0x184, TPDO1.to_vec())];
    assert_eq!(b.sdo_upload(ID, 0x1F80, 0), Ok(value.to_le_bytes().to_vec()), "the stored value is back");
    assert_eq!(started, b.node.state() == NmtState::Operational);
    b.node.state()
}

#[test]
fn nmt_startup_bit_2_starts_the_node_after_its_boot_up() {
    assert_eq!(state_after_reset_with_startup(0x04), NmtState::Operational, "bit 2: the node starts itself (CiA 302-2)");
    assert_eq!(state_after_reset_with_startup(0x0B), NmtState::PreOperational, "other bits: it waits for NMT");
}
