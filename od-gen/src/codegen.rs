//! Rust code for one dictionary: flash tables, one RAM struct, typed accessors.
//!
//! The output has this order (style guide §2.5): index constants, sizing
//! constants, entry tables, the `Ram` struct, its accessors. It is
//! rustfmt-clean, warning-free and has no trait object per entry.

use std::collections::{BTreeMap, HashSet};
use std::fmt::Write;

use canopen_core::od::{Attr, DataType, NO_LIMITS, Number, Services};

use crate::model::{Access, Eds, Object, ObjectKind, SubObject};

/// Why a dictionary cannot be laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutError(pub String);

/// One table entry, placed.
pub(crate) struct Placed<'a> {
    pub(crate) obj: &'a Object,
    pub(crate) sub: &'a SubObject,
    pub(crate) data_type: DataType,
    pub(crate) attr: Attr,
    pub(crate) len: usize,
    pub(crate) offset: usize,
    pub(crate) limits: u16,
}

/// The placed dictionary: what the generated module and [`crate::runtime`] hold.
pub(crate) struct Layout<'a> {
    pub(crate) entries: Vec<Placed<'a>>,
    pub(crate) limits: Vec<(u64, u64)>,
    pub(crate) rom: Vec<u8>,
    pub(crate) ram: Vec<u8>,
    pub(crate) comm_len: usize,
    pub(crate) node_id_relative: Vec<usize>,
}

pub(crate) fn layout(eds: &Eds) -> Result<Layout<'_>, LayoutError> {
    let mut l =
        Layout { entries: Vec::new(), limits: Vec::new(), rom: Vec::new(), ram: Vec::new(), comm_len: 0, node_id_relative: Vec::new() };
    for o in eds.objects.values().filter(|o| !o.opaque) {
        for s in o.subs.values() {
            let Some(t) = s.data_type else { continue };
            let mut attr = s.access.attr(s.pdo_mapping);
            if s.node_id {
                // A `$NODEID` value changes with the node-id, so even a `const` one lives in RAM.
                attr = Attr(attr.union(Attr::NODE_ID).0 & !Attr::IN_ROM.0);
            }
            let len = s.size();
            let mut value = s.value.clone();
            value.resize(len, 0);
            let offset = if t == DataType::Domain {
                0
            } else if attr.contains(Attr::IN_ROM) {
                l.rom.extend_from_slice(&value);
                l.rom.len() - len
            } else {
                l.ram.extend_from_slice(&value);
                l.ram.len() - len
            };
            let limits = match s.limits {
                Some((lo, hi)) => {
                    let pair = (lo.to_limit(), hi.to_limit());
                    let pos = l.limits.iter().position(|p| *p == pair).unwrap_or_else(|| {
                        l.limits.push(pair);
                        l.limits.len() - 1
                    });
                    u16::try_from(pos).map_err(|_| LayoutError("more than 65535 distinct limits".into()))?
                }
                None => NO_LIMITS,
            };
            if s.node_id && !attr.contains(Attr::IN_ROM) {
                l.node_id_relative.push(l.entries.len());
            }
            l.entries.push(Placed { obj: o, sub: s, data_type: t, attr, len, offset, limits });
        }
        if o.index < 0x2000 {
            l.comm_len = l.ram.len();
        }
    }
    if l.ram.len() > usize::from(u16::MAX) || l.rom.len() > usize::from(u16::MAX) {
        return Err(LayoutError(format!("RAM image {} B / ROM {} B exceed 65535 B", l.ram.len(), l.rom.len())));
    }
    if l.entries.len() > usize::from(u16::MAX) {
        return Err(LayoutError("more than 65535 entries".into()));
    }
    Ok(l)
}

