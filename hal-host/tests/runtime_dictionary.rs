//! `vnode --eds` builds its dictionary at run time (`od_gen::runtime`): it
//! must be the dictionary the generated module holds for the same file.

use std::path::Path;

use hal_host::fixtures::interop::od;

#[test]
fn runtime_tables_equal_the_generated_ones() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/eds/interop.eds");
    let (eds, diagnostics) = od_gen::load_path(&path, od_gen::Options { strict: true }).expect("readable");
    assert!(!diagnostics.has_errors(), "{diagnostics}");
    let loaded = od_gen::runtime::Tables::new(&eds).expect("laid out").leak();
    let generated = &od::DICTIONARY;
    assert_eq!(loaded.entries, generated.entries);
    assert_eq!(loaded.limits, generated.limits);
    assert_eq!(loaded.rom, generated.rom);
    assert_eq!(
        (loaded.defaults.len, loaded.defaults.runs, loaded.defaults.bytes),
        (generated.defaults.len, generated.defaults.runs, generated.defaults.bytes)
    );
    assert_eq!(loaded.comm_len, generated.comm_len);
    assert_eq!(loaded.node_id_relative, generated.node_id_relative);
    assert_eq!(loaded.device, generated.device);
    assert_eq!(loaded.layout_id, generated.layout_id);
    // And the RAM image a node starts from, `$NODEID` resolved.
    let ram = od_gen::runtime::RuntimeRam::new(loaded, 5);
    use canopen_core::od::ObjectDictionary;
    assert_eq!(ram.image(), od::Ram::new(5).image());
}
