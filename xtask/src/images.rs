//! Firmware images: one per device and board, named `<device>-<board>` in
//! `target/thumbv7m-none-eabi/release/`.
//!
//! - `build`: builds every image (release profile: opt-level "s", fat LTO,
//!   one codegen unit), prints the sections and the worst-case stack
//!   ([`stack`]) of each and fails if one exceeds its [`flash_budget`]
//!   ([`FLASH_BUDGET`], or its program region for the CiA 402 drives),
//!   [`RAM_BUDGET`] or [`DATA_BUDGET`], if static RAM and stack leave
//!   less than [`STACK_MARGIN`] of the chip's RAM ([`chip_ram`]) free, or
//!   if the node's static is not in `.bss` (the unpowered node must be all
//!   zero bits: the module docs of `canopen_core::node`).
//! - `qemu <device> [--listen HOST:PORT]`: boots a device's QEMU image with
//!   its UART (SLCAN) on that TCP port, waiting for the first client.
//! - `smoke`: runs `tests/python/test_qemu_smoke.py` (python-canopen against
//!   every QEMU image) under a hard timeout, with each image's stack
//!   estimate as the bound of the stack it measures.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::{TARGET, ensure_target, root, run};

mod stack;

/// The boards and the cargo feature that selects each.
pub const BOARDS: [(&str, &str); 2] = [("qemu", "board-qemu"), ("stm32f103", "board-stm32f103")];
/// Flash an image may use (vector table, code, constants, initialised data).
/// 48 KiB of the STM32F103C8's 62 KiB program region (the last 2 KiB hold
/// the stored parameters of every non-drive device), leaving the rest for
/// the device profiles.
pub const FLASH_BUDGET: u64 = 48 * 1024;
/// The devices whose images run the CiA 402 profile: the profile and the
/// axis model take about 12 KiB (docs/firmware.md, "CiA 402"), more than
/// [`FLASH_BUDGET`] leaves, so their images may fill the STM32F103C8's
/// whole program region ([`drive_flash_budget`]).
pub const DRIVES: [&str; 3] = ["ec5000", "agile", "bmaxx4400"];

/// The flash budget of `device`'s images: [`FLASH_BUDGET`], or for a drive
/// [`drive_flash_budget`].
pub fn flash_budget(device: &str) -> u64 {
    if DRIVES.contains(&device) { drive_flash_budget(device) } else { FLASH_BUDGET }
}

/// The flash a drive's images may use: its STM32F103C8 image's program
/// region, the 64 KiB less the pages its stored parameters take (2 KiB for
/// a set that fits a page, 4 KiB for two: firmware/build.rs, `memory.x`).
/// Its QEMU image, with more flash, keeps its STM32 twin's budget.
pub fn drive_flash_budget(device: &str) -> u64 {
    u64::from(firmware::boards::stm32f103::program_flash(&format!("{device}-stm32f103")))
}
/// RAM an image may use statically (initialised and zeroed data); the rest
/// of the 20 KiB of an STM32F103C8 is stack.
pub const RAM_BUDGET: u64 = 12 * 1024;
/// RAM of each board's chip (STM32F103C8: 20 KiB, lm3s6965: 64 KiB), which
/// static RAM and the worst-case stack ([`stack::estimate`]) share.
pub fn chip_ram(board: &str) -> u64 {
    if board == "stm32f103" { 20 * 1024 } else { 64 * 1024 }
}
/// RAM that must stay free beyond static RAM and the stack estimate.
pub const STACK_MARGIN: u64 = 2 * 1024;
/// `.data` an image may have. The node must not be there (its static is
/// checked to be in `.bss`: canopen_core::node), nor much else.
pub const DATA_BUDGET: u64 = 256;
/// Default TCP address of `qemu`'s UART.
const DEFAULT_LISTEN: &str = "127.0.0.1:4555";
/// The whole smoke run may take this long before it is killed.
const SMOKE_TIMEOUT: Duration = Duration::from_secs(600);

