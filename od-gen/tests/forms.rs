//! Forms real files use around CiA 306's: each one read as other INI
//! readers (python-canopen's configparser) read it, or refused with a
//! message that says what is wrong on which line.

use od_gen::{Options, Severity, load};

/// A device with 0x2000 written as `object`.
fn file(object: &str) -> String {
    format!(
        "[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=1\nRevisionNumber=1\nOrderCode=O\nBaudRate_250=1\n\
         NrOfRXPDO=0\nNrOfTXPDO=0\n\n[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n\n\
         [ManufacturerObjects]\nSupportedObjects=1\n1=0x2000\n\n\
         [1000]\nParameterName=Device Type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n\n\
         [1001]\nParameterName=Error Register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\n\n{object}"
    )
}

fn line_of(text: &str, wanted: &str) -> usize {
    text.lines().position(|l| l == wanted).expect("line") + 1
}

#[test]
fn a_comment_after_a_section_header_is_a_warning() {
    let text = file("[2000] ; the set-point\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=7\n");
    let (eds, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(!d.has_errors(), "{d}");
    let line = line_of(&text, "[2000] ; the set-point");
    assert!(d.mentions(Severity::Warning, line, "comment `; the set-point` after a section header"), "{d}");
    assert_eq!(eds.sub(0x2000, 0).map(|s| s.value.clone()), Some(vec![7, 0, 0, 0]));
}

#[test]
fn other_text_after_a_section_header_is_an_error_that_says_so() {
    let text = file("[2000] x\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(d.mentions(Severity::Error, line_of(&text, "[2000] x"), "text `x` after the section header `[2000]`"), "{d}");
    // A header without its `]` says that.
    let text = file("[2000\nParameterName=X\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(d.mentions(Severity::Error, line_of(&text, "[2000"), "has no closing `]`"), "{d}");
}

#[test]
fn node_id_subtracted_is_an_error_that_says_so() {
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x600-$NODEID\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(d.mentions(Severity::Error, line_of(&text, "DefaultValue=0x600-$NODEID"), "$NODEID may only be added, and only once"), "{d}");
}

#[test]
fn a_default_outside_a_single_limit_names_the_value_and_the_missing_limit() {
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=5\nLowLimit=10\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    let line = line_of(&text, "DefaultValue=5");
    assert!(d.mentions(Severity::Error, line, "value `5` is outside LowLimit 10..no HighLimit (0x2000 sub 0)"), "{d}");
}

#[test]
fn a_leading_zero_decimal_is_octal_and_the_message_says_so() {
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0800\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(d.mentions(Severity::Error, line_of(&text, "DefaultValue=0800"), "a leading 0 makes it octal"), "{d}");
    // 017 is octal 15, as CiA 306 has it.
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=017\n");
    let (eds, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(!d.has_errors(), "{d}");
    assert_eq!(eds.sub(0x2000, 0).map(|s| s.value.clone()), Some(vec![15, 0, 0, 0]));
}

#[test]
fn a_file_without_objects_is_an_error() {
    for text in ["", "# Corpus\n\n| file | origin |\n", "[FileInfo]\nFileName=x.eds\n\n[DeviceInfo]\nVendorName=V\n"] {
        let (_, d) = load("x.eds", text.as_bytes(), Options::default());
        assert!(d.mentions(Severity::Error, 0, "no object sections"), "{text:?}: {d}");
    }
}

#[test]
fn spaces_within_a_number_are_dropped_with_a_warning() {
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x1 0\n");
    let (eds, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(
        d.mentions(Severity::Warning, line_of(&text, "DefaultValue=0x1 0"), "the spaces within `0x1 0` are dropped: read as 16"),
        "{d}"
    );
    assert_eq!(eds.sub(0x2000, 0).map(|s| s.value.clone()), Some(vec![0x10, 0, 0, 0]));
    // Around `+` they are how `$NODEID + 0x600` is written: nothing to say.
    let text = file("[2000]\nParameterName=X\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID + 0x600\n");
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(!d.items.iter().any(|i| i.message.contains("spaces")), "{d}");
}

/// As python-canopen's `examples/eds/e35.eds` (MIT) has its 0x2103 sub 4
/// "Frequency": measured, read-only, limits and no default.
#[test]
fn no_default_outside_the_limits_is_a_warning() {
    let text = file(
        "[2000]\nParameterName=Frequency\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nPDOMapping=0x0\nLowLimit=0x3E8\nHighLimit=0x13880\n",
    );
    let (_, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(!d.has_errors(), "{d}");
    let line = line_of(&text, "[2000]");
    assert!(
        d.mentions(Severity::Warning, line, "0x2000 sub 0 has no default and starts at 0, outside LowLimit 0x3E8..HighLimit 0x13880"),
        "{d}"
    );
}

#[test]
fn index_zero_is_left_out_with_a_warning() {
    let text = file("[0000]\nParameterName=Zero\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=1\n");
    let (eds, d) = load("c.eds", text.as_bytes(), Options::default());
    assert!(d.mentions(Severity::Warning, line_of(&text, "[0000]"), "index 0x0000 is not used (CiA 301); left out"), "{d}");
    assert!(!eds.objects.contains_key(&0), "left out");
}
