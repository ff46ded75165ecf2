//! `cargo xtask hil`: the bench check of a board (`tests/python/hil.py`):
//! boot-up, identity, SDO, PDO both ways, NMT, heartbeat, EMCY and a save
//! across a power cycle, through any adapter python-can supports
//! (docs/hardware-test.md).
//!
//! ```text
//! cargo xtask hil --interface slcan --channel /dev/ttyACM0 --bitrate 250000 --device ec5000 --node-id 127
//! cargo xtask hil --interface socketcan --channel can0 --device sendix --node-id 63 --power-cycle-command "relay off; sleep 1; relay on"
//! cargo xtask hil --qemu --device ec5000 [--node-id 127]
//! ```
//!
//! With `--qemu` it builds the device's QEMU image and the script runs it
//! over SLCAN/TCP, with its storage in a host file so that parameters
//! survive the power cycle (QEMU killed and started again). `cargo xtask
//! test` runs that for every device ([`qemu_all`]).

use std::process::Command;
use std::time::{Duration, Instant};

use crate::images::{self, build_board, ensure_venv, image_path};
use crate::root;

/// A QEMU run is killed after this long (about 4 s each on an idle host).
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

/// `cargo xtask hil` options; see the module docs and docs/hardware-test.md.
#[derive(clap::Args)]
pub struct HilArgs {
    /// The python-can interface of the adapter (slcan, socketcan, pcan, kvaser, ...).
    #[arg(long, required_unless_present = "qemu")]
    interface: Option<String>,
    /// The adapter's channel (/dev/ttyACM0, can0, PCAN_USBBUS1, socket://HOST:PORT, ...).
    #[arg(long, required_unless_present = "qemu")]
    channel: Option<String>,
    /// The bus bit rate in bit/s.
    #[arg(long, default_value_t = 250_000, conflicts_with = "qemu")]
    bitrate: u32,
    /// The device the board runs.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(firmware::devices::ALL.iter().map(|d| d.name)))]
    device: String,
    /// The node's id (default: the image's own).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=127))]
    node_id: Option<u8>,
    /// A shell command that cycles the board's power (default: ask the user to do it).
    #[arg(long, value_name = "CMD", conflicts_with = "qemu")]
    power_cycle_command: Option<String>,
    /// The device's EDS (default: firmware/eds/DEVICE.eds).
    #[arg(long, value_name = "FILE", conflicts_with = "qemu")]
    eds: Option<String>,
    /// Check the device's QEMU image instead of a board (what CI runs).
    #[arg(long, conflicts_with_all = ["interface", "channel"])]
    qemu: bool,
}

impl HilArgs {
    /// What clap cannot see: the QEMU image runs its device's own node-id
    /// (docs/firmware.md), so another `--node-id` would reach nothing.
    fn check(&self) -> Result<(), clap::Error> {
        let image = firmware::devices::by_name(&self.device).map(|d| d.default_node_id);
        match (self.qemu, self.node_id, image) {
            (true, Some(asked), Some(own)) if asked != own => Err(clap::Error::raw(
                clap::error::ErrorKind::ArgumentConflict,
                format!("the {} QEMU image runs node-id {own}: `--node-id {asked}` would reach nothing (leave it out)\n", self.device),
            )),
            _ => Ok(()),
        }
    }
}

/// `cargo xtask hil ...`.
pub fn hil(args: &HilArgs) -> Result<(), String> {
    if let Err(e) = args.check() {
        e.exit();
    }
    let device = args.device.as_str();
    let known = firmware::devices::by_name(device).ok_or_else(|| format!("unknown device {device}"))?;
    if NOT_CANOPEN.contains(&device) {
        return Err(format!(
            "{device} does not speak CANopen (its own register protocol owns the bus): the bench check of tests/python/hil.py does not apply; tests/python/unitek.py is its python-can session"
        ));
    }
    let node_id = args.node_id.unwrap_or(known.default_node_id).to_string();
    if args.qemu {
        return run_qemu(device, &node_id);
    }
    let mut script_args =
        vec!["--device".to_string(), device.to_string(), "--node-id".into(), node_id, "--bitrate".into(), args.bitrate.to_string()];
    let options = [
        ("--interface", &args.interface),
        ("--channel", &args.channel),
        ("--power-cycle-command", &args.power_cycle_command),
        ("--eds", &args.eds),
    ];
    for (flag, value) in options {
        if let Some(value) = value {
            script_args.extend([flag.to_string(), value.clone()]);
        }
    }
    run_script(&script_args, None)
}

