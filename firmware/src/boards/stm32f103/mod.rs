//! The STM32F103C8 board ("Blue Pill": 8 MHz crystal, CAN on PA11/PA12
//! through a transceiver).
//!
//! - **Clocks**: HSE 8 MHz → 72 MHz core, 36 MHz APB1 (the CAN clock).
//! - **CAN**: bxCAN through the `bxcan` crate on stm32f1xx-hal. The bit rate
//!   is the node's (stored by LSS), else the device's start-up one, else the
//!   image's `Config::bit_rate_kbps`, turned into BTR by [`bit_timing`]; an
//!   LSS "activate bit timing" re-initialises the controller. Received frames
//!   go from the FIFO 0 interrupt to the CANopen task; the task fills every
//!   free mailbox from the node's queue, and the TX-empty interrupt wakes it
//!   when one is free. Both read and write the mailboxes through the
//!   registers ([`mailbox`]); the controller runs in TX FIFO mode, so a
//!   burst leaves back to back in the queue's order. RX overruns (FIFO or channel), error passive and
//!   bus-off recoveries are counted for the CANopen task, whose node raises
//!   EMCY 0x8110, 0x8120 and 0x8140 (`Node::controller_event`). The acceptance filter passes the
//!   identifiers the node consumes ([`filters`]), reprogrammed whenever that
//!   list changes (see `docs/firmware.md`).
//! - **Storage**: [`flash_storage`] on the last 4 KiB of flash.
//! - **Executors**: the CANopen task owns the node and runs on an interrupt
//!   executor at the priority of the CAN interrupts; the application slot
//!   runs in thread mode and reaches the node through requests.
//! - **Logs**: defmt over RTT; a panic logs its location and stops with
//!   `udf` (as panic-probe does, without its `core::fmt` cost).

pub mod bit_timing;
pub mod filters;
pub mod flash_storage;
pub mod mailbox;
pub mod reset_cause;

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod board;
#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod can;
#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod flash;

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
pub use board::{Config, Storage, StorageHandle, run, unattached_storage};
