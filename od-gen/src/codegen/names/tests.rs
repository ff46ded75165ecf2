//! The naming rule (docs/od-gen.md, "Names") on small dictionaries: each
//! part of a sub-index's own name, and each collision.

use super::*;

const HEAD: &str = "[FileInfo]\nFileVersion=1\n[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=2\nRevisionNumber=3\nBaudRate_250=1\n";

/// An object: index, name, and its sub-indices as (sub-index, name), none for a VAR.
type Spec<'a> = (u16, &'a str, &'a [(u8, &'a str)]);

/// An EDS text of `objects`; every
/// entry an UNSIGNED32 `rw`, sub-index 0 an UNSIGNED8 `ro`.
fn eds_text(objects: &[Spec]) -> String {
    let mut t = HEAD.to_owned();
    for (index, name, subs) in objects {
        if subs.is_empty() {
            t += &format!("[{index:04X}]\nParameterName={name}\nDataType=0x0007\nAccessType=rw\nDefaultValue=0\n");
            continue;
        }
        t += &format!("[{index:04X}]\nParameterName={name}\nObjectType=0x9\nSubNumber={}\n", subs.len());
        for (sub, sub_name) in *subs {
            let ty = if *sub == 0 { "0x0005\nAccessType=ro" } else { "0x0007\nAccessType=rw" };
            t += &format!("[{index:04X}sub{sub:X}]\nParameterName={sub_name}\nDataType={ty}\nDefaultValue=0\n");
        }
    }
    t
}

/// The getter names of the generated module, in order.
fn getters(objects: &[Spec]) -> Vec<String> {
    let (eds, d) = crate::eds::read("t.eds", eds_text(objects).as_bytes());
    assert!(!d.has_errors(), "{d}");
    let module = crate::codegen::generate(&eds, "t.eds").unwrap_or_else(|e| panic!("{}", e.0));
    module.lines().filter_map(|l| Some(l.trim().strip_prefix("pub fn ")?.split_once("(&self")?.0.to_owned())).collect()
}

/// The own name of sub-index `sub` named `sub_name` in an object named `object`.
fn own(object: &str, sub: u8, sub_name: &str) -> String {
    let (eds, d) = crate::eds::read("t.eds", eds_text(&[(0x2000, object, &[(0, "n"), (sub.max(1), sub_name)])]).as_bytes());
    assert!(!d.has_errors(), "{d}");
    let o = &eds.objects[&0x2000];
    let s = if sub == 0 { o.subs[&0].clone() } else { o.subs[&sub].clone() };
    let s = SubObject { name: sub_name.to_owned(), sub, ..s };
    own_name(o, &s)
}

#[test]
fn snake_splits_words_at_separators_and_case_changes() {
    assert_eq!(snake("Consumer heartbeat time"), "consumer_heartbeat_time");
    assert_eq!(snake("TPDO1Communication COB-ID"), "tpdo1_communication_cob_id");
    assert_eq!(snake("vlVelocityDemand"), "vl_velocity_demand");
    assert_eq!(snake("  --Mode  of__operation--"), "mode_of_operation");
    assert_eq!(snake("24 V supply"), "o_24_v_supply");
    assert_eq!(snake("---"), "o_");
    assert_eq!(snake("Type"), "type_");
    assert_eq!(snake("Image"), "image_");
    assert_eq!(snake("Zeroed"), "zeroed_");
}

#[test]
fn the_object_name_is_not_repeated() {
    assert_eq!(own("Consumer heartbeat time", 1, "Consumer heartbeat time 1"), "1");
    assert_eq!(own("Identity object", 1, "Vendor-ID"), "vendor_id");
    assert_eq!(own("Interpolation data record", 1, "Interpolation_data_record_position"), "position");
    // Only the shared start goes, word by word.
    assert_eq!(own("High temperature warning level", 1, "High temperature warning threshold"), "threshold");
    assert_eq!(own("Speed", 1, "Speedometer"), "speedometer");
    // The object's number joined to its first word, as PDO sub-indices spell it.
    assert_eq!(own("TPDO communication parameter 4", 2, "TPDO4 transmission type"), "transmission_type");
    assert_eq!(own("TPDO1 communication parameter", 1, "TPDO1 communication COB-ID"), "cob_id");
    // The object's next word with a number is that number.
    assert_eq!(own("TPDO mapping parameter", 1, "TPDO mapping parameter1"), "1");
    // Nothing left: the sub-index number.
    assert_eq!(own("Motor", 3, "Motor"), "sub3");
}

#[test]
fn every_spelling_of_the_highest_sub_index_is_one_name() {
    for name in [
        "Highest sub-index supported",
        "highest subindex supported",
        "Largest sub-index supported",
        "Highest sub-index",
        "TPDO1 communication highest sub-index",
        "interpolation_data_configuration_highest_subindex",
        "HighestSubIndex",
    ] {
        assert_eq!(own("Anything", 0, name), "highest_sub_index", "{name}");
    }
    // Other counts keep their own words; a later sub-index keeps its name.
    assert_eq!(own("Pre-defined error field", 0, "Number of errors"), "number_of_errors");
    assert_eq!(own("Store parameters", 0, "Number of entries"), "number_of_entries");
    assert_eq!(own("Anything", 1, "Highest sub-index supported"), "highest_sub_index_supported");
}

#[test]
fn sub_index_accessors_carry_the_object_name_once() {
    let names = getters(&[
        (0x1018, "Identity object", &[(0, "Highest sub-index supported"), (1, "Vendor-ID"), (2, "Product code")]),
        (0x1800, "TPDO communication parameter 1", &[(0, "TPDO1 communication highest sub-index"), (1, "TPDO1 COB-ID")]),
    ]);
    assert_eq!(
        names,
        [
            "identity_object_highest_sub_index",
            "identity_object_vendor_id",
            "identity_object_product_code",
            "tpdo_communication_parameter_1_highest_sub_index",
            "tpdo_communication_parameter_1_cob_id",
        ]
    );
}

#[test]
fn a_taken_name_falls_back_to_the_sub_index_then_the_index() {
    let names = getters(&[
        // Sub-index 2 would be `motor_current`, the name of 0x2001; sub-index 3 too.
        (0x2000, "Motor", &[(0, "Number of entries"), (1, "Motor"), (2, "Motor current"), (3, "current")]),
        (0x2001, "Motor current", &[]),
        // `set_point` is 0x2002's getter, so 0x2003 cannot be `point` (its setter would be `set_point`).
        (0x2002, "Set point", &[]),
        (0x2003, "Point", &[]),
        // `a_b` + `c` and `a` + `b_c` meet: the second takes `_sub<n>`, and
        // with that taken too (by 0x2006), `_<index>_sub<n>`.
        (0x2004, "A b", &[(0, "Number of entries"), (1, "c")]),
        (0x2005, "A", &[(0, "Number of entries"), (1, "b c"), (2, "b c")]),
        (0x2006, "A sub2", &[]),
        // Two objects of one name: the second gets its index, its sub-indices follow.
        (0x2007, "Twin", &[]),
        (0x2008, "Twin", &[(0, "Number of entries"), (1, "x")]),
    ]);
    assert_eq!(
        names,
        [
            "motor_number_of_entries",
            "motor_sub1",
            "motor_sub2",
            "motor_sub3",
            "motor_current",
            "set_point",
            "point_2003",
            "a_b_number_of_entries",
            "a_b_c",
            "a_number_of_entries",
            "a_sub1",
            "a_2005_sub2",
            "a_sub2",
            "twin",
            "twin_2008_number_of_entries",
            "twin_2008_x",
        ]
    );
}
