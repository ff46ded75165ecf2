//! `Dictionary::find` on the tables od-gen lays out for every device EDS and
//! every valid corpus file: for each object present and every sub-index
//! 0..=255 (and for indices around each object), the entry or the abort code
//! a scan of the whole table gives (0x06020000 no object, 0x06090011 no
//! sub-index). `find` searches the object by index, then tries the
//! sub-index at its position; records with gaps in their sub-indices
//! (0x1003, the PDO mappings of some files) are where that must fall back.

use canopen_core::abort::AbortCode;
use canopen_core::od::Entry;
use od_gen::runtime::Tables;
use od_gen::{Options, load};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// What a scan of the whole table answers, from the table's (index, sub) map.
fn scan(all: &BTreeMap<(u16, u8), Entry>, objects: &BTreeSet<u16>, index: u16, sub: u8) -> Result<Entry, AbortCode> {
    match all.get(&(index, sub)) {
        Some(e) => Ok(*e),
        None if objects.contains(&index) => Err(AbortCode::NoSubIndex),
        None => Err(AbortCode::NoObject),
    }
}

fn check_file(path: &Path) -> usize {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let name = path.file_name().and_then(|n| n.to_str()).expect("file name");
    let (eds, diags) = load(name, &bytes, Options::default());
    assert!(!diags.has_errors(), "{name}:\n{diags}");
    let dict = Tables::new(&eds).unwrap_or_else(|e| panic!("{name}: {}", e.0)).leak();
    let all: BTreeMap<(u16, u8), Entry> = dict.entries.iter().map(|e| ((e.index, e.sub), *e)).collect();
    let objects: BTreeSet<u16> = dict.entries.iter().map(|e| e.index).collect();
    for &index in &objects {
        for probe in [index.wrapping_sub(1), index, index.wrapping_add(1)] {
            for sub in 0..=255u8 {
                assert_eq!(dict.find(probe, sub).copied(), scan(&all, &objects, probe, sub), "{name}: {probe:#06x} sub {sub}");
            }
        }
    }
    let mut gaps = 0;
    for e in dict.entries {
        let index = e.index;
        // A record whose sub-index is not its position in the record.
        let first = dict.entries.iter().position(|f| f.index == index).expect("present");
        let sub = e.sub;
        if dict.entries.get(first + usize::from(sub)).is_none_or(|f| f.index != index || f.sub != sub) {
            gaps += 1;
        }
    }
    gaps
}

#[test]
fn find_answers_as_a_scan_of_the_table() {
    let mut files: Vec<PathBuf> = ["ec5000", "unitek-ds", "sendix", "bmaxx4400", "agile"]
        .iter()
        .map(|d| workspace().join("firmware/eds").join(format!("{d}.eds")))
        .collect();
    let dir = workspace().join("tests/eds-corpus");
    let manifest = std::fs::read_to_string(dir.join("MANIFEST.md")).expect("manifest is readable");
    files.extend(manifest.lines().filter(|l| l.starts_with("| `")).filter_map(|l| {
        let cells: Vec<&str> = l.split('|').map(str::trim).collect();
        cells[6].starts_with("valid").then(|| dir.join(cells[1].trim_matches('`')))
    }));
    assert_eq!(files.len(), 28);
    let gaps: usize = files.iter().map(|f| check_file(f)).sum();
    // The fallback along the record is exercised, not only the direct hit.
    assert!(gaps > 0, "no record with a gap in its sub-indices");
}
