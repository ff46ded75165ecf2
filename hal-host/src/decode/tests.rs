use super::*;
use firmware::devices::ec5000::od;

fn f(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn ec5000() -> Decoder {
    Decoder::new(Some(ObjectNames::new(&od::DICTIONARY, &od::NAMES)))
}

#[test]
fn nmt_heartbeat_sync_and_guarding() {
    let mut d = ec5000();
    assert_eq!(d.decode(&f(0x000, &[0x01, 127])), "NMT Start remote node 127");
    assert_eq!(d.decode(&f(0x000, &[0x02, 127])), "NMT Stop remote node 127");
    assert_eq!(d.decode(&f(0x000, &[0x80, 0])), "NMT Enter pre-operational (all nodes)");
    assert_eq!(d.decode(&f(0x000, &[0x81, 3])), "NMT Reset node 3");
    assert_eq!(d.decode(&f(0x000, &[0x82, 3])), "NMT Reset communication, node 3");
    assert_eq!(d.decode(&f(0x000, &[0x03, 3])), "NMT malformed (2 bytes)");
    assert_eq!(d.decode(&f(0x000, &[0x01])), "NMT malformed (1 bytes)");
    assert_eq!(d.decode(&f(0x77F, &[0x00])), "Boot-up node 127");
    assert_eq!(d.decode(&f(0x77F, &[0x05])), "Heartbeat node 127: Operational");
    assert_eq!(d.decode(&f(0x77F, &[0x7F])), "Heartbeat node 127: Pre-operational");
    assert_eq!(d.decode(&f(0x701, &[0x84])), "Heartbeat node 1: Stopped");
    assert_eq!(d.decode(&f(0x701, &[0x33])), "Heartbeat node 1: unknown state 0x33");
    assert_eq!(d.decode(&f(0x701, &[])), "Heartbeat node 1: malformed (0 bytes)");
    assert_eq!(d.decode(&CanFrame::remote(0x77F, 1).unwrap()), "Node guarding request node 127");
    assert_eq!(d.decode(&f(0x080, &[])), "SYNC");
    assert_eq!(d.decode(&f(0x080, &[7])), "SYNC counter 7");
    assert_eq!(d.decode(&f(0x100, &[0; 6])), "TIME stamp");
    assert_eq!(d.decode(&f(0x7E5, &[0x04, 1, 0, 0, 0, 0, 0, 0])), "LSS request");
    assert_eq!(d.decode(&f(0x7FF, &[1])), "");
}

#[test]
fn sdo_expedited_values_by_data_type() {
    let mut d = ec5000();
    assert_eq!(d.decode(&f(0x67F, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])), "SDO upload request 0x1018:01 Vendor-ID");
    assert_eq!(d.decode(&f(0x5FF, &[0x43, 0x18, 0x10, 0x01, 0xFB, 0x03, 0, 0])), "SDO upload 0x1018:01 Vendor-ID = 0x000003FB (1019)");
    assert_eq!(d.decode(&f(0x5FF, &[0x4F, 0x18, 0x10, 0x00, 4, 0, 0, 0])), "SDO upload 0x1018:00 Identity highest sub-index = 0x04 (4)");
    // INTEGER32 (0x60FF target velocity) in decimal; no size indicated: all four bytes.
    assert_eq!(d.decode(&f(0x5FF, &[0x42, 0xFF, 0x60, 0x00, 0x9C, 0xFF, 0xFF, 0xFF])), "SDO upload 0x60FF:00 Target velocity = -100");
    assert_eq!(
        d.decode(&f(0x67F, &[0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0])),
        "SDO download 0x1017:00 Producer heartbeat time = 0x0064 (100)"
    );
    assert_eq!(d.decode(&f(0x5FF, &[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0])), "SDO download 0x1017:00 Producer heartbeat time done");
    // A length that does not fit the type is shown raw.
    assert_eq!(d.decode(&f(0x5FF, &[0x4B, 0x18, 0x10, 0x01, 1, 2, 0, 0])), "SDO upload 0x1018:01 Vendor-ID = [01 02] (not a UNSIGNED32)");
    // An object the dictionary lacks: no name, raw bytes.
    assert_eq!(d.decode(&f(0x5FF, &[0x4F, 0x00, 0x30, 0x02, 9, 0, 0, 0])), "SDO upload 0x3000:02 = [09]");
}

