//! Generates the dictionaries of the test fixtures in `tests/eds/`.

use std::path::Path;

fn main() {
    od_gen::build::generate_strict(Path::new("../tests/eds/interop.eds"), "interop", &[]);
}
