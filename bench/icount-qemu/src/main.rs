//! `canopen-icount-qemu`: instructions per handled frame on thumbv7m, and
//! the worst case for one received frame, measured in QEMU's lm3s6965evb
//! under `-icount shift=0` (see [`clock`]). `cargo xtask icount` builds and
//! runs it after the host bench and prints its figures beside the host's.
//!
//! The node and the frames are `canopen-icount`'s (the host bench's), and
//! the node is called through the firmware's `can_node::CanNode` trait object, as
//! the firmware's CANopen task calls it. Results go to semihosting stdout as
//! `icount-qemu ...` lines of `key=value` fields; the image exits through
//! semihosting with 0 only if every replayed frame got exactly the answers
//! its sequence expects.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod clock;
#[cfg(target_os = "none")]
mod image;
#[cfg(target_os = "none")]
mod isr;

/// On the host there is nothing to run: the image is for QEMU.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("canopen-icount-qemu is a thumbv7m image for QEMU's lm3s6965evb; `cargo xtask icount` builds and runs it");
    std::process::exit(2);
}
