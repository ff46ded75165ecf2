//! `HAS_LIMITS` says whether the generated limits table has an entry: a
//! node on a dictionary without limits leaves the downloads' limit check
//! out (`ObjectDictionary::HAS_LIMITS`), so it must never say `false` for
//! a dictionary that has one. Checked on every real EDS of the project.

use std::path::Path;

use od_gen::{Options, codegen, load_path};

#[test]
fn has_limits_says_whether_the_limits_table_has_an_entry() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let (mut with, mut without) = (0, 0);
    for dir in ["firmware/eds", "tests/eds-corpus", "tests/eds"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("the folder is there") {
            let path = entry.expect("a readable folder").path();
            if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("eds") || e.eq_ignore_ascii_case("dcf")) {
                continue;
            }
            let (eds, d) = load_path(&path, Options::default()).expect("readable");
            if d.has_errors() {
                continue;
            }
            let module = codegen::generate(&eds, &d.file).unwrap_or_else(|e| panic!("{}: {}", path.display(), e.0));
            let table = module.lines().find_map(|l| l.strip_prefix("static LIMITS: [Limits; ")?.split(']').next()?.parse::<usize>().ok());
            let table = table.unwrap_or_else(|| panic!("{}: no limits table", path.display()));
            let has =
                module.lines().find_map(|l| l.trim().strip_prefix("const HAS_LIMITS: bool = ")?.strip_suffix(';')?.parse::<bool>().ok());
            assert_eq!(has, Some(table > 0), "{}", path.display());
            if table > 0 { with += 1 } else { without += 1 }
        }
    }
    // Both kinds occur: the five devices have limits, CANopenNode's profile has none.
    assert!(with >= 5 && without >= 1, "{with} with limits, {without} without");
}
