//! [`HalfWordFlash`] on the stm32f1xx-hal flash writer. The HAL unlocks,
//! checks alignment and range, waits for the controller and verifies; it
//! needs no `unsafe` here.

use canopen_core::storage::StorageError;
use stm32f1xx_hal::flash::{FlashSize, FlashWriter, Parts, SectorSize};

use super::flash_storage::{HalfWordFlash, PAGE};

/// The flash controller of an STM32F103C8 (64 KiB, 1 KiB pages).
///
/// Built in a `const` without the peripheral (the image's node, which holds
/// its storage, lies in `.bss`) and given it at start-up ([`Flash::attach`]);
/// until then every access fails.
pub struct Flash {
    parts: Option<Parts>,
}

impl Flash {
    /// No flash controller yet.
    pub const UNATTACHED: Flash = Flash { parts: None };

    /// Takes the constrained FLASH peripheral (after the clocks are set).
    pub fn attach(&mut self, parts: Parts) {
        self.parts = Some(parts);
    }

    fn writer(&mut self) -> Result<FlashWriter<'_>, StorageError> {
        Ok(self.parts.as_mut().ok_or(StorageError::Failed)?.writer(SectorSize::Sz1K, FlashSize::Sz64K))
    }
}

impl HalfWordFlash for Flash {
    fn erase_page(&mut self, offset: u32) -> Result<(), StorageError> {
        self.writer()?.erase(offset, PAGE).map_err(|_| StorageError::Failed)
    }

    fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError> {
        self.writer()?.write(offset, &half_word.to_le_bytes()).map_err(|_| StorageError::Failed)
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        let writer = self.writer()?;
        let bytes = writer.read(offset, buf.len()).map_err(|_| StorageError::OutOfRange)?;
        buf.copy_from_slice(bytes);
        Ok(())
    }
}
