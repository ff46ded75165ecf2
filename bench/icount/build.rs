//! Generates the interop test dictionary (`tests/eds/interop.eds`), as
//! hal-host does, but for a `no_std` library the thumbv7m image can use.

use std::path::Path;

fn main() {
    od_gen::build::generate_strict(Path::new("../../tests/eds/interop.eds"), "interop", &[]);
}
