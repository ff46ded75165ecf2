//! The QEMU board: lm3s6965evb (Cortex-M3) under `qemu-system-arm`.
//!
//! QEMU emulates no CAN controller, so the board plays a serial CAN adapter
//! (SLCAN, [`slcan`]) on UART0 whose only other bus member is the node; the
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
//! only, so this frame never means anything to a node.

pub mod ram_storage;
pub mod slcan;

#[cfg(all(target_os = "none", feature = "board-qemu"))]
mod board;
#[cfg(all(target_os = "none", feature = "board-qemu"))]
mod uart;

#[cfg(all(target_os = "none", feature = "board-qemu"))]
pub use board::{Config, Storage, run};

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

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    #[test]
    fn only_the_exit_frame_exits() {
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXIT").unwrap()), Some(0));
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXIT\x03").unwrap()), Some(3));
        assert_eq!(exit_request(&CanFrame::extended(EXIT_ID, b"EXI").unwrap()), None);
        assert_eq!(exit_request(&CanFrame::extended(0x1FFF_FFFE, b"EXIT").unwrap()), None);
        assert_eq!(exit_request(&CanFrame::standard(0x7FF, b"EXIT").unwrap()), None);
    }
}
