//! The five device dictionaries as the firmware compiles them: every entry
//! holds exactly what its EDS says (checked against an independent read of the
//! EDS by od-gen's reader), `$NODEID` values follow the node-id, and the typed
//! accessors and index constants reach the objects the manuals name.

use canopen_core::abort::AbortCode;
use canopen_core::od::{DataType, Dictionary, ObjectDictionary};
use canopen_firmware::devices::{self, agile, bmaxx4400, ec5000, sendix, unitek_ds};

fn image(d: &Dictionary, node_id: u8) -> Vec<u8> {
    let mut img = vec![0u8; d.defaults.len];
    d.reset_application(&mut img, node_id);
    d.reset_communication(&mut img, node_id);
    img
}

/// Every entry of every device equals the EDS value, for two node-ids.
#[test]
fn every_entry_matches_its_eds() {
    for dev in &devices::ALL {
        let path = format!("{}/eds/{}.eds", env!("CARGO_MANIFEST_DIR"), dev.name);
        let (eds, diags) = od_gen::load_path(path.as_ref(), od_gen::Options { strict: true }).unwrap();
        assert!(diags.items.is_empty(), "{diags}");
        let d = dev.dictionary;
        let visible = eds.objects.values().filter(|o| !o.opaque).map(|o| o.subs.len()).sum::<usize>();
        assert_eq!(d.entries.len(), visible, "{}", dev.name);
        for node_id in [1u8, 127] {
            let img = image(d, node_id);
            for e in d.entries {
                let sub = eds.sub(e.index, e.sub).expect("entry comes from the EDS");
                assert_eq!(Some(e.data_type), sub.data_type);
                let mut expected = sub.value.clone();
                if sub.node_id {
                    let v = u32::from_le_bytes(expected[..4].try_into().unwrap()) + u32::from(node_id);
                    expected = v.to_le_bytes().to_vec();
                }
                let got = d.value(&img, e);
                if e.data_type == DataType::Domain {
                    assert!(got.is_empty());
                    continue;
                }
                assert_eq!(&got[..expected.len()], &expected[..], "{} 0x{:04X} sub {}", dev.name, { e.index }, { e.sub });
                assert!(got[expected.len()..].iter().all(|&b| b == 0));
            }
        }
    }
}

#[test]
fn device_types_identify_the_profiles() {
    // CiA 402 drives report 0x0192 in the low word, the CiA 406 encoder 0x0196.
    assert_eq!(ec5000::od::Ram::new(1).device_type(), 0x0042_0192);
    assert_eq!(bmaxx4400::od::Ram::new(1).device_type(), 0x0202_0192);
    assert_eq!(agile::od::Ram::new(1).device_type(), 0x0041_0192);
    assert_eq!(sendix::od::Ram::new(1).device_type(), 0x000B_0196);
    assert_eq!(unitek_ds::od::Ram::new(1).device_type(), 0);
}

#[test]
fn node_id_relative_cob_ids_follow_reset_communication() {
    let mut ram = ec5000::od::Ram::new(127);
    assert_eq!(ram.sdo_server_parameter_cob_id_client_to_server(), 0x67F);
    assert_eq!(ram.dictionary().read(ram.image(), 0x1800, 1), Ok(&0x1FFu32.to_le_bytes()[..]));
    ram.reset_communication(5);
    assert_eq!(ram.sdo_server_parameter_cob_id_client_to_server(), 0x605);
    assert_eq!(ram.sdo_server_parameter_cob_id_server_to_client(), 0x585);
    // The encoder's TPDO1 refuses RTR (bit 30), as its manual says.
    let enc = sendix::od::Ram::new(0x3F);
    assert_eq!(enc.dictionary().read(enc.image(), 0x1800, 1), Ok(&0x4000_01BFu32.to_le_bytes()[..]));
}

#[test]
fn typed_accessors_and_index_constants_reach_the_profile_objects() {
    let mut drive = ec5000::od::Ram::new(1);
    assert_eq!(ec5000::od::index::CONTROLWORD, 0x6040);
    assert_eq!(ec5000::od::index::STATUSWORD, 0x6041);
    drive.set_controlword(0x000F);
    assert_eq!(drive.dictionary().read(drive.image(), ec5000::od::index::CONTROLWORD, 0), Ok(&[0x0F, 0x00][..]));
    drive.set_modes_of_operation(3);
    assert_eq!(drive.modes_of_operation(), 3);
    // An SDO write is seen by the typed accessor.
    let d = drive.dictionary();
    d.write(drive.image_mut(), 0x6040, 0, &[0x06, 0x00]).unwrap();
    assert_eq!(drive.controlword(), 0x0006);

    let mut encoder = sendix::od::Ram::new(0x3F);
    encoder.set_position_value(0x0012_3456);
    assert_eq!(encoder.dictionary().read(encoder.image(), sendix::od::index::POSITION_VALUE, 0), Ok(&[0x56, 0x34, 0x12, 0x00][..]));
}

