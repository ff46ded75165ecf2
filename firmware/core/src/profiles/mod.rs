//! Device profiles on the application slot ([`crate::node::Application`]):
//! what a CiA device profile asks of a device beyond CiA 301, reached
//! through the dictionary and a sensor or drive trait, never a CAN frame.

pub mod cia406;
