//! For `build.rs` scripts: generate a dictionary module into `OUT_DIR`, and
//! turn od-gen's diagnostics into cargo build errors.

use std::path::Path;

use crate::Options;

/// Generates the module for `eds` into `OUT_DIR/<module>.rs`, strictly (any
/// warning fails the build), and asks cargo to rerun when the file changes.
/// Stops the build with the diagnostics if the file is not valid. `kept`
/// names the read-only objects the device stores itself ([`crate::model::Eds::kept`]).
/// Returns the bytes a stored parameter set of the module holds (its
/// `STORED_SIZE`), for a build script that sizes something by it (the
/// firmware's flash storage).
pub fn generate_strict(eds: &Path, module: &str, kept: &[u16]) -> usize {
    println!("cargo::rerun-if-changed={}", eds.display());
    let (mut model, diagnostics) = match crate::load_path(eds, Options { strict: true }) {
        Ok(loaded) => loaded,
        Err(e) => fail(&e),
    };
    if diagnostics.has_errors() {
        fail(&diagnostics.to_string());
    }
    if let Some(index) = kept.iter().find(|i| !model.objects.contains_key(i)) {
        fail(&format!("{}: error: kept object 0x{index:04X} is not in the dictionary", diagnostics.file));
    }
    model.kept = kept.to_vec();
    match crate::codegen::generate(&model, &diagnostics.file).and_then(|code| Ok((code, crate::codegen::stored_size(&model)?))) {
        Ok((code, stored_size)) => {
            write_out(module, &code);
            stored_size
        }
        Err(e) => fail(&format!("{}: error: {}", diagnostics.file, e.0)),
    }
}

/// Generates the module for `eds` into `OUT_DIR/<module>.rs` as the tolerant
/// reader reads it: warnings become cargo warnings (`file:line: warning: ...`),
/// errors stop the build as cargo errors. The one line of a device crate's
/// `build.rs`.
pub fn generate(eds: &Path, module: &str) {
    println!("cargo::rerun-if-changed={}", eds.display());
    let (model, diagnostics) = match crate::load_path(eds, Options { strict: false }) {
        Ok(loaded) => loaded,
        Err(e) => fail(&e),
    };
    if diagnostics.has_errors() {
        fail(&diagnostics.to_string());
    }
    for line in diagnostics.to_string().lines() {
        println!("cargo::warning={line}");
    }
    match crate::codegen::generate(&model, &diagnostics.file) {
        Ok(code) => write_out(module, &code),
        Err(e) => fail(&format!("{}: error: {}", diagnostics.file, e.0)),
    }
}

/// Writes `code` to `OUT_DIR/<module>.rs`.
pub fn write_out(module: &str, code: &str) {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    std::fs::write(Path::new(&out).join(format!("{module}.rs")), code).expect("OUT_DIR is writable");
}

/// Reports rendered diagnostics as cargo build errors, one per line, and stops.
pub fn fail(diagnostics: &str) -> ! {
    for line in diagnostics.lines() {
        println!("cargo::error={line}");
    }
    std::process::exit(1);
}