const RESERVED: &[&str] = &[
    "as",
    "break",
    "const",
    "continue",
    "crate",
    "else",
    "enum",
    "extern",
    "false",
    "fn",
    "for",
    "if",
    "impl",
    "in",
    "let",
    "loop",
    "match",
    "mod",
    "move",
    "mut",
    "pub",
    "ref",
    "return",
    "self",
    "static",
    "struct",
    "super",
    "trait",
    "true",
    "type",
    "unsafe",
    "use",
    "where",
    "while",
    "async",
    "await",
    "dyn",
    "abstract",
    "become",
    "box",
    "do",
    "final",
    "macro",
    "override",
    "priv",
    "typeof",
    "unsized",
    "virtual",
    "yield",
    "try",
    "gen",
    // Methods of `Ram` itself.
    "new",
    "reset_communication",
    "reset_application",
    "dictionary",
    "image",
    "image_mut",
    "clone",
    "fmt",
    "eq",
];

/// snake_case identifier from an EDS name.
pub fn snake(name: &str) -> String {
    let mut out = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            if c.is_ascii_uppercase() && prev_lower {
                out.push('_');
            }
            prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
            out.push(c.to_ascii_lowercase());
        } else {
            prev_lower = false;
            if !out.ends_with('_') && !out.is_empty() {
                out.push('_');
            }
        }
    }
    let mut out = out.trim_end_matches('_').to_owned();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert_str(0, "o_");
    }
    if RESERVED.contains(&out.as_str()) {
        out.push('_');
    }
    out
}

/// Rust type of a typed accessor.
fn rust_type(t: DataType) -> Option<&'static str> {
    Some(match t {
        DataType::Boolean => "bool",
        DataType::Integer8 => "i8",
        DataType::Integer16 => "i16",
        DataType::Integer24 | DataType::Integer32 => "i32",
        DataType::Integer40 | DataType::Integer48 | DataType::Integer56 | DataType::Integer64 => "i64",
        DataType::Unsigned8 => "u8",
        DataType::Unsigned16 => "u16",
        DataType::Unsigned24 | DataType::Unsigned32 => "u32",
        DataType::Unsigned40 | DataType::Unsigned48 | DataType::Unsigned56 | DataType::Unsigned64 => "u64",
        DataType::Real32 => "f32",
        DataType::Real64 => "f64",
        DataType::TimeOfDay | DataType::TimeDifference => "[u8; 6]",
        DataType::VisibleString | DataType::OctetString | DataType::UnicodeString => "&[u8]",
        DataType::Domain => return None,
    })
}

/// Size in bytes of a numeric accessor type (the types `rust_type` names).
fn rust_width(ty: &str) -> usize {
    match ty {
        "i8" | "u8" => 1,
        "i16" | "u16" => 2,
        "i32" | "u32" | "f32" => 4,
        _ => 8,
    }
}

/// Expression reading a value of type `t` at `off` (an expression) from `src`.
fn getter_expr(t: DataType, src: &str, off: &str, len: usize) -> String {
    let size = t.size().unwrap_or(len);
    let load = format!("od::load::<{size}>({src}, {off})");
    match t {
        DataType::Boolean => format!("{load}[0] != 0"),
        DataType::TimeOfDay | DataType::TimeDifference => load,
        DataType::VisibleString => format!("od::load_str({src}, {off}, {len})"),
        DataType::OctetString | DataType::UnicodeString => format!("od::load_bytes({src}, {off}, {len})"),
        _ => {
            let ty = rust_type(t).unwrap_or("u8");
            let width = rust_width(ty);
            if width == size {
                format!("{ty}::from_le_bytes({load})")
            } else if ty.starts_with('i') {
                format!("od::load_int::<{size}>({src}, {off}) as {ty}")
            } else if ty == "u64" {
                format!("od::load_uint::<{size}>({src}, {off})")
            } else {
                format!("od::load_uint::<{size}>({src}, {off}) as {ty}")
            }
        }
    }
}

