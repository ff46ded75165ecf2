//! The no_std CANopen slave core.
//!
//! This crate is sans-IO: it never touches a clock, a CAN controller or a
//! `static`. Everything a node needs comes in as arguments, which is why it
//! builds unchanged for `thumbv7m-none-eabi` and for host tests.
//!
//! Layers (see `docs/` and the style guide):
//! - [`od`]: the runtime side of an object dictionary that `od-gen` generated
//!   from an EDS: flash tables of entry metadata, one RAM image of values.
//! - [`frame`]: the [`frame::CanFrame`] that crosses the boundary (an `embedded_can::Frame`).
//! - [`storage`]: the two-region [`storage::Storage`] trait behind store/restore.
//! - [`time`]: the [`time::Instant`]s and [`time::Duration`]s callers pass in.
//! - [`id`]: node-IDs, COB-ID entries and the restricted CAN-IDs.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
// Nothing panics on input (docs: style guide §2.3): no indexing or slicing,
// `unwrap`, `expect` or `panic!` in the library; tests may use them. No
// arithmetic that can overflow either: counters and positions wrap
// (`wrapping_*`), and every other `+ - * / %` carries a narrow
// `#[allow(clippy::arithmetic_side_effects)]` with the reason it cannot
// overflow (`Instant` and `Duration` saturate: clippy.toml).
#![cfg_attr(
    not(test),
    deny(clippy::indexing_slicing, clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::arithmetic_side_effects)
)]

pub mod abort;
pub mod axis;
pub mod frame;
pub mod id;
pub mod node;
pub mod od;
pub mod profiles;
pub mod services;
pub mod storage;
pub mod time;
pub mod txq;
pub mod wire;
