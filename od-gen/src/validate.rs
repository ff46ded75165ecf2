//! Consistency rules over a parsed dictionary (CiA 306 §4, CiA 301 §7.4).
//!
//! Errors mark a dictionary that cannot be built as written; warnings mark
//! what real tools write and a tolerant reader accepts. `strict` (used for the
//! project's own device files) turns every warning into an error.

use std::collections::BTreeMap;

use canopen_core::od::{DataType, Number};

use crate::diag::{Diagnostics, Severity};
use crate::model::{Eds, ObjectKind, SubObject};

/// How strict the rules are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Treat every warning as an error (a complete device, as we ship them).
    pub strict: bool,
}

/// Applies every rule; marks objects that cannot become code as opaque.
pub fn validate(eds: &mut Eds, d: &mut Diagnostics, opts: Options) {
    file_info(eds, d);
    mandatory(eds, d);
    object_lists(eds, d);
    objects(eds, d);
    pdo_mappings(eds, d);
    pdo_counts(eds, d);
    default_sdo_server(eds, d);
    cob_ids(eds, d);
    // What the generated tables can address (offsets and sizes are u16): a
    // file check passes must also generate.
    if !d.has_errors()
        && let Err(e) = crate::codegen::ram_size(eds)
    {
        d.error(0, e.0);
    }
    if opts.strict {
        for item in &mut d.items {
            item.severity = Severity::Error;
        }
    }
}

fn file_info(eds: &Eds, d: &mut Diagnostics) {
    let Some(s) = &eds.file_info else {
        d.warn(0, "no [FileInfo] section");
        return;
    };
    for key in ["CreationDate", "ModificationDate"] {
        if let Some(p) = s.get(key) {
            let ok =
                p.value.len() == 10 && p.value.char_indices().all(|(i, c)| if i == 2 || i == 5 { c == '-' } else { c.is_ascii_digit() });
            let year: u32 = p.value.get(6..).and_then(|y| y.parse().ok()).unwrap_or(0);
            if !ok {
                d.warn(p.line, format!("{key} `{}` is not mm-dd-yyyy", p.value));
            } else if year < 1980 {
                d.warn(p.line, format!("{key} `{}` is a placeholder date", p.value));
            }
        }
    }
    for key in ["CreationTime", "ModificationTime"] {
        if let Some(p) = s.get(key) {
            let v = p.value.to_ascii_uppercase();
            let ok = v.len() == 7
                && (v.ends_with("AM") || v.ends_with("PM"))
                && v.char_indices().take(5).all(|(i, c)| if i == 2 { c == ':' } else { c.is_ascii_digit() });
            if !ok {
                d.warn(p.line, format!("{key} `{}` is not hh:mmAM/PM", p.value));
            }
        }
    }
    for key in ["FileVersion", "FileRevision"] {
        if let Some(p) = s.get(key) {
            if !p.value.chars().all(|c| c.is_ascii_digit()) || p.value.is_empty() {
                d.warn(p.line, format!("{key} `{}` is not a decimal number", p.value));
            }
        } else {
            d.warn(s.line, format!("[FileInfo] has no {key}"));
        }
    }
    if let Some(p) = s.get("EDSVersion")
        && !matches!(p.value.as_str(), "4.0" | "4" | "4.00")
    {
        d.warn(p.line, format!("EDSVersion `{}` is not a CiA 306 version; read as 4.0", p.value));
    }
}

fn mandatory(eds: &Eds, d: &mut Diagnostics) {
    // An empty file, or one that is not an EDS (a README, a binary), has no
    // dictionary to build: "valid" would let gen write an empty one.
    if eds.objects.is_empty() && !d.has_errors() {
        d.error(0, "no object sections ([1000], [1018], ...): not an EDS or DCF with a dictionary");
        return;
    }
    for index in [0x1000u16, 0x1001, 0x1018] {
        if !eds.objects.contains_key(&index) {
            d.warn(0, format!("mandatory object 0x{index:04X} is missing (CiA 301 §7.5.1)"));
        }
    }
    if let Some(o) = eds.objects.get(&0x1018)
        && !o.subs.contains_key(&1)
    {
        d.warn(o.line, "0x1018 has no vendor-ID (sub-index 1), which CiA 301 makes mandatory");
    }
}