/// Statement storing `v` of type `t` at `off`.
fn setter_stmt(t: DataType, off: &str, len: usize) -> String {
    let size = t.size().unwrap_or(len);
    match t {
        DataType::Boolean => format!("od::store::<1>(&mut self.image, {off}, [u8::from(v)]);"),
        DataType::TimeOfDay | DataType::TimeDifference => format!("od::store::<6>(&mut self.image, {off}, v);"),
        DataType::VisibleString | DataType::OctetString | DataType::UnicodeString => {
            format!("od::store_str(&mut self.image, {off}, {len}, v)")
        }
        _ => {
            let ty = rust_type(t).unwrap_or("u8");
            let width = rust_width(ty);
            if width == size {
                format!("od::store::<{size}>(&mut self.image, {off}, v.to_le_bytes());")
            } else if ty.starts_with('i') {
                format!("od::store_uint::<{size}>(&mut self.image, {off}, v as u64);")
            } else if ty == "u64" {
                format!("od::store_uint::<{size}>(&mut self.image, {off}, v);")
            } else {
                format!("od::store_uint::<{size}>(&mut self.image, {off}, u64::from(v));")
            }
        }
    }
}

fn attr_name(a: Attr) -> String {
    let mut s = String::from(if a.contains(Attr::IN_ROM) {
        "CONST"
    } else if a.contains(Attr::READ) && a.contains(Attr::WRITE) {
        "RW"
    } else if a.contains(Attr::WRITE) {
        "WO"
    } else {
        "RO"
    });
    if a.contains(Attr::MAP_TPDO) {
        s.push_str("_TPDO");
    }
    if a.contains(Attr::MAP_RPDO) {
        s.push_str("_RPDO");
    }
    if a.contains(Attr::NODE_ID) {
        s.push_str("_NODE_ID");
    }
    s
}

fn attr_expr(a: Attr) -> String {
    let mut parts = Vec::new();
    for (bit, name) in [
        (Attr::READ, "READ"),
        (Attr::WRITE, "WRITE"),
        (Attr::IN_ROM, "IN_ROM"),
        (Attr::MAP_TPDO, "MAP_TPDO"),
        (Attr::MAP_RPDO, "MAP_RPDO"),
        (Attr::NODE_ID, "NODE_ID"),
    ] {
        if a.contains(bit) {
            parts.push(format!("Attr::{name}.0"));
        }
    }
    format!("Attr({})", parts.join(" | "))
}

/// `decl = [items];` laid out as rustfmt does: on one line when it fits,
/// else short items filled line by line, else one item per line.
fn array(out: &mut String, decl: &str, items: &[String], short: bool) {
    let one_line = format!("{decl} = [{}];", items.join(", "));
    if one_line.len() <= 140 {
        let _ = writeln!(out, "{one_line}");
        return;
    }
    let _ = writeln!(out, "{decl} = [");
    if short {
        fill(out, items.iter().cloned());
    } else {
        for item in items {
            let _ = writeln!(out, "    {item},");
        }
    }
    let _ = writeln!(out, "];");
}