/// Where an image lands.
pub fn image_path(device: &str, board: &str) -> PathBuf {
    let target_dir = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from);
    target_dir.join(TARGET).join("release").join(format!("{device}-{board}"))
}

/// Builds the images of one board (all devices, or the given one).
///
/// Images log at defmt level `info`: the start-up (reset cause, clock,
/// stored sets, node-id, bit rate) and NMT state changes are how a first
/// bring-up sees inside a board, and they cost under 1 KiB of flash. A
/// `DEFMT_LOG` in the environment wins.
pub fn build_board(board: &str, device: Option<&str>) -> Result<(), String> {
    let feature = BOARDS.iter().find(|(b, _)| *b == board).map(|(_, f)| *f).ok_or_else(|| format!("unknown board {board}"))?;
    let bin = device.map(|d| format!("{d}-{board}"));
    let mut args = vec!["build", "--release", "-p", "canopen-firmware", "--target", TARGET, "--features", feature];
    match &bin {
        Some(bin) => args.extend(["--bin", bin.as_str()]),
        None => args.push("--bins"),
    }
    let mut cmd = Command::new("cargo");
    cmd.args(&args).current_dir(root());
    if std::env::var_os("DEFMT_LOG").is_none() {
        cmd.env("DEFMT_LOG", "info");
    }
    eprintln!("+ cargo {}", args.join(" "));
    let status = cmd.status().map_err(|e| format!("cargo: {e}"))?;
    if status.success() { Ok(()) } else { Err(format!("building the {board} images failed ({status})")) }
}

/// The sections of an ELF image, in bytes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sizes {
    /// `.vector_table`.
    pub vectors: u64,
    /// `.text`.
    pub text: u64,
    /// `.rodata`.
    pub rodata: u64,
    /// `.data` (in flash and in RAM).
    pub data: u64,
    /// `.bss`.
    pub bss: u64,
    /// `.uninit`.
    pub uninit: u64,
}

impl Sizes {
    /// Bytes of flash.
    pub fn flash(&self) -> u64 {
        self.vectors + self.text + self.rodata + self.data
    }

    /// Bytes of RAM outside the stack.
    pub fn ram(&self) -> u64 {
        self.data + self.bss + self.uninit
    }
}

/// A binutils program for ARM: GNU's (`arm-none-eabi-<name>` from
/// binutils-arm-none-eabi) or LLVM's (`llvm-<name>`, or the one
/// `rustup component add llvm-tools` installs).
fn binutil(name: &str) -> Result<String, String> {
    let works =
        |tool: &str| Command::new(tool).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success());
    for tool in [format!("arm-none-eabi-{name}"), format!("llvm-{name}")] {
        if works(&tool) {
            return Ok(tool);
        }
    }
    let sysroot = Command::new("rustc").args(["--print", "sysroot"]).output().map_err(|e| e.to_string())?;
    let sysroot = String::from_utf8_lossy(&sysroot.stdout).trim().to_owned();
    let bundled = Path::new(&sysroot).join(format!("lib/rustlib/x86_64-unknown-linux-gnu/bin/llvm-{name}"));
    if bundled.exists() {
        return Ok(bundled.to_string_lossy().into_owned());
    }
    Err(format!("no {name} tool: `apt-get install binutils-arm-none-eabi` or `rustup component add llvm-tools`"))
}

/// Checks that `nm` output for an image has the node's static (`NODE`,
/// which `firmware::image!` defines) in `.bss` (`b`/`B`): it lies there
/// only if the unpowered node is all zero bits (canopen_core::node).
fn node_in_bss(nm: &str) -> Result<(), String> {
    let node = nm.lines().find_map(|l| {
        let mut f = l.split_whitespace();
        let (_address, class, name) = (f.next()?, f.next()?, f.next()?);
        name.ends_with("::NODE").then_some((class, name))
    });
    match node {
        Some(("b" | "B", _)) => Ok(()),
        Some((class, name)) => Err(format!(
            "the node ({name}) is not in .bss but in symbol class `{class}`: the unpowered node must be all zero bits (canopen_core::node)"
        )),
        None => Err("no `NODE` symbol: the image no longer builds its node as firmware::image! does".into()),
    }
}

