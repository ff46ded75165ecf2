//! The flash tables of the generated module: entries, limits, constants,
//! defaults, `$NODEID`-relative entries and names. Every row says which
//! object it belongs to (`// 0x1018:01 Identity object / Vendor-ID`), so a
//! reviewer checks a default or a limit without counting offsets. The
//! tables are laid out here, row by row, and marked `#[rustfmt::skip]`:
//! rustfmt would refill the byte rows around the comments.

use std::fmt::Write;

use canopen_core::od::{Attr, DataType, NO_LIMITS};

use super::emit::{attr_name, doc_escape};
use super::layout::{Layout, Placed};

/// Bytes per line of a long value.
const BYTES_PER_LINE: usize = 16;

/// The object of an entry, as a row's comment: `0x1018:01 Identity object /
/// Vendor-ID`, or `0x1000:00 Device type` for a VAR.
fn label(e: &Placed<'_>) -> String {
    let name = if e.obj.kind.has_subs() { format!("{} / {}", e.obj.name, e.sub.name) } else { e.obj.name.clone() };
    format!("0x{:04X}:{:02X} {}", e.obj.index, e.sub.sub, name.replace(['\t', '\r', '\n'], " "))
}

/// A new run costs its (zeros before, length) pair, 2 bytes: a gap of zeros
/// splits runs only when it is longer.
const RUN_COST: usize = 2;

/// The runs of `image` that the defaults keep, as (offset, length): the
/// bytes that are not zero, a gap of at most [`RUN_COST`] zeros bridged.
pub(crate) fn default_runs(image: &[u8]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (at, _) in image.iter().enumerate().filter(|(_, b)| **b != 0) {
        match runs.last_mut() {
            Some((off, len)) if at - (*off + *len) <= RUN_COST => *len = at + 1 - *off,
            _ => runs.push((at, 1)),
        }
    }
    runs
}

/// `runs` as the core's `Defaults::runs`: (zeros before, length) pairs of
/// bytes, a longer gap as runs of no bytes, a longer run as runs with no
/// gap.
pub(crate) fn run_pairs(runs: &[(usize, usize)]) -> Vec<(u8, u8)> {
    let mut pairs = Vec::new();
    let mut end = 0;
    for &(off, len) in runs {
        let mut gap = off - end;
        while gap > 255 {
            pairs.push((255, 0));
            gap -= 255;
        }
        let mut left = len;
        let mut first = gap as u8;
        while left > 0 {
            let n = left.min(255);
            pairs.push((first, n as u8));
            (first, left) = (0, left - n);
        }
        end = off + len;
    }
    pairs
}

/// `decl = [rows];`, one row per line with its comment; `[]` without rows.
fn table(w: &mut String, doc: Option<&str>, decl: &str, rows: &[(String, String)]) {
    if let Some(doc) = doc {
        let _ = writeln!(w, "/// {doc}");
    }
    if rows.is_empty() {
        let _ = writeln!(w, "{decl} = [];");
        let _ = writeln!(w);
        return;
    }
    let _ = writeln!(w, "#[rustfmt::skip]");
    let _ = writeln!(w, "{decl} = [");
    for (items, comment) in rows {
        let _ = writeln!(w, "    {items} // {comment}");
    }
    let _ = writeln!(w, "];");
    let _ = writeln!(w);
}

/// The bytes of one value as table items, a line break every
/// [`BYTES_PER_LINE`] (the row's comment follows the last line).
fn byte_items(bytes: &[u8]) -> String {
    let lines: Vec<String> =
        bytes.chunks(BYTES_PER_LINE).map(|c| c.iter().map(|b| format!("0x{b:02X},")).collect::<Vec<_>>().join(" ")).collect();
    lines.join("\n    ")
}

/// One row per entry that has bytes in `image` (the constants or the
/// defaults), each `len` bytes at its offset, in order.
fn value_rows<'a>(entries: impl Iterator<Item = &'a Placed<'a>>, image: &[u8]) -> Vec<(String, String)> {
    entries.filter(|e| e.len > 0).map(|e| (byte_items(image.get(e.offset..e.offset + e.len).unwrap_or_default()), label(e))).collect()
}