/// Array items filled greedily up to the line width, as rustfmt lays out
/// arrays of short items (`use_small_heuristics = "Max"`, `max_width = 140`).
fn fill(out: &mut String, items: impl Iterator<Item = String>) {
    const WIDTH: usize = 140;
    let mut line = String::new();
    for item in items {
        if !line.is_empty() && 4 + line.len() + 1 + item.len() + 1 > WIDTH {
            let _ = writeln!(out, "    {line}");
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(&item);
        line.push(',');
    }
    if !line.is_empty() {
        let _ = writeln!(out, "    {line}");
    }
}

fn doc_escape(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

/// Generates the module for `eds`. `source` is the file name quoted in comments.
pub fn generate(eds: &Eds, source: &str) -> Result<String, LayoutError> {
    generate_with(eds, source, services(eds))
}

/// Values longer than this (or a DOMAIN) make block transfer worth linking:
/// below it a segmented transfer takes a handful of frames.
pub const BLOCK_THRESHOLD: usize = 64;

/// The optional services a node on `eds` links, from its objects: LSS if
/// `LSS_Supported`, block SDO if a value is a DOMAIN or longer than
/// [`BLOCK_THRESHOLD`] bytes, guarding with 0x100C and 0x100D (or without
/// a heartbeat producer 0x1017: CiA 301 asks for one error control
/// protocol, so such a node keeps answering guarding requests), TIME with
/// 0x1012, storage with 0x1010 or 0x1011 (or LSS, which stores its
/// configuration; a device that stores by a command of its own says so
/// with `Application::STORES`).
pub fn services(eds: &Eds) -> Services {
    let has = |i: u16| eds.objects.get(&i).is_some_and(|o| !o.opaque);
    let large = eds
        .objects
        .values()
        .filter(|o| !o.opaque)
        .flat_map(|o| o.subs.values())
        .any(|s| s.data_type == Some(DataType::Domain) || (s.data_type.is_some() && s.size() > BLOCK_THRESHOLD));
    Services {
        lss: eds.device.lss_supported,
        block_sdo: large,
        guarding: (has(0x100C) && has(0x100D)) || !has(0x1017),
        time: has(0x1012),
        storage: has(0x1010) || has(0x1011) || eds.device.lss_supported,
    }
}

/// As [`generate`], with the services given (a reference image that
/// links more or less than its EDS implies).
pub fn generate_with(eds: &Eds, source: &str, services: Services) -> Result<String, LayoutError> {
    let l = layout(eds)?;
    let mut out = String::new();
    let w = &mut out;
    let product =
        eds.device_info.as_ref().and_then(|s| s.get("ProductName")).map(|p| p.value.trim_matches('"').to_owned()).filter(|s| !s.is_empty());
    let _ = writeln!(w, "// @generated by od-gen from {source}. Do not edit.");
    // Plain comments, not `//!`: the module is pulled in with `include!`.
    let _ = writeln!(w, "// Object dictionary of {} ({source}).", product.as_deref().unwrap_or("the device"));
    let _ = writeln!(w, "// {} entries: {} bytes of RAM, {} bytes of constants.", l.entries.len(), l.ram.len(), l.rom.len());
    let _ = writeln!(w);
    let _ = writeln!(w, "use canopen_core::od::{{self, Attr, DataType, DeviceInfo, Entry, Limits, NO_LIMITS}};");
    let _ = writeln!(w);

    // Names: objects, then per-entry accessor names.
    let mut used: HashSet<String> = HashSet::new();
    let mut object_names: BTreeMap<u16, String> = BTreeMap::new();
    for o in eds.objects.values().filter(|o| !o.opaque) {
        let mut n = snake(&o.name);
        if !used.insert(n.clone()) {
            n = format!("{n}_{:04x}", o.index);
            used.insert(n.clone());
        }
        object_names.insert(o.index, n);
    }

    let _ = writeln!(w, "/// Object indices by name.");
    let _ = writeln!(w, "pub mod index {{");
    for o in eds.objects.values().filter(|o| !o.opaque) {
        let _ = writeln!(w, "    /// 0x{:04X} {} ({source}:{})", o.index, doc_escape(&o.name), o.line);
        let _ = writeln!(w, "    pub const {}: u16 = 0x{:04X};", object_names[&o.index].to_uppercase(), o.index);
    }
    let _ = writeln!(w, "}}");
    let _ = writeln!(w);

    let count = |r: std::ops::RangeInclusive<u16>| eds.objects.range(r).filter(|(_, o)| !o.opaque).count();
    let subs_of = |i: u16| eds.objects.get(&i).filter(|o| !o.opaque).map_or(0, |o| o.subs.keys().filter(|&&k| k > 0).count());
    for (name, doc, v) in [
        ("ENTRY_COUNT", "Number of entries in the dictionary.", l.entries.len()),
        ("RAM_SIZE", "Size of the RAM image in bytes.", l.ram.len()),
        ("ROM_SIZE", "Size of the constant values in flash, in bytes.", l.rom.len()),
        ("RPDO_COUNT", "RPDOs (communication objects 0x1400–0x15FF).", count(0x1400..=0x15FF)),
        ("TPDO_COUNT", "TPDOs (communication objects 0x1800–0x19FF).", count(0x1800..=0x19FF)),
        ("SDO_SERVER_COUNT", "SDO servers (0x1200–0x127F).", count(0x1200..=0x127F)),
        ("SDO_CLIENT_COUNT", "SDO clients (0x1280–0x12FF).", count(0x1280..=0x12FF)),
        ("HB_CONSUMER_COUNT", "Heartbeat consumers (entries of 0x1016).", subs_of(0x1016)),
        ("ERROR_HISTORY_LEN", "Entries of the pre-defined error field 0x1003.", subs_of(0x1003)),
    ] {
        let _ = writeln!(w, "/// {doc}");
        let _ = writeln!(w, "pub const {name}: usize = {v};");
    }
    let _ = writeln!(w);
    let _ = writeln!(w, "/// SDO servers a node on this dictionary runs: the default one even without 0x1200.");
    let _ = writeln!(w, "pub const SDO_SERVERS: usize = {};", count(0x1200..=0x127F).max(1));
    let _ = writeln!(w);
    let _ = writeln!(w, "/// A node on this dictionary, with the device's hooks `A` and storage `S`.");
    let _ =
        writeln!(w, "pub type Node<A, S> = canopen_core::node::Node<Ram, A, S, RPDO_COUNT, TPDO_COUNT, HB_CONSUMER_COUNT, SDO_SERVERS>;");
    let _ = writeln!(w);

    let mut attrs: Vec<Attr> = Vec::new();
    for e in &l.entries {
        if !attrs.contains(&e.attr) {
            attrs.push(e.attr);
        }
    }
    attrs.sort_by_key(|a| a.0);
    for a in &attrs {
        let _ = writeln!(w, "const {}: Attr = {};", attr_name(*a), attr_expr(*a));
    }
    let _ = writeln!(w);

    let entries: Vec<String> = l
        .entries
        .iter()
        .map(|e| {
            let limits = if e.limits == NO_LIMITS { "NO_LIMITS".to_owned() } else { e.limits.to_string() };
            format!(
                "Entry::new(0x{:04X}, 0x{:02X}, DataType::{:?}, {}, {}, {}, {limits})",
                e.obj.index,
                e.sub.sub,
                e.data_type,
                attr_name(e.attr),
                e.len,
                e.offset
            )
        })
        .collect();
    let _ = writeln!(w, "/// Entry metadata, sorted by (index, sub-index).");
    array(w, "static ENTRIES: [Entry; ENTRY_COUNT]", &entries, false);
    let _ = writeln!(w);
    let limits: Vec<String> = l.limits.iter().map(|(lo, hi)| format!("Limits {{ low: 0x{lo:X}, high: 0x{hi:X} }}")).collect();
    array(w, &format!("static LIMITS: [Limits; {}]", l.limits.len()), &limits, false);
    let _ = writeln!(w);
    let hex = |b: &[u8]| b.iter().map(|b| format!("0x{b:02X}")).collect::<Vec<_>>();
    array(w, "static ROM: [u8; ROM_SIZE]", &hex(&l.rom), true);
    let _ = writeln!(w);
    array(w, "static DEFAULTS: [u8; RAM_SIZE]", &hex(&l.ram), true);
    let _ = writeln!(w);
    let relative: Vec<String> = l.node_id_relative.iter().map(ToString::to_string).collect();
    array(w, &format!("static NODE_ID_RELATIVE: [u16; {}]", relative.len()), &relative, true);
    let _ = writeln!(w);
    let _ = writeln!(w, "/// Entry names (`ParameterName`), parallel to the entry table. Left out of an image that never reads them.");
    let names: Vec<String> = l.entries.iter().map(|e| format!("\"{}\"", doc_escape(&e.sub.name).replace('\t', "\\t"))).collect();
    array(w, "pub static NAMES: [&str; ENTRY_COUNT]", &names, false);
    let _ = writeln!(w);
    let f = &eds.device;
    let _ = writeln!(w, "/// The flash half of the dictionary.");
    let _ = writeln!(w, "pub static DICTIONARY: od::Dictionary = od::Dictionary {{");
    let _ = writeln!(w, "    entries: &ENTRIES,");
    let _ = writeln!(w, "    limits: &LIMITS,");
    let _ = writeln!(w, "    rom: &ROM,");
    let _ = writeln!(w, "    defaults: &DEFAULTS,");
    let _ = writeln!(w, "    comm_len: {},", l.comm_len);
    let _ = writeln!(w, "    node_id_relative: &NODE_ID_RELATIVE,");
    let _ = writeln!(w, "    layout_id: od::layout_id(&ENTRIES),");
    let _ = writeln!(w, "    device: DeviceInfo {{");
    let _ = writeln!(w, "        baud_rates: 0x{:03X},", f.baud_rates);
    let _ = writeln!(w, "        lss_supported: {},", f.lss_supported);
    let _ = writeln!(w, "        granularity: {},", f.granularity);
    let _ = writeln!(w, "        simple_boot_up_slave: {},", f.simple_boot_up_slave);
    let _ = writeln!(w, "        dynamic_channels: {},", f.dynamic_channels);
    let _ = writeln!(w, "        group_messaging: {},", f.group_messaging);
    let _ = writeln!(w, "    }},");
    let _ = writeln!(w, "}};");
    let _ = writeln!(w);

    let _ = writeln!(w, "/// Every variable value of the dictionary, as one image in RAM.");
    let _ = writeln!(w, "#[derive(Clone, Debug, PartialEq, Eq)]");
    let _ = writeln!(w, "pub struct Ram {{");
    let _ = writeln!(w, "    image: [u8; RAM_SIZE],");
    let _ = writeln!(w, "}}");
    let _ = writeln!(w);
    let _ = writeln!(w, "impl od::ObjectDictionary for Ram {{");
    let _ = writeln!(
        w,
        "    const SERVICES: od::Services = od::Services {{ lss: {}, block_sdo: {}, guarding: {}, time: {}, storage: {} }};",
        services.lss, services.block_sdo, services.guarding, services.time, services.storage
    );
    let _ = writeln!(w, "    fn dictionary(&self) -> &'static od::Dictionary {{\n        &DICTIONARY\n    }}");
    let _ = writeln!(w, "    fn image(&self) -> &[u8] {{\n        &self.image\n    }}");
    let _ = writeln!(w, "    fn image_mut(&mut self) -> &mut [u8] {{\n        &mut self.image\n    }}");
    let _ = writeln!(w, "}}");
    let _ = writeln!(w);
    let _ = writeln!(w, "impl Ram {{");
    let _ = writeln!(w, "    /// The power-on values, with `$NODEID` defaults resolved for `node_id`.");
    let _ = writeln!(w, "    pub fn new(node_id: u8) -> Self {{");
    let _ = writeln!(w, "        let mut ram = Ram {{ image: [0; RAM_SIZE] }};");
    let _ = writeln!(w, "        ram.reset_application(node_id);");
    let _ = writeln!(w, "        ram.reset_communication(node_id);");
    let _ = writeln!(w, "        ram");
    let _ = writeln!(w, "    }}");
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// Every byte zero, without running the resets: for a node whose");
    let _ = writeln!(w, "    /// power-on resets the whole image anyway (`Node::power_on`).");
    let _ = writeln!(w, "    pub const fn zeroed() -> Self {{");
    let _ = writeln!(w, "        Ram {{ image: [0; RAM_SIZE] }}");
    let _ = writeln!(w, "    }}");
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// Restores 0x1000–0x1FFF to the defaults for `node_id` (NMT reset communication).");
    let _ = writeln!(w, "    pub fn reset_communication(&mut self, node_id: u8) {{");
    let _ = writeln!(w, "        DICTIONARY.reset_communication(&mut self.image, node_id);");
    let _ = writeln!(w, "    }}");
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// Restores 0x2000 and up to the defaults (NMT reset application).");
    let _ = writeln!(w, "    pub fn reset_application(&mut self, node_id: u8) {{");
    let _ = writeln!(w, "        DICTIONARY.reset_application(&mut self.image, node_id);");
    let _ = writeln!(w, "    }}");
    accessors(w, eds, &l, &object_names, &mut used, source);
    let _ = writeln!(w, "}}");
    Ok(out)
}

/// Whether entries 1..=n of an ARRAY share one type and sit back to back in RAM.
fn uniform_array<'a>(o: &Object, entries: &'a [&'a Placed<'a>]) -> Option<(&'a Placed<'a>, usize)> {
    if o.kind != ObjectKind::Array {
        return None;
    }
    let elems: Vec<&&Placed> = entries.iter().filter(|e| e.sub.sub > 0).collect();
    let first = **elems.first()?;
    let n = elems.len();
    let contiguous = elems.iter().enumerate().all(|(i, e)| {
        e.sub.sub as usize == i + 1
            && e.data_type == first.data_type
            && e.len == first.len
            && !e.attr.contains(Attr::IN_ROM)
            && e.offset == first.offset + i * first.len
    });
    (contiguous && n >= 2 && first.data_type.size().is_some()).then_some((first, n))
}

fn accessors(w: &mut String, eds: &Eds, l: &Layout<'_>, object_names: &BTreeMap<u16, String>, used: &mut HashSet<String>, source: &str) {
    let mut by_object: BTreeMap<u16, Vec<&Placed>> = BTreeMap::new();
    for e in &l.entries {
        by_object.entry(e.obj.index).or_default().push(e);
    }
    for (index, entries) in &by_object {
        let o = &eds.objects[index];
        let base = &object_names[index];
        if let Some((first, n)) = uniform_array(o, entries) {
            let s0 = entries.iter().find(|e| e.sub.sub == 0);
            if let Some(s0) = s0 {
                one_accessor(w, s0, &format!("{base}_sub0"), used, source);
            }
            let ty = rust_type(first.data_type).unwrap_or("u8");
            let size = first.len;
            let _ = writeln!(w);
            let _ = writeln!(w, "    /// 0x{index:04X} {} sub-index `i` (1..={n}) ({source}:{})", doc_escape(&o.name), o.line);
            let _ = writeln!(w, "    pub fn {base}(&self, i: u8) -> Option<{ty}> {{");
            let _ = writeln!(w, "        if !(1..={n}).contains(&i) {{\n            return None;\n        }}");
            let _ = writeln!(w, "        let off = {};", element_offset(first.offset, size));
            let _ = writeln!(w, "        Some({})", getter_expr(first.data_type, "&self.image", "off", size));
            let _ = writeln!(w, "    }}");
            let _ = writeln!(w);
            let _ =
                writeln!(w, "    /// Sets 0x{index:04X} {} sub-index `i` (1..={n}); false if `i` is out of range.", doc_escape(&o.name));
            let _ = writeln!(w, "    pub fn set_{base}(&mut self, i: u8, v: {ty}) -> bool {{");
            let _ = writeln!(w, "        if !(1..={n}).contains(&i) {{\n            return false;\n        }}");
            let _ = writeln!(w, "        let off = {};", element_offset(first.offset, size));
            let _ = writeln!(w, "        {}", setter_stmt(first.data_type, "off", size));
            let _ = writeln!(w, "        true");
            let _ = writeln!(w, "    }}");
            used.insert(base.clone());
            continue;
        }
        for e in entries {
            let name = if o.kind.has_subs() { format!("{base}_{}", snake(&e.sub.name).trim_start_matches("o_")) } else { base.clone() };
            one_accessor(w, e, &name, used, source);
        }
    }
}

/// Offset of element `i` (1-based) of an array starting at `base`, written
/// without operations that have no effect.
fn element_offset(base: usize, size: usize) -> String {
    let index = if size == 1 { "usize::from(i)".to_owned() } else { format!("usize::from(i) * {size}") };
    match base.checked_sub(size) {
        Some(0) => index,
        Some(b) => format!("{b} + {index}"),
        None => format!("{index} - {}", size - base),
    }
}

fn one_accessor(w: &mut String, e: &Placed<'_>, name: &str, used: &mut HashSet<String>, source: &str) {
    let Some(ty) = rust_type(e.data_type) else { return };
    let mut name = name.to_owned();
    if name != snake(&e.obj.name) && !used.insert(name.clone()) || RESERVED.contains(&name.as_str()) {
        name = format!("{name}_{:04x}_{}", e.obj.index, e.sub.sub);
        used.insert(name.clone());
    }
    let (src, lifetime) = if e.attr.contains(Attr::IN_ROM) { ("&ROM", "") } else { ("&self.image", "") };
    let _ = lifetime;
    let what = if e.obj.kind.has_subs() {
        format!("0x{:04X} sub {} {} / {}", e.obj.index, e.sub.sub, doc_escape(&e.obj.name), doc_escape(&e.sub.name))
    } else {
        format!("0x{:04X} {}", e.obj.index, doc_escape(&e.obj.name))
    };
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// {what} ({source}:{}, {})", e.sub.line, access_doc(e));
    let _ = writeln!(w, "    pub fn {name}(&self) -> {ty} {{");
    let _ = writeln!(w, "        {}", getter_expr(e.data_type, src, &e.offset.to_string(), e.len));
    let _ = writeln!(w, "    }}");
    if !e.attr.contains(Attr::IN_ROM) {
        let ret = if e.data_type.size().is_none() { " -> usize" } else { "" };
        let note = if e.data_type.size().is_none() {
            format!(" Cut to {} bytes; returns the number stored.", e.len)
        } else if matches!(e.data_type.size(), Some(3 | 5 | 6 | 7)) && rust_type(e.data_type) != Some("[u8; 6]") {
            format!(" Only the low {} bits are kept.", 8 * e.len)
        } else {
            String::new()
        };
        let _ = writeln!(w);
        let _ = writeln!(w, "    /// Sets {what}.{note}");
        let _ = writeln!(w, "    pub fn set_{name}(&mut self, v: {ty}){ret} {{");
        let _ = writeln!(w, "        {}", setter_stmt(e.data_type, &e.offset.to_string(), e.len));
        let _ = writeln!(w, "    }}");
    }
}

fn access_doc(e: &Placed<'_>) -> String {
    let mut s = format!("{} {}", e.data_type.name(), e.sub.access.as_str());
    if e.sub.pdo_mapping {
        s.push_str(", PDO-mappable");
    }
    if e.sub.node_id {
        s.push_str(", $NODEID-relative");
    }
    if e.sub.access == Access::Const {
        s.push_str(", in flash");
    }
    s
}

/// The value as the doc generator prints it.
pub fn show_value(s: &SubObject) -> String {
    let Some(t) = s.data_type else { return String::new() };
    let v = match t {
        DataType::VisibleString => format!("\"{}\"", String::from_utf8_lossy(&s.value)),
        DataType::Domain => String::new(),
        _ if t.size().is_none() || matches!(t, DataType::TimeOfDay | DataType::TimeDifference) => {
            s.value.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
        }
        _ => match Number::decode(t, &s.value) {
            Some(Number::Unsigned(v)) if v > 9 => format!("0x{v:X}"),
            Some(Number::Unsigned(v)) => v.to_string(),
            Some(Number::Signed(v)) => v.to_string(),
            Some(Number::Real(v)) => format!("{v}"),
            None => String::new(),
        },
    };
    if s.node_id { format!("$NODEID+{v}") } else { v }
}

#[cfg(test)]
mod tests;
