//! Reader tests: each section kind, key form and tolerance, with its diagnostic.

use super::*;
use crate::diag::Severity;
use crate::model::{Access, ObjectKind};
use canopen_core::od::DataType;

fn read_str(text: &str) -> (Eds, Diagnostics) {
    read("t.eds", text.as_bytes())
}

const HEAD: &str = "[FileInfo]\nFileVersion=1\nFileRevision=0\n[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=2\nRevisionNumber=3\nBaudRate_250=1\nBaudRate_1000=1\nLSS_Supported=1\nGranularity=8\nNrOfRXPDO=0\nNrOfTXPDO=0\n";

#[test]
fn device_info_bit_rates_and_flags() {
    let (eds, d) = read_str(HEAD);
    assert_eq!(eds.device.baud_rates, 0b1001);
    assert!(eds.device.lss_supported);
    assert_eq!(eds.device.granularity, 8);
    assert!(!d.has_errors(), "{d}");
}

#[test]
fn var_record_and_sub_sections_in_hex() {
    let text = format!(
        "{HEAD}[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=2\n[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n[1018Sub1]\nParameterName=Vendor\nDataType=0x0007\nAccessType=RO\nDefaultValue=0x1234\n[2000]\nParameterName=Big\nObjectType=8\nSubNumber=2\n[2000sub0]\nParameterName=n\nDataType=5\nAccessType=ro\nDefaultValue=0x10\n[2000sub10]\nParameterName=x\nDataType=0x0006\nAccessType=rww\nPDOMapping=1\nDefaultValue=017\n"
    );
    let (eds, d) = read_str(&text);
    assert!(!d.has_errors(), "{d}");
    let id = &eds.objects[&0x1018];
    assert_eq!(id.kind, ObjectKind::Record);
    assert_eq!(id.subs[&1].value, 0x1234u32.to_le_bytes());
    assert_eq!(id.subs[&1].access, Access::Ro);
    // `sub10` is hex: sub-index 0x10. `017` is octal 15.
    let big = &eds.objects[&0x2000].subs[&0x10];
    assert_eq!(big.value, 15u16.to_le_bytes());
    assert_eq!(big.access, Access::Rww);
    assert!(big.pdo_mapping);
}

#[test]
fn object_type_defaults_to_var_and_node_id_values_are_marked() {
    let (eds, d) = read_str(&format!("{HEAD}[1014]\nParameterName=EMCY\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x80 + $nodeid\n"));
    assert!(!d.has_errors(), "{d}");
    let s = &eds.objects[&0x1014].subs[&0];
    assert_eq!(eds.objects[&0x1014].kind, ObjectKind::Var);
    assert!(s.node_id);
    assert_eq!(s.value, 0x80u32.to_le_bytes());
}

#[test]
fn parameter_value_wins_over_default() {
    let (eds, _) =
        read_str(&format!("{HEAD}[1017]\nParameterName=HB\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\nParameterValue=500\n"));
    assert_eq!(eds.objects[&0x1017].subs[&0].value, 500u16.to_le_bytes());
}

#[test]
fn compact_sub_obj_expands_with_names_and_values() {
    let text = format!(
        "{HEAD}[1016]\nParameterName=Consumer heartbeat time\nObjectType=0x8\nDataType=0x0007\nAccessType=rw\nDefaultValue=0\nCompactSubObj=3\n[1016Name]\nNrOfEntries=1\n2=Second\n[1016Value]\nNrOfEntries=1\n3=0x000501F4\n"
    );
    let (eds, d) = read_str(&text);
    assert!(!d.has_errors(), "{d}");
    let o = &eds.objects[&0x1016];
    assert_eq!(o.subs.len(), 4);
    assert_eq!(o.subs[&0].value, [3]);
    assert_eq!(o.subs[&0].access, Access::Ro);
    assert_eq!(o.subs[&1].name, "Consumer heartbeat time1");
    assert_eq!(o.subs[&2].name, "Second");
    assert_eq!(o.subs[&3].value, 0x0005_01F4u32.to_le_bytes());
}

