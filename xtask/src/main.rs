//! `cargo xtask <task>`: the project's commands.
//!
//! - `test`: installs what is missing (the thumbv7m target, qemu-system-arm and
//!   binutils-arm-none-eabi through apt, a Python venv with python-can and
//!   canopen) and runs every check CI runs: rustfmt, clippy, all tests, the
//!   strict device-EDS check, the Cortex-M builds with the size budget, the
//!   python-canopen interop tests against `vnode` and the QEMU smoke tests.
//! - `demo [--device ec5000|unitek-ds] [--connect HOST:PORT] [--node-id N]`: boots the EC5000 image in
//!   QEMU and drives it like a PLC (NMT, SDO, PDO, SYNC, heartbeat, EMCY),
//!   with a live decoded trace and a summary; fails if the node misbehaves.
//!   `--device unitek-ds` drives the UNITEK DS servo in its register protocol.
//!   `--device sendix`: the Kübler Sendix encoder image (CiA 406) instead.
//! - `fuzz [SECONDS]`: runs the fuzz targets (needs a nightly toolchain and cargo-fuzz).
//! - `bench`: the bus-level benchmarks on the virtual bus (release build), with wall times.
//! - `build`: every firmware image (each device on each board), with its sizes and the budget check.
//! - `qemu DEVICE [--listen HOST:PORT]`: boots a device's QEMU image, SLCAN on that TCP port.
//! - `smoke`: python-canopen against every QEMU image (tests/python/test_qemu_smoke.py).
//! - `hil --interface IF --channel CH --device NAME --node-id N` (or `--qemu`): the bench check of a board.

mod bench;
mod demo;
mod hil;
mod images;
mod measure;
mod new_device;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use clap::{Parser, Subcommand};

const TARGET: &str = "thumbv7m-none-eabi";

/// Fuzz targets with the directory of real inputs each one starts from.
const FUZZ_TARGETS: &[(&str, &str)] = &[("eds_parser", "../tests/eds-corpus"), ("node_frames", "seeds/node_frames")];

/// The project's commands (`cargo xtask <command>`).
#[derive(Parser)]
#[command(
    name = "xtask",
    bin_name = "cargo xtask",
    version,
    about = "The project's commands: what CI runs, the demo, images, measurements"
)]
struct Cli {
    #[command(subcommand)]
    command: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Install what is missing and run every check CI runs.
    Test,
    /// Boot the EC5000 image in QEMU (or connect to a running vnode) and drive it like a PLC.
    Demo(demo::DemoArgs),
    /// Run the fuzz targets (nightly toolchain and cargo-fuzz).
    Fuzz {
        /// Seconds per target.
        #[arg(default_value_t = 60)]
        seconds: u32,
    },
    /// The bus-level benchmarks on the virtual bus (release build), with wall times.
    Bench,
    /// Build every firmware image, with its sizes and the budget check.
    Build,
    /// Boot a device's QEMU image with SLCAN on a TCP port.
    Qemu(images::QemuArgs),
    /// python-canopen against every QEMU image.
    Smoke,
    /// The bench check of a board through a python-can adapter (or of a QEMU image with --qemu).
    Hil(hil::HilArgs),
    /// Flash and RAM of the core and of each device on thumbv7m.
    Size,
    /// A device crate of your own from the template and an EDS (README, "Your device").
    NewDevice(new_device::NewDeviceArgs),
    /// Instructions per handled frame (host under callgrind, thumbv7m in QEMU).
    Icount {
        /// Frames per measurement.
        #[arg(default_value_t = 1000)]
        n: u64,
    },
}

