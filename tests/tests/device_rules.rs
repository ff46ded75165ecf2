//! The devices' own rules (docs/devices/<device>.md), each with exact
//! frames, the manual's own where it prints them, run by each device's
//! application as its image runs it.

mod common;

use canopen_core::node::Application;
use canopen_core::od::ObjectDictionary;
use common::{Bench, abort, ms, ok_write};
use firmware::devices::{agile, bmaxx4400, ec5000, sendix};
use hal_host::storage::MemStorage;

/// A device's node on the bench at t = 0, boot-up checked.
fn boot<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    od: O,
    app: A,
    storage: MemStorage,
    id: u8,
) -> Bench<O, A, MemStorage, R, T, HB> {
    let mut b = Bench::new(od, app, storage, id);
    assert_eq!(b.at(ms(0)), [(0x700 + u16::from(id), vec![0x00])]);
    b
}

// ---- agile ----------------------------------------------------------------------

type Agile = Bench<agile::od::Ram, agile::App, MemStorage, 4, 4, 0>;

fn agile_node(storage: MemStorage) -> Agile {
    boot(agile::od::Ram::new(1), agile::App::NEW, storage, 1)
}

#[test]
fn agile_communication_cycle_period_in_whole_milliseconds_d6() {
    let mut b = agile_node(MemStorage::new(8192));
    // 1500 µs: not a whole millisecond.
    assert_eq!(b.sdo_write(1, 0x1006, 0, &1500u32.to_le_bytes()), abort(0x1006, 0, 0x0609_0030));
    assert_eq!(b.sdo_write(1, 0x1006, 0, &2000u32.to_le_bytes()), ok_write(0x1006, 0));
    assert_eq!(b.sdo_upload(1, 0x1006, 0), Ok(2000u32.to_le_bytes().to_vec()));
}

#[test]
fn agile_data_set_0_writes_every_data_set_d25() {
    let mut b = agile_node(MemStorage::new(8192));
    // 0x2175 (parameter 373, four data sets, UNSIGNED16 1..24): 2B 75 21 00 0C 00 → all four.
    assert_eq!(b.rx(ms(1), 0x601, &[0x2B, 0x75, 0x21, 0x00, 0x0C, 0x00, 0, 0]), [(0x581, ok_write(0x2175, 0))]);
    for set in 1..=4 {
        assert_eq!(b.sdo_upload(1, 0x2175, set), Ok(vec![0x0C, 0x00]), "data set {set}");
    }
    assert_eq!(b.sdo_write(1, 0x2175, 0, &[0x19, 0x00]), abort(0x2175, 0, 0x0609_0031), "each data set's limits");
    assert_eq!(b.sdo_upload(1, 0x2175, 0), Ok(vec![0x0C, 0x00]), "data set 0 reads the four while they are equal (D49)");
    assert_eq!(b.sdo_write(1, 0x2175, 0, &[0x34]), abort(0x2175, 0, 0x0607_0013), "its own length");
    // A single-value parameter whose value happens to be 9 is written as itself (0x2183 p.387, INTEGER16).
    assert_eq!(b.sdo_write(1, 0x2183, 0, &[9, 0]), ok_write(0x2183, 0));
    assert_eq!(b.sdo_write(1, 0x2183, 0, &[10, 0]), ok_write(0x2183, 0));
    assert_eq!(b.sdo_upload(1, 0x2183, 0), Ok(vec![10, 0]));
}

