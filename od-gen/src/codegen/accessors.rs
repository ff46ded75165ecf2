//! The typed accessors of `Ram`: a getter and (unless the entry is
//! `const`) a setter per entry, or one indexed pair for an ARRAY whose
//! elements share a type and sit back to back.

use std::collections::BTreeMap;
use std::fmt::Write;

use canopen_core::od::{Attr, DataType};

use super::emit::doc_escape;
use super::layout::{Layout, Placed};
use super::names::Taken;
use crate::model::{Access, Eds, Object, ObjectKind};

/// Whether entries 1..=n of an ARRAY share one type and sit back to back in RAM.
fn uniform_array<'a>(o: &Object, entries: &[&'a Placed<'a>]) -> Option<(&'a Placed<'a>, usize)> {
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

/// What an object gets: a getter and setter per entry, or for a uniform
/// ARRAY an indexed pair and sub-index 0's own.
enum Plan<'a> {
    Entries(Vec<&'a Placed<'a>>),
    Indexed { first: &'a Placed<'a>, n: usize, sub0: Option<&'a Placed<'a>> },
}

pub(super) fn accessors(w: &mut String, eds: &Eds, l: &Layout<'_>, object_names: &BTreeMap<u16, String>, source: &str) {
    let mut by_object: BTreeMap<u16, Vec<&Placed>> = BTreeMap::new();
    for e in &l.entries {
        // DOMAIN entries have no accessor (and take no name).
        if rust_type(e.data_type).is_some() {
            by_object.entry(e.obj.index).or_default().push(e);
        }
    }
    let plans: Vec<(u16, Plan)> = by_object
        .into_iter()
        .map(|(index, entries)| {
            let plan = match uniform_array(&eds.objects[&index], &entries) {
                Some((first, n)) => Plan::Indexed { first, n, sub0: entries.iter().copied().find(|e| e.sub.sub == 0) },
                None => Plan::Entries(entries),
            };
            (index, plan)
        })
        .collect();
    // Names (names.rs): the objects' own accessors first, then the sub-indices'.
    let mut taken = Taken::new();
    let mut names: BTreeMap<(u16, u8), String> = BTreeMap::new();
    for (index, plan) in &plans {
        let o = &eds.objects[index];
        match plan {
            Plan::Indexed { .. } => {
                names.insert((*index, 1), taken.object(&object_names[index], *index));
            }
            Plan::Entries(_) if !o.kind.has_subs() => {
                names.insert((*index, 0), taken.object(&object_names[index], *index));
            }
            Plan::Entries(_) => {}
        }
    }
    for (index, plan) in &plans {
        let o = &eds.objects[index];
        let subs: Vec<&Placed> = match plan {
            Plan::Indexed { sub0, .. } => sub0.iter().copied().collect(),
            Plan::Entries(entries) if o.kind.has_subs() => entries.clone(),
            Plan::Entries(_) => Vec::new(),
        };
        for e in subs {
            names.insert((*index, e.sub.sub), taken.sub(&object_names[index], o, e.sub));
        }
    }
    for (index, plan) in &plans {
        let o = &eds.objects[index];
        match plan {
            Plan::Indexed { first, n, sub0 } => {
                if let Some(s0) = sub0 {
                    one_accessor(w, s0, &names[&(*index, 0)], source);
                }
                indexed_accessors(w, o, first, *n, &names[&(*index, 1)], source);
            }
            Plan::Entries(entries) => {
                for e in entries {
                    one_accessor(w, e, &names[&(*index, e.sub.sub)], source);
                }
            }
        }
    }
}

/// The getter and setter of elements 1..=`n` of a uniform ARRAY.
fn indexed_accessors(w: &mut String, o: &Object, first: &Placed<'_>, n: usize, name: &str, source: &str) {
    let index = o.index;
    let ty = rust_type(first.data_type).unwrap_or("u8");
    let size = first.len;
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// 0x{index:04X} {} sub-index `i` (1..={n}) ({source}:{})", doc_escape(&o.name), o.line);
    let _ = writeln!(w, "    pub fn {name}(&self, i: u8) -> Option<{ty}> {{");
    let _ = writeln!(w, "        if !(1..={n}).contains(&i) {{\n            return None;\n        }}");
    let _ = writeln!(w, "        let off = {};", element_offset(first.offset, size));
    let _ = writeln!(w, "        Some({})", getter_expr(first.data_type, "&self.image", "off", size));
    let _ = writeln!(w, "    }}");
    let _ = writeln!(w);
    let _ = writeln!(w, "    /// Sets 0x{index:04X} {} sub-index `i` (1..={n}); false if `i` is out of range.", doc_escape(&o.name));
    let _ = writeln!(w, "    pub fn set_{name}(&mut self, i: u8, v: {ty}) -> bool {{");
    let _ = writeln!(w, "        if !(1..={n}).contains(&i) {{\n            return false;\n        }}");
    let _ = writeln!(w, "        let off = {};", element_offset(first.offset, size));
    let _ = writeln!(w, "        {}", setter_stmt(first.data_type, "off", size));
    let _ = writeln!(w, "        true");
    let _ = writeln!(w, "    }}");
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

fn one_accessor(w: &mut String, e: &Placed<'_>, name: &str, source: &str) {
    let Some(ty) = rust_type(e.data_type) else { return };
    let src = if e.attr.contains(Attr::IN_ROM) { "&ROM" } else { "&self.image" };
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
