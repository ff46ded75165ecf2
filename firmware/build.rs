//! Generates one object-dictionary module per device EDS in `eds/`.
//!
//! The device files are checked strictly: any warning fails the build, so a
//! device never ships a dictionary the tolerant reader had to guess at.
//!
//! For MCU builds it also hands the linker the cortex-m-rt and defmt
//! scripts; the memory layout is the root `memory.x`, with a symbol that
//! selects the QEMU board's regions.

use std::path::Path;

const DEVICES: [&str; 5] = ["ec5000", "unitek-ds", "sendix", "bmaxx4400", "agile"];

fn main() {
    for device in DEVICES {
        od_gen::build::generate_strict(&Path::new("eds").join(format!("{device}.eds")), &device.replace('-', "_"));
    }
    if std::env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "none") {
        link_board();
    }
}

/// Puts the board's memory layout into `OUT_DIR` as `memory.x` (the name
/// cortex-m-rt's `link.x` includes) and adds the linker scripts to the bins.
fn link_board() {
    // One layout file, the root `memory.x` (the linker finds it first: it runs
    // in the workspace root); the QEMU board selects its own regions in it.
    println!("cargo::rerun-if-changed=../memory.x");
    if std::env::var_os("CARGO_FEATURE_BOARD_QEMU").is_some() {
        println!("cargo::rustc-link-arg-bins=--defsym=__qemu_lm3s6965=1");
    }
    for script in ["-Tlink.x", "-Tdefmt.x"] {
        println!("cargo::rustc-link-arg-bins={script}");
    }
    println!("cargo::rustc-link-arg-bins=--nmagic");
}
