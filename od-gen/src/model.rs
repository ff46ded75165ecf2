//! The dictionary an EDS or DCF describes, after parsing and before code generation.

use std::collections::BTreeMap;

use canopen_core::od::{Attr, DataType, Number};

use crate::lexer::Section;

/// `ObjectType` of CiA 306 §4.6.3 (CiA 301 table 42).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectKind {
    /// NULL (0x0).
    Null,
    /// DOMAIN (0x2).
    Domain,
    /// DEFTYPE (0x5).
    DefType,
    /// DEFSTRUCT (0x6).
    DefStruct,
    /// VAR (0x7), the default when the key is missing.
    Var,
    /// ARRAY (0x8).
    Array,
    /// RECORD (0x9).
    Record,
}

impl ObjectKind {
    /// From the numeric `ObjectType`.
    pub fn from_code(code: i128) -> Option<Self> {
        Some(match code {
            0 => ObjectKind::Null,
            2 => ObjectKind::Domain,
            5 => ObjectKind::DefType,
            6 => ObjectKind::DefStruct,
            7 => ObjectKind::Var,
            8 => ObjectKind::Array,
            9 => ObjectKind::Record,
            _ => return None,
        })
    }

    /// The numeric `ObjectType`.
    pub fn code(self) -> u8 {
        match self {
            ObjectKind::Null => 0,
            ObjectKind::Domain => 2,
            ObjectKind::DefType => 5,
            ObjectKind::DefStruct => 6,
            ObjectKind::Var => 7,
            ObjectKind::Array => 8,
            ObjectKind::Record => 9,
        }
    }

    /// Whether the object has sub-objects in their own sections.
    pub fn has_subs(self) -> bool {
        matches!(self, ObjectKind::Array | ObjectKind::Record | ObjectKind::DefStruct)
    }

    /// The CiA 306 name.
    pub fn name(self) -> &'static str {
        match self {
            ObjectKind::Null => "NULL",
            ObjectKind::Domain => "DOMAIN",
            ObjectKind::DefType => "DEFTYPE",
            ObjectKind::DefStruct => "DEFSTRUCT",
            ObjectKind::Var => "VAR",
            ObjectKind::Array => "ARRAY",
            ObjectKind::Record => "RECORD",
        }
    }
}

/// `AccessType` of CiA 306 §4.6.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read only.
    Ro,
    /// Write only.
    Wo,
    /// Read and write.
    Rw,
    /// Read and write, mapped into TPDOs (process input).
    Rwr,
    /// Read and write, mapped into RPDOs (process output).
    Rww,
    /// Read only, never changes.
    Const,
}

impl Access {
    /// From the EDS spelling, case-insensitive.
    pub fn parse(s: &str) -> Option<Access> {
        Some(match s.trim().to_ascii_lowercase().as_str() {
            "ro" => Access::Ro,
            "wo" => Access::Wo,
            "rw" => Access::Rw,
            "rwr" => Access::Rwr,
            "rww" => Access::Rww,
            "const" => Access::Const,
            _ => return None,
        })
    }

    /// The EDS spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Access::Ro => "ro",
            Access::Wo => "wo",
            Access::Rw => "rw",
            Access::Rwr => "rwr",
            Access::Rww => "rww",
            Access::Const => "const",
        }
    }

    /// SDO access bits plus the PDO directions a mappable entry allows.
    pub fn attr(self, mappable: bool) -> Attr {
        let (base, tpdo, rpdo) = match self {
            Access::Ro => (Attr::READ, true, false),
            Access::Const => (Attr::READ.union(Attr::IN_ROM), true, false),
            Access::Wo => (Attr::WRITE, false, true),
            Access::Rw => (Attr::READ.union(Attr::WRITE), true, true),
            Access::Rwr => (Attr::READ.union(Attr::WRITE), true, false),
            Access::Rww => (Attr::READ.union(Attr::WRITE), false, true),
        };
        let mut a = base;
        if mappable && tpdo {
            a = a.union(Attr::MAP_TPDO);
        }
        if mappable && rpdo {
            a = a.union(Attr::MAP_RPDO);
        }
        a
    }
}

/// A raw key value with the line it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Text {
    /// The value as written.
    pub text: String,
    /// 1-based line.
    pub line: usize,
}

/// Capacity in bytes of a writable string whose default is shorter. CiA 306
/// has no key for a string's capacity; 16 bytes hold the names, serial
/// numbers and catalogue numbers devices let a master write.
pub const MIN_WRITABLE_STRING: usize = 16;

/// One sub-object (for a VAR: sub-index 0, described by the object's own section).
#[derive(Clone, Debug, PartialEq)]
pub struct SubObject {
    /// Sub-index.
    pub sub: u8,
    /// `ParameterName`.
    pub name: String,
    /// `DataType` as written (index of the type).
    pub type_index: u16,
    /// Line of the `DataType` key.
    pub type_line: usize,
    /// The basic type, if `type_index` is one.
    pub data_type: Option<DataType>,
    /// `AccessType`.
    pub access: Access,
    /// `PDOMapping`.
    pub pdo_mapping: bool,
    /// `DefaultValue`.
    pub default: Option<Text>,
    /// `ParameterValue` (DCF); it wins over the default.
    pub parameter_value: Option<Text>,
    /// `Denotation` (DCF).
    pub denotation: Option<String>,
    /// `LowLimit`.
    pub low: Option<Text>,
    /// `HighLimit`.
    pub high: Option<Text>,
    /// `ObjFlags`.
    pub obj_flags: u32,
    /// `UploadFile` (DOMAIN).
    pub upload_file: Option<String>,
    /// `DownloadFile` (DOMAIN).
    pub download_file: Option<String>,
    /// The value bytes (ParameterValue, else DefaultValue, else zero).
    pub value: Vec<u8>,
    /// Whether `$NODEID` is added to `value` at run time.
    pub node_id: bool,
    /// Parsed limits, if both are usable.
    pub limits: Option<(Number, Number)>,
    /// Line of the section that defines it.
    pub line: usize,
}

