//! `cargo xtask new-device NAME --eds FILE`: a device crate of your own,
//! outside this tree, from `firmware/template/` and an EDS.
//!
//! The EDS is checked as `od-gen check` checks it (warnings shown, errors
//! stop) and, with `--profile`, for the objects the profile needs; the
//! template is copied with the crate's name, the node-id and the device
//! module of the profile (`firmware/template/profiles/`: the CiA 402
//! profile driving the axis model, or the CiA 406 profile on a simulated
//! shaft), and the path dependencies point at this checkout.
//! `new_device_ci` is what `cargo xtask test` runs: corpus EDS files into a
//! temporary folder, built for QEMU, booted and driven by python-canopen.

use std::path::{Path, PathBuf};
use std::process::Command;

use clap::{Args, ValueEnum};

use crate::{TARGET, root};

/// The template's files, relative to `firmware/template/` (the device module comes from [`device_template`]).
const FILES: [&str; 5] = ["Cargo.toml", ".cargo/config.toml", "memory.x", "build.rs", "src/main.rs"];
/// The link flag that selects the QEMU board's regions in the template's `memory.x`.
const QEMU_RUSTFLAGS: &str = "-C link-arg=--defsym=__qemu_lm3s6965=1";
/// What CI makes: (EDS, profile, node-id), each booted and driven by its
/// python test. The corpus has no CiA 406 EDS (no 0x6004), so the encoder
/// comes from the Sendix's EDS.
const CI_DEVICES: [(&str, Profile, u8); 3] = [
    ("tests/eds-corpus/canopennode__DS301_profile.eds", Profile::None, 0x22),
    ("tests/eds-corpus/ros2-canopen__cia402_slave.eds", Profile::Cia402, 0x23),
    ("firmware/eds/sendix.eds", Profile::Cia406, 0x24),
];
/// The crate name every CI device gets, so one target folder serves them all.
const CI_NAME: &str = "corpus-device";

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

impl Profile {
    /// The name on the command line.
    fn name(self) -> &'static str {
        match self {
            Profile::None => "none",
            Profile::Cia402 => "cia402",
            Profile::Cia406 => "cia406",
        }
    }
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

/// Rust's keywords, strict and reserved (2024 edition): a crate's name
/// (`-` as `_`) is its binary's, which must be an identifier.
const KEYWORDS: [&str; 52] = [
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for", "if", "impl", "in", "let", "loop",
    "match", "mod", "move", "mut", "pub", "ref", "return", "self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use",
    "where", "while", "async", "await", "dyn", "abstract", "become", "box", "do", "final", "macro", "override", "priv", "typeof",
    "unsized", "virtual", "yield", "try", "gen", "union",
];
/// Names cargo or the build refuse for a binary crate: cargo's folders in
/// `target/`, and the built-in crates the device's code names (`core`).
const RESERVED: [&str; 9] = ["build", "deps", "examples", "incremental", "test", "core", "std", "alloc", "proc-macro"];

fn crate_name(s: &str) -> Result<String, String> {
    let ok = s.starts_with(|c: char| c.is_ascii_lowercase()) && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-');
    if !ok {
        return Err("a crate name: a lower-case letter, then lower-case letters, digits and `-`".into());
    }
    if KEYWORDS.contains(&s.replace('-', "_").as_str()) {
        return Err(format!("`{s}` is a Rust keyword, which cannot name the device's binary"));
    }
    if RESERVED.contains(&s) {
        return Err(format!("`{s}` is a name cargo or the build reserves (a target folder or a built-in crate)"));
    }
    Ok(s.to_owned())
}