fn object_lists(eds: &Eds, d: &mut Diagnostics) {
    if !eds.lists.present {
        d.warn(0, "no [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects] section");
    }
    let listed: Vec<u16> = eds.lists.mandatory.iter().chain(&eds.lists.optional).chain(&eds.lists.manufacturer).copied().collect();
    for index in &listed {
        if !eds.objects.contains_key(index) {
            d.warn(eds.lists.lines.get(index).copied().unwrap_or(0), format!("0x{index:04X} is in an object list but has no section"));
        }
    }
    let unlisted: Vec<String> = eds
        .objects
        .values()
        .filter(|o| !o.synthesized && !listed.contains(&o.index) && o.index >= 0x1000)
        .map(|o| format!("0x{:04X}", o.index))
        .collect();
    if !unlisted.is_empty() {
        let shown: Vec<&str> = unlisted.iter().take(8).map(String::as_str).collect();
        let more = if unlisted.len() > 8 { format!(" and {} more", unlisted.len() - 8) } else { String::new() };
        d.warn(0, format!("{} objects are in no object list: {}{more}", unlisted.len(), shown.join(", ")));
    }
}

fn objects(eds: &mut Eds, d: &mut Diagnostics) {
    let defined_types: Vec<u16> =
        eds.objects.values().filter(|o| matches!(o.kind, ObjectKind::DefType | ObjectKind::DefStruct)).map(|o| o.index).collect();
    for o in eds.objects.values_mut() {
        if matches!(o.kind, ObjectKind::Null | ObjectKind::DefType | ObjectKind::DefStruct) || o.index < 0x1000 {
            // Type definitions describe types; they hold no application value.
            o.opaque = true;
            continue;
        }
        if o.kind.has_subs() && o.compact_sub_obj.is_none_or(|n| n == 0) {
            if o.subs.is_empty() {
                d.warn(
                    o.line,
                    format!("{} 0x{:04X} has no SubNumber, no CompactSubObj and no sub-objects; it is left out", o.kind.name(), o.index),
                );
                o.opaque = true;
                continue;
            }
            if let Some(n) = o.sub_number
                && usize::from(n) != o.subs.len()
            {
                d.warn(o.sub_number_line, format!("[{:04X}] SubNumber {n} but {} sub-objects", o.index, o.subs.len()));
            }
            let highest = o.subs.keys().next_back().copied().unwrap_or(0);
            match o.subs.get(&0) {
                None => d.warn(o.line, format!("{} 0x{:04X} has no sub-index 0", o.kind.name(), o.index)),
                Some(s0) => {
                    if s0.data_type != Some(DataType::Unsigned8) {
                        d.warn(s0.type_line, format!("sub-index 0 of 0x{:04X} is {}, not UNSIGNED8", o.index, type_name(s0)));
                    } else if let Some(v) = s0.unsigned() {
                        let counts_use = o.index == 0x1003 || (0x1600..=0x17FF).contains(&o.index) || (0x1A00..=0x1BFF).contains(&o.index);
                        if (counts_use && v > u64::from(highest)) || (!counts_use && v != u64::from(highest)) {
                            let line = s0.parameter_value.as_ref().or(s0.default.as_ref()).map_or(s0.line, |t| t.line);
                            d.warn(line, format!("sub-index 0 of 0x{:04X} is {v} but the highest sub-index is 0x{highest:02X}", o.index));
                        }
                    }
                }
            }
            if o.kind == ObjectKind::Array {
                let mut types = o.subs.values().filter(|s| s.sub > 0).map(|s| s.type_index);
                if let Some(first) = types.next()
                    && types.any(|t| t != first)
                {
                    d.warn(o.line, format!("ARRAY 0x{:04X} mixes element DataTypes; treated as a RECORD", o.index));
                }
            }
        }
        let mut opaque_reason = None;
        let mut opaque_line = o.line;
        for s in o.subs.values() {
            if s.data_type.is_some() {
                continue;
            }
            let t = s.type_index;
            opaque_line = s.type_line;
            if (0x20..=0x25F).contains(&t) && !defined_types.contains(&t) {
                opaque_reason = Some(format!(
                    "DataType 0x{t:04X} of 0x{:04X} is a complex or manufacturer type the file never defines; the object is left out",
                    o.index
                ));
            } else if defined_types.contains(&t) {
                opaque_reason = Some(format!(
                    "DataType 0x{t:04X} of 0x{:04X} is a file-defined type, which the generator does not lay out; the object is left out",
                    o.index
                ));
            } else {
                d.error(s.type_line, format!("unknown DataType 0x{t:04X}"));
            }
        }
        if let Some(reason) = opaque_reason {
            d.warn(opaque_line, reason);
            o.opaque = true;
        }
        for s in o.subs.values() {
            entry(o.index, s, o.opaque, d);
        }
    }
}