/// [`node_in_bss`] for the image at `elf`.
fn check_node_in_bss(elf: &Path) -> Result<(), String> {
    let tool = binutil("nm")?;
    let out = Command::new(&tool).arg("-C").arg(elf).output().map_err(|e| format!("{tool}: {e}"))?;
    if !out.status.success() {
        return Err(format!("{tool} -C {}: {}", elf.display(), String::from_utf8_lossy(&out.stderr)));
    }
    node_in_bss(&String::from_utf8_lossy(&out.stdout))
}

/// Reads the sections of `elf` with `size -A`.
pub fn sizes(elf: &Path) -> Result<Sizes, String> {
    let tool = binutil("size")?;
    let out = Command::new(&tool).arg("-A").arg(elf).output().map_err(|e| format!("{tool}: {e}"))?;
    if !out.status.success() {
        return Err(format!("{tool} -A {}: {}", elf.display(), String::from_utf8_lossy(&out.stderr)));
    }
    let mut s = Sizes::default();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let mut fields = line.split_whitespace();
        let (Some(name), Some(size)) = (fields.next(), fields.next().and_then(|v| v.parse::<u64>().ok())) else { continue };
        match name {
            ".vector_table" => s.vectors = size,
            ".text" => s.text = size,
            ".rodata" => s.rodata = size,
            ".data" => s.data = size,
            ".bss" => s.bss = size,
            ".uninit" => s.uninit = size,
            _ => {}
        }
    }
    Ok(s)
}

/// `cargo xtask build`: every image, its sizes, and the budget check.
pub fn build() -> Result<(), String> {
    ensure_target()?;
    for (board, _) in BOARDS {
        build_board(board, None)?;
    }
    println!(
        "{:<22} {:>7} {:>7} {:>6} {:>6} {:>7} {:>7} {:>6} {:>6} {:>6}",
        "image", ".text", ".rodata", ".data", ".bss", "flash", "budget", "RAM", "stack", "free"
    );
    let mut over = Vec::new();
    let mut largest = Vec::new();
    for (board, _) in BOARDS {
        for device in &firmware::devices::ALL {
            let elf = image_path(device.name, board);
            let s = sizes(&elf)?;
            let st = stack::estimate(&elf, board)?;
            let name = format!("{}-{board}", device.name);
            let chip = chip_ram(board);
            let free = chip as i64 - (s.ram() + st.worst) as i64;
            let budget = flash_budget(device.name);
            println!(
                "{name:<22} {:>7} {:>7} {:>6} {:>6} {:>7} {budget:>7} {:>6} {:>6} {free:>6}",
                s.text,
                s.rodata,
                s.data,
                s.bss,
                s.flash(),
                s.ram(),
                st.worst
            );
            let levels: Vec<String> = st.levels.iter().map(|(l, d)| format!("level {l} {d}")).collect();
            largest.push(format!(
                "{name}: start-up {}, running: thread {} + {}; largest frame {} B in {}",
                st.startup,
                st.thread,
                levels.join(" + "),
                st.largest.1,
                st.largest.0
            ));
            if s.flash() > budget {
                over.push(format!("{name}: {} bytes of flash > {budget}", s.flash()));
            }
            if s.ram() > RAM_BUDGET {
                over.push(format!("{name}: {} bytes of RAM > {RAM_BUDGET}", s.ram()));
            }
            if let Err(e) = check_node_in_bss(&elf) {
                over.push(format!("{name}: {e}"));
            }
            if s.data > DATA_BUDGET {
                over.push(format!("{name}: {} bytes of .data > {DATA_BUDGET} (is the node still all zero bits?)", s.data));
            }
            if free < STACK_MARGIN as i64 {
                over.push(format!(
                    "{name}: {} bytes of RAM + {} of stack leave {free} of the {chip} free (< {STACK_MARGIN})",
                    s.ram(),
                    st.worst
                ));
            }
        }
    }
    println!(
        "(flash budget {FLASH_BUDGET} B; the CiA 402 drives {} (the profile and the axis model need about 12 KiB) may fill their STM32 image's",
        DRIVES.join(", ")
    );
    println!(" program region, 64 KiB less the pages of their stored parameters, on both boards;");
    println!(" flash = .vector_table + .text + .rodata + .data; RAM = .data + .bss + .uninit;");
    println!(" stack = static worst case (start-up, or thread mode + each interrupt priority level); free = chip RAM - RAM - stack:");
    println!(" {} bytes on the STM32F103C8, {} on QEMU's lm3s6965)", chip_ram("stm32f103"), chip_ram("qemu"));
    for line in largest {
        println!("  {line}");
    }
    if over.is_empty() { Ok(()) } else { Err(format!("over budget:\n  {}", over.join("\n  "))) }
}

