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

const USAGE: &str = "usage: cargo xtask hil (--interface IF --channel CH [--bitrate BPS] [--power-cycle-command CMD] | --qemu) \
                     --device NAME [--node-id N]";

/// `cargo xtask hil ...`.
pub fn hil(args: &[String]) -> Result<(), String> {
    let mut script_args: Vec<String> = Vec::new();
    let mut device = None;
    let mut node_id = None;
    let mut qemu = false;
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--qemu" => qemu = true,
            "--device" => device = Some(it.next().ok_or(USAGE)?.clone()),
            "--node-id" => node_id = Some(it.next().ok_or(USAGE)?.clone()),
            "--interface" | "--channel" | "--bitrate" | "--power-cycle-command" | "--eds" => {
                script_args.extend([arg.clone(), it.next().ok_or(USAGE)?.clone()]);
            }
            other => return Err(format!("unknown argument {other}\n{USAGE}")),
        }
    }
    let device = device.ok_or(USAGE)?;
    let known = firmware::devices::by_name(&device).ok_or_else(|| format!("unknown device {device}"))?;
    let node_id = node_id.unwrap_or_else(|| known.default_node_id.to_string());
    if qemu {
        return run_qemu(&device, &node_id);
    }
    script_args.extend(["--device".into(), device, "--node-id".into(), node_id]);
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

/// Every device's QEMU image (already built by `cargo xtask build`), for `cargo xtask test`.
pub fn qemu_all() -> Result<(), String> {
    for device in &firmware::devices::ALL {
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
