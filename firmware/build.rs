//! Generates one object-dictionary module per device EDS in `eds/`.
//!
//! The device files are checked strictly: any warning fails the build, so a
//! device never ships a dictionary the tolerant reader had to guess at.
//!
//! For MCU builds it also hands the linker the cortex-m-rt and defmt
//! scripts; the memory layout is the root `memory.x`, with a symbol that
//! selects the QEMU board's regions, and for each STM32F103 image one that
//! sizes the flash its stored parameters take (the program gets the rest).

use std::fmt::Write as _;
use std::path::Path;

/// The devices, each with the read-only objects it stores itself
/// (`save_objects`, read back with `Ctx::stored` or `store::stored_value`):
/// a stored set holds them with the writable values. The EC5000's
/// monitoring records 0x2200; the Sendix's CiA 406 operating time 0x6508
/// and preset offset 0x6509.
const DEVICES: [(&str, &[u16]); 5] =
    [("ec5000", &[0x2200]), ("unitek-ds", &[]), ("sendix", &[0x6508, 0x6509]), ("bmaxx4400", &[]), ("agile", &[])];

fn main() {
    let mut linked = String::from("[\n");
    let mut storage = Vec::new();
    for (device, kept) in DEVICES {
        let stored_size = od_gen::build::generate_strict(&Path::new("eds").join(format!("{device}.eds")), &device.replace('-', "_"), kept);
        let kib = storage_kib(stored_size);
        let _ = writeln!(linked, "    (\"{device}-stm32f103\", {kib}),");
        storage.push((device, kib));
    }
    linked.push(']');
    // The firmware checks these against its flash layout (`boards::stm32f103::LINKED_STORAGE_KIB`).
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    std::fs::write(Path::new(&out).join("linked_storage.rs"), linked).expect("OUT_DIR is writable");
    if std::env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "none") {
        link_board(&storage);
    }
}

/// KiB of STM32F103C8 flash the stored parameters of a device whose stored
/// set is `stored_size` bytes (od-gen's `STORED_SIZE`) take: two regions of
/// the 1 KiB pages one set needs, the set plus the 24-byte store header in half-words
/// (`boards::region_size`, `Layout::stm32f103c8`; the firmware checks that
/// they agree with this at compile time).
fn storage_kib(stored_size: usize) -> usize {
    2 * (stored_size + 24).next_multiple_of(2).div_ceil(1024).max(1)
}

/// Puts the board's memory layout into `OUT_DIR` as `memory.x` (the name
/// cortex-m-rt's `link.x` includes) and adds the linker scripts to the bins.
fn link_board(storage: &[(&str, usize)]) {
    // One layout file, the root `memory.x` (the linker finds it first: it runs
    // in the workspace root); the QEMU board selects its own regions in it,
    // each STM32 image the flash its storage takes.
    println!("cargo::rerun-if-changed=../memory.x");
    if std::env::var_os("CARGO_FEATURE_BOARD_QEMU").is_some() {
        println!("cargo::rustc-link-arg-bins=--defsym=__qemu_lm3s6965=1");
    }
    if std::env::var_os("CARGO_FEATURE_BOARD_STM32F103").is_some() {
        for (device, kib) in storage {
            println!("cargo::rustc-link-arg-bin={device}-stm32f103=--defsym=__storage_kib={kib}");
        }
    }
    for script in ["-Tlink.x", "-Tdefmt.x"] {
        println!("cargo::rustc-link-arg-bins={script}");
    }
    println!("cargo::rustc-link-arg-bins=--nmagic");
}
