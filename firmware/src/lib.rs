//! Device firmware on canopen-core.
//!
//! Each device is its EDS (`eds/<device>.eds`, turned into an object
//! dictionary by `build.rs`) plus one short module in [`devices`]. An image
//! is a device on a board: [`boards`] holds the QEMU and STM32F103 boards,
//! [`can_node`] the node behind a trait object, [`runner`] the CANopen
//! task's work, `shared` (MCU builds and unit tests) the channels around it
//! and the task's loop, [`slcan`] the SLCAN codec (the QEMU board's and
//! hal-host's), `app` (MCU builds only) embassy-time and the
//! application slot, and `src/bin/` one
//! `<device>-<board>` entry point per image (see `docs/firmware.md`).
#![no_std]
// Unsafe code stays denied (workspace lints); only `boards` allows it, per
// module, with a `// SAFETY:` comment on every block.
#![deny(unsafe_code)]

#[cfg(target_os = "none")]
pub mod app;
pub mod boards;
pub mod can_node;
pub mod devices;
pub mod runner;
#[cfg(any(target_os = "none", test))]
pub mod shared;
pub mod slcan;

/// What [`image!`] expands to, reached through this crate so that a crate
/// using the macro needs no dependency for it.
#[cfg(target_os = "none")]
#[doc(hidden)]
pub mod __private {
    pub use static_cell::ConstStaticCell;
}
