//! The EDS/DCF reader, validator, generator and exporter never panic, and an
//! accepted file survives export and re-reading.
#![no_main]

use libfuzzer_sys::fuzz_target;
use od_gen::{Options, codegen, export, load};

fuzz_target!(|data: &[u8]| {
    let (eds, diags) = load("fuzz.eds", data, Options::default());
    if diags.has_errors() {
        return;
    }
    let _ = codegen::generate(&eds, "fuzz.eds");
    let text = export::export(&eds);
    let (again, d2) = load("export.eds", text.as_bytes(), Options::default());
    assert!(!d2.has_errors(), "export of an accepted file is rejected:\n{d2}");
    assert_eq!(eds.objects.len(), again.objects.len());
});