fn type_name(s: &SubObject) -> String {
    s.data_type.map_or_else(|| format!("DataType 0x{:04X}", s.type_index), |t| t.name().to_owned())
}

fn entry(index: u16, s: &SubObject, opaque: bool, d: &mut Diagnostics) {
    let sev = if opaque { Severity::Warning } else { Severity::Error };
    let text = |t: &Option<crate::model::Text>| t.as_ref().map_or(String::new(), |t| t.text.clone());
    // A dictionary entry's length is one byte (canopen-core's `Entry`).
    if s.size() > usize::from(u8::MAX) {
        let line = s.parameter_value.as_ref().or(s.default.as_ref()).map_or(s.line, |t| t.line);
        d.push(
            sev,
            line,
            format!("{} of {} bytes is longer than the 255 an entry holds (0x{index:04X} sub {})", type_name(s), s.size(), s.sub),
        );
    }
    let limit_line = s.high.as_ref().or(s.low.as_ref()).map_or(s.line, |t| t.line);
    match s.limits {
        Some((l, h)) if less(h, l) => {
            d.push(
                sev,
                limit_line,
                format!("HighLimit {} is below LowLimit {} (0x{index:04X} sub {})", text(&s.high), text(&s.low), s.sub),
            );
        }
        Some((l, h)) => {
            let given = s.parameter_value.as_ref().or(s.default.as_ref()).is_some_and(|v| !v.text.is_empty());
            let bound = |t: &Option<crate::model::Text>, key: &str| t.as_ref().map_or(format!("no {key}"), |t| format!("{key} {}", t.text));
            if let Some(v) = s.data_type.and_then(|t| Number::decode(t, &s.value)).filter(|_| !s.node_id && !given)
                && (less(v, l) || less(h, v))
            {
                // Vendor files leave measured values without a default (python-canopen's
                // e35.eds: a frequency 1000..80000); the node starts them at zero.
                d.warn(
                    s.line,
                    format!(
                        "0x{index:04X} sub {} has no default and starts at 0, outside {}..{}",
                        s.sub,
                        bound(&s.low, "LowLimit"),
                        bound(&s.high, "HighLimit")
                    ),
                );
            }
            if let Some(v) = s.data_type.and_then(|t| Number::decode(t, &s.value)).filter(|_| !s.node_id && given)
                && (less(v, l) || less(h, v))
            {
                let value = s.parameter_value.as_ref().or(s.default.as_ref());
                let line = value.map_or(s.line, |t| t.line);
                // A single limit is enforced with the type's own range as the other bound.
                d.push(
                    sev,
                    line,
                    format!(
                        "value `{}` is outside {}..{} (0x{index:04X} sub {})",
                        text(&value.cloned()),
                        bound(&s.low, "LowLimit"),
                        bound(&s.high, "HighLimit"),
                        s.sub
                    ),
                );
            }
        }
        None if opaque => {
            if let (Some(lo), Some(hi)) = (&s.low, &s.high)
                && let (Ok(l), Ok(h)) = (crate::value::parse_int(&lo.text), crate::value::parse_int(&hi.text))
                && h.value < l.value
            {
                d.warn(hi.line, format!("HighLimit {} is below LowLimit {}", hi.text, lo.text));
            }
        }
        None => {}
    }
    if s.node_id && s.access == crate::model::Access::Const {
        d.warn(s.line, format!("const 0x{index:04X} sub {} depends on $NODEID; it is kept in RAM like ro", s.sub));
    }
}

fn less(a: Number, b: Number) -> bool {
    match (a, b) {
        (Number::Signed(a), Number::Signed(b)) => a < b,
        (Number::Unsigned(a), Number::Unsigned(b)) => a < b,
        (Number::Real(a), Number::Real(b)) => a < b,
        _ => false,
    }
}