/// The QEMU image of `device` through the same script.
fn run_qemu(device: &str, node_id: &str) -> Result<(), String> {
    if !images::have("qemu-system-arm") {
        return Err("qemu-system-arm is missing: apt-get install -y --no-install-recommends qemu-system-arm".into());
    }
    build_board("qemu", Some(device))?;
    qemu_image(device, node_id)
}

fn qemu_image(device: &str, node_id: &str) -> Result<(), String> {
    let elf = image_path(device, "qemu");
    let elf = elf.to_str().ok_or("non-UTF-8 path")?;
    let args = ["--qemu", elf, "--device", device, "--node-id", node_id].map(String::from);
    run_script(&args, Some(QEMU_TIMEOUT))
}

/// Devices whose image switches CANopen off (docs/devices/unitek-ds.md); the
/// QEMU smoke tests and `tests/python/test_unitek_vnode.py` check them in their own protocol.
const NOT_CANOPEN: [&str; 1] = ["unitek-ds"];

/// Every CANopen device's QEMU image (already built by `cargo xtask build`), for `cargo xtask test`.
pub fn qemu_all() -> Result<(), String> {
    for device in firmware::devices::ALL.iter().filter(|d| !NOT_CANOPEN.contains(&d.name)) {
        qemu_image(device.name, &device.default_node_id.to_string())?;
    }
    Ok(())
}

fn run_script(args: &[String], timeout: Option<Duration>) -> Result<(), String> {
    let python = ensure_venv()?;
    let script = root().join("tests/python/hil.py");
    eprintln!("+ {} {} {}", python.display(), script.display(), args.join(" "));
    let mut child =
        Command::new(&python).arg(&script).args(args).current_dir(root()).spawn().map_err(|e| format!("{}: {e}", python.display()))?;
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return if status.success() { Ok(()) } else { Err(format!("hil checks failed ({status})")) };
        }
        if timeout.is_some_and(|t| start.elapsed() > t) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("hil killed after {} s", timeout.map_or(0, |t| t.as_secs())));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::HilArgs;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        hil: HilArgs,
    }

    fn parse(args: &[&str]) -> Result<HilArgs, clap::Error> {
        let cli = Cli::try_parse_from(std::iter::once("hil").chain(args.iter().copied()))?;
        cli.hil.check().map(|()| cli.hil)
    }

    #[test]
    fn qemu_takes_only_what_the_image_has() {
        assert!(parse(&["--qemu", "--device", "sendix"]).is_ok());
        assert!(parse(&["--qemu", "--device", "sendix", "--node-id", "63"]).is_ok());
        assert!(parse(&["--interface", "slcan", "--channel", "x", "--device", "sendix", "--node-id", "5"]).is_ok());
        for args in [
            &["--qemu", "--device", "sendix", "--node-id", "5"][..],
            &["--qemu", "--device", "ec5000", "--bitrate", "500000"],
            &["--qemu", "--device", "ec5000", "--eds", "my.eds"],
            &["--qemu", "--device", "ec5000", "--channel", "can0"],
        ] {
            let e = parse(args).err().unwrap_or_else(|| panic!("{args:?} parsed"));
            assert_eq!(e.exit_code(), 2, "{args:?}: {e}");
        }
        let e = parse(&["--qemu", "--device", "sendix", "--node-id", "5"]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("runs node-id 63"), "{e}");
    }
}
