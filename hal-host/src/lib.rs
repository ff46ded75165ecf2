//! Host support for running canopen-core nodes on a PC.
//!
//! - [`clock`]: the virtual clock tests advance; a node never sees wall time.
#![forbid(unsafe_code)]

pub mod clock;
