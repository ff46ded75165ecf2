//! The QEMU board: lm3s6965evb (Cortex-M3) under `qemu-system-arm`.
//!
//! QEMU emulates no CAN controller, so the board plays a serial CAN adapter
//! (SLCAN, [`crate::slcan`], answering as [`slcan`] says) on UART0 whose only other bus member is the node; the
//! host connects with python-can's `slcan` interface through the TCP socket
//! QEMU makes of the UART. Frames from the host pass a software acceptance
//! filter, the node's identifier list, as bxCAN's banks do on the STM32
//! (the rest are counted and dropped). Time comes from SysTick, storage is RAM
//! ([`ram_storage`]), defmt logs and the exit code leave through
//! semihosting.
//!
//! **Ending a run.** A 29-bit data frame with identifier `0x1FFF_FFFF` and
//! data `EXIT` (plus an optional status byte, 0 if absent) ends QEMU through
//! semihosting: status 0 exits with code 0, anything else with code 1. A
//! panic or HardFault exits with code 1. CANopen uses 11-bit identifiers
//! only, so this frame never means anything to a node. Before exiting, the
//! board reports the stack it used and the frames its filter dropped
//! ([`exit_report`], on QEMU's stderr):
//! `stack.rs` paints the stack at start-up and finds the high-water mark.

pub mod host_file;
pub mod ram_storage;
pub mod slcan;

#[cfg(all(target_os = "none", feature = "board-qemu"))]
mod board;
#[cfg(all(target_os = "none", feature = "board-qemu"))]
mod uart;

#[cfg(all(target_os = "none", feature = "board-qemu"))]
pub use board::{Config, Storage, StorageHandle, run, unattached_storage};

/// What the STM32F103 board's `check_link` checks (its storage regions
/// against the program's flash) has nothing to check here: the stored
/// parameters are in RAM ([`ram_storage`]).
pub const fn check_link(_image: &str, _region: usize) {}

use canopen_core::frame::CanFrame;
use embedded_can::Frame;

/// Identifier of the frame that ends a QEMU run.
pub const EXIT_ID: u32 = 0x1FFF_FFFF;
/// First data bytes of the frame that ends a QEMU run.
pub const EXIT_MAGIC: &[u8; 4] = b"EXIT";

/// The exit status `frame` asks for, if it is the exit frame.
pub fn exit_request(frame: &CanFrame) -> Option<u8> {
    let data = frame.data();
    let is_exit = frame.is_extended() && frame.raw_id() == EXIT_ID && !frame.is_remote_frame() && data.starts_with(EXIT_MAGIC);
    is_exit.then(|| data.get(EXIT_MAGIC.len()).copied().unwrap_or(0))
}

/// What the board reports when the exit frame arrives ([`exit_report`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExitReport {
    /// Bytes of stack used at most until the node was powered on.
    pub startup_stack: usize,
    /// Bytes of stack used at most from then to the exit frame.
    pub running_stack: usize,
    /// Bytes of stack available (painted).
    pub stack_size: usize,
    /// Frames the software acceptance filter dropped.
    pub rejected: usize,
    /// Received frames lost (channel full).
    pub lost: usize,
}

/// Bytes of the longest [`exit_report`] line.
pub const EXIT_REPORT_LEN: usize = 175;

/// The line the exit frame writes to QEMU's stderr (and the smoke tests
/// read without a defmt decoder): `stack: start-up S bytes, running R bytes
/// of N; filter rejected F frames, lost L` and a newline. Returns its
/// length; no `core::fmt`, which the image does not otherwise link.
pub fn exit_report(out: &mut [u8; EXIT_REPORT_LEN], report: &ExitReport) -> usize {
    let mut n = 0;
    let mut put = |bytes: &[u8]| {
        for &b in bytes {
            if let Some(slot) = out.get_mut(n) {
                *slot = b;
                n += 1;
            }
        }
    };
    let fields = [
        ("stack: start-up ", report.startup_stack),
        (" bytes, running ", report.running_stack),
        (" bytes of ", report.stack_size),
        ("; filter rejected ", report.rejected),
        (" frames, lost ", report.lost),
    ];
    for (text, value) in fields {
        put(text.as_bytes());
        let mut digits = [0u8; 20];
        let mut i = digits.len();
        let mut v = value;
        loop {
            i -= 1;
            if let Some(d) = digits.get_mut(i) {
                *d = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || i == 0 {
                break;
            }
        }
        put(digits.get(i..).unwrap_or(&[]));
    }
    put(b"\n");
    n
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    #[test]
    fn exit_report_is_one_plain_line() {
        let mut out = [0u8; EXIT_REPORT_LEN];
        let report = ExitReport { startup_stack: 5_712, running_stack: 0, stack_size: 64_876, rejected: 3, lost: 0 };
        let n = exit_report(&mut out, &report);
        assert_eq!(&out[..n], b"stack: start-up 5712 bytes, running 0 bytes of 64876; filter rejected 3 frames, lost 0\n");
        // The longest figures still fit whole.
        let max = usize::MAX;
        let report = ExitReport { startup_stack: max, running_stack: max, stack_size: max, rejected: max, lost: max };
        let n = exit_report(&mut out, &report);
        let expected =
            std::format!("stack: start-up {max} bytes, running {max} bytes of {max}; filter rejected {max} frames, lost {max}\n");
        assert_eq!(&out[..n], expected.as_bytes());
        assert_eq!(n, EXIT_REPORT_LEN);
    }

    #[test]
    fn only_the_exit_frame_exits() {
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXIT").unwrap()), Some(0));
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXIT\x03").unwrap()), Some(3));
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXI").unwrap()), None);
        assert_eq!(exit_request(&CanFrame::extended(0x1FFF_FFFE, b"EXIT").unwrap()), None);
        assert_eq!(exit_request(&CanFrame::standard(0x7FF, b"EXIT").unwrap()), None);
    }
}
