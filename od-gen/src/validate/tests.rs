//! Validator tests: each rule with the diagnostic it gives.

use super::*;
use crate::eds;

fn check(text: &str, strict: bool) -> Diagnostics {
    let (mut e, mut d) = eds::read("t.eds", text.as_bytes());
    validate(&mut e, &mut d, Options { strict });
    d
}

const GOOD: &str = "[FileInfo]\nFileVersion=1\nFileRevision=0\nEDSVersion=4.0\nCreationTime=09:00AM\nCreationDate=01-31-2026\n\
[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=2\nRevisionNumber=3\nOrderCode=O\nBaudRate_250=1\nNrOfRXPDO=1\nNrOfTXPDO=1\nGranularity=8\n\
[DummyUsage]\nDummy0005=1\n\
[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n\
[OptionalObjects]\nSupportedObjects=6\n1=0x1014\n2=0x1200\n3=0x1400\n4=0x1600\n5=0x1800\n6=0x1A00\n\
[ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n\
[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=const\nDefaultValue=0x192\n\
[1001]\nParameterName=Error register\nDataType=0x0005\nAccessType=ro\nPDOMapping=1\n\
[1014]\nParameterName=COB-ID EMCY\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x80\n\
[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=2\n\
[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
[1018sub1]\nParameterName=Vendor-ID\nDataType=0x0007\nAccessType=ro\nDefaultValue=1\n\
[1200]\nParameterName=SDO server\nObjectType=0x9\nSubNumber=3\n\
[1200sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\n\
[1200sub1]\nParameterName=rx\nDataType=0x0007\nAccessType=ro\nDefaultValue=$NODEID+0x600\n\
[1200sub2]\nParameterName=tx\nDataType=0x0007\nAccessType=ro\nDefaultValue=$NODEID+0x580\n\
[1400]\nParameterName=RPDO1\nObjectType=0x9\nSubNumber=2\n\
[1400sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
[1400sub1]\nParameterName=COB\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x200\n\
[1600]\nParameterName=RPDO1 map\nObjectType=0x9\nSubNumber=3\n\
[1600sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=2\n\
[1600sub1]\nParameterName=m1\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x20000010\n\
[1600sub2]\nParameterName=m2\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x00050008\n\
[1800]\nParameterName=TPDO1\nObjectType=0x9\nSubNumber=2\n\
[1800sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
[1800sub1]\nParameterName=COB\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x180\n\
[1A00]\nParameterName=TPDO1 map\nObjectType=0x9\nSubNumber=2\n\
[1A00sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=1\n\
[1A00sub1]\nParameterName=m1\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x10010008\n\
[2000]\nParameterName=Setpoint\nDataType=0x0003\nAccessType=rww\nPDOMapping=1\nLowLimit=-100\nHighLimit=100\nDefaultValue=5\n";

/// GOOD with `old` replaced by `new`, and the line the replacement starts on.
fn with(old: &str, new: &str) -> (String, usize) {
    assert!(GOOD.contains(old), "{old}");
    let line = GOOD[..GOOD.find(old).unwrap()].lines().count() + 1;
    (GOOD.replacen(old, new, 1), line)
}

#[test]
fn a_complete_device_is_clean_even_when_strict() {
    let d = check(GOOD, true);
    assert!(d.items.is_empty(), "{d}");
}

#[test]
fn missing_mandatory_objects_warn_and_fail_strict() {
    let (text, _) = with("[1001]\nParameterName=Error register\nDataType=0x0005\nAccessType=ro\nPDOMapping=1\n", "");
    let d = check(&text, false);
    assert!(d.mentions(Severity::Warning, 0, "mandatory object 0x1001 is missing"), "{d}");
    assert!(!d.has_errors());
    assert!(check(&text, true).mentions(Severity::Error, 0, "mandatory object 0x1001"));
}

#[test]
fn sub_number_and_sub0_are_checked() {
    let (text, line) = with(
        "[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=2\n",
        "[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=3\n",
    );
    assert!(check(&text, false).mentions(Severity::Warning, line + 3, "SubNumber 3 but 2 sub-objects"));
    let (text, line) = with("DefaultValue=1\n[1018sub1]", "DefaultValue=4\n[1018sub1]");
    let d = check(&text, false);
    assert!(d.mentions(Severity::Warning, line, "sub-index 0 of 0x1018 is 4"), "{d}");
    assert!(d.items.iter().any(|x| x.message.contains("sub-index 0 of 0x1018 is 4 but the highest sub-index is 0x01")), "{d}");
}

#[test]
fn defaults_outside_limits_and_inverted_limits_are_errors() {
    let (text, line) = with("DefaultValue=5\n", "DefaultValue=101\n");
    assert!(check(&text, false).mentions(Severity::Error, line, "is outside LowLimit -100..HighLimit 100"));
    let (text, line) = with("HighLimit=100\n", "HighLimit=-101\n");
    assert!(check(&text, false).mentions(Severity::Error, line, "HighLimit -101 is below LowLimit -100"));
    let (text, line) = with("LowLimit=-100\n", "LowLimit=-40000\n");
    assert!(check(&text, false).mentions(Severity::Error, line, "does not fit INTEGER16"));
}

#[test]
fn pdo_mappings_name_existing_mappable_objects_of_the_right_length() {
    let (text, line) = with("DefaultValue=0x20000010\n", "DefaultValue=0x30000010\n");
    assert!(check(&text, false).mentions(Severity::Warning, line, "maps 0x3000 sub 0, which does not exist"));
    assert!(check(&text, true).mentions(Severity::Error, line, "which does not exist"));
    let (text, line) = with("DefaultValue=0x20000010\n", "DefaultValue=0x20000020\n");
    assert!(check(&text, false).mentions(Severity::Warning, line, "with 32 bits; it has 16"));
    let (text, line) = with("DefaultValue=0x10010008\n", "DefaultValue=0x10000020\n");
    assert!(check(&text, false).mentions(Severity::Warning, line, "which has PDOMapping=0"));
    let (text, line) = with("DefaultValue=0x10010008\n", "DefaultValue=0x20000010\n");
    assert!(check(&text, false).mentions(Severity::Warning, line, "(rww) into a TPDO"));
    let (text, line) = with("DefaultValue=0x00050008\n", "DefaultValue=0x00060010\n");
    assert!(check(&text, false).mentions(Severity::Warning, line, "dummy type 0x0006"));
    let (text, line) = with(
        "[1600sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=2\n",
        "[1600sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=3\n",
    );
    let _ = line;
    assert!(check(&text, false).items.iter().any(|x| x.message.contains("maps 3 objects but has no sub-index 3")));
}

#[test]
fn over_64_bits_in_one_pdo() {
    let text = GOOD
        .replace("[1600sub2]\nParameterName=m2\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x00050008\n", "[1600sub2]\nParameterName=m2\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x00050008\n[1600sub3]\nParameterName=m3\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x00070020\n[1600sub4]\nParameterName=m4\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x00070020\n")
        .replace("SubNumber=3\n\n[1600sub0]", "SubNumber=5\n[1600sub0]")
        .replace("[1600sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=2", "[1600sub0]\nParameterName=n\nDataType=0x0005\nAccessType=rw\nDefaultValue=4")
        .replace("Dummy0005=1", "Dummy0005=1\nDummy0007=1");
    let d = check(&text, false);
    assert!(d.items.iter().any(|x| x.message.contains("maps 88 bits; a PDO carries at most 64")), "{d}");
}

#[test]
fn colliding_cob_ids() {
    let (text, line) = with("DefaultValue=$NODEID+0x200\n", "DefaultValue=$NODEID+0x180\n");
    let d = check(&text, false);
    let tpdo_line = GOOD[..GOOD.find("DefaultValue=$NODEID+0x180").unwrap()].lines().count() + 1;
    assert!(d.mentions(Severity::Error, tpdo_line, "TPDO1 COB-ID 0x180 collides with RPDO1"), "{d} {line}");
    // A fixed id against a node-relative one collides for one node-id only.
    let (text, line) = with("DefaultValue=$NODEID+0x200\n", "DefaultValue=0x181\n");
    let tpdo_line = GOOD[..GOOD.find("DefaultValue=$NODEID+0x180").unwrap()].lines().count() + 1;
    assert!(
        check(&text, false).mentions(Severity::Warning, tpdo_line, "TPDO1 and RPDO1 share COB-ID 0x181 when the node-id is 1"),
        "{line}"
    );
    // A disabled PDO (bit 31) takes part in nothing.
    let (text, _) = with("DefaultValue=$NODEID+0x200\n", "DefaultValue=$NODEID+0x80000180\n");
    assert!(!check(&text, false).has_errors());
}

#[test]
fn unknown_and_undefined_types() {
    let (text, line) = with("[2000]\nParameterName=Setpoint\nDataType=0x0003", "[2000]\nParameterName=Setpoint\nDataType=0x0017");
    assert!(check(&text, false).mentions(Severity::Error, line + 2, "unknown DataType 0x0017"));
    let (text, line) = with("[2000]\nParameterName=Setpoint\nDataType=0x0003", "[2000]\nParameterName=Setpoint\nDataType=0x0040");
    let d = check(&text, false);
    assert!(d.mentions(Severity::Warning, line + 2, "never defines; the object is left out"), "{d}");
}

#[test]
fn file_info_forms() {
    let (text, line) = with("CreationTime=09:00AM", "CreationTime=9:00AM");
    assert!(check(&text, false).mentions(Severity::Warning, line, "is not hh:mmAM/PM"));
    let (text, line) = with("CreationDate=01-31-2026", "CreationDate=2026-01-31");
    assert!(check(&text, false).mentions(Severity::Warning, line, "is not mm-dd-yyyy"));
}

#[test]
fn a_value_longer_than_an_entry_holds_is_an_error_at_its_line() {
    // 255 bytes fit an entry's one-byte length; 256 do not.
    let listed = "[ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n";
    let text = |n: usize| {
        let (text, _) = with(listed, "[ManufacturerObjects]\nSupportedObjects=2\n1=0x2000\n2=0x2001\n");
        format!("{text}[2001]\nParameterName=Name\nDataType=0x0009\nAccessType=ro\nDefaultValue={}\n", "x".repeat(n))
    };
    let d = check(&text(255), true);
    assert!(d.items.is_empty(), "{d}");
    let long = text(256);
    let line = long.lines().count();
    let d = check(&long, false);
    assert!(d.mentions(Severity::Error, line, "VISIBLE_STRING of 256 bytes is longer than the 255 an entry holds (0x2001 sub 0)"), "{d}");
    assert!(d.to_string().contains(&format!("t.eds:{line}: error: VISIBLE_STRING of 256 bytes")), "{d}");
}