/// CiA 301 §7.4.8.2: each mapping entry names an existing, mappable object of
/// the mapped length, and a PDO carries at most 64 bits. Real files break
/// these rules (lely maps 28 of 32 bits); the PDO service refuses such a
/// mapping when the PDO is enabled, so here they are warnings.
fn pdo_mappings(eds: &Eds, d: &mut Diagnostics) {
    for o in eds.objects.values().filter(|o| !o.opaque) {
        let rpdo = (0x1600..=0x17FF).contains(&o.index);
        let tpdo = (0x1A00..=0x1BFF).contains(&o.index);
        if !rpdo && !tpdo {
            continue;
        }
        let Some(count) = o.subs.get(&0).and_then(SubObject::unsigned) else { continue };
        let mut bits = 0u64;
        for k in 1..=count.min(0xFF) as u8 {
            let Some(s) = o.subs.get(&k) else {
                d.warn(o.line, format!("0x{:04X} maps {count} objects but has no sub-index {k}", o.index));
                continue;
            };
            let line = s.parameter_value.as_ref().or(s.default.as_ref()).map_or(s.line, |t| t.line);
            let Some(m) = s.unsigned() else { continue };
            let (index, sub, len) = ((m >> 16) as u16, (m >> 8) as u8, (m & 0xFF));
            bits += len;
            if (0x0001..=0x0007).contains(&index) {
                if eds.device.dummy_usage & (1 << index) == 0 {
                    d.warn(line, format!("0x{:04X} sub {k} maps dummy type 0x{index:04X}, which [DummyUsage] does not enable", o.index));
                }
                continue;
            }
            let Some(target) = eds.sub(index, sub) else {
                d.warn(line, format!("0x{:04X} sub {k} maps 0x{index:04X} sub {sub}, which does not exist", o.index));
                continue;
            };
            if eds.objects.get(&index).is_some_and(|t| t.opaque) {
                d.warn(line, format!("0x{:04X} sub {k} maps 0x{index:04X}, which is left out", o.index));
                continue;
            }
            let attr = target.access.attr(true);
            let direction_ok =
                if rpdo { attr.contains(canopen_core::od::Attr::MAP_RPDO) } else { attr.contains(canopen_core::od::Attr::MAP_TPDO) };
            if !target.pdo_mapping {
                d.warn(line, format!("0x{:04X} sub {k} maps 0x{index:04X} sub {sub}, which has PDOMapping=0", o.index));
            } else if !direction_ok {
                d.warn(
                    line,
                    format!(
                        "0x{:04X} sub {k} maps 0x{index:04X} sub {sub} ({}) into a{}",
                        o.index,
                        target.access.as_str(),
                        if rpdo { "n RPDO" } else { " TPDO" }
                    ),
                );
            }
            if let Some(size) = target.data_type.and_then(DataType::size)
                && len != 8 * size as u64
            {
                d.warn(line, format!("0x{:04X} sub {k} maps 0x{index:04X} sub {sub} with {len} bits; it has {}", o.index, 8 * size));
            }
        }
        if bits > 64 {
            d.warn(o.line, format!("0x{:04X} maps {bits} bits; a PDO carries at most 64", o.index));
        }
    }
}

fn pdo_counts(eds: &Eds, d: &mut Diagnostics) {
    let Some(info) = &eds.device_info else { return };
    for (key, range, given) in
        [("NrOfRXPDO", 0x1600..=0x17FFu16, eds.device.nr_rx_pdo), ("NrOfTXPDO", 0x1A00..=0x1BFF, eds.device.nr_tx_pdo)]
    {
        let have = eds.objects.range(range).count();
        if have != usize::from(given) {
            let line = info.get(key).map_or(info.line, |p| p.line);
            d.warn(line, format!("{key}={given} but the file has {have} mapping objects"));
        }
    }
}

