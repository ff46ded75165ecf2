//! The sections and keys of a CiA 306 file: which section a header names,
//! and the keys the reader knows in each.

/// Which section a header names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    FileInfo,
    DeviceInfo,
    DummyUsage,
    Comments,
    Mandatory,
    Optional,
    Manufacturer,
    Commissioning,
    Object(u16),
    Sub(u16, u8),
    Names(u16),
    Values(u16),
    Links(u16),
    Other,
}

pub(super) fn classify(name: &str) -> Kind {
    let lower = name.to_ascii_lowercase();
    match lower.as_str() {
        "fileinfo" => return Kind::FileInfo,
        "deviceinfo" => return Kind::DeviceInfo,
        "dummyusage" => return Kind::DummyUsage,
        "comments" => return Kind::Comments,
        "mandatoryobjects" => return Kind::Mandatory,
        "optionalobjects" => return Kind::Optional,
        "manufacturerobjects" => return Kind::Manufacturer,
        // CiA 306 spells it with one m; accept the dictionary spelling too.
        "devicecomissioning" | "devicecommissioning" => return Kind::Commissioning,
        _ => {}
    }
    let hex4 = |s: &str| (s.len() == 4 && s.chars().all(|c| c.is_ascii_hexdigit())).then(|| u16::from_str_radix(s, 16).ok()).flatten();
    if let Some(i) = hex4(&lower) {
        return Kind::Object(i);
    }
    if lower.len() > 4 && lower.is_char_boundary(4) {
        let (head, tail) = lower.split_at(4);
        if let Some(i) = hex4(head) {
            if let Some(s) = tail.strip_prefix("sub")
                && (1..=2).contains(&s.len())
                && let Ok(sub) = u8::from_str_radix(s, 16)
            {
                return Kind::Sub(i, sub);
            }
            match tail {
                "name" => return Kind::Names(i),
                "value" => return Kind::Values(i),
                "objectlinks" => return Kind::Links(i),
                _ => {}
            }
        }
    }
    Kind::Other
}

pub(super) const OBJECT_KEYS: &[&str] = &[
    "parametername",
    "objecttype",
    "datatype",
    "accesstype",
    "defaultvalue",
    "parametervalue",
    "lowlimit",
    "highlimit",
    "pdomapping",
    "objflags",
    "subnumber",
    "compactsubobj",
    "denotation",
    "uploadfile",
    "downloadfile",
];

pub(super) const DEVICE_INFO_KEYS: &[&str] = &[
    "vendorname",
    "vendornumber",
    "productname",
    "productnumber",
    "revisionnumber",
    "ordercode",
    "baudrate_10",
    "baudrate_20",
    "baudrate_50",
    "baudrate_125",
    "baudrate_250",
    "baudrate_500",
    "baudrate_800",
    "baudrate_1000",
    "simplebootupmaster",
    "simplebootupslave",
    "granularity",
    "dynamicchannelssupported",
    "groupmessaging",
    "nrofrxpdo",
    "nroftxpdo",
    "lss_supported",
    "compactpdo",
];

/// CiA 305 bit-timing table index of each `BaudRate_*` key.
pub(super) const BAUD_KEYS: &[(&str, u16)] = &[
    ("BaudRate_1000", 0),
    ("BaudRate_800", 1),
    ("BaudRate_500", 2),
    ("BaudRate_250", 3),
    ("BaudRate_125", 4),
    ("BaudRate_50", 6),
    ("BaudRate_20", 7),
    ("BaudRate_10", 8),
];
