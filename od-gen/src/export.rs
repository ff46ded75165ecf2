//! A normalised EDS: every object written out in full (CompactSubObj and
//! CompactPDO expanded), values in canonical number forms, object lists
//! rebuilt. Parsing the export gives the same dictionary.

use std::fmt::Write;

use canopen_core::od::{DataType, Number};

use crate::lexer::Section;
use crate::model::{Eds, ObjectKind, SubObject};

/// Writes `eds` as EDS text (LF line ends, UTF-8).
pub fn export(eds: &Eds) -> String {
    let mut out = String::new();
    if let Some(s) = &eds.file_info {
        section(&mut out, s);
    }
    if let Some(s) = &eds.device_info {
        section(&mut out, s);
    }
    let _ = writeln!(out, "[DummyUsage]");
    // Dummy0001..0007 always, higher types only when set (lely lists up to Dummy001B).
    for t in (1..=0x1Fu32).filter(|&t| t <= 7 || eds.device.dummy_usage & (1 << t) != 0) {
        let _ = writeln!(out, "Dummy{t:04X}={}", u8::from(eds.device.dummy_usage & (1 << t) != 0));
    }
    let _ = writeln!(out);
    if !eds.comments.is_empty() {
        let _ = writeln!(out, "[Comments]\nLines={}", eds.comments.len());
        for (i, c) in eds.comments.iter().enumerate() {
            let _ = writeln!(out, "Line{}={c}", i + 1);
        }
        let _ = writeln!(out);
    }
    let mandatory: Vec<u16> = [0x1000u16, 0x1001, 0x1018].into_iter().filter(|i| eds.objects.contains_key(i)).collect();
    let optional: Vec<u16> =
        eds.objects.keys().copied().filter(|&i| !mandatory.contains(&i) && ((0x1000..0x2000).contains(&i) || i >= 0x6000)).collect();
    let manufacturer: Vec<u16> = eds.objects.keys().copied().filter(|i| (0x2000..0x6000).contains(i)).collect();
    for (name, list) in [("MandatoryObjects", &mandatory), ("OptionalObjects", &optional), ("ManufacturerObjects", &manufacturer)] {
        let _ = writeln!(out, "[{name}]\nSupportedObjects={}", list.len());
        for (n, i) in list.iter().enumerate() {
            let _ = writeln!(out, "{}=0x{i:04X}", n + 1);
        }
        let _ = writeln!(out);
    }
    for o in eds.objects.values() {
        let _ = writeln!(out, "[{:04X}]", o.index);
        let _ = writeln!(out, "ParameterName={}", o.name);
        if let Some(d) = &o.denotation {
            let _ = writeln!(out, "Denotation={d}");
        }
        let _ = writeln!(out, "ObjectType=0x{:X}", o.kind.code());
        if o.kind.has_subs() {
            if let Some(n) = o.sub_number.filter(|_| o.subs.is_empty()) {
                let _ = writeln!(out, "SubNumber={n}");
            } else {
                let _ = writeln!(out, "SubNumber={}", o.subs.len());
            }
            let _ = writeln!(out);
            for s in o.subs.values() {
                let _ = writeln!(out, "[{:04X}sub{:X}]", o.index, s.sub);
                let _ = writeln!(out, "ParameterName={}", s.name);
                let _ = writeln!(out, "ObjectType=0x7");
                entry_keys(&mut out, s, o.opaque);
                let _ = writeln!(out);
            }
        } else {
            if let Some(s) = o.subs.get(&0) {
                entry_keys(&mut out, s, o.opaque);
            }
            let _ = writeln!(out);
        }
        if !o.links.is_empty() && o.kind != ObjectKind::Null {
            let _ = writeln!(out, "[{:04X}ObjectLinks]\nObjectLinks={}", o.index, o.links.len());
            for (n, l) in o.links.iter().enumerate() {
                let _ = writeln!(out, "{}=0x{l:04X}", n + 1);
            }
            let _ = writeln!(out);
        }
    }
    if let Some(s) = &eds.commissioning {
        section(&mut out, s);
    }
    for s in &eds.other_sections {
        section(&mut out, s);
    }
    out
}

fn section(out: &mut String, s: &Section) {
    let _ = writeln!(out, "[{}]", s.name);
    for p in &s.pairs {
        let _ = writeln!(out, "{}={}", p.key, p.value);
    }
    let _ = writeln!(out);
}

