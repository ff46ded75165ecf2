//! Generates one object-dictionary module per device EDS in `eds/`.
//!
//! The device files are checked strictly: any warning fails the build, so a
//! device never ships a dictionary the tolerant reader had to guess at.

use std::path::Path;

const DEVICES: [&str; 5] = ["ec5000", "unitek-ds", "sendix", "bmaxx4400", "agile"];

fn main() {
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    for device in DEVICES {
        let eds = Path::new("eds").join(format!("{device}.eds"));
        println!("cargo::rerun-if-changed={}", eds.display());
        let code = match od_gen::generate_path(&eds, od_gen::Options { strict: true }) {
            Ok(code) => code,
            Err(diagnostics) => {
                for line in diagnostics.lines() {
                    println!("cargo::error={line}");
                }
                std::process::exit(1);
            }
        };
        let file = Path::new(&out).join(format!("{}.rs", device.replace('-', "_")));
        std::fs::write(&file, code).expect("OUT_DIR is writable");
    }
}