/// Creates the crate; returns its folder.
pub fn new_device(args: &NewDeviceArgs) -> Result<PathBuf, String> {
    let eds = check_eds(&args.eds)?;
    check_profile_objects(&eds, &args.eds, args.profile)?;
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from(&args.name));
    if out.join("Cargo.toml").exists() {
        return Err(format!("{}: a crate is there already", out.display()));
    }
    let template = root().join("firmware/template");
    let firmware = root().join("firmware");
    // A DCF stays a DCF: od-gen reads `ParameterValue` as a DCF's own, and
    // warns of it in an EDS.
    let dcf = args.eds.extension().is_some_and(|e| e.eq_ignore_ascii_case("dcf"));
    let eds_file = if dcf { "device.dcf" } else { "device.eds" };
    let path = |p: &Path| p.display().to_string();
    for file in FILES.into_iter().chain(["src/device.rs"]) {
        let source = if file == "src/device.rs" { device_template(args.profile) } else { file };
        let text = std::fs::read_to_string(template.join(source)).map_err(|e| format!("{}: {e}", template.join(source).display()))?;
        let text = match file {
            "Cargo.toml" => text
                .replace("name = \"canopen-template\"", &format!("name = \"{}\"", args.name))
                .replace("path = \"../core\"", &format!("path = \"{}\"", path(&firmware.join("core"))))
                .replace("path = \"..\"", &format!("path = \"{}\"", path(&firmware)))
                .replace("path = \"../../od-gen\"", &format!("path = \"{}\"", path(&root().join("od-gen")))),
            "src/device.rs" => {
                let value = |index| eds.sub(index, 0).and_then(|s| s.unsigned()).unwrap_or(0);
                text.replace("name: \"canopen-template\"", &format!("name: \"{}\"", args.name))
                    .replace("default_node_id: 0x10", &format!("default_node_id: {}", args.node_id))
                    // The CiA 406 shaft: the sensor's resolution and turns, as the EDS declares them.
                    .replace("const RESOLUTION: u32 = 4096;", &format!("const RESOLUTION: u32 = {};", value(0x6501)))
                    .replace("const TURNS: u32 = 0;", &format!("const TURNS: u32 = {};", value(0x6502)))
            }
            _ => text,
        };
        let text = text.replace("device.eds", eds_file);
        let dst = out.join(file);
        if let Some(dir) = dst.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        std::fs::write(&dst, text).map_err(|e| format!("{}: {e}", dst.display()))?;
    }
    std::fs::copy(&args.eds, out.join(eds_file)).map_err(|e| format!("{}: {e}", args.eds.display()))?;
    eprintln!(
        "created {} ({} on {}, node-id {}): `cargo run --release` there flashes an STM32F103C8 through probe-rs",
        out.display(),
        args.name,
        args.eds.display(),
        args.node_id
    );
    Ok(out)
}

/// The template of the device module (relative to `firmware/template/`).
fn device_template(profile: Profile) -> &'static str {
    match profile {
        Profile::None => "src/device.rs",
        Profile::Cia402 => "profiles/cia402.rs",
        Profile::Cia406 => "profiles/cia406.rs",
    }
}

/// The objects a profile's device module cannot run without, with their names.
fn profile_objects(profile: Profile) -> &'static [(u16, &'static str)] {
    match profile {
        Profile::None => &[],
        // The state machine (controlword, statusword) and a mode to move in (CiA 402-2 §6, §6.4).
        Profile::Cia402 => {
            &[(0x6040, "controlword"), (0x6041, "statusword"), (0x6060, "modes of operation"), (0x6061, "modes of operation display")]
        }
        // The position and the steps per turn the scaling starts from (CiA 406 §6.2, §6.5).
        Profile::Cia406 => &[(0x6004, "position value"), (0x6501, "single-turn resolution")],
    }
}

/// The profile's objects are in the EDS; else one line naming the missing ones.
fn check_profile_objects(eds: &od_gen::Eds, path: &Path, profile: Profile) -> Result<(), String> {
    let missing: Vec<String> = profile_objects(profile)
        .iter()
        .filter(|(index, _)| eds.sub(*index, 0).is_none())
        .map(|(index, name)| format!("0x{index:04X} {name}"))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(format!("{}: error: --profile {} needs {}, which the EDS does not define", path.display(), profile.name(), missing.join(", ")))
}

