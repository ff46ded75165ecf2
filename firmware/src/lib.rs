//! Device firmware on canopen-core.
//!
//! Each device is its EDS (`eds/<device>.eds`, turned into an object
//! dictionary by `build.rs`) plus one short module in [`devices`].
#![no_std]
#![forbid(unsafe_code)]

pub mod devices;