#[test]
fn agile_node_id_and_bit_rate_from_p387_and_p385_when_set() {
    let mut storage = MemStorage::new(8192);
    assert_eq!(agile::startup(&mut storage), (1, None), "factory (p.387 = -1): node 1, the image's bit rate");
    let mut b = agile_node(storage);
    assert_eq!(b.sdo_write(1, 0x2183, 0, &[0x05, 0x00]), ok_write(0x2183, 0));
    assert_eq!(b.sdo_write(1, 0x2181, 0, &[0x07, 0x00]), ok_write(0x2181, 0));
    assert_eq!(b.sdo_write(1, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(agile::startup(b.node.storage_mut()), (5, Some(2)), "node 5 at 500 kbit/s (CiA 305 index 2)");
    assert_eq!(b.sdo_write(1, 0x2183, 0, &[0xFF, 0xFF]), ok_write(0x2183, 0));
    assert_eq!(b.sdo_write(1, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(agile::startup(b.node.storage_mut()).0, 1, "-1 stored again: reachable as node 1");
}

// ---- ec5000 ---------------------------------------------------------------------

type Ec5000 = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

fn ec5000_node(id: u8, storage: MemStorage) -> Ec5000 {
    boot(ec5000::od::Ram::new(id), ec5000::App::NEW, storage, id)
}

#[test]
fn ec5000_modes_of_operation_and_polarity_d34_d35() {
    let mut b = ec5000_node(5, MemStorage::new(4096));
    for mode in [0u8, 1, 3, 6] {
        assert_eq!(b.sdo_write(5, 0x6060, 0, &[mode]), ok_write(0x6060, 0));
    }
    for mode in [2u8, 4, 5] {
        assert_eq!(b.sdo_write(5, 0x6060, 0, &[mode]), abort(0x6060, 0, 0x0609_0030), "mode {mode}");
    }
    for polarity in [0u8, 64, 128, 192] {
        assert_eq!(b.sdo_write(5, 0x607E, 0, &[polarity]), ok_write(0x607E, 0));
    }
    assert_eq!(b.sdo_write(5, 0x607E, 0, &[0x20]), abort(0x607E, 0, 0x0609_0030));
    assert_eq!(b.sdo_upload(5, 0x607E, 0), Ok(vec![192]));
}

#[test]
fn ec5000_active_node_id_in_0x4650_sub2_after_boot_and_lss_d31() {
    let mut b = ec5000_node(5, MemStorage::new(4096));
    assert_eq!(b.sdo_upload(5, 0x4650, 2), Ok(vec![5]));
    // LSS: switch state global (configuration), configure node-ID 9, back to waiting, reset communication.
    assert_eq!(b.rx(ms(1), 0x7E5, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.rx(ms(2), 0x7E5, &[0x11, 0x09, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(3), 0x7E5, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]), []);
    assert_eq!(b.nmt(0x82, 0), [(0x709, vec![0x00])]);
    assert_eq!(b.sdo_upload(9, 0x4650, 2), Ok(vec![9]));
}

#[test]
fn ec5000_static_node_id_is_read_at_boot_d31() {
    let mut b = ec5000_node(127, MemStorage::new(4096));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (127, None));
    assert_eq!(b.sdo_write(127, 0x4650, 1, &[0x0C]), ok_write(0x4650, 1));
    // With it the set holds 0x4651 sub 1's default: 250 kbit/s (D69).
    assert_eq!(ec5000::startup(b.node.storage_mut()), (12, Some(3)), "stored when written");
    // 0x1010 sub 1 stores "all parameters except node-ID" (L744).
    assert_eq!(b.sdo_write(127, 0x4650, 1, &[0x0D]), ok_write(0x4650, 1));
    assert_eq!(b.sdo_write(127, 0x4650, 1, &[0x0C]), ok_write(0x4650, 1));
    assert_eq!(b.sdo_write(127, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (12, Some(3)));
}

#[test]
fn ec5000_can_bit_rate_0x4651_sub1_takes_effect_at_the_next_start_l1390_d69() {
    let mut b = ec5000_node(5, MemStorage::new(4096));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (127, None), "nothing stored: the image's bit rate");
    // 125 and 250 kbit/s only (the EDS's bit rates); outside 125..250 the limits answer first.
    assert_eq!(b.sdo_write(5, 0x4651, 1, &200u16.to_le_bytes()), abort(0x4651, 1, 0x0609_0030));
    assert_eq!(b.sdo_write(5, 0x4651, 1, &100u16.to_le_bytes()), abort(0x4651, 1, 0x0609_0032));
    assert_eq!(b.sdo_write(5, 0x4651, 1, &500u16.to_le_bytes()), abort(0x4651, 1, 0x0609_0031));
    assert_eq!(b.sdo_write(5, 0x4651, 1, &[0x7D, 0x00]), ok_write(0x4651, 1));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (127, None), "not stored yet");
    assert_eq!(b.sdo_write(5, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (127, Some(4)), "125 kbit/s (CiA 305 index 4) from the next start");
    // 0x4651 shows the rate configured, the bus keeps its own until the
    // next start; back to 250 by a save of the manufacturer scope.
    assert_eq!(b.sdo_upload(5, 0x4651, 1), Ok(vec![0x7D, 0x00]));
    assert_eq!(b.sdo_write(5, 0x4651, 1, &[0xFA, 0x00]), ok_write(0x4651, 1));
    assert_eq!(b.sdo_write(5, 0x1010, 4, b"save"), ok_write(0x1010, 4));
    assert_eq!(ec5000::startup(b.node.storage_mut()), (127, Some(3)));
}

#[test]
fn ec5000_save_and_load_of_ssw_parameters_work_f8() {
    let mut b = ec5000_node(5, MemStorage::new(4096));
    assert_eq!(b.sdo_upload(5, 0x1010, 5), Ok(vec![1, 0, 0, 0]), "saves on command");
    assert_eq!(b.sdo_write(5, 0x4231, 1, &[0x46, 0x00]), ok_write(0x4231, 1));
    assert_eq!(b.rx(ms(1), 0x605, &[0x23, 0x10, 0x10, 0x05, 0x73, 0x61, 0x76, 0x65]), [(0x585, ok_write(0x1010, 5))]);
    b.nmt(0x81, 5);
    assert_eq!(b.sdo_upload(5, 0x4231, 1), Ok(vec![0x46, 0x00]), "stored by 0x1010:5");
    assert_eq!(b.rx(ms(2), 0x605, &[0x23, 0x11, 0x10, 0x05, 0x6C, 0x6F, 0x61, 0x64]), [(0x585, ok_write(0x1011, 5))]);
    b.nmt(0x81, 5);
    assert_eq!(b.sdo_upload(5, 0x4231, 1), Ok(vec![95, 0x00]), "the default again after 0x1011:5");
    assert_eq!(b.sdo_write(5, 0x1010, 5, b"load"), abort(0x1010, 5, 0x0800_0020), "the wrong signature");
}

// ---- sendix ---------------------------------------------------------------------

type Sendix = Bench<sendix::od::Ram, sendix::App, MemStorage, 0, 3, 0>;

fn sendix_node(storage: MemStorage) -> Sendix {
    boot(sendix::od::Ram::new(0x3F), sendix::App::NEW, storage, 0x3F)
}

#[test]
fn sendix_cyclic_timer_and_tpdo1_event_timer_are_one_value_d11() {
    let mut b = sendix_node(MemStorage::new(4096));
    assert_eq!(b.sdo_write(0x3F, 0x6200, 0, &[0x64, 0x00]), ok_write(0x6200, 0));
    assert_eq!(b.sdo_upload(0x3F, 0x1800, 5), Ok(vec![0x64, 0x00]));
    assert_eq!(b.sdo_write(0x3F, 0x1800, 5, &[0x32, 0x00]), ok_write(0x1800, 5));
    assert_eq!(b.sdo_upload(0x3F, 0x6200, 0), Ok(vec![0x32, 0x00]));
    // Start, then TPDO1 every cyclic-timer period.
    b.nmt(0x01, 0x3F);
    let out: Vec<u64> = b.run_until(ms(160)).iter().filter(|(_, f)| f.0 == 0x1BF).map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(out, [50, 100, 150]);
}

#[test]
fn sendix_preset_is_stored_when_written_d17() {
    let mut b = sendix_node(MemStorage::new(4096));
    assert_eq!(b.sdo_write(0x3F, 0x6003, 0, &[0x10, 0x27, 0, 0]), ok_write(0x6003, 0));
    let storage = b.node.storage_mut().clone();
    let mut again = sendix_node(storage);
    assert_eq!(again.sdo_upload(0x3F, 0x6003, 0), Ok(vec![0x10, 0x27, 0, 0]), "after a power cycle");
    // A store that fails fails the write: the master learns the preset is not permanent, and
    // the memory's EMCY 0x5000 (L3688) and warning 0x6505 bit 15's 0x5200 (L2750, docs/devices/sendix.md D40, D42).
    again.node.storage_mut().cut_after(0);
    let out = again.rx(ms(1), 0x63F, &[0x23, 0x03, 0x60, 0x00, 0x20, 0x4E, 0, 0]);
    let nvm = vec![0x00, 0x50, 0x01, 0xE1, 0x01, 0, 0, 0];
    assert_eq!(out, [(0x0BF, nvm), (0x0BF, vec![0x00, 0x52, 0x01, 0, 0, 0, 0, 0]), (0x5BF, abort(0x6003, 0, 0x0606_0000))]);
}

#[test]
fn sendix_bus_parameters_become_permanent_only_through_0x2105_d5() {
    let mut b = sendix_node(MemStorage::new(4096));
    assert_eq!(b.sdo_write(0x3F, 0x2101, 0, &[0x22]), ok_write(0x2101, 0));
    assert_eq!(b.sdo_write(0x3F, 0x2100, 0, &[4]), ok_write(0x2100, 0));
    assert_eq!(b.sdo_write(0x3F, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(sendix::startup(b.node.storage_mut()), (0x3F, Some(3)), "0x1010 leaves them as stored");
    assert_eq!(b.sdo_write(0x3F, 0x2105, 0, b"load"), abort(0x2105, 0, 0x0800_0020));
    assert_eq!(b.rx(ms(1), 0x63F, &[0x23, 0x05, 0x21, 0x00, 0x73, 0x61, 0x76, 0x65]), [(0x5BF, ok_write(0x2105, 0))]);
    assert_eq!(sendix::startup(b.node.storage_mut()), (0x22, Some(4)));
}

#[test]
fn sendix_100_kbit_is_refused_and_no_stored_code_panics_a_board() {
    let mut b = sendix_node(MemStorage::new(4096));
    assert_eq!(b.sdo_write(0x3F, 0x2100, 0, &[3]), abort(0x2100, 0, 0x0609_0030));
    // A code 3 stored by an older image starts at the factory 250 kbit/s (index 3, which every board has).
    let mut ram = sendix::od::Ram::new(0x3F);
    ram.set_baud_rate(3);
    let mut storage = MemStorage::new(4096);
    canopen_core::services::store::save(
        &sendix::od::DICTIONARY,
        ram.image(),
        0x3F,
        &mut storage,
        canopen_core::services::store::Scope::All,
    )
    .unwrap();
    assert_eq!(sendix::startup(&mut storage), (0x3F, Some(3)));
}

#[test]
fn sendix_device_type_is_the_m5868_column_d2() {
    let mut b = sendix_node(MemStorage::new(4096));
    assert_eq!(b.rx(ms(1), 0x63F, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [(0x5BF, vec![0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x0B, 0x00])]);
}

// ---- bmaxx4400 -------------------------------------------------------------------

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

fn bmaxx_node(id: u8) -> Bmaxx {
    boot(bmaxx4400::od::Ram::new(id), bmaxx4400::App::NEW, MemStorage::new(8192), id)
}

/// One expedited download as the manual prints it; the confirmation.
fn download(b: &mut Bmaxx, id: u8, req: [u8; 8]) {
    let out = b.rx(b.now, 0x600 + u16::from(id), &req);
    assert_eq!(out, [(0x580 + u16::from(id), ok_write(u16::from_le_bytes([req[1], req[2]]), req[3]))], "{req:02X?}");
}

#[test]
fn bmaxx_pdo_mapping_sequence_of_the_manual_d27() {
    // §5.5.3 (B14), node 2: the entries written into valid, non-empty mappings, sub 0 last.
    let mut b = bmaxx_node(2);
    for req in [
        [0x23, 0x00, 0x1A, 0x01, 0x10, 0x00, 0x86, 0x60],
        [0x23, 0x00, 0x1A, 0x02, 0x10, 0x00, 0x44, 0x60],
        [0x2F, 0x00, 0x1A, 0x00, 0x02, 0, 0, 0],
        [0x23, 0x01, 0x1A, 0x01, 0x10, 0x00, 0x41, 0x60],
        [0x23, 0x01, 0x1A, 0x02, 0x10, 0x00, 0x44, 0x60],
        [0x2F, 0x01, 0x1A, 0x00, 0x02, 0, 0, 0],
        [0x23, 0x00, 0x16, 0x01, 0x10, 0x00, 0x40, 0x60],
        [0x23, 0x00, 0x16, 0x02, 0x10, 0x00, 0x42, 0x60],
        [0x2F, 0x00, 0x16, 0x00, 0x02, 0, 0, 0],
    ] {
        download(&mut b, 2, req);
    }
    // B15, node 2: TPDO1 on 0x207 while valid, type 255; TPDO2 type 254 with a 10 ms timer.
    download(&mut b, 2, [0x23, 0x00, 0x18, 0x01, 0x07, 0x02, 0x00, 0x00]);
    download(&mut b, 2, [0x2F, 0x00, 0x18, 0x02, 0xFF, 0, 0, 0]);
    download(&mut b, 2, [0x2F, 0x01, 0x18, 0x02, 0xFE, 0, 0, 0]);
    download(&mut b, 2, [0x2B, 0x01, 0x18, 0x05, 0x0A, 0x00, 0, 0]);
    // Operational: TPDO1 (0x6086 + 0x6044) at once on 0x207; TPDO2 (0x6041 + 0x6044) on its timer only.
    let out = b.nmt(0x01, 2);
    assert!(out.contains(&(0x207, vec![0, 0, 0, 0])), "{out:x?}");
    assert!(!out.iter().any(|f| f.0 == 0x282), "type 254 does not send on entering Operational: {out:x?}");
    let tpdo2: Vec<u64> = b.run_until(ms(25)).iter().filter(|(_, f)| f.0 == 0x282).map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(tpdo2, [10, 20]);
    // Mappings change in Pre-operational only; in Operational a COB-ID follows CiA 301.
    assert_eq!(b.sdo_write(2, 0x1A00, 1, &[0x10, 0x00, 0x41, 0x60]), abort(0x1A00, 1, 0x0800_0022));
    assert_eq!(b.sdo_write(2, 0x1A00, 2, &[0x10, 0x00, 0x41, 0x60]), abort(0x1A00, 2, 0x0800_0022));
    assert_eq!(b.sdo_write(2, 0x1A00, 0, &[1]), abort(0x1A00, 0, 0x0800_0022));
    assert_eq!(b.sdo_write(2, 0x1800, 1, &[0x82, 0x01, 0x00, 0x00]), abort(0x1800, 1, 0x0609_0030), "valid: no move");
    assert_eq!(b.sdo_write(2, 0x1800, 1, &[0x07, 0x02, 0x00, 0x80]), ok_write(0x1800, 1), "made invalid");
    let out = b.rx(b.now, 0x602, &[0x23, 0x00, 0x18, 0x01, 0x82, 0x01, 0x00, 0x00]);
    assert_eq!(out, [(0x182, vec![0, 0, 0, 0]), (0x582, ok_write(0x1800, 1))], "valid again on 0x182, sent at once (type 255)");
    assert_eq!(b.sdo_write(2, 0x1801, 5, &[0x14, 0x00]), ok_write(0x1801, 5), "an event timer may change");
}

#[test]
fn bmaxx_type_254_is_timer_only_d26() {
    let mut b = bmaxx_node(1);
    // TPDO3/TPDO4 are type 254 with event timer 0: silent on entering Operational and on a change.
    let out = b.nmt(0x01, 1);
    assert!(!out.iter().any(|f| f.0 == 0x381 || f.0 == 0x481), "{out:x?}");
    b.node.write_object(ms(1), 0x6064, 0, &[1, 0, 0, 0]).ok();
    b.node.od_mut();
    assert!(!b.at(ms(2)).iter().any(|f| f.0 == 0x381), "no send on change");
}

#[test]
fn bmaxx_heartbeat_time_written_with_one_byte_d9() {
    let mut b = bmaxx_node(1);
    assert_eq!(b.rx(ms(0), 0x601, &[0x2F, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]), [(0x581, ok_write(0x1017, 0))]);
    assert_eq!(b.sdo_upload(1, 0x1017, 0), Ok(vec![0x64, 0x00]));
    assert_eq!(b.run_until(ms(200)), [(ms(100), (0x701, vec![0x7F])), (ms(200), (0x701, vec![0x7F]))]);
}
