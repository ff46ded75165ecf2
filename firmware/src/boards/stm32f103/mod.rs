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
//! - **Storage**: [`flash_storage`] on the last pages of flash, two regions
//!   of the pages the image's parameter set needs (2 KiB in all for a set
//!   that fits a page, 4 KiB for the b maXX 4400's); the program gets the
//!   rest ([`LINKED_STORAGE_KIB`]).
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

use flash_storage::Layout;

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod board;
#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod can;
#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod flash;

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
pub use board::{Config, Storage, StorageHandle, run, unattached_storage};

/// KiB of flash the build script has the linker leave after the program of
/// each of this crate's STM32F103 images, by image name: the stored
/// parameters' two regions (`--defsym=__storage_kib`, root `memory.x`),
/// sized from the stored set od-gen computes (`STORED_SIZE`), as [`Layout::stm32f103c8`]
/// sizes them from `STORED_SIZE`. [`check_link`] checks that the two agree.
pub const LINKED_STORAGE_KIB: [(&str, u32); 5] = include!(concat!(env!("OUT_DIR"), "/linked_storage.rs"));

/// KiB of flash an image without its own `__storage_kib` leaves after its
/// program (the template and out-of-tree images; `memory.x`'s fallback):
/// room for two regions of two pages, any set up to 2 KiB.
pub const DEFAULT_STORAGE_KIB: u32 = 4;

/// Bytes of flash the image `image` (its bin name) links its program into:
/// the 64 KiB less its [`LINKED_STORAGE_KIB`], or less
/// [`DEFAULT_STORAGE_KIB`] for an image not of this crate.
pub const fn program_flash(image: &str) -> u32 {
    let kib = match linked_storage_kib(image) {
        Some(kib) => kib,
        None => DEFAULT_STORAGE_KIB,
    };
    FLASH - kib * 1024
}

/// Stops the build of the image `image` (its bin name, `CARGO_BIN_NAME`)
/// with sets of `region` bytes if its storage regions and its program's
/// flash disagree: for this crate's images the regions start right where
/// the program's flash ends, for other images at or after it.
pub const fn check_link(image: &str, region: usize) {
    let base = Layout::stm32f103c8(region).base;
    match linked_storage_kib(image) {
        Some(kib) => assert!(base == FLASH - kib * 1024, "the storage regions do not start where build.rs ends the program's flash"),
        None => assert!(base >= program_flash(image), "the storage regions overlap the program's flash (memory.x)"),
    }
}

/// Bytes of flash of an STM32F103C8.
const FLASH: u32 = 64 * 1024;

/// The [`LINKED_STORAGE_KIB`] of `image`, if it is one of this crate's.
const fn linked_storage_kib(image: &str) -> Option<u32> {
    let mut i = 0;
    while i < LINKED_STORAGE_KIB.len() {
        let (name, kib) = LINKED_STORAGE_KIB[i];
        if same(name.as_bytes(), image.as_bytes()) {
            return Some(kib);
        }
        i += 1;
    }
    None
}

/// `a == b`, in a `const fn`.
const fn same(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boards::region_size;

    #[test]
    fn the_storage_of_each_image_starts_where_its_program_ends() {
        assert_eq!(LINKED_STORAGE_KIB.len(), crate::devices::ALL.len());
        for (image, _) in LINKED_STORAGE_KIB {
            let device = image.strip_suffix("-stm32f103").and_then(crate::devices::by_name).expect("an image of a device");
            check_link(image, region_size(device.dictionary.stored_len));
        }
        // Images of your own keep 4 KiB: sets of one page or two fit.
        check_link("my-device", 1000);
        check_link("my-device", 2048);
    }

    #[test]
    #[should_panic(expected = "do not start where build.rs ends")]
    fn a_set_other_than_the_linked_one_is_refused() {
        // Its set fits one page: a region of two is not the linked one.
        check_link("bmaxx4400-stm32f103", 1100);
    }

    #[test]
    #[should_panic(expected = "overlap the program")]
    fn a_set_too_large_for_the_default_storage_is_refused() {
        check_link("my-device", 2050);
    }
}