fn entry_keys(out: &mut String, s: &SubObject, opaque: bool) {
    let _ = writeln!(out, "DataType=0x{:04X}", s.type_index);
    let _ = writeln!(out, "AccessType={}", s.access.as_str());
    // Only a value the file gave is written: an entry without one must not gain a default.
    let given = s.parameter_value.as_ref().or(s.default.as_ref()).is_some_and(|v| !v.text.is_empty());
    let canonical = s.data_type.filter(|_| !opaque && given).map(|t| canonical(t, s));
    match (&s.parameter_value, canonical) {
        (Some(_), Some(v)) => {
            // An empty ParameterValue reads as none and the default would win, so then it goes too.
            if let Some(d) = s.default.as_ref().filter(|_| !v.is_empty()) {
                let _ = writeln!(out, "DefaultValue={}", d.text);
            }
            let _ = writeln!(out, "ParameterValue={v}");
        }
        (None, Some(v)) => {
            let _ = writeln!(out, "DefaultValue={v}");
        }
        (pv, None) => {
            if let Some(d) = &s.default {
                let _ = writeln!(out, "DefaultValue={}", d.text);
            }
            if let Some(p) = pv {
                let _ = writeln!(out, "ParameterValue={}", p.text);
            }
        }
    }
    if let Some(l) = &s.low {
        let _ = writeln!(out, "LowLimit={}", l.text);
    }
    if let Some(h) = &s.high {
        let _ = writeln!(out, "HighLimit={}", h.text);
    }
    let _ = writeln!(out, "PDOMapping={}", u8::from(s.pdo_mapping));
    if s.obj_flags != 0 {
        let _ = writeln!(out, "ObjFlags=0x{:X}", s.obj_flags);
    }
    if let Some(f) = &s.upload_file {
        let _ = writeln!(out, "UploadFile={f}");
    }
    if let Some(f) = &s.download_file {
        let _ = writeln!(out, "DownloadFile={f}");
    }
}

/// The value in a form the reader parses back to the same bytes.
fn canonical(t: DataType, s: &SubObject) -> String {
    let hex = |b: &[u8]| b.iter().map(|x| format!("{x:02X}")).collect::<String>();
    let v = match t {
        DataType::VisibleString => quote(String::from_utf8_lossy(&s.value).into_owned()),
        DataType::UnicodeString => {
            let units: Vec<u16> = s.value.chunks(2).map(|c| u16::from_le_bytes([c[0], *c.get(1).unwrap_or(&0)])).collect();
            quote(String::from_utf16_lossy(&units))
        }
        DataType::OctetString | DataType::Domain => hex(&s.value),
        DataType::TimeOfDay | DataType::TimeDifference => {
            let mut b = [0u8; 6];
            let n = s.value.len().min(6);
            b[..n].copy_from_slice(&s.value[..n]);
            format!("{} {}", u16::from_le_bytes([b[4], b[5]]), u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        }
        _ => match Number::decode(t, &s.value) {
            Some(Number::Unsigned(v)) => format!("0x{v:X}"),
            Some(Number::Signed(v)) => v.to_string(),
            Some(Number::Real(v)) if v.is_finite() && t == DataType::Real32 => format!("{:?}", v as f32),
            Some(Number::Real(v)) if v.is_finite() => format!("{v:?}"),
            // NaN and infinities only survive as bit patterns.
            Some(Number::Real(_)) => format!("0x{}", hex(&s.value.iter().rev().copied().collect::<Vec<_>>())),
            None => String::new(),
        },
    };
    match v.strip_prefix('-') {
        // `$NODEID+-5` is no number; `$NODEID-5` is.
        Some(magnitude) if s.node_id => format!("$NODEID-{magnitude}"),
        _ if s.node_id => format!("$NODEID+{v}"),
        _ => v,
    }
}

/// A string the reader would change (it trims the line and drops one pair of
/// enclosing quotes) is written in quotes, which the reader drops again.
fn quote(s: String) -> String {
    if s.starts_with(|c: char| c.is_whitespace() || c == '"') || s.ends_with(|c: char| c.is_whitespace() || c == '"') {
        format!("\"{s}\"")
    } else {
        s
    }
}