#[test]
fn sdo_segmented_upload_shows_the_whole_value_at_the_end() {
    let mut d = ec5000();
    assert_eq!(d.decode(&f(0x67F, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0])), "SDO upload request 0x1008:00 Manufacturer device name");
    assert_eq!(
        d.decode(&f(0x5FF, &[0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0])),
        "SDO upload 0x1008:00 Manufacturer device name: segmented, 10 bytes"
    );
    assert_eq!(d.decode(&f(0x67F, &[0x60, 0, 0, 0, 0, 0, 0, 0])), "SDO upload segment request (toggle 0)");
    assert_eq!(d.decode(&f(0x5FF, &[0x00, b'R', b'o', b'l', b'l', b'e', b'r', b'D'])), "SDO upload segment 1 (7 bytes)");
    assert_eq!(d.decode(&f(0x67F, &[0x70, 0, 0, 0, 0, 0, 0, 0])), "SDO upload segment request (toggle 1)");
    // 7 - n = 3 bytes, c = 1.
    assert_eq!(
        d.decode(&f(0x5FF, &[0x19, b'r', b'v', b'e', 0, 0, 0, 0])),
        "SDO upload segment 2 (3 bytes, last): 0x1008:00 Manufacturer device name = \"RollerDrve\""
    );
    // The transfer is over: a stray segment has no object.
    assert_eq!(d.decode(&f(0x5FF, &[0x0B, b'x', b'y', 0, 0, 0, 0, 0])), "SDO upload segment (2 bytes, last)");
}

#[test]
fn sdo_segmented_download_and_aborts() {
    let mut d = ec5000();
    assert_eq!(
        d.decode(&f(0x67F, &[0x21, 0x08, 0x10, 0x00, 8, 0, 0, 0])),
        "SDO download 0x1008:00 Manufacturer device name: segmented, 8 bytes"
    );
    assert_eq!(d.decode(&f(0x5FF, &[0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0])), "SDO download 0x1008:00 Manufacturer device name done");
    assert_eq!(d.decode(&f(0x67F, &[0x00, b'A', b'B', b'C', b'D', b'E', b'F', b'G'])), "SDO download segment 1 (7 bytes)");
    assert_eq!(d.decode(&f(0x5FF, &[0x20, 0, 0, 0, 0, 0, 0, 0])), "SDO download segment confirmed (toggle 0)");
    assert_eq!(
        d.decode(&f(0x67F, &[0x1D, b'H', 0, 0, 0, 0, 0, 0])),
        "SDO download segment 2 (1 bytes, last): 0x1008:00 Manufacturer device name = \"ABCDEFGH\""
    );
    assert_eq!(
        d.decode(&f(0x5FF, &[0x80, 0x34, 0x12, 0x00, 0x00, 0x00, 0x02, 0x06])),
        "SDO abort 0x1234:00: 0x06020000 Object does not exist in the object dictionary"
    );
    assert_eq!(
        d.decode(&f(0x5FF, &[0x80, 0x18, 0x10, 0x7F, 0x11, 0x00, 0x09, 0x06])),
        "SDO abort 0x1018:7F: 0x06090011 Sub-index does not exist"
    );
    assert_eq!(
        d.decode(&f(0x67F, &[0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05])),
        "SDO abort by the master 0x1000:00 Device type: 0x05040000 SDO protocol timed out"
    );
    assert_eq!(
        d.decode(&f(0x5FF, &[0x80, 0x00, 0x10, 0x00, 0x78, 0x56, 0x34, 0x12])),
        "SDO abort 0x1000:00 Device type: 0x12345678 not a CiA 301 abort code"
    );
    assert_eq!(d.decode(&f(0x5FF, &[0x40, 0, 0])), "SDO response from node 127: [40 00 00]");
    assert_eq!(d.decode(&f(0x67F, &[0xE0, 0, 0, 0, 0, 0, 0, 0])), "SDO request to node 127: [E0 00 00 00 00 00 00 00]");
}

#[test]
fn emcy_codes() {
    let mut d = ec5000();
    assert_eq!(
        d.decode(&f(0x0FF, &[0x30, 0x81, 0x11, 0x03, 0, 0, 0, 0])),
        "EMCY node 127: 0x8130 Life guard error or heartbeat error, register 0x11, info [03 00 00 00 00]"
    );
    assert_eq!(d.decode(&f(0x0FF, &[0x00, 0x00, 0x00, 0, 0, 0, 0, 0])), "EMCY node 127: error reset, register 0x00");
    assert_eq!(
        d.decode(&f(0x081, &[0x10, 0x42, 0x09, 0, 0, 0, 0, 0])),
        "EMCY node 1: 0x4210 Temperature, register 0x09, info [00 00 00 00 00]"
    );
    assert_eq!(d.decode(&f(0x081, &[0x10, 0x42])), "EMCY node 1: malformed (2 bytes)");
    assert_eq!(emcy_text(0xFF01), "Device specific");
    assert_eq!(emcy_text(0xA000), "Unknown error code");
}

