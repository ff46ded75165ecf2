//! Byte formats of the CANopen protocols, one file per service, and nothing
//! else: no state, no time. Every parser takes untrusted bytes and returns a
//! `Result`; every emitter writes a fixed-size array.

pub mod emcy;
pub mod lss;
pub mod nmt;
pub mod pdo_mapping;
pub mod sdo;
pub mod sdo_block;
pub mod sync;
pub mod time_stamp;
