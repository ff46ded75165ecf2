//! `cargo xtask new-device NAME --eds FILE`: a device crate of your own,
//! outside this tree, from `firmware/template/` and an EDS.
//!
//! The EDS is checked as `od-gen check` checks it (warnings shown, errors
//! stop), the template is copied with the crate's name, the node-id and the
//! profile filled in, and the path dependencies point at this checkout.
//! `new_device_ci` is what `cargo xtask test` runs: a corpus EDS into a
//! temporary folder, built for QEMU, booted, read by python-canopen.

use std::path::{Path, PathBuf};
use std::process::Command;

use clap::{Args, ValueEnum};

use crate::{TARGET, root};

/// The template's files, relative to `firmware/template/`.
const FILES: [&str; 6] = ["Cargo.toml", ".cargo/config.toml", "memory.x", "build.rs", "src/main.rs", "src/device.rs"];
/// The link flag that selects the QEMU board's regions in the template's `memory.x`.
const QEMU_RUSTFLAGS: &str = "-C link-arg=--defsym=__qemu_lm3s6965=1";
/// The corpus EDS CI makes a device from.
const CI_EDS: &str = "tests/eds-corpus/canopennode__DS301_profile.eds";

/// A device profile the new device starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Profile {
    /// CiA 301 only.
    None,
    /// CiA 402 drives and motion control.
    Cia402,
    /// CiA 406 encoders.
    Cia406,
}

/// `cargo xtask new-device`.
#[derive(Args, Debug)]
pub struct NewDeviceArgs {
    /// The crate's name (lower case, digits, `-`).
    #[arg(value_parser = crate_name)]
    pub name: String,
    /// The device's EDS or DCF.
    #[arg(long, value_name = "FILE")]
    pub eds: PathBuf,
    /// The device profile module the device starts from.
    #[arg(long, value_enum, default_value_t = Profile::None)]
    pub profile: Profile,
    /// The node-id the device starts with when nothing is stored.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node_id: u8,
    /// Where to create the crate (default: ./NAME).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

fn crate_name(s: &str) -> Result<String, String> {
    let ok = s.starts_with(|c: char| c.is_ascii_lowercase()) && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-');
    if ok { Ok(s.to_owned()) } else { Err("a crate name: a lower-case letter, then lower-case letters, digits and `-`".into()) }
}

/// Creates the crate; returns its folder.
pub fn new_device(args: &NewDeviceArgs) -> Result<PathBuf, String> {
    let profile = profile_module(args.profile)?;
    check_eds(&args.eds)?;
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from(&args.name));
    if out.join("Cargo.toml").exists() {
        return Err(format!("{}: a crate is there already", out.display()));
    }
    let template = root().join("firmware/template");
    let firmware = root().join("firmware");
    let path = |p: &Path| p.display().to_string();
    for file in FILES {
        let text = std::fs::read_to_string(template.join(file)).map_err(|e| format!("{}: {e}", template.join(file).display()))?;
        let text = match file {
            "Cargo.toml" => text
                .replace("name = \"canopen-template\"", &format!("name = \"{}\"", args.name))
                .replace("path = \"../core\"", &format!("path = \"{}\"", path(&firmware.join("core"))))
                .replace("path = \"..\"", &format!("path = \"{}\"", path(&firmware)))
                .replace("path = \"../../od-gen\"", &format!("path = \"{}\"", path(&root().join("od-gen")))),
            "src/device.rs" => {
                let mut t = text
                    .replace("name: \"canopen-template\"", &format!("name: \"{}\"", args.name))
                    .replace("default_node_id: 0x10", &format!("default_node_id: {}", args.node_id));
                if let Some(module) = profile {
                    t.push_str(&format!("\n/// The device profile this device implements.\npub use {module} as profile;\n"));
                }
                t
            }
            _ => text,
        };
        let dst = out.join(file);
        if let Some(dir) = dst.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        std::fs::write(&dst, text).map_err(|e| format!("{}: {e}", dst.display()))?;
    }
    std::fs::copy(&args.eds, out.join("device.eds")).map_err(|e| format!("{}: {e}", args.eds.display()))?;
    eprintln!(
        "created {} ({} on {}, node-id {}): `cargo run --release` there flashes an STM32F103C8 through probe-rs",
        out.display(),
        args.name,
        args.eds.display(),
        args.node_id
    );
    Ok(out)
}

/// The core's module for a profile, or what is missing for it.
fn profile_module(profile: Profile) -> Result<Option<&'static str>, String> {
    let name = match profile {
        Profile::None => return Ok(None),
        Profile::Cia402 => "cia402",
        Profile::Cia406 => "cia406",
    };
    let dir = root().join("firmware/core/src/profiles");
    if dir.join(name).is_dir() || dir.join(format!("{name}.rs")).is_file() {
        Ok(Some(match profile {
            Profile::Cia402 => "canopen_core::profiles::cia402",
            _ => "canopen_core::profiles::cia406",
        }))
    } else {
        Err(format!(
            "--profile {name} needs the {name} profile of canopen-core (firmware/core/src/profiles/{name}), which this checkout does not have"
        ))
    }
}

/// `od-gen check`: warnings shown, errors stop.
fn check_eds(eds: &Path) -> Result<(), String> {
    let (_, diagnostics) = od_gen::load_path(eds, od_gen::Options { strict: false })?;
    eprint!("{diagnostics}");
    if diagnostics.has_errors() { Err(format!("{}: not a usable EDS (errors above)", eds.display())) } else { Ok(()) }
}

/// What CI runs: a device from a corpus EDS into a temporary folder, built
/// for the QEMU board, booted, and read by python-canopen.
pub fn new_device_ci(python: &str) -> Result<(), String> {
    let out = std::env::temp_dir().join(format!("xtask-new-device-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let args = NewDeviceArgs {
        name: "corpus-device".into(),
        eds: root().join(CI_EDS),
        profile: Profile::None,
        node_id: 0x22,
        out: Some(out.clone()),
    };
    let target = root().join("target/new-device");
    let result = new_device(&args).and_then(|dir| {
        eprintln!("+ cargo build --release --no-default-features --features qemu (in {})", dir.display());
        let status = Command::new("cargo")
            .args(["build", "--release", "--no-default-features", "--features", "qemu"])
            .env("CARGO_TARGET_THUMBV7M_NONE_EABI_RUSTFLAGS", QEMU_RUSTFLAGS)
            // Kept between runs, so only the device's own crate is built again.
            .env("CARGO_TARGET_DIR", &target)
            .current_dir(&dir)
            .status()
            .map_err(|e| format!("cargo: {e}"))?;
        if !status.success() {
            return Err(format!("the new device did not build ({status})"));
        }
        let elf = target.join(TARGET).join("release/corpus-device");
        let status = Command::new(python)
            .args(["-m", "unittest", "-v", "tests/python/test_new_device.py"])
            .env("NEW_DEVICE_ELF", &elf)
            .env("NEW_DEVICE_NODE_ID", "34")
            .env("NEW_DEVICE_EDS", root().join(CI_EDS))
            .current_dir(root())
            .status()
            .map_err(|e| format!("{python}: {e}"))?;
        if status.success() { Ok(()) } else { Err("python-canopen could not read the new device".into()) }
    });
    let _ = std::fs::remove_dir_all(&out);
    result
}
