//! Test support for the whole workspace.
//!
//! [`corpus`] holds one generated dictionary per valid file in
//! `eds-corpus/`: that it compiles (also for `thumbv7m-none-eabi`, as CI
//! checks) proves that od-gen's output builds into the no_std core for the
//! EDS files real vendors and tools write.
#![no_std]
#![forbid(unsafe_code)]

/// Dictionaries generated from the real EDS/DCF corpus.
pub mod corpus {
    include!(concat!(env!("OUT_DIR"), "/corpus.rs"));
}
