//! Device profiles on the application slot ([`crate::node::Application`]):
//! what a CiA device profile asks of a device beyond CiA 301, reached
//! through the dictionary ([`crate::node::Ctx`]) and a drive or sensor
//! trait, never a CAN frame.

pub mod cia402;
pub mod cia406;