/// The QEMU command line for `elf` with its UART as a TCP server on
/// `listen` that waits for the first client (so no frame is lost).
pub fn qemu_command(elf: &Path, listen: &str) -> Command {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", "lm3s6965evb", "-cpu", "cortex-m3", "-display", "none", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"])
        // Virtual time: 2^4 ns per instruction; while the guest sleeps (WFI)
        // it passes in real time, so the node's timers keep wall-clock time.
        .args(["-icount", "shift=4,align=off,sleep=on"])
        // nodelay: without it QEMU's socket holds each answer back until the
        // client's delayed ACK (about 40 ms per SDO round trip instead of 2).
        .arg("-serial")
        .arg(format!("tcp:{listen},server=on,wait=on,nodelay=on"))
        .arg("-kernel")
        .arg(elf);
    cmd
}

pub(crate) fn have(program: &str) -> bool {
    Command::new(program).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
}

/// `cargo xtask qemu` options.
#[derive(clap::Args)]
pub struct QemuArgs {
    /// The device whose image to boot.
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(firmware::devices::ALL.iter().map(|d| d.name)))]
    device: String,
    /// Where the image's SLCAN UART listens.
    #[arg(long, value_name = "HOST:PORT", default_value = DEFAULT_LISTEN, value_parser = crate::host_port)]
    listen: String,
}

