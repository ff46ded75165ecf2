//! CiA 306 v1.3 reader: sections → [`Eds`].
//!
//! Tolerant of what real tools write (each tolerance is a warning) and strict
//! about what leaves part of the dictionary undetermined (an error). See
//! `tests/corpus/MANIFEST.md` for the real files this was built against.

use std::collections::{BTreeMap, BTreeSet};

use canopen_core::od::{DataType, Number};

use crate::diag::Diagnostics;
use crate::lexer::{self, Pair, Section};
use crate::model::{Access, DeviceFacts, Eds, Object, ObjectKind, SubObject, Text};
use crate::value::{self, parse_int};

/// Which section a header names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
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

fn classify(name: &str) -> Kind {
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

const OBJECT_KEYS: &[&str] = &[
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

const DEVICE_INFO_KEYS: &[&str] = &[
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
const BAUD_KEYS: &[(&str, u16)] = &[
    ("BaudRate_1000", 0),
    ("BaudRate_800", 1),
    ("BaudRate_500", 2),
    ("BaudRate_250", 3),
    ("BaudRate_125", 4),
    ("BaudRate_50", 6),
    ("BaudRate_20", 7),
    ("BaudRate_10", 8),
];

/// Reads an EDS/DCF from its bytes. Never panics; every problem is a diagnostic.
pub fn read(file: &str, bytes: &[u8]) -> (Eds, Diagnostics) {
    let mut d = Diagnostics::new(file);
    let (text, latin1) = lexer::decode(bytes);
    if latin1 {
        d.warn(0, "file is not UTF-8; read as Latin-1");
    }
    let sections = lexer::sections(&text, &mut d);
    let eds =
        Reader { d: &mut d, unknown_keys: BTreeSet::new(), is_eds: file.to_ascii_lowercase().ends_with(".eds") }.build(file, sections);
    (eds, d)
}

struct Reader<'a> {
    d: &'a mut Diagnostics,
    unknown_keys: BTreeSet<String>,
    /// An EDS describes a device type; `ParameterValue` belongs in a DCF.
    is_eds: bool,
}

impl Reader<'_> {
    fn build(mut self, file: &str, sections: Vec<Section>) -> Eds {
        let mut eds = Eds { file: file.to_owned(), ..Eds::default() };
        let mut object_sections: BTreeMap<u16, Section> = BTreeMap::new();
        let mut sub_sections: BTreeMap<(u16, u8), Section> = BTreeMap::new();
        let mut names: BTreeMap<u16, Section> = BTreeMap::new();
        let mut values: BTreeMap<u16, Section> = BTreeMap::new();
        let mut links: BTreeMap<u16, Section> = BTreeMap::new();
        let mut dummy_usage = None;
        for s in sections {
            match classify(&s.name) {
                Kind::FileInfo => eds.file_info = Some(s),
                Kind::DeviceInfo => eds.device_info = Some(s),
                Kind::DummyUsage => dummy_usage = Some(s),
                Kind::Comments => eds.comments = self.comments(&s),
                Kind::Mandatory => eds.lists.mandatory = self.listed(&mut eds.lists, &s),
                Kind::Optional => eds.lists.optional = self.listed(&mut eds.lists, &s),
                Kind::Manufacturer => eds.lists.manufacturer = self.listed(&mut eds.lists, &s),
                Kind::Commissioning => {
                    eds.node_id = self.commissioning_node_id(&s);
                    eds.commissioning = Some(s);
                }
                Kind::Object(i) => {
                    object_sections.insert(i, s);
                }
                Kind::Sub(i, sub) => {
                    // Sub-index sections are hex; `sub10` is 0x10, not decimal 10.
                    if let Some(prev) = sub_sections.get(&(i, sub)) {
                        self.d.error(
                            s.line,
                            format!("[{}] repeats sub-index 0x{sub:02X} of 0x{i:04X} (first at line {})", s.name, prev.line),
                        );
                    } else {
                        sub_sections.insert((i, sub), s);
                    }
                }
                Kind::Names(i) => {
                    names.insert(i, s);
                }
                Kind::Values(i) => {
                    values.insert(i, s);
                }
                Kind::Links(i) => {
                    links.insert(i, s);
                }
                Kind::Other => {
                    self.d.warn(s.line, format!("section [{}] is not interpreted; kept as is", s.name));
                    eds.other_sections.push(s);
                }
            }
        }
        eds.device = self.device_facts(eds.device_info.as_ref(), dummy_usage.as_ref());
        for (index, s) in &object_sections {
            let subs: Vec<Section> = sub_sections.range((*index, 0)..=(*index, 0xFF)).map(|(_, s)| s.clone()).collect();
            if let Some(o) = self.object(*index, s, subs, names.get(index), values.get(index)) {
                eds.objects.insert(*index, o);
            }
        }
        for ((index, sub), s) in &sub_sections {
            if !object_sections.contains_key(index) {
                self.d.error(
                    s.line,
                    format!("[{}] describes sub-index 0x{sub:02X} of 0x{index:04X}, which has no [{index:04X}] section", s.name),
                );
            }
        }
        for (index, s) in names.iter().chain(values.iter()) {
            let compact = eds.objects.get(index).is_some_and(|o| o.compact_sub_obj.is_some());
            if !compact {
                self.d.warn(s.line, format!("[{}] belongs to no object with CompactSubObj; ignored", s.name));
            }
        }
        for (index, s) in &links {
            let list = self.object_list(s, "ObjectLinks");
            match eds.objects.get_mut(index) {
                Some(o) => o.links = list,
                None => self.d.warn(s.line, format!("[{}] links an object that does not exist", s.name)),
            }
        }
        self.synthesize_compact_pdo(&mut eds);
        eds
    }

    fn comments(&mut self, s: &Section) -> Vec<String> {
        let lines = s.get("Lines").and_then(|p| self.int(p)).unwrap_or(0);
        // Walk the keys, not 1..=Lines: `Lines` may be any number up to 10^40.
        let numbered: BTreeMap<i128, String> = s
            .pairs
            .iter()
            .filter_map(|p| {
                let n: i128 = p.key.get(4..)?.parse().ok()?;
                ((1..=lines).contains(&n) && p.key.eq_ignore_ascii_case(&format!("Line{n}"))).then(|| (n, p.value.clone()))
            })
            .collect();
        let out: Vec<String> = numbered.into_values().collect();
        if out.len() as i128 != lines {
            self.d.warn(s.line, format!("[Comments] Lines={lines} but {} LineN keys", out.len()));
        }
        out
    }

    /// An `[xxxObjects]` list, remembering where each index is listed.
    fn listed(&mut self, lists: &mut crate::model::ObjectLists, s: &Section) -> Vec<u16> {
        lists.present = true;
        let out = self.object_list(s, "SupportedObjects");
        for p in &s.pairs {
            if let Ok(e) = parse_int(&p.value)
                && let (Ok(i), false) = (u16::try_from(e.value), p.key.eq_ignore_ascii_case("SupportedObjects"))
            {
                lists.lines.entry(i).or_insert(p.line);
            }
        }
        out
    }

    fn object_list(&mut self, s: &Section, count_key: &str) -> Vec<u16> {
        let mut out = Vec::new();
        let mut count = None;
        for p in &s.pairs {
            if p.key.eq_ignore_ascii_case(count_key) {
                count = self.int(p).map(|n| (n, p.line));
                continue;
            }
            if parse_int(&p.key).is_err() {
                self.d.warn(p.line, format!("key {} in [{}] is not a list position; ignored", p.key, s.name));
                continue;
            }
            match parse_int(&p.value).ok().and_then(|e| u16::try_from(e.value).ok().filter(|_| !e.node_id)) {
                Some(i) if out.contains(&i) => self.d.warn(p.line, format!("0x{i:04X} is listed twice in [{}]", s.name)),
                Some(i) => out.push(i),
                None => self.d.error(p.line, format!("`{}` in [{}] is not an object index", p.value, s.name)),
            }
        }
        match count {
            Some((n, line)) if n != s.pairs.len() as i128 - 1 => {
                self.d.warn(line, format!("[{}] {count_key}={n} but it has {} entries", s.name, s.pairs.len().saturating_sub(1)))
            }
            None => self.d.warn(s.line, format!("[{}] has no {count_key} key", s.name)),
            _ => {}
        }
        out
    }

    fn commissioning_node_id(&mut self, s: &Section) -> Option<u8> {
        let p = s.get("NodeID")?;
        let id = self.int(p)?;
        if (1..=127).contains(&id) {
            Some(id as u8)
        } else {
            self.d.warn(p.line, format!("NodeID {id} is outside 1..=127, i.e. not configured (LSS)"));
            None
        }
    }

    fn device_facts(&mut self, info: Option<&Section>, dummy: Option<&Section>) -> DeviceFacts {
        let mut f = DeviceFacts::default();
        if let Some(s) = info {
            for p in &s.pairs {
                if !DEVICE_INFO_KEYS.contains(&p.key.to_ascii_lowercase().as_str()) {
                    self.d.warn(p.line, format!("unknown key {} in [DeviceInfo]", p.key));
                }
            }
            for key in ["VendorName", "VendorNumber", "ProductName", "ProductNumber", "RevisionNumber", "OrderCode"] {
                match s.get(key) {
                    None => self.d.warn(s.line, format!("[DeviceInfo] has no {key}")),
                    Some(p) if p.value.is_empty() || p.value == "\"\"" => self.d.warn(p.line, format!("{key} is empty")),
                    Some(p) if key.ends_with("Number") && parse_int(&p.value).is_err() => {
                        self.d.error(p.line, format!("{key} `{}` is not a number", p.value))
                    }
                    _ => {}
                }
            }
            for (key, bit) in BAUD_KEYS {
                if self.flag(s, key) {
                    f.baud_rates |= 1 << bit;
                }
            }
            if f.baud_rates == 0 {
                self.d.warn(s.line, "no supported bit rate (every BaudRate_* is 0 or missing)");
            }
            f.lss_supported = self.flag(s, "LSS_Supported");
            f.simple_boot_up_master = self.flag(s, "SimpleBootUpMaster");
            f.simple_boot_up_slave = self.flag(s, "SimpleBootUpSlave");
            f.dynamic_channels = self.flag(s, "DynamicChannelsSupported");
            f.group_messaging = self.flag(s, "GroupMessaging");
            f.granularity = self.small(s, "Granularity", 64) as u8;
            f.nr_rx_pdo = self.small(s, "NrOfRXPDO", 512) as u16;
            f.nr_tx_pdo = self.small(s, "NrOfTXPDO", 512) as u16;
            f.compact_pdo = self.small(s, "CompactPDO", 0xFF) as u8;
        } else {
            self.d.warn(0, "no [DeviceInfo] section");
        }
        if let Some(s) = dummy {
            for p in &s.pairs {
                let t = p.key.to_ascii_lowercase().strip_prefix("dummy").and_then(|t| u16::from_str_radix(t, 16).ok());
                match t {
                    Some(t @ 1..=0x1F) if self.int(p) == Some(1) => f.dummy_usage |= 1 << t,
                    Some(1..=0x1F) => {}
                    _ => self.d.warn(p.line, format!("unknown key {} in [DummyUsage]", p.key)),
                }
            }
        }
        f
    }

    fn flag(&mut self, s: &Section, key: &str) -> bool {
        match s.get(key) {
            None => false,
            Some(p) => match parse_int(&p.value).map(|e| e.value) {
                Ok(0) => false,
                Ok(1) => true,
                _ => {
                    self.d.warn(p.line, format!("{key}=`{}` is not 0 or 1; read as 0", p.value));
                    false
                }
            },
        }
    }

    fn small(&mut self, s: &Section, key: &str, max: i128) -> i128 {
        let Some(p) = s.get(key) else { return 0 };
        match self.int(p) {
            Some(v) if (0..=max).contains(&v) => v,
            Some(v) => {
                self.d.error(p.line, format!("{key}={v} is outside 0..={max}"));
                0
            }
            None => 0,
        }
    }

    fn int(&mut self, p: &Pair) -> Option<i128> {
        match parse_int(&p.value) {
            Ok(e) if !e.node_id => Some(e.value),
            Ok(_) => {
                self.d.error(p.line, format!("{} may not depend on $NODEID", p.key));
                None
            }
            Err(e) => {
                self.d.error(p.line, format!("{}: {e}", p.key));
                None
            }
        }
    }

    fn check_keys(&mut self, s: &Section) {
        for p in &s.pairs {
            let k = p.key.to_ascii_lowercase();
            if !OBJECT_KEYS.contains(&k.as_str()) && self.unknown_keys.insert(k) {
                self.d.warn(p.line, format!("unknown key {} (further uses of it are not reported)", p.key));
            }
        }
    }

    fn object(&mut self, index: u16, s: &Section, subs: Vec<Section>, names: Option<&Section>, values: Option<&Section>) -> Option<Object> {
        self.check_keys(s);
        let name = s.get("ParameterName").map(|p| p.value.clone()).unwrap_or_else(|| {
            self.d.warn(s.line, format!("[{}] has no ParameterName", s.name));
            format!("Object {index:04X}")
        });
        let kind = match s.get("ObjectType") {
            None => ObjectKind::Var,
            Some(p) => match parse_int(&p.value).ok().and_then(|e| ObjectKind::from_code(e.value)) {
                Some(k) => k,
                None => {
                    self.d.error(p.line, format!("ObjectType `{}` is not 0x0, 0x2, 0x5, 0x6, 0x7, 0x8 or 0x9", p.value));
                    return None;
                }
            },
        };
        let sub_number = s.get("SubNumber").and_then(|p| self.int(p)).map(|n| n.clamp(0, 0x100) as u16);
        let sub_number_line = s.get("SubNumber").map_or(s.line, |p| p.line);
        let compact = s.get("CompactSubObj").and_then(|p| self.int(p)).map(|n| n.clamp(0, 0x100) as u16);
        let compact_line = s.get("CompactSubObj").map_or(s.line, |p| p.line);
        if name.trim().is_empty() || name.trim().eq_ignore_ascii_case("None") {
            let line = s.get("ParameterName").map_or(s.line, |p| p.line);
            self.d.warn(line, format!("ParameterName `{name}` of 0x{index:04X} is a placeholder, not a name"));
        }
        let mut o = Object {
            index,
            name,
            kind,
            sub_number,
            sub_number_line,
            compact_sub_obj: compact,
            denotation: s.get("Denotation").map(|p| p.value.clone()),
            links: Vec::new(),
            subs: BTreeMap::new(),
            opaque: false,
            synthesized: false,
            line: s.line,
        };
        if !kind.has_subs() {
            for sub in &subs {
                self.d.error(sub.line, format!("[{}] is a sub-object of 0x{index:04X}, which is a {}", sub.name, kind.name()));
            }
            if let Some(v) = self.sub_object(s, 0, &o.name) {
                o.subs.insert(0, v);
            }
        } else if let Some(n) = compact.filter(|&n| n > 0) {
            if kind == ObjectKind::Record {
                self.d.warn(
                    compact_line,
                    format!("CompactSubObj on RECORD 0x{index:04X}; CiA 306 defines it for ARRAY, expanded the same way"),
                );
            }
            if n > 0xFE {
                self.d.warn(
                    compact_line,
                    format!("CompactSubObj={n} on 0x{index:04X} reaches sub-index 0x{:02X}; the highest is 0xFE", n.min(0xFF)),
                );
            }
            for sub in &subs {
                self.d.warn(sub.line, format!("[{}] is ignored: 0x{index:04X} uses CompactSubObj", sub.name));
            }
            self.expand_compact(&mut o, s, n.min(0xFF) as u8, names, values);
        } else {
            for sub in &subs {
                self.check_keys(sub);
                let Kind::Sub(_, si) = classify(&sub.name) else { continue };
                let default_name = format!("{} sub{si}", o.name);
                let sub_name = sub.get("ParameterName").map(|p| p.value.clone()).unwrap_or(default_name);
                if let Some(v) = self.sub_object(sub, si, &sub_name) {
                    o.subs.insert(si, v);
                }
            }
        }
        Some(o)
    }

    /// CiA 306 §4.5.2.2: the header gives the type of entries 1..=n, the
    /// `[xxxxName]`/`[xxxxValue]` sections name and set them by sub-index.
    fn expand_compact(&mut self, o: &mut Object, s: &Section, n: u8, names: Option<&Section>, values: Option<&Section>) {
        let index = o.index;
        let Some(template) = self.sub_object(s, 1, &o.name) else { return };
        let entry_key = |p: &Pair| parse_int(&p.key).ok().and_then(|e| u8::try_from(e.value).ok());
        let mut value_count = 0u8;
        let mut overrides: BTreeMap<u8, &Pair> = BTreeMap::new();
        for p in values.map(|v| v.pairs.as_slice()).unwrap_or(&[]) {
            if p.key.eq_ignore_ascii_case("NrOfEntries") {
                continue;
            }
            match entry_key(p) {
                Some(k) if (1..=n).contains(&k) => {
                    overrides.insert(k, p);
                    value_count = value_count.max(k);
                }
                _ => self.d.warn(p.line, format!("key {} in [{:04X}Value] is not a sub-index 1..={n}", p.key, index)),
            }
        }
        let mut sub_names: BTreeMap<u8, String> = BTreeMap::new();
        for p in names.map(|v| v.pairs.as_slice()).unwrap_or(&[]) {
            if p.key.eq_ignore_ascii_case("NrOfEntries") {
                continue;
            }
            match entry_key(p) {
                Some(k) if (1..=n).contains(&k) => {
                    sub_names.insert(k, p.value.clone());
                }
                _ => self.d.warn(p.line, format!("key {} in [{:04X}Name] is not a sub-index 1..={n}", p.key, index)),
            }
        }
        // Sub-index 0. For the error history and PDO mappings it counts the
        // entries in use, so it is writable and starts at the values given.
        let counts_use = index == 0x1003 || (0x1600..=0x17FF).contains(&index) || (0x1A00..=0x1BFF).contains(&index);
        let sub0_default = if counts_use { value_count } else { n };
        o.subs.insert(
            0,
            SubObject {
                sub: 0,
                name: "Highest sub-index supported".into(),
                type_index: DataType::Unsigned8.index(),
                type_line: s.line,
                data_type: Some(DataType::Unsigned8),
                access: if counts_use { Access::Rw } else { Access::Ro },
                pdo_mapping: false,
                default: Some(Text { text: sub0_default.to_string(), line: s.line }),
                parameter_value: None,
                denotation: None,
                low: None,
                high: None,
                obj_flags: 0,
                upload_file: None,
                download_file: None,
                value: vec![sub0_default],
                node_id: false,
                limits: None,
                line: s.line,
            },
        );
        for k in 1..=n {
            let mut e = template.clone();
            e.sub = k;
            e.name = sub_names.remove(&k).unwrap_or_else(|| format!("{}{k}", o.name));
            if let Some(p) = overrides.get(&k) {
                e.parameter_value = None;
                e.default = Some(Text { text: p.value.clone(), line: p.line });
                if let Some(t) = e.data_type {
                    self.set_value(&mut e, t, &p.value, p.line);
                }
            }
            o.subs.insert(k, e);
        }
    }

    fn set_value(&mut self, e: &mut SubObject, t: DataType, text: &str, line: usize) {
        match value::encode(t, text) {
            Ok(v) => {
                if let Some(note) = v.note {
                    self.d.warn(line, note);
                }
                e.value = v.bytes;
                e.node_id = v.node_id;
            }
            Err(msg) => self.d.error(line, format!("value {msg}")),
        }
    }

    /// Reads the entry keys of a VAR section or a `[xxxxsubN]` section.
    fn sub_object(&mut self, s: &Section, sub: u8, name: &str) -> Option<SubObject> {
        let text = |key: &str| s.get(key).map(|p| Text { text: p.value.clone(), line: p.line });
        let Some(dt) = s.get("DataType") else {
            self.d.error(s.line, format!("[{}] has no DataType", s.name));
            return None;
        };
        let type_index = match parse_int(&dt.value).ok().and_then(|e| u16::try_from(e.value).ok()) {
            Some(t) => t,
            None => {
                self.d.error(dt.line, format!("DataType `{}` is not a type index", dt.value));
                return None;
            }
        };
        let data_type = DataType::from_index(type_index);
        let access = match s.get("AccessType") {
            Some(p) => match Access::parse(&p.value) {
                Some(a) => a,
                None => {
                    self.d.error(p.line, format!("AccessType `{}` is not ro, wo, rw, rwr, rww or const", p.value));
                    return None;
                }
            },
            None => {
                self.d.error(s.line, format!("[{}] has no AccessType", s.name));
                return None;
            }
        };
        let pdo_mapping = match s.get("PDOMapping") {
            None => false,
            Some(p) => match parse_int(&p.value).map(|e| e.value) {
                Ok(0) => false,
                Ok(1) => true,
                _ => {
                    self.d.error(p.line, format!("PDOMapping `{}` is not 0 or 1", p.value));
                    false
                }
            },
        };
        let obj_flags = s.get("ObjFlags").and_then(|p| self.int(p)).and_then(|v| u32::try_from(v).ok()).unwrap_or(0);
        let mut e = SubObject {
            sub,
            name: name.to_owned(),
            type_index,
            type_line: dt.line,
            data_type,
            access,
            pdo_mapping,
            default: text("DefaultValue"),
            parameter_value: text("ParameterValue"),
            denotation: s.get("Denotation").map(|p| p.value.clone()),
            low: text("LowLimit").filter(|t| !t.text.is_empty()),
            high: text("HighLimit").filter(|t| !t.text.is_empty()),
            obj_flags,
            upload_file: s.get("UploadFile").map(|p| p.value.clone()),
            download_file: s.get("DownloadFile").map(|p| p.value.clone()),
            value: Vec::new(),
            node_id: false,
            limits: None,
            line: s.line,
        };
        if let Some(pv) = e.parameter_value.as_ref().filter(|_| self.is_eds) {
            self.d.warn(pv.line, "ParameterValue belongs in a DCF; in this EDS it is taken as the value");
        }
        let Some(t) = data_type else { return Some(e) };
        e.value = vec![0; t.size().unwrap_or(0)];
        // A DCF's ParameterValue is the configured value; it wins over the default.
        let chosen = e.parameter_value.clone().filter(|p| !p.text.is_empty()).or_else(|| e.default.clone());
        if let Some(v) = chosen.filter(|v| !v.text.is_empty()) {
            self.set_value(&mut e, t, &v.text, v.line);
        }
        if (e.low.is_some() || e.high.is_some()) && t.size().is_some() && t.kind() != canopen_core::od::Kind::Bytes {
            // A single limit still bounds the value; the type's own range is the other bound.
            let parse = |this: &mut Self, lim: &Option<Text>, what: &str| -> Option<Option<Number>> {
                let Some(lim) = lim else { return Some(None) };
                match value::parse_number(t, &lim.text) {
                    Ok((_, true, _)) => {
                        this.d.warn(lim.line, format!("{what} relative to $NODEID is not checked"));
                        None
                    }
                    Ok((n, false, note)) => {
                        if let Some(n) = note {
                            this.d.warn(lim.line, format!("{what} {n}"));
                        }
                        Some(Some(n))
                    }
                    Err(m) => {
                        this.d.error(lim.line, format!("{what} {m}"));
                        None
                    }
                }
            };
            let low = parse(self, &e.low, "LowLimit");
            let high = parse(self, &e.high, "HighLimit");
            if let (Some(low), Some(high)) = (low, high) {
                let (min, max) = value::type_bounds(t);
                e.limits = Some((low.unwrap_or(min), high.unwrap_or(max)));
            }
        }
        Some(e)
    }

    /// CiA 306 §4.5.2.3: with `CompactPDO`, PDO objects the file leaves out
    /// exist with default values for each PDO up to `NrOfRXPDO`/`NrOfTXPDO`.
    fn synthesize_compact_pdo(&mut self, eds: &mut Eds) {
        let f = eds.device.clone();
        if f.compact_pdo == 0 {
            return;
        }
        for (count, comm, map, base) in [(f.nr_rx_pdo, 0x1400u16, 0x1600u16, 0x200u32), (f.nr_tx_pdo, 0x1800, 0x1A00, 0x180)] {
            for n in 0..count.min(512) {
                let tx = comm == 0x1800;
                let cob = if n < 4 { format!("$NODEID+0x{:X}", base + 0x100 * u32::from(n)) } else { "0x80000000".into() };
                let mut comm_subs: Vec<(u8, &str, DataType, String)> = Vec::new();
                let bits = f.compact_pdo;
                if bits & 0x01 != 0 {
                    comm_subs.push((1, "COB-ID", DataType::Unsigned32, cob));
                }
                if bits & 0x02 != 0 {
                    comm_subs.push((2, "Transmission type", DataType::Unsigned8, "0xFF".into()));
                }
                if bits & 0x04 != 0 {
                    comm_subs.push((3, "Inhibit time", DataType::Unsigned16, "0".into()));
                }
                if bits & 0x10 != 0 {
                    comm_subs.push((5, "Event timer", DataType::Unsigned16, "0".into()));
                }
                if tx && bits & 0x20 != 0 {
                    comm_subs.push((6, "SYNC start value", DataType::Unsigned8, "0".into()));
                }
                let ci = comm + n;
                if !eds.objects.contains_key(&ci) && !comm_subs.is_empty() {
                    let highest = comm_subs.last().map_or(0, |s| s.0);
                    let mut subs =
                        vec![(0u8, "Highest sub-index supported".to_owned(), DataType::Unsigned8, highest.to_string(), Access::Ro)];
                    subs.extend(comm_subs.into_iter().map(|(s, name, t, v)| (s, name.to_owned(), t, v, Access::Rw)));
                    let name = format!("{} communication parameter {}", if tx { "TPDO" } else { "RPDO" }, n + 1);
                    eds.objects.insert(ci, synthetic(ci, &name, subs));
                }
                let mi = map + n;
                eds.objects.entry(mi).or_insert_with(|| {
                    let mut subs = vec![(0u8, "Number of mapped objects".to_owned(), DataType::Unsigned8, "0".to_owned(), Access::Rw)];
                    subs.extend((1..=8u8).map(|k| (k, format!("Mapped object {k}"), DataType::Unsigned32, "0".to_owned(), Access::Rw)));
                    let name = format!("{} mapping parameter {}", if tx { "TPDO" } else { "RPDO" }, n + 1);
                    synthetic(mi, &name, subs)
                });
            }
        }
    }
}

fn synthetic(index: u16, name: &str, subs: Vec<(u8, String, DataType, String, Access)>) -> Object {
    let subs = subs
        .into_iter()
        .map(|(sub, name, t, text, access)| {
            let v = value::encode(t, &text).unwrap_or(value::Encoded { bytes: vec![0; t.size().unwrap_or(0)], node_id: false, note: None });
            let e = SubObject {
                sub,
                name,
                type_index: t.index(),
                type_line: 0,
                data_type: Some(t),
                access,
                pdo_mapping: false,
                default: Some(Text { text, line: 0 }),
                parameter_value: None,
                denotation: None,
                low: None,
                high: None,
                obj_flags: 0,
                upload_file: None,
                download_file: None,
                value: v.bytes,
                node_id: v.node_id,
                limits: None,
                line: 0,
            };
            (sub, e)
        })
        .collect::<BTreeMap<_, _>>();
    Object {
        index,
        name: name.to_owned(),
        kind: ObjectKind::Record,
        sub_number: Some(subs.len() as u16),
        sub_number_line: 0,
        compact_sub_obj: None,
        denotation: None,
        links: Vec::new(),
        subs,
        opaque: false,
        synthesized: true,
        line: 0,
    }
}

#[cfg(test)]
mod tests;
