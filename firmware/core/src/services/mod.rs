//! The CANopen state machines. They never touch a clock, a driver or a
//! `static`: time comes in as an argument and frames go out through the
//! caller.

pub mod emcy;
pub mod heartbeat;
pub mod lss;
pub mod nmt;
pub mod pdo;
pub mod sdo_server;
pub mod store;
pub mod sync;
