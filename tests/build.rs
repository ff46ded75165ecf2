//! Generates a dictionary module for every corpus file that reads without
//! errors, so that `src/lib.rs` proves they all compile into the no_std core.

use std::fmt::Write;
use std::path::Path;

fn main() {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    println!("cargo::rerun-if-changed=eds-corpus");
    let mut files: Vec<_> = std::fs::read_dir("eds-corpus")
        .expect("tests/eds-corpus exists")
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "eds" || x == "dcf"))
        .collect();
    files.sort();
    let mut index = String::new();
    for path in files {
        // Invalid files are the corpus test's business; only valid ones become code.
        let Ok(code) = od_gen::generate_path(&path, od_gen::Options::default()) else { continue };
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("corpus");
        let module = od_gen::codegen::snake(stem);
        std::fs::write(Path::new(&out).join(format!("{module}.rs")), code).expect("OUT_DIR is writable");
        let _ = writeln!(index, "/// Generated from `eds-corpus/{}`.", path.file_name().and_then(|s| s.to_str()).unwrap_or(""));
        let _ = writeln!(index, "pub mod {module} {{\n    include!(concat!(env!(\"OUT_DIR\"), \"/{module}.rs\"));\n}}");
    }
    std::fs::write(Path::new(&out).join("corpus.rs"), index).expect("OUT_DIR is writable");
}