#[test]
fn default_pdo_mappings_are_the_manuals() {
    // RPDO1 carries the controlword and TPDO1 the statusword on every drive.
    for (d, rpdo1, tpdo1) in [
        (&ec5000::od::DICTIONARY, 0x6040_0010u32, 0x6041_0010u32),
        (&bmaxx4400::od::DICTIONARY, 0x6040_0010, 0x6041_0010),
        (&agile::od::DICTIONARY, 0x6040_0010, 0x6041_0010),
    ] {
        let img = image(d, 1);
        assert_eq!(d.read(&img, 0x1600, 1), Ok(&rpdo1.to_le_bytes()[..]));
        assert_eq!(d.read(&img, 0x1A00, 1), Ok(&tpdo1.to_le_bytes()[..]));
    }
    // The encoder sends its 32-bit position in TPDO1 and has no RPDO.
    let img = image(&sendix::od::DICTIONARY, 1);
    assert_eq!(sendix::od::DICTIONARY.read(&img, 0x1A00, 1), Ok(&0x6004_0020u32.to_le_bytes()[..]));
    assert_eq!(sendix::od::RPDO_COUNT, 0);
    assert_eq!(sendix::od::DICTIONARY.find(0x1400, 0), Err(AbortCode::NoObject));
}

#[test]
fn unitek_registers_are_objects_at_0x2000_plus_regid() {
    // The register protocol's CAN identifiers are registers 0x68/0x69.
    let ram = unitek_ds::od::Ram::new(1);
    let d = ram.dictionary();
    assert_eq!(d.read(ram.image(), 0x2068, 0), Ok(&0x0201u16.to_le_bytes()[..]));
    assert_eq!(d.read(ram.image(), 0x2069, 0), Ok(&0x0181u16.to_le_bytes()[..]));
    // No SDO server, no PDO: the device does not speak CANopen.
    assert_eq!(unitek_ds::od::SDO_SERVER_COUNT, 0);
    assert_eq!(unitek_ds::od::TPDO_COUNT, 0);
}

#[test]
fn sizing_constants_match_the_manuals() {
    assert_eq!((ec5000::od::RPDO_COUNT, ec5000::od::TPDO_COUNT), (4, 4));
    assert_eq!((bmaxx4400::od::RPDO_COUNT, bmaxx4400::od::TPDO_COUNT), (4, 4));
    assert_eq!((agile::od::RPDO_COUNT, agile::od::TPDO_COUNT), (3, 3));
    assert_eq!(sendix::od::TPDO_COUNT, 3);
    assert_eq!(ec5000::od::ERROR_HISTORY_LEN, 8);
    assert!(ec5000::od::DICTIONARY.device.lss_supported && sendix::od::DICTIONARY.device.lss_supported);
    assert!(!agile::od::DICTIONARY.device.lss_supported);
}

#[test]
fn every_image_fits_the_ram_budget() {
    // 20 KiB parts: the dictionary must leave room for the stack and the services.
    for dev in &devices::ALL {
        assert!(dev.dictionary.defaults.len < 2048, "{}: {} B", dev.name, dev.dictionary.defaults.len);
    }
    assert_eq!(devices::by_name("sendix").map(|d| d.default_node_id), Some(0x3F));
    assert!(devices::by_name("nope").is_none());
}

#[test]
fn sendix_starts_from_its_stored_bus_parameters_or_the_factory_values() {
    use canopen_core::od::ObjectDictionary;
    use canopen_core::services::store::{self, Scope};
    struct Flash([[u8; 1024]; 2]);
    impl canopen_core::storage::Storage for Flash {
        fn region_size(&self) -> usize {
            1024
        }
        fn read(&mut self, r: u8, off: usize, buf: &mut [u8]) -> Result<(), canopen_core::storage::StorageError> {
            buf.copy_from_slice(&self.0[usize::from(r)][off..off + buf.len()]);
            Ok(())
        }
        fn erase(&mut self, r: u8) -> Result<(), canopen_core::storage::StorageError> {
            self.0[usize::from(r)].fill(0xFF);
            Ok(())
        }
        fn write(&mut self, r: u8, off: usize, data: &[u8]) -> Result<(), canopen_core::storage::StorageError> {
            self.0[usize::from(r)][off..off + data.len()].copy_from_slice(data);
            Ok(())
        }
    }
    let mut flash = Flash([[0xFF; 1024]; 2]);
    assert_eq!(sendix::startup(&mut flash), (0x3F, Some(3)), "factory: node 0x3F, 250 kbit/s");
    let mut ram = sendix::od::Ram::new(0x3F);
    ram.set_node_address(0x22);
    ram.set_baud_rate(4); // 8 - 4 = table index 4, 125 kbit/s
    store::save(&sendix::od::DICTIONARY, ram.image(), 0x3F, &mut flash, Scope::All).unwrap();
    assert_eq!(sendix::startup(&mut flash), (0x22, Some(4)));
}