/// Writes the tables of `l`.
pub(super) fn tables(w: &mut String, l: &Layout<'_>) {
    let entries: Vec<(String, String)> = l
        .entries
        .iter()
        .map(|e| {
            let item = format!(
                "Entry::new(0x{:04X}, 0x{:02X}, DataType::{:?}, {}, {}, {}),",
                e.obj.index,
                e.sub.sub,
                e.data_type,
                attr_name(e.attr),
                e.len,
                e.offset
            );
            (item, label(e))
        })
        .collect();
    table(w, Some("Entry metadata, sorted by (index, sub-index)."), "static ENTRIES: [Entry; ENTRY_COUNT]", &entries);

    // Each entry's limits row, parallel to the entries; none at all in a
    // dictionary without limits (most have none: a byte an entry saved).
    let rows: Vec<(String, String)> = if l.limits.is_empty() {
        Vec::new()
    } else {
        l.entries
            .iter()
            .map(|e| (if e.limits == NO_LIMITS { "NO_LIMITS,".to_owned() } else { format!("{},", e.limits) }, label(e)))
            .collect()
    };
    table(w, None, &format!("static LIMIT_ROWS: [u8; {}]", rows.len()), &rows);

    let limits: Vec<(String, String)> = l
        .limits
        .iter()
        .enumerate()
        .map(|(i, (lo, hi))| {
            let users: Vec<&Placed> = l.entries.iter().filter(|e| usize::from(e.limits) == i).collect();
            let comment = match users.as_slice() {
                [] => "no entry".to_owned(),
                [one] => label(one),
                [first, more @ ..] => format!("{} and {} more", label(first), more.len()),
            };
            (format!("Limits {{ low: 0x{lo:X}, high: 0x{hi:X} }},"), comment)
        })
        .collect();
    table(w, None, &format!("static LIMITS: [Limits; {}]", l.limits.len()), &limits);

    // A DOMAIN has no bytes in either image.
    let in_rom = |e: &&Placed<'_>| e.attr.contains(Attr::IN_ROM) && e.data_type != DataType::Domain;
    let in_ram = |e: &&Placed<'_>| !e.attr.contains(Attr::IN_ROM) && e.data_type != DataType::Domain;
    table(w, None, "static ROM: [u8; ROM_SIZE]", &value_rows(l.entries.iter().filter(in_rom), &l.rom));
    // The RAM image is not in index order (the stored values come first): its rows go by offset.
    let mut ram: Vec<&Placed<'_>> = l.entries.iter().filter(in_ram).collect();
    ram.sort_by_key(|e| e.offset);
    // The defaults keep only the runs that are not zero; each row says which objects its run begins and ends in.
    let runs = default_runs(&l.ram);
    let object_at = |at: usize| ram.iter().find(|e| (e.offset..e.offset + e.len).contains(&at)).map(|e| label(e)).unwrap_or_default();
    let mut end = 0;
    let run_rows: Vec<(String, String)> = run_pairs(&runs)
        .iter()
        .map(|&(zeros, len)| {
            let off = end + usize::from(zeros);
            end = off + usize::from(len);
            let comment = match (object_at(off), object_at(end.max(1) - 1)) {
                _ if len == 0 => "zeros".to_owned(),
                (first, last) if first == last => first,
                (first, last) => format!("{first} .. {last}"),
            };
            (format!("({zeros}, {len}),"), comment)
        })
        .collect();
    table(w, None, &format!("static DEFAULT_RUNS: [(u8, u8); {}]", run_rows.len()), &run_rows);
    let byte_rows: Vec<(String, String)> =
        runs.iter().map(|&(off, len)| (byte_items(l.ram.get(off..off + len).unwrap_or_default()), format!("run at {off}"))).collect();
    let total: usize = runs.iter().map(|r| r.1).sum();
    table(w, None, &format!("static DEFAULTS: [u8; {total}]"), &byte_rows);

    let relative: Vec<(String, String)> =
        l.node_id_relative.iter().map(|&i| (format!("{i},"), l.entries.get(i).map(label).unwrap_or_default())).collect();
    table(w, None, &format!("static NODE_ID_RELATIVE: [u16; {}]", relative.len()), &relative);

    let names: Vec<(String, String)> = l
        .entries
        .iter()
        .map(|e| (format!("\"{}\",", doc_escape(&e.sub.name).replace('\t', "\\t")), format!("0x{:04X}:{:02X}", e.obj.index, e.sub.sub)))
        .collect();
    table(
        w,
        Some("Entry names (`ParameterName`), parallel to the entry table. Left out of an image that never reads them."),
        "pub static NAMES: [&str; ENTRY_COUNT]",
        &names,
    );
}
