//! Links the image like the firmware's QEMU images: cortex-m-rt's `link.x`
//! with the root `memory.x`, whose lm3s6965 regions `__qemu_lm3s6965` selects.

fn main() {
    println!("cargo::rerun-if-changed=../../memory.x");
    if std::env::var("CARGO_CFG_TARGET_OS").is_ok_and(|os| os == "none") {
        for arg in ["--defsym=__qemu_lm3s6965=1", "-Tlink.x", "--nmagic"] {
            println!("cargo::rustc-link-arg-bins={arg}");
        }
    }
}