/// `cargo xtask qemu <device> [--listen HOST:PORT]`.
pub fn qemu(args: &QemuArgs) -> Result<(), String> {
    let device = args.device.as_str();
    let listen = args.listen.as_str();
    if !have("qemu-system-arm") {
        return Err("qemu-system-arm is missing: apt-get install -y --no-install-recommends qemu-system-arm".into());
    }
    ensure_target()?;
    build_board("qemu", Some(device))?;
    let elf = image_path(device, "qemu");
    let mut cmd = qemu_command(&elf, listen);
    // stdout carries defmt frames only: decoded if defmt-print is there, else kept in a file.
    let log = elf.with_extension("defmt");
    let decoder = have("defmt-print");
    if decoder {
        cmd.stdout(Stdio::piped());
    } else {
        cmd.stdout(std::fs::File::create(&log).map_err(|e| format!("{}: {e}", log.display()))?);
    }
    eprintln!("qemu: {device} on lm3s6965evb, SLCAN on tcp:{listen} (waiting for a client)");
    eprintln!("qemu: end it with the frame 0x1FFFFFFF [45 58 49 54] (\"EXIT\") or Ctrl-C");
    let mut child = cmd.spawn().map_err(|e| format!("qemu-system-arm: {e}"))?;
    let mut printer = None;
    if decoder {
        if let Some(out) = child.stdout.take() {
            printer = Command::new("defmt-print").arg("-e").arg(&elf).stdin(out).spawn().ok();
        }
    } else {
        eprintln!("qemu: defmt log (undecoded) in {}; `cargo install defmt-print` to see it live", log.display());
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    if let Some(mut printer) = printer {
        // It ends at the end of QEMU's stdout.
        let _ = printer.wait();
    }
    if status.success() { Ok(()) } else { Err(format!("qemu ended with {status}")) }
}

/// `cargo xtask smoke`: python-canopen against every QEMU image.
pub fn smoke() -> Result<(), String> {
    if !have("qemu-system-arm") {
        return Err("qemu-system-arm is missing: apt-get install -y --no-install-recommends qemu-system-arm".into());
    }
    ensure_target()?;
    build_board("qemu", None)?;
    // The test checks each image's measured stack against its static estimate.
    let mut bounds = Vec::new();
    for device in &firmware::devices::ALL {
        let st = stack::estimate(&image_path(device.name, "qemu"), "qemu")?;
        bounds.push(format!("{}={}/{}", device.name, st.startup, st.running()));
    }
    let python = ensure_venv()?;
    let script = root().join("tests/python/test_qemu_smoke.py");
    eprintln!("+ {} -m unittest -v {}", python.display(), script.display());
    let mut child = Command::new(&python)
        .args(["-m", "unittest", "-v"])
        .arg(&script)
        .env("QEMU_SMOKE", "1")
        .env("QEMU_STACK_BOUNDS", bounds.join(","))
        .current_dir(root())
        .spawn()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return if status.success() { Ok(()) } else { Err(format!("QEMU smoke tests failed ({status})")) };
        }
        if start.elapsed() > SMOKE_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("QEMU smoke tests killed after {} s", SMOKE_TIMEOUT.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The venv `cargo xtask test` also uses, with python-can and canopen.
pub(crate) fn ensure_venv() -> Result<PathBuf, String> {
    let python = root().join(".venv/bin/python");
    let ready = Command::new(&python).args(["-c", "import can, canopen, serial"]).status().is_ok_and(|s| s.success());
    if !ready {
        run("python3", &["-m", "venv", ".venv"])?;
        let py = python.to_str().ok_or("non-UTF-8 path")?;
        run(py, &["-m", "pip", "install", "--quiet", "python-can", "canopen", "pyserial"])?;
    }
    Ok(python)
}

#[cfg(test)]
mod tests {
    use super::{flash_budget, node_in_bss};

    #[test]
    fn a_drive_may_fill_its_program_region_the_others_48_kib() {
        // The drives' sets (their writable values) fit a page each: 2 KiB of storage.
        assert_eq!(flash_budget("ec5000"), 62 * 1024);
        assert_eq!(flash_budget("agile"), 62 * 1024);
        assert_eq!(flash_budget("bmaxx4400"), 62 * 1024);
        assert_eq!(flash_budget("sendix"), 48 * 1024);
        assert_eq!(flash_budget("unitek-ds"), 48 * 1024);
    }

    #[test]
    fn the_node_must_be_in_bss() {
        let nm = "20000060 b ec5000_qemu::__cortex_m_rt_main::NODE\n0000d900 r canopen_firmware::devices::ec5000::od::ENTRIES\n";
        assert_eq!(node_in_bss(nm), Ok(()));
        assert_eq!(node_in_bss(&nm.replace(" b ", " B ")), Ok(()));
        let in_data = node_in_bss(&nm.replace(" b ", " d "));
        assert!(in_data.as_ref().is_err_and(|e| e.contains("symbol class `d`")), "{in_data:?}");
        assert!(node_in_bss("0000d900 r canopen_firmware::devices::ec5000::od::ENTRIES\n").is_err());
    }
}
