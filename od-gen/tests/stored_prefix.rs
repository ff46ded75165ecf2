//! The RAM layout rule: the values a stored parameter set holds (writable
//! values in RAM but the commands and the error history, and the read-only
//! objects a device keeps, `Eds::kept`) come first, as one prefix of `stored_len` bytes; the rest follow. Checked
//! on the firmware's device files with the objects their build keeps.

use canopen_core::od::{Attr, Entry};
use od_gen::codegen::NEVER_STORED;
use od_gen::runtime::Tables;
use od_gen::{Options, load};
use std::path::Path;

/// Lays out `firmware/eds/<device>.eds` keeping `kept`; checks the rule and
/// returns the prefix length.
fn check(device: &str, kept: &[u16]) -> usize {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/eds").join(format!("{device}.eds"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (mut eds, diags) = load(device, &bytes, Options { strict: true });
    assert!(!diags.has_errors(), "{device}:\n{diags}");
    eds.kept = kept.to_vec();
    let t = Tables::new(&eds).unwrap_or_else(|e| panic!("{device}: {}", e.0));
    let ram: Vec<&Entry> = t.entries.iter().filter(|e| !e.attr.contains(Attr::IN_ROM) && e.len > 0).collect();
    let is_stored = |e: &Entry| !NEVER_STORED.contains(&{ e.index }) && (e.attr.contains(Attr::WRITE) || kept.contains(&{ e.index }));
    let end = |e: &Entry| usize::from(e.offset) + usize::from(e.len);
    for e in &ram {
        let inside = end(e) <= t.stored_len;
        assert_eq!(inside, is_stored(e), "{device} {:#06x}:{} at {}", { e.index }, { e.sub }, { e.offset });
    }
    let stored: usize = ram.iter().filter(|e| is_stored(e)).map(|e| usize::from(e.len)).sum();
    assert_eq!(stored, t.stored_len, "{device}: the prefix is the stored values, without gaps");
    stored
}

#[test]
fn the_stored_values_are_the_prefix_of_each_device_image() {
    for device in ["unitek-ds", "bmaxx4400", "agile"] {
        check(device, &[]);
    }
}

#[test]
fn kept_read_only_objects_join_the_prefix() {
    let (plain, kept) = (check("sendix", &[]), check("sendix", &[0x6508, 0x6509]));
    assert_eq!(kept, plain + 8, "the operating time and the preset offset, 4 bytes each");
    let (plain, kept) = (check("ec5000", &[]), check("ec5000", &[0x2200]));
    assert!(kept > plain, "the monitoring records");
}
