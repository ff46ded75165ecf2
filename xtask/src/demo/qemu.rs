//! The demo's QEMU side: build and boot an image with its SLCAN UART on a
//! free TCP port, a watchdog, and the exit frame.

use std::process::{Child, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use hal_host::decode::EXIT_ID;
use hal_host::live::LiveMaster;

use crate::{ensure_apt, ensure_target, images, root};

/// QEMU is killed after this long, whatever happens.
const QEMU_TIMEOUT: Duration = Duration::from_secs(60);
/// Builds `<device>-qemu`, boots it with its SLCAN UART on a free TCP port,
/// runs `session` on that address, and makes sure QEMU ends.
pub(super) fn in_qemu(device: &str, session: impl FnOnce(&str, &Mutex<Child>) -> Result<(), String>) -> Result<(), String> {
    ensure_apt(&[("qemu-system-arm", "qemu-system-arm")])?;
    ensure_target()?;
    images::build_board("qemu", Some(device))?;
    let elf = images::image_path(device, "qemu");
    let port = std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map_err(|e| e.to_string())?.port();
    let addr = format!("127.0.0.1:{port}");
    let target_dir = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), std::path::PathBuf::from);
    let logs = target_dir.join("qemu-demo");
    std::fs::create_dir_all(&logs).map_err(|e| format!("{}: {e}", logs.display()))?;
    let defmt = logs.join(format!("{device}.defmt"));
    let mut cmd = images::qemu_command(&elf, &addr);
    cmd.stdout(std::fs::File::create(&defmt).map_err(|e| format!("{}: {e}", defmt.display()))?).stderr(Stdio::null());
    eprintln!("demo: {device}-qemu on lm3s6965evb, SLCAN on tcp:{addr}; defmt log in {}", defmt.display());
    let child = Arc::new(Mutex::new(cmd.spawn().map_err(|e| format!("qemu-system-arm: {e}"))?));
    let watchdog = spawn_watchdog(Arc::clone(&child));
    let result = session(&addr, &child);
    // Whatever happened, QEMU does not outlive the demo.
    let mut c = child.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if c.try_wait().ok().flatten().is_none() {
        let _ = c.kill();
        let _ = c.wait();
    }
    drop(c);
    drop(watchdog);
    result
}

/// Sends the exit frame and waits up to 5 s for QEMU's exit code.
pub(super) fn send_exit(m: &mut LiveMaster, child: &Mutex<Child>) -> Result<Option<i32>, String> {
    let frame = canopen_core::frame::CanFrame::extended(EXIT_ID, b"EXIT\x00").ok_or("exit frame")?;
    m.send(frame).map_err(|e| format!("SLCAN connection: {e}"))?;
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let status = child.lock().unwrap_or_else(std::sync::PoisonError::into_inner).try_wait().map_err(|e| e.to_string())?;
        if let Some(status) = status {
            return Ok(Some(status.code().unwrap_or(-1)));
        }
        if Instant::now() > deadline {
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Kills QEMU once [`QEMU_TIMEOUT`] has passed; ends with it.
fn spawn_watchdog(child: Arc<Mutex<Child>>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let start = Instant::now();
        loop {
            std::thread::sleep(Duration::from_millis(100));
            let mut c = child.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            if c.try_wait().ok().flatten().is_some() {
                return;
            }
            if start.elapsed() > QEMU_TIMEOUT {
                eprintln!("demo: QEMU still running after {} s: killed", QEMU_TIMEOUT.as_secs());
                let _ = c.kill();
                let _ = c.wait();
                return;
            }
        }
    })
}
