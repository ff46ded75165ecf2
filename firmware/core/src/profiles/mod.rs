//! Device profiles on the application slot ([`crate::node::Application`]):
//! they see the dictionary through [`crate::node::Ctx`] and a device behind
//! a trait, never a CAN frame.

pub mod cia402;