#[test]
fn pdos_along_their_mapping() {
    let mut d = ec5000();
    let m = |v: u32| MappingEntry::from_u32(v);
    // EC5000 TPDO1 (0x1A00) and RPDO1 (0x1600) as the EDS maps them.
    d.add_pdo(0x1FF, "TPDO1 node 127", &[m(0x6041_0010), m(0x6061_0008), m(0x1001_0008), m(0x2200_0610), m(0x6077_0010)]);
    d.add_pdo(0x27F, "RPDO1 node 127", &[m(0x6040_0010), m(0x6060_0008), m(0x6081_0020)]);
    assert_eq!(
        d.decode(&f(0x1FF, &[0x37, 0x02, 0x03, 0x00, 0x19, 0x00, 0xF6, 0xFF])),
        "TPDO1 node 127: Statusword=0x0237 (567), Modes of operation display=3, Error register=0x00 (0), \
         Actual temperature=25, Torque actual value=-10"
    );
    assert_eq!(
        d.decode(&f(0x27F, &[0x0F, 0x00, 0x03, 0xF4, 0x01, 0x00, 0x00])),
        "RPDO1 node 127: Controlword=0x000F (15), Modes of operation=3, Profile velocity=0x000001F4 (500)"
    );
    assert_eq!(d.decode(&f(0x27F, &[0x0F, 0x00])), "RPDO1 node 127: PDO of 2 bytes, mapping needs 7");
    // Without a mapping: the default connection set names it.
    assert_eq!(d.decode(&f(0x2FF, &[1, 2])), "TPDO2 node 127: [01 02] (mapping unknown)");
    assert_eq!(d.decode(&f(0x57F, &[])), "RPDO4 node 127: [] (mapping unknown)");
    assert_eq!(d.decode(&f(0x401, &[9])), "RPDO3 node 1: [09] (mapping unknown)");
}

#[test]
fn without_a_dictionary_and_extended_frames() {
    let mut d = Decoder::new(None);
    assert_eq!(d.decode(&f(0x5FF, &[0x43, 0x18, 0x10, 0x01, 0xFB, 0x03, 0, 0])), "SDO upload 0x1018:01 = [FB 03 00 00]");
    assert_eq!(d.decode(&CanFrame::extended(EXIT_ID, b"EXIT\x00").unwrap()), "QEMU exit request (status 0)");
    assert_eq!(d.decode(&CanFrame::extended(EXIT_ID, b"EXIT\x01").unwrap()), "QEMU exit request (status 1)");
    assert_eq!(d.decode(&CanFrame::extended(EXIT_ID, b"EXIT").unwrap()), "QEMU exit request (status 0)");
    assert_eq!(d.decode(&CanFrame::extended(0x123, b"EXIT").unwrap()), "");
    assert_eq!(format_value(Some(DataType::Boolean), &[1]), "true");
    assert_eq!(format_value(Some(DataType::Real32), &1.5f32.to_le_bytes()), "1.5");
    assert_eq!(format_value(Some(DataType::OctetString), &[0xDE, 0xAD]), "[DE AD]");
    assert_eq!(format_value(Some(DataType::VisibleString), b"EC5000\0\0"), "\"EC5000\"");
}

#[test]
fn unitek_register_protocol_by_name() {
    use firmware::devices::unitek_ds::od as unitek;
    let mut d = Decoder::new(Some(ObjectNames::new(&unitek::DICTIONARY, &unitek::NAMES)));
    d.add_unitek(0x201, 0x181);
    assert_eq!(d.decode(&f(0x201, &[0x3D, 0x30, 0x0A])), "UNITEK read 0x30 Speed actual value every 10 ms");
    assert_eq!(d.decode(&f(0x201, &[0x3D, 0x40, 0x00])), "UNITEK read 0x40 Status map");
    assert_eq!(d.decode(&f(0x201, &[0x3D, 0x30, 0xFF])), "UNITEK stop cyclic 0x30 Speed actual value");
    assert_eq!(d.decode(&f(0x201, &[0x31, 0xCD, 0x0C])), "UNITEK write 0x31 Speed set point = 3277");
    assert_eq!(d.decode(&f(0x201, &[0x6E, 0x00, 0x80])), "UNITEK write 0x6E Position destination = -32768");
    assert_eq!(d.decode(&f(0x201, &[0x51, 0x04, 0x00])), "UNITEK write 0x51 Mode = 0x0004 (4)");
    assert_eq!(d.decode(&f(0x181, &[0x40, 0x81, 0x31, 0x00, 0x00, 0x00])), "UNITEK 0x40 Status map = 0x00003181 (12673)");
    assert_eq!(d.decode(&f(0x181, &[0x30, 0x01, 0x80, 0x00])), "UNITEK 0x30 Speed actual value = -32767");
    assert_eq!(d.decode(&f(0x201, &[0x31])), "UNITEK malformed request [31]");
    assert_eq!(d.decode(&f(0x181, &[0x31, 0x00])), "UNITEK malformed reply [31 00]");
    assert_eq!(d.decode(&f(0x202, &[0x31, 0x00, 0x00])), "RPDO1 node 2: [31 00 00] (mapping unknown)", "another drive's id");
}
