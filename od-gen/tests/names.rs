//! The naming rule (docs/od-gen.md, "Names") on every real EDS the project
//! has: the five devices (`firmware/eds/`) and the corpus
//! (`tests/eds-corpus/`). Every generated module has unique method names,
//! and no accessor repeats its object's name; on the devices none is
//! longer than [`LONGEST`] characters (the corpus has sub-index names of 50).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use od_gen::{Options, codegen, load_path};

/// The longest accessor name (setter included) a device gets.
const LONGEST: usize = 68;

fn files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    for dir in ["firmware/eds", "tests/eds-corpus"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("the folder is there") {
            let path = entry.expect("a readable folder").path();
            if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("eds") || e.eq_ignore_ascii_case("dcf")) {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The module of `path`, or `None` for a file with errors (the corpus has some on purpose).
fn module(path: &Path) -> Option<String> {
    let (eds, d) = load_path(path, Options::default()).expect("readable");
    if d.has_errors() {
        return None;
    }
    Some(codegen::generate(&eds, &d.file).unwrap_or_else(|e| panic!("{}: {}", path.display(), e.0)))
}

#[test]
fn every_name_is_unique_short_and_says_its_object_once() {
    let mut generated = 0;
    let mut longest = (0, String::new());
    for path in files() {
        let Some(module) = module(&path) else { continue };
        generated += 1;
        let file = path.display();
        let methods: Vec<&str> = module.lines().filter_map(|l| l.trim().strip_prefix("pub fn ")?.split('(').next()).collect();
        let mut seen = HashSet::new();
        for m in &methods {
            assert!(seen.insert(*m), "{file}: `{m}` twice");
            if m.len() > longest.0 && path.parent().is_some_and(|p| p.ends_with("firmware/eds")) {
                longest = (m.len(), format!("{file}: {m}"));
            }
        }
        let objects: Vec<String> = module
            .lines()
            .filter_map(|l| Some(l.trim().strip_prefix("pub const ")?.strip_suffix(";")?.split_once(": u16")?.0.to_ascii_lowercase()))
            .collect();
        for m in &methods {
            let getter = m.strip_prefix("set_").unwrap_or(m);
            for o in &objects {
                assert!(!getter.starts_with(&format!("{o}_{o}")), "{file}: `{m}` repeats the object name `{o}`");
            }
        }
    }
    assert!(generated >= 20, "only {generated} files generated");
    assert!(longest.0 <= LONGEST, "longest device name: {} ({} characters)", longest.1, longest.0);
}