fn main() -> ExitCode {
    // clap prints usage errors with the usage and exits with 2; `--help` and `--version` exit with 0.
    let cli = Cli::parse();
    let result = match cli.command {
        Task::Test => test(),
        Task::Demo(args) => demo::demo(&args),
        Task::Fuzz { seconds } => fuzz(seconds),
        Task::Bench => bench::bench(),
        Task::Build => images::build(),
        Task::Qemu(args) => images::qemu(&args),
        Task::Smoke => images::smoke(),
        Task::Hil(args) => hil::hil(&args),
        Task::Size => measure::size(),
        Task::Icount { n } => measure::icount(n),
        Task::NewDevice(args) => new_device::new_device(&args).map(|_| ()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A `HOST:PORT` that names an address (`--connect`, `--listen`): anything
/// else is a usage error, not a failure of the command.
fn host_port(s: &str) -> Result<String, String> {
    use std::net::ToSocketAddrs;
    match s.to_socket_addrs().map(|mut addrs| addrs.next()) {
        Ok(Some(_)) => Ok(s.to_owned()),
        Ok(None) => Err("names no address".into()),
        Err(e) => Err(format!("not HOST:PORT, e.g. 127.0.0.1:4557 ({e})")),
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

fn run(program: &str, args: &[&str]) -> Result<(), String> {
    eprintln!("+ {program} {}", args.join(" "));
    let status = Command::new(program).args(args).current_dir(root()).status().map_err(|e| format!("{program}: {e}"))?;
    if status.success() { Ok(()) } else { Err(format!("`{program} {}` failed ({status})", args.join(" "))) }
}

fn output(program: &str, args: &[&str]) -> Result<String, String> {
    let out = Command::new(program).args(args).current_dir(root()).output().map_err(|e| format!("{program}: {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Installs the Cortex-M target if rustup lacks it.
fn ensure_target() -> Result<(), String> {
    if output("rustup", &["target", "list", "--installed"])?.lines().any(|l| l.trim() == TARGET) {
        return Ok(());
    }
    run("rustup", &["target", "add", TARGET])
}

fn test() -> Result<(), String> {
    ensure_target()?;
    run("cargo", &["fmt", "--all", "--check"])?;
    run("cargo", &["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"])?;
    run("cargo", &["test", "--workspace"])?;
    let eds: Vec<String> = firmware::devices::ALL.iter().map(|d| format!("firmware/eds/{}.eds", d.name)).collect();
    let mut check = vec!["run", "--quiet", "-p", "od-gen", "--", "check", "--strict"];
    check.extend(eds.iter().map(String::as_str));
    run("cargo", &check)?;
    // The no_std crates must build for the MCU: the core, the five device
    // dictionaries, and every dictionary generated from the EDS corpus.
    run(
        "cargo",
        &["build", "--release", "--target", TARGET, "-p", "canopen-core", "-p", "canopen-firmware", "-p", "canopen-tests", "--lib"],
    )?;
    run("cargo", &["clippy", "--target", TARGET, "-p", "canopen-core", "-p", "canopen-firmware", "--", "-D", "warnings"])?;
    interop()?;
    ensure_apt(&[("qemu-system-arm", "qemu-system-arm"), ("arm-none-eabi-size", "binutils-arm-none-eabi")])?;
    // README, "Your device": a corpus EDS to a device crate booted in QEMU (the venv is interop's).
    new_device::new_device_ci(&root().join(".venv/bin/python").to_string_lossy())?;
    images::build()?;
    images::smoke()?;
    hil::qemu_all()?;
    demo::demo(&demo::DemoArgs::default())?;
    demo::demo(&demo::DemoArgs { device: Some("unitek-ds".to_owned()), ..demo::DemoArgs::default() })?;
    demo::demo(&demo::DemoArgs { device: Some("sendix".to_owned()), ..demo::DemoArgs::default() })?;
    eprintln!("xtask test: all checks passed");
    Ok(())
}

/// Installs Debian packages whose program is missing (CI machines start bare).
fn ensure_apt(needed: &[(&str, &str)]) -> Result<(), String> {
    let missing: Vec<&str> = needed
        .iter()
        .filter(|(program, _)| {
            // `command -v` prints the path: keep it off stdout, which the demo's trace uses.
            let found = Command::new("sh").args(["-c", &format!("command -v {program}")]).stdout(std::process::Stdio::null()).status();
            !found.is_ok_and(|s| s.success())
        })
        .map(|(_, package)| *package)
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    let sudo: &[&str] = if Command::new("id").arg("-u").output().is_ok_and(|o| o.stdout.starts_with(b"0")) { &[] } else { &["sudo"] };
    let apt = |args: &[&str]| {
        let mut all: Vec<&str> = sudo.to_vec();
        all.push("apt-get");
        all.extend(args);
        run(all[0], &all[1..])
    };
    apt(&["update", "-qq"])?;
    let mut install = vec!["install", "-y", "-qq", "--no-install-recommends"];
    install.extend(missing);
    apt(&install)
}

/// The independent check: python-canopen from PyPI, in a venv made here,
/// drives `vnode` over SLCAN (tests/python).
fn interop() -> Result<(), String> {
    let venv = root().join(".venv");
    let python = venv.join("bin/python");
    let python = python.to_str().ok_or("non-UTF-8 path")?;
    let ready = Command::new(python).args(["-c", "import can, canopen"]).status().is_ok_and(|s| s.success());
    if !ready {
        run("python3", &["-m", "venv", ".venv"])?;
        run(python, &["-m", "pip", "install", "--quiet", "python-can", "canopen", "pyserial"])?;
    }
    run("cargo", &["build", "-p", "hal-host", "--bin", "vnode"])?;
    run(python, &["-m", "unittest", "discover", "-s", "tests/python", "-v"])
}

fn fuzz(seconds: u32) -> Result<(), String> {
    let time = format!("-max_total_time={seconds}");
    // Each target starts from the real files it parses; new inputs go to fuzz/corpus/<target>.
    for &(target, seeds) in FUZZ_TARGETS {
        let corpus = format!("corpus/{target}");
        std::fs::create_dir_all(root().join("fuzz").join(&corpus)).map_err(|e| e.to_string())?;
        let status = Command::new("cargo")
            .args(["+nightly", "fuzz", "run", target, &corpus, seeds, "--", &time])
            .current_dir(root().join("fuzz"))
            .status()
            .map_err(|e| format!("cargo +nightly fuzz: {e} (install with `cargo install cargo-fuzz`)"))?;
        if !status.success() {
            return Err(format!("fuzz target {target} failed ({status})"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod cli_tests {
    use clap::CommandFactory;
    use clap::error::ErrorKind;

    use super::{Cli, Parser, Task};

    fn parse(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(std::iter::once("xtask").chain(args.iter().copied()))
    }

    #[test]
    fn every_command_has_help_and_version() {
        Cli::command().debug_assert();
        assert_eq!(parse(&["--version"]).err().map(|e| e.kind()), Some(ErrorKind::DisplayVersion));
        for command in ["test", "demo", "fuzz", "bench", "build", "qemu", "smoke", "hil", "size", "icount", "new-device"] {
            assert_eq!(parse(&[command, "--help"]).err().map(|e| e.kind()), Some(ErrorKind::DisplayHelp), "{command}");
        }
    }

    #[test]
    fn arguments_keep_their_meaning() {
        assert!(matches!(parse(&["fuzz"]).map(|c| c.command), Ok(Task::Fuzz { seconds: 60 })));
        assert!(matches!(parse(&["fuzz", "5"]).map(|c| c.command), Ok(Task::Fuzz { seconds: 5 })));
        assert!(matches!(parse(&["icount"]).map(|c| c.command), Ok(Task::Icount { n: 1000 })));
        assert!(matches!(parse(&["icount", "50"]).map(|c| c.command), Ok(Task::Icount { n: 50 })));
        assert!(parse(&["demo", "--connect", "127.0.0.1:4557", "--node-id", "5"]).is_ok());
        assert!(parse(&["qemu", "sendix", "--listen", "127.0.0.1:4600"]).is_ok());
        assert!(parse(&["new-device", "pump", "--eds", "pump.eds", "--profile", "cia402", "--node-id", "5", "--out", "x"]).is_ok());
    }

    #[test]
    fn usage_errors_are_exit_code_2() {
        for args in [
            &[][..],
            &["bogus"],
            &["demo", "--node-id", "5"],
            &["demo", "--node-id", "0", "--connect", "127.0.0.1:1"],
            &["demo", "--connect", "nothost"],
            &["qemu", "sendix", "--listen", "4600"],
            &["qemu", "nosuch"],
            &["icount", "x"],
            &["new-device", "pump"],
            &["new-device", "Pump", "--eds", "pump.eds"],
            &["new-device", "fn", "--eds", "pump.eds"],
            &["new-device", "build", "--eds", "pump.eds"],
            &["new-device", "core", "--eds", "pump.eds"],
            &["new-device", "pump", "--eds", "pump.eds", "--profile", "cia999"],
            &["new-device", "pump", "--eds", "pump.eds", "--node-id", "128"],
        ] {
            let e = parse(args).err().unwrap_or_else(|| panic!("{args:?} parsed"));
            assert_eq!(e.exit_code(), 2, "{args:?}: {e}");
        }
    }
}
