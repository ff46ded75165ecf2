//! od-gen: CiA 306 EDS/DCF files to static object dictionaries.
//!
//! The pipeline is [`lexer`] (INI text) → [`eds`] (the CiA 306 model) →
//! [`validate`] (consistency rules) → [`codegen`] (Rust for `canopen-core`),
//! or [`runtime`] (the same tables, built at run time),
//! with [`export`] and [`doc`] as other outputs; [`build`] serves the
//! `build.rs` scripts that compile dictionaries into crates. Every stage reports through
//! [`diag::Diagnostics`], which prints `file:line: error: ...`.

pub mod build;
pub mod codegen;
pub mod diag;
pub mod doc;
pub mod eds;
pub mod export;
pub mod lexer;
pub mod model;
pub mod runtime;
pub mod validate;
pub mod value;

use std::path::Path;

pub use diag::{Diagnostic, Diagnostics, Severity};
pub use model::Eds;
pub use validate::Options;

/// Reads and validates an EDS/DCF given as bytes.
pub fn load(file: &str, bytes: &[u8], opts: Options) -> (Eds, Diagnostics) {
    let (mut eds, mut d) = eds::read(file, bytes);
    validate::validate(&mut eds, &mut d, opts);
    (eds, d)
}

/// Reads and validates a file; the diagnostics name it by its file name.
pub fn load_path(path: &Path, opts: Options) -> Result<(Eds, Diagnostics), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: error: {e}", path.display()))?;
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    Ok(load(&name, &bytes, opts))
}

/// Generates the module for an EDS file, as `build.rs` scripts do. Fails with
/// the rendered diagnostics when the file has errors.
pub fn generate_path(path: &Path, opts: Options) -> Result<String, String> {
    let (eds, d) = load_path(path, opts)?;
    if d.has_errors() {
        return Err(d.to_string());
    }
    codegen::generate(&eds, &d.file).map_err(|e| format!("{}: error: {}", d.file, e.0))
}
