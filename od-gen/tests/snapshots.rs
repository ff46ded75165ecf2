//! Snapshot tests of the generated Rust module.
//!
//! For each of the five device EDS files in `firmware/eds/` and the
//! hand-written `fixtures/mini.eds` (every basic type 0x0001–0x001B, an ARRAY,
//! a RECORD, CompactSubObj, `$NODEID`, limits, `const` and PDO mappings),
//! `codegen::generate` must reproduce `snapshots/<name>.rs` byte for byte.
//! Run with `UPDATE_SNAPSHOTS=1` to rewrite the snapshots after an intended
//! change, then review the diff. Every snapshot must also be rustfmt-clean
//! under the workspace `rustfmt.toml`.

use std::path::{Path, PathBuf};
use std::process::Command;

use od_gen::model::{Access, ObjectKind};
use od_gen::{Options, codegen, load_path};

fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn snapshot_path(name: &str) -> PathBuf {
    manifest_dir().join("tests").join("snapshots").join(format!("{name}.rs"))
}

/// The EDS file of each snapshot.
const CASES: &[(&str, &str)] = &[
    ("ec5000", "../firmware/eds/ec5000.eds"),
    ("unitek-ds", "../firmware/eds/unitek-ds.eds"),
    ("sendix", "../firmware/eds/sendix.eds"),
    ("bmaxx4400", "../firmware/eds/bmaxx4400.eds"),
    ("agile", "../firmware/eds/agile.eds"),
    ("mini", "tests/fixtures/mini.eds"),
];

/// Generates the module as the firmware's `build.rs` does: strict, so the file
/// must be free of warnings too.
fn generate(eds_file: &str) -> String {
    let path = manifest_dir().join(eds_file);
    let (eds, d) = load_path(&path, Options { strict: true }).expect("EDS file is readable");
    assert!(d.items.is_empty(), "{eds_file} is not strict-clean:\n{d}");
    codegen::generate(&eds, &d.file).unwrap_or_else(|e| panic!("{eds_file}: {}", e.0))
}

fn check_snapshot(name: &str) {
    let &(_, eds_file) = CASES.iter().find(|c| c.0 == name).expect("a listed case");
    let actual = generate(eds_file);
    let path = snapshot_path(name);
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some_and(|v| v == "1") {
        // Write then rename, so a concurrent reader never sees half a file.
        let tmp = path.with_extension("rs.tmp");
        std::fs::write(&tmp, &actual).expect("snapshot directory is writable");
        std::fs::rename(&tmp, &path).expect("snapshot directory is writable");
        return;
    }
    let expected =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}; run with UPDATE_SNAPSHOTS=1 to create it", path.display()));
    if actual != expected {
        let line = actual
            .lines()
            .zip(expected.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| actual.lines().count().min(expected.lines().count()));
        panic!(
            "{name}: generated code differs from {} at line {}:\n  generated: {:?}\n  snapshot:  {:?}\nrun with UPDATE_SNAPSHOTS=1 to accept the change",
            path.display(),
            line + 1,
            actual.lines().nth(line).unwrap_or("<end of file>"),
            expected.lines().nth(line).unwrap_or("<end of file>"),
        );
    }
}

#[test]
fn snapshot_ec5000() {
    check_snapshot("ec5000");
}

#[test]
fn snapshot_unitek_ds() {
    check_snapshot("unitek-ds");
}

#[test]
fn snapshot_sendix() {
    check_snapshot("sendix");
}

#[test]
fn snapshot_bmaxx4400() {
    check_snapshot("bmaxx4400");
}

#[test]
fn snapshot_agile() {
    check_snapshot("agile");
}

#[test]
fn snapshot_mini() {
    check_snapshot("mini");
}

/// Every file in `snapshots/` belongs to a case, so a renamed or dropped EDS
/// leaves no stale snapshot behind.
#[test]
fn no_stale_snapshots() {
    let dir = manifest_dir().join("tests").join("snapshots");
    for entry in std::fs::read_dir(&dir).expect("snapshot directory exists") {
        let name = entry.expect("directory entry").file_name().to_string_lossy().into_owned();
        if name.ends_with(".rs.tmp") {
            continue;
        }
        let stem = name.strip_suffix(".rs").unwrap_or_else(|| panic!("{name}: not a snapshot"));
        assert!(CASES.iter().any(|c| c.0 == stem), "{name} has no case in CASES");
    }
}

#[test]
fn snapshots_are_rustfmt_clean() {
    let config = manifest_dir().join("..").join("rustfmt.toml");
    for (name, _) in CASES {
        let path = snapshot_path(name);
        let output = match Command::new("rustfmt").arg("--check").arg("--config-path").arg(&config).arg(&path).output() {
            Ok(output) => output,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                println!("note: rustfmt is not installed; snapshots were not checked for formatting");
                return;
            }
            Err(e) => panic!("running rustfmt: {e}"),
        };
        assert!(
            output.status.success(),
            "{} is not rustfmt-clean:\n{}{}",
            path.display(),
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
}

/// The mini fixture covers what its doc comment promises.
#[test]
fn mini_fixture_covers_every_feature() {
    let (eds, d) = load_path(&manifest_dir().join("tests/fixtures/mini.eds"), Options { strict: true }).expect("fixture is readable");
    assert!(d.items.is_empty(), "{d}");
    let types: std::collections::BTreeSet<u16> = eds.objects.values().flat_map(|o| o.subs.values()).map(|s| s.type_index).collect();
    for t in canopen_core::od::DataType::ALL {
        assert!(types.contains(&t.index()), "{} is not used", t.name());
    }
    let subs = || eds.objects.values().flat_map(|o| o.subs.values());
    assert!(eds.objects.values().any(|o| o.kind == ObjectKind::Array && o.compact_sub_obj.is_none()));
    assert!(eds.objects.values().any(|o| o.kind == ObjectKind::Record));
    assert!(eds.objects.values().any(|o| o.compact_sub_obj.is_some_and(|n| n > 0)));
    assert!(subs().any(|s| s.node_id));
    assert!(subs().any(|s| s.limits.is_some()));
    assert!(subs().any(|s| s.access == Access::Const));
    assert!(subs().any(|s| s.pdo_mapping));
    assert!(eds.objects.contains_key(&0x1600) && eds.objects.contains_key(&0x1A00));
    let code = generate("tests/fixtures/mini.eds");
    assert!(code.contains("Attr::NODE_ID.0"), "a $NODEID attribute");
    assert!(code.contains("Attr::IN_ROM.0"), "a const in flash");
    assert!(code.contains("Attr::MAP_TPDO.0") && code.contains("Attr::MAP_RPDO.0"), "PDO-mappable entries");
}