#[test]
fn compact_pdo_mapping_record_counts_its_values() {
    let text = format!(
        "{HEAD}[1A00]\nParameterName=TPDO map\nObjectType=0x09\nDataType=0x0007\nAccessType=rw\nCompactSubObj=2\n[1A00Value]\nNrOfEntries=2\n1=0x2000001c\n2=0x20010020\n"
    );
    let (eds, d) = read_str(&text);
    assert!(d.mentions(Severity::Warning, 21, "CompactSubObj on RECORD"), "{d}");
    let o = &eds.objects[&0x1A00];
    assert_eq!(o.subs[&0].value, [2]);
    assert_eq!(o.subs[&0].access, Access::Rw);
}

#[test]
fn compact_pdo_synthesises_pdo_objects() {
    let text = "[DeviceInfo]\nNrOfRXPDO=1\nNrOfTXPDO=5\nCompactPDO=0x3f\n";
    let (eds, _) = read_str(text);
    let rpdo = &eds.objects[&0x1400];
    assert!(rpdo.synthesized);
    assert!(rpdo.subs[&1].node_id);
    assert_eq!(rpdo.subs[&1].value, 0x200u32.to_le_bytes());
    assert!(!rpdo.subs.contains_key(&6), "SYNC start value is TPDO only");
    assert_eq!(eds.objects[&0x1804].subs[&1].value, 0x8000_0000u32.to_le_bytes());
    assert_eq!(eds.objects[&0x1A04].subs.len(), 9);
    assert!(!eds.objects.contains_key(&0x1401));
}

#[test]
fn every_broken_key_names_its_line() {
    let text = format!(
        "{HEAD}[2000]\nParameterName=a\nDataType=0x0006\nAccessType=rx\n[2001]\nParameterName=b\nDataType=0x0006\nAccessType=rw\nDefaultValue=70000\n[2002]\nParameterName=c\nObjectType=0x4\n[2003]\nParameterName=d\nAccessType=rw\n[2004sub1]\nParameterName=e\n[2005]\nParameterName=f\nDataType=zz\nAccessType=rw\n[2006]\nParameterName=g\nDataType=0x0005\nAccessType=rw\nPDOMapping=2\n"
    );
    let (_, d) = read_str(&text);
    assert!(d.mentions(Severity::Error, 19, "AccessType `rx`"), "{d}");
    assert!(d.mentions(Severity::Error, 24, "does not fit UNSIGNED16"), "{d}");
    assert!(d.mentions(Severity::Error, 27, "ObjectType `0x4`"), "{d}");
    assert!(d.mentions(Severity::Error, 28, "has no DataType"), "{d}");
    assert!(d.mentions(Severity::Error, 31, "which has no [2004] section"), "{d}");
    assert!(d.mentions(Severity::Error, 35, "not a type index"), "{d}");
    assert!(d.mentions(Severity::Error, 41, "PDOMapping `2`"), "{d}");
}

#[test]
fn object_lists_and_comments() {
    let text =
        format!("{HEAD}[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n3=0x1018\n[Comments]\nLines=2\nLine1=a\nLine2=b\n");
    let (eds, d) = read_str(&text);
    assert_eq!(eds.lists.mandatory, [0x1000, 0x1001, 0x1018]);
    assert_eq!(eds.comments, ["a", "b"]);
    assert!(d.mentions(Severity::Warning, 17, "SupportedObjects=2 but it has 3 entries"), "{d}");
}

#[test]
fn commissioning_node_id_and_unknown_sections() {
    let (eds, d) = read_str(&format!("{HEAD}[DeviceComissioning]\nNodeID=0x05\n[Tools]\nx=1\n"));
    assert_eq!(eds.node_id, Some(5));
    assert_eq!(eds.other_sections.len(), 1);
    assert!(d.mentions(Severity::Warning, 18, "[Tools] is not interpreted"));
    let (eds, d) = read_str("[DeviceComissioning]\nNodeID=255\n");
    assert_eq!(eds.node_id, None);
    assert!(d.mentions(Severity::Warning, 2, "not configured"));
}

#[test]
fn latin1_and_crlf_files_read() {
    let mut bytes = HEAD.replace('\n', "\r\n").into_bytes();
    bytes.extend_from_slice(b"[1008]\r\nParameterName=Ger\xE4t\r\nDataType=0x0009\r\nAccessType=const\r\nDefaultValue=M\xFCller\r\n");
    let (eds, d) = read("t.eds", &bytes);
    assert_eq!(eds.objects[&0x1008].name, "Gerät");
    assert_eq!(eds.objects[&0x1008].subs[&0].value, "Müller".as_bytes());
    assert!(d.mentions(Severity::Warning, 0, "Latin-1"));
}