/// The default SDO server's COB-IDs are 0x600 + node-ID and 0x580 + node-ID
/// whatever the node-id (CiA 301 §7.3.5, the pre-defined connection set;
/// 0x1200 only shows them). Tools such as CanFestival's objdictgen write
/// them for the node-id they had, `1600` for node 64: a node built from
/// that file with any other node-id would answer no SDO. Such a value is
/// read as `0x600+$NODEID` (`0x580+$NODEID`), with a warning unless the
/// DCF configures that node-id.
fn default_sdo_server(eds: &mut Eds, d: &mut Diagnostics) {
    let configured = eds.node_id;
    let Some(server) = eds.objects.get_mut(&0x1200) else { return };
    for (sub, base, direction) in [(1u8, 0x600u64, "client -> server"), (2, 0x580, "server -> client")] {
        let Some(s) = server.subs.get_mut(&sub).filter(|s| !s.node_id) else { continue };
        let Some(node) = s.unsigned().and_then(|v| v.checked_sub(base)).filter(|n| (1..=127).contains(n)) else { continue };
        let len = s.value.len().min(8);
        s.value = base.to_le_bytes()[..len].to_vec();
        s.node_id = true;
        if configured != Some(node as u8) {
            let line = s.parameter_value.as_ref().or(s.default.as_ref()).map_or(s.line, |t| t.line);
            d.warn(
                line,
                format!(
                    "0x1200:{sub:02X} ({direction}) is 0x{:03X}, the COB-ID of node {node}; the default SDO server's follows the node-id: read as 0x{base:03X}+$NODEID",
                    base + node
                ),
            );
        }
    }
}

/// Default COB-IDs of the services this node produces or consumes must not
/// collide (CiA 301 §7.3.5). Identical expressions always collide; a fixed
/// identifier against a `$NODEID`-relative one collides only for some node-ids,
/// which is a warning unless the DCF configures that node-id.
fn cob_ids(eds: &Eds, d: &mut Diagnostics) {
    let mut ids: Vec<(String, u32, bool, usize)> = vec![("NMT".into(), 0, false, 0), ("heartbeat".into(), 0x700, true, 0)];
    let mut add = |what: String, s: Option<&SubObject>| {
        let Some(s) = s else { return };
        let Some(v) = s.unsigned() else { return };
        let v = v as u32;
        if v & 0x8000_0000 != 0 || v & 0x2000_0000 != 0 {
            return;
        }
        let line = s.parameter_value.as_ref().or(s.default.as_ref()).map_or(s.line, |t| t.line);
        ids.push((what, v & 0x7FF, s.node_id, line));
    };
    add("SYNC".into(), eds.sub(0x1005, 0));
    add("TIME".into(), eds.sub(0x1012, 0));
    add("EMCY".into(), eds.sub(0x1014, 0));
    for (i, o) in eds.objects.range(0x1200..=0x127F) {
        add(format!("SDO server {} receive", i - 0x11FF), o.subs.get(&1));
        add(format!("SDO server {} transmit", i - 0x11FF), o.subs.get(&2));
    }
    for (i, o) in eds.objects.range(0x1400..=0x15FF) {
        add(format!("RPDO{}", i - 0x13FF), o.subs.get(&1));
    }
    for (i, o) in eds.objects.range(0x1800..=0x19FF) {
        add(format!("TPDO{}", i - 0x17FF), o.subs.get(&1));
    }
    if eds.device.lss_supported {
        ids.push(("LSS master".into(), 0x7E5, false, 0));
        ids.push(("LSS slave".into(), 0x7E4, false, 0));
    }
    let mut reported: BTreeMap<(usize, usize), ()> = BTreeMap::new();
    for (a, x) in ids.iter().enumerate() {
        for (b, y) in ids.iter().enumerate().skip(a + 1) {
            let (what_a, id_a, rel_a, _) = x;
            let (what_b, id_b, rel_b, line_b) = y;
            let line = if *line_b == 0 { x.3 } else { *line_b };
            if rel_a == rel_b {
                if id_a == id_b && reported.insert((a, b), ()).is_none() {
                    d.error(line, format!("{what_b} COB-ID 0x{id_b:03X} collides with {what_a}"));
                }
                continue;
            }
            let (fixed, base) = if *rel_a { (*id_b, *id_a) } else { (*id_a, *id_b) };
            let Some(node) = fixed.checked_sub(base).filter(|n| (1..=127).contains(n)) else { continue };
            let msg = format!("{what_b} and {what_a} share COB-ID 0x{fixed:03X} when the node-id is {node}");
            if eds.node_id == Some(node as u8) {
                d.error(line, msg);
            } else if eds.node_id.is_none() {
                d.warn(line, msg);
            }
        }
    }
}

#[cfg(test)]
mod tests;