/// `od-gen check`: warnings shown, errors stop; the parsed EDS.
fn check_eds(eds: &Path) -> Result<od_gen::Eds, String> {
    let (parsed, diagnostics) = od_gen::load_path(eds, od_gen::Options { strict: false })?;
    eprint!("{diagnostics}");
    if diagnostics.has_errors() { Err(format!("{}: not a usable EDS (errors above)", eds.display())) } else { Ok(parsed) }
}

/// What CI runs: devices from corpus EDS files into a temporary folder,
/// built for the QEMU board (one target folder, so only the device crate
/// builds again), booted, and driven by python-canopen
/// (`tests/python/test_new_device.py`); an EDS without the profile's
/// objects is refused.
pub fn new_device_ci(python: &str) -> Result<(), String> {
    let out = std::env::temp_dir().join(format!("xtask-new-device-{}", std::process::id()));
    let target = root().join("target/new-device");
    let result = (|| {
        // A CiA 402 device from an EDS without the drive objects: refused, naming them.
        let refused = NewDeviceArgs {
            name: CI_NAME.into(),
            eds: root().join(CI_DEVICES[0].0),
            profile: Profile::Cia402,
            node_id: 1,
            out: Some(out.clone()),
        };
        match new_device(&refused) {
            Err(e) if e.contains("0x6040 controlword") && e.contains("0x6041 statusword") => eprintln!("refused as it should be: {e}"),
            other => return Err(format!("an EDS without 0x6040/0x6041 was not refused for --profile cia402: {other:?}")),
        }
        for (eds, profile, node_id) in CI_DEVICES {
            let _ = std::fs::remove_dir_all(&out);
            let args = NewDeviceArgs { name: CI_NAME.into(), eds: root().join(eds), profile, node_id, out: Some(out.clone()) };
            let dir = new_device(&args)?;
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
                return Err(format!("the new device from {eds} (--profile {profile:?}) did not build ({status})"));
            }
            let elf = target.join(TARGET).join("release").join(CI_NAME);
            let status = Command::new(python)
                .args(["-m", "unittest", "-v", "tests/python/test_new_device.py"])
                .env("NEW_DEVICE_ELF", &elf)
                .env("NEW_DEVICE_NODE_ID", node_id.to_string())
                .env("NEW_DEVICE_EDS", root().join(eds))
                .env("NEW_DEVICE_PROFILE", profile.name())
                .current_dir(root())
                .status()
                .map_err(|e| format!("{python}: {e}"))?;
            if !status.success() {
                return Err(format!("python-canopen could not drive the new device from {eds}"));
            }
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&out);
    result
}

#[cfg(test)]
mod tests {
    use super::{NewDeviceArgs, Profile, new_device};
    use crate::root;

    /// A DCF becomes `device.dcf`, which `build.rs` reads: as `device.eds`
    /// its `ParameterValue`s were warnings ("belongs in a DCF") in every build.
    #[test]
    fn a_dcf_stays_a_dcf() {
        let out = std::env::temp_dir().join(format!("xtask-new-device-dcf-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let args = NewDeviceArgs {
            name: "ctl".into(),
            eds: root().join("tests/eds-corpus/lely__coctl.dcf"),
            profile: Profile::None,
            node_id: 5,
            out: Some(out.clone()),
        };
        let made = new_device(&args).map(|dir| {
            let build = std::fs::read_to_string(dir.join("build.rs")).unwrap_or_default();
            let loaded = od_gen::load_path(&dir.join("device.dcf"), od_gen::Options::default());
            (build, dir.join("device.eds").exists(), loaded)
        });
        let _ = std::fs::remove_dir_all(&out);
        let (build, eds_too, loaded) = made.expect("the crate is made");
        assert!(build.contains("generate(\"device.dcf\".as_ref(), \"od\")"), "{build}");
        assert!(!eds_too, "only device.dcf");
        let (_, d) = loaded.expect("device.dcf reads");
        assert!(!d.items.iter().any(|i| i.message.contains("belongs in a DCF")), "{d}");
    }
}