#[test]
fn never_panics_on_garbage() {
    for text in [
        "",
        "[",
        "]",
        "[1000sub]",
        "[1000subXYZ]",
        "[10000]",
        "=",
        "[1000]\nSubNumber=99999999999999999999999999\n",
        "[1003]\nObjectType=8\nCompactSubObj=999\nDataType=7\nAccessType=ro\n",
    ] {
        let _ = read_str(text);
    }
}

#[test]
fn an_object_left_out_for_where_it_sits_is_reported() {
    // A heartbeat object typed DEFTYPE (0x5 for 0x7) and a VAR in the reserved range both vanish from the dictionary.
    let text = format!(
        "{HEAD}[1017]\nParameterName=Producer heartbeat time\nObjectType=0x5\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\n[0800]\nParameterName=r\nObjectType=0x7\nDataType=0x0005\nAccessType=rw\n[0007]\nParameterName=UNSIGNED32\nObjectType=0x5\nDataType=0x0007\nAccessType=ro\nDefaultValue=32\n"
    );
    let (_, d) = read_str(&text);
    assert!(d.mentions(Severity::Warning, 18, "ObjectType DEFTYPE of 0x1017 defines a data type"), "{d}");
    assert!(d.mentions(Severity::Warning, 24, "0x0800 is in the range CiA 301 reserves"), "{d}");
    // A type definition where CiA 301 puts them is no finding.
    assert_eq!(d.warnings().filter(|w| w.message.contains("0x0007")).count(), 0, "{d}");
}

#[test]
fn a_sub_object_without_datatype_takes_the_type_it_cannot_differ_from() {
    // Sub-index 0 is UNSIGNED8 and an ARRAY's elements have the header's DataType: warnings.
    // A RECORD's entry has no such type: still an error.
    let text = format!(
        "{HEAD}[2000]\nParameterName=Arr\nObjectType=0x8\nDataType=0x0006\nSubNumber=2\n[2000sub0]\nParameterName=n\nAccessType=ro\nDefaultValue=1\n[2000sub1]\nParameterName=a\nAccessType=rw\nDefaultValue=7\n[2001]\nParameterName=Rec\nObjectType=0x9\nSubNumber=2\n[2001sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n[2001sub1]\nParameterName=r\nAccessType=rw\n"
    );
    let (eds, d) = read_str(&text);
    assert!(d.mentions(Severity::Warning, 21, "[2000sub0] has no DataType; read as 0x0005"), "{d}");
    assert!(d.mentions(Severity::Warning, 25, "[2000sub1] has no DataType; read as 0x0006, the ARRAY's"), "{d}");
    assert!(d.mentions(Severity::Error, 38, "[2001sub1] has no DataType"), "{d}");
    let arr = &eds.objects[&0x2000];
    assert_eq!(arr.subs[&0].data_type, Some(DataType::Unsigned8));
    assert_eq!(arr.subs[&1].data_type, Some(DataType::Unsigned16));
    assert_eq!(arr.subs[&1].value, [7, 0]);
}

#[test]
fn a_utf16_file_is_one_error() {
    // Windows editors save "Unicode" as UTF-16: read as Latin-1 it was a warning per line and "no object sections".
    let text = format!("{HEAD}[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n");
    for bom in [[0xFF, 0xFE], [0xFE, 0xFF]] {
        let mut bytes = bom.to_vec();
        for u in text.encode_utf16() {
            bytes.extend(if bom[0] == 0xFF { u.to_le_bytes() } else { u.to_be_bytes() });
        }
        let (_, d) = read("t.eds", &bytes);
        assert_eq!(d.errors().count(), 1, "{d}");
        assert!(d.mentions(Severity::Error, 0, "file is UTF-16"), "{d}");
        assert_eq!(d.warnings().count(), 0, "{d}");
    }
    // Without a byte-order mark too.
    let bytes: Vec<u8> = text.encode_utf16().flat_map(u16::to_le_bytes).collect();
    assert!(read("t.eds", &bytes).1.mentions(Severity::Error, 0, "file is UTF-16"));
}