impl SubObject {
    /// The size of the value in the dictionary: the type size; for strings
    /// the capacity, which is the length of the default, and at least
    /// [`MIN_WRITABLE_STRING`] for a string an SDO may write; 0 for DOMAIN.
    pub fn size(&self) -> usize {
        match self.data_type {
            Some(DataType::Domain) | None => 0,
            Some(t) => t.size().unwrap_or_else(|| {
                let writable = !matches!(self.access, Access::Ro | Access::Const);
                if writable { self.value.len().max(MIN_WRITABLE_STRING) } else { self.value.len() }
            }),
        }
    }

    /// The value as an unsigned number, for communication-parameter checks.
    pub fn unsigned(&self) -> Option<u64> {
        let t = self.data_type?;
        t.size()?;
        match Number::decode(t, &self.value)? {
            Number::Unsigned(v) => Some(v),
            Number::Signed(v) => u64::try_from(v).ok(),
            Number::Real(_) => None,
        }
    }
}

/// One object `[xxxx]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Index.
    pub index: u16,
    /// `ParameterName`.
    pub name: String,
    /// `ObjectType`.
    pub kind: ObjectKind,
    /// `SubNumber` as written.
    pub sub_number: Option<u16>,
    /// Line of the `SubNumber` key, else of the section.
    pub sub_number_line: usize,
    /// `CompactSubObj` as written.
    pub compact_sub_obj: Option<u16>,
    /// `Denotation` (DCF).
    pub denotation: Option<String>,
    /// `ObjectLinks` from `[xxxxObjectLinks]`.
    pub links: Vec<u16>,
    /// The sub-objects by sub-index.
    pub subs: BTreeMap<u8, SubObject>,
    /// The object cannot become code (an undefined manufacturer type, an empty
    /// ARRAY); the reason was reported as a warning.
    pub opaque: bool,
    /// The object was synthesised (from `CompactPDO`), not written in the file.
    pub synthesized: bool,
    /// Line of `[xxxx]`.
    pub line: usize,
}

/// Device facts from `[DeviceInfo]`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DeviceFacts {
    /// Supported bit rates, as a bit set over the CiA 305 table index.
    pub baud_rates: u16,
    /// `LSS_Supported`.
    pub lss_supported: bool,
    /// `Granularity`.
    pub granularity: u8,
    /// `NrOfRXPDO`.
    pub nr_rx_pdo: u16,
    /// `NrOfTXPDO`.
    pub nr_tx_pdo: u16,
    /// `CompactPDO` bit set.
    pub compact_pdo: u8,
    /// `SimpleBootUpMaster`.
    pub simple_boot_up_master: bool,
    /// `SimpleBootUpSlave`.
    pub simple_boot_up_slave: bool,
    /// `DynamicChannelsSupported`.
    pub dynamic_channels: bool,
    /// `GroupMessaging`.
    pub group_messaging: bool,
    /// Dummy entries (types 0x0001..0x0007) the device accepts in PDO mappings, as a bit set over the type index.
    pub dummy_usage: u32,
}

/// The `[xxxObjects]` lists.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ObjectLists {
    /// `[MandatoryObjects]`.
    pub mandatory: Vec<u16>,
    /// `[OptionalObjects]`.
    pub optional: Vec<u16>,
    /// `[ManufacturerObjects]`.
    pub manufacturer: Vec<u16>,
    /// The line where each index is first listed.
    pub lines: std::collections::BTreeMap<u16, usize>,
    /// Whether the file has any of the three lists.
    pub present: bool,
}

/// A parsed EDS or DCF.
#[derive(Clone, Debug, Default)]
pub struct Eds {
    /// The file name used in messages and generated comments.
    pub file: String,
    /// `[FileInfo]`, kept as written.
    pub file_info: Option<Section>,
    /// `[DeviceInfo]`, kept as written.
    pub device_info: Option<Section>,
    /// Facts decoded from `[DeviceInfo]` and `[DummyUsage]`.
    pub device: DeviceFacts,
    /// `[Comments]` lines.
    pub comments: Vec<String>,
    /// The object lists.
    pub lists: ObjectLists,
    /// `[DeviceComissioning]` (DCF), kept as written.
    pub commissioning: Option<Section>,
    /// Node-id from `[DeviceComissioning]`, if configured (1..=127).
    pub node_id: Option<u8>,
    /// Sections this reader does not interpret (`[Tools]`, modular-device sections), kept for export.
    pub other_sections: Vec<Section>,
    /// The objects by index.
    pub objects: BTreeMap<u16, Object>,
    /// Read-only objects the device stores itself (a preset offset, an
    /// operating time it saves with `save_objects`): their RAM values join
    /// the writable ones at the front of the image, in the stored set. Not
    /// from the file: the firmware's build names them.
    pub kept: Vec<u16>,
}

impl Eds {
    /// The sub-object at (index, sub), if any.
    pub fn sub(&self, index: u16, sub: u8) -> Option<&SubObject> {
        self.objects.get(&index)?.subs.get(&sub)
    }
}
