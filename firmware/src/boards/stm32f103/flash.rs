//! [`HalfWordFlash`] on the stm32f1xx-hal flash writer. The HAL unlocks,
//! checks alignment and range, waits for the controller and verifies; it
//! needs no `unsafe` here.

use canopen_core::storage::StorageError;
use cortex_m::peripheral::DWT;
use stm32f1xx_hal::flash::{FlashSize, FlashWriter, Parts, SectorSize};

use super::flash_storage::{HalfWordFlash, Layout};
use crate::boards::systick;

/// Runs a flash erase or program and gives the time base back what the
/// stall took (the store runs with interrupts masked, docs/firmware.md "Storage").
fn stalling<R>(op: impl FnOnce() -> R) -> R {
    let start = DWT::cycle_count();
    let result = op();
    systick::account_stall(DWT::cycle_count().wrapping_sub(start));
    result
}

/// The flash controller of an STM32F103C8 (64 KiB, 1 KiB pages), holding
/// parameter sets of `REGION` bytes.
///
/// Built in a `const` without the peripheral (the image's node holds its
/// storage: [`canopen_core::node`]) and given it at start-up ([`Flash::attach`]);
/// until then every access fails.
pub struct Flash<const REGION: usize> {
    parts: Option<Parts>,
}

impl<const REGION: usize> Flash<REGION> {
    const LAYOUT: Layout = Layout::stm32f103c8(REGION);

    /// No flash controller yet.
    pub const UNATTACHED: Self = {
        let _ = Self::LAYOUT;
        Flash { parts: None }
    };

    /// Takes the constrained FLASH peripheral (after the clocks are set).
    pub fn attach(&mut self, parts: Parts) {
        self.parts = Some(parts);
    }

    fn writer(&mut self) -> Result<FlashWriter<'_>, StorageError> {
        Ok(self.parts.as_mut().ok_or(StorageError::Failed)?.writer(SectorSize::Sz1K, FlashSize::Sz64K))
    }
}

impl<const REGION: usize> HalfWordFlash for Flash<REGION> {
    fn layout(&self) -> Layout {
        Self::LAYOUT
    }

    fn erase_page(&mut self, offset: u32) -> Result<(), StorageError> {
        let mut writer = self.writer()?;
        stalling(|| writer.page_erase(offset)).map_err(|_| StorageError::Failed)
    }

    fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError> {
        let mut writer = self.writer()?;
        stalling(|| writer.write(offset, &half_word.to_le_bytes())).map_err(|_| StorageError::Failed)
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        // The HAL rejects an odd offset (`FlashWriter::read`): callers read whole half-words.
        let writer = self.writer()?;
        let bytes = writer.read(offset, buf.len()).map_err(|_| StorageError::OutOfRange)?;
        buf.copy_from_slice(bytes);
        Ok(())
    }
}
