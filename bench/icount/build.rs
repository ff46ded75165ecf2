//! Generates the interop test dictionary (`tests/eds/interop.eds`), as
//! hal-host does, but for a `no_std` library the thumbv7m image can use.

use std::path::Path;

fn main() {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    let eds = Path::new("../../tests/eds/interop.eds");
    println!("cargo::rerun-if-changed={}", eds.display());
    match od_gen::generate_path(eds, od_gen::Options { strict: true }) {
        Ok(code) => std::fs::write(Path::new(&out).join("interop.rs"), code).expect("OUT_DIR is writable"),
        Err(diagnostics) => {
            for line in diagnostics.lines() {
                println!("cargo::error={line}");
            }
            std::process::exit(1);
        }
    }
}
