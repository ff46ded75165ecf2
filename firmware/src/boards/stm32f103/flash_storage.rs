//! The core's two-region [`Storage`] on STM32F1 flash.
//!
//! STM32F1 flash is read, programmed and erased by the rules of RM0008 §3.3
//! and PM0075 §2.3, which stm32f1xx-hal's `FlashWriter` enforces and the
//! host model (`hal_host::storage`) checks in every test:
//! - reads start at an even offset (the HAL rejects an odd one); this
//!   storage reads whole half-words and picks the bytes asked for;
//! - a half-word is programmed once after an erase (programming one that
//!   is not 0xFFFF fails with PGERR), at an even offset;
//! - erase works on whole pages: 1 KiB on low- and medium-density parts
//!   (the F103C8), 2 KiB on high-density and connectivity-line parts.
//!
//! The core writes byte ranges of any alignment, front to back, then the
//! header at offset 0; an odd trailing byte therefore waits here until the
//! next byte of the same half-word arrives, or is programmed with 0xFF as
//! its partner before anything else happens. A store erases only the pages
//! the set occupies ([`Layout::region`] rounded up to pages), and each
//! region has just those pages ([`Layout::stm32f103c8`]): one for every
//! image but the b maXX 4400's, whose set takes two.

use canopen_core::storage::{Storage, StorageError};

/// Where the two regions lie in a flash and how that flash erases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Offset of region 0 from the start of flash (a page boundary).
    pub base: u32,
    /// Bytes of an erase page.
    pub page: u32,
    /// Bytes from region 0 to region 1 (whole pages).
    pub stride: u32,
    /// Bytes of a region a parameter set may use (at most `stride`).
    pub region: u32,
}

impl Layout {
    /// STM32F103C8 (64 KiB, 1 KiB pages) for sets of `region` bytes (what
    /// the image's set needs, `boards::region_size`): each region has the
    /// whole pages one set needs (at least one), and the two lie at the end
    /// of flash, region 1 right after region 0, so the program gets all
    /// below [`Layout::base`] (the image's `memory.x` region, which the
    /// firmware's build script sizes the same way: [`super::LINKED_STORAGE_KIB`]).
    /// One page for every set but the b maXX 4400's (1090 bytes of RAM image
    /// plus the store header), which takes two.
    pub const fn stm32f103c8(region: usize) -> Layout {
        const PAGE: u32 = 1024;
        const FLASH: u32 = 64 * 1024;
        let pages = if region == 0 { 1 } else { region.div_ceil(PAGE as usize) };
        // Half the flash at most: the program needs the rest.
        assert!(pages <= 16, "the RAM image does not fit a storage region");
        let stride = pages as u32 * PAGE;
        let layout = Layout { base: FLASH - 2 * stride, page: PAGE, stride, region: region as u32 };
        assert!(layout.is_valid(), "the RAM image does not fit a storage region");
        layout
    }

    /// Whether the regions start on pages, do not overlap and hold `region` bytes.
    pub const fn is_valid(&self) -> bool {
        self.page >= 2
            && self.page.is_multiple_of(2)
            && self.base.is_multiple_of(self.page)
            && self.stride.is_multiple_of(self.page)
            && self.region <= self.stride
            && self.region.is_multiple_of(2)
    }

    /// Pages a store erases: those the region's `region` bytes occupy.
    pub const fn pages_per_set(&self) -> u32 {
        self.region.div_ceil(self.page)
    }
}

/// Half-word flash as the chip offers it; offsets count from the start of
/// flash. Each call follows the chip's rules; a call that breaks one fails.
pub trait HalfWordFlash {
    /// Where the regions are and how large a page is.
    fn layout(&self) -> Layout;
    /// Erases the page starting at `offset` (a multiple of the page size).
    fn erase_page(&mut self, offset: u32) -> Result<(), StorageError>;
    /// Programs the erased half-word at the even `offset`.
    fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError>;
    /// Reads whole half-words: `buf.len()` (even) bytes at the even `offset`.
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError>;
}

/// Two regions (see [`Layout`]) on `F`.
#[derive(Clone, Debug)]
pub struct FlashStorage<F> {
    flash: F,
    /// A byte at an even offset whose partner has not been written yet.
    pending: Option<(u32, u8)>,
}

impl<F: HalfWordFlash> FlashStorage<F> {
    /// Storage on `flash`.
    pub const fn new(flash: F) -> Self {
        FlashStorage { flash, pending: None }
    }

    /// The flash, for a board that hands it its peripheral at start-up.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// The flash.
    pub fn flash(&self) -> &F {
        &self.flash
    }

    fn address(&self, region: u8, offset: usize, len: usize) -> Result<u32, StorageError> {
        let layout = self.flash.layout();
        let end = offset.checked_add(len).ok_or(StorageError::OutOfRange)?;
        if region > 1 || end > layout.region as usize {
            return Err(StorageError::OutOfRange);
        }
        Ok(layout.base + u32::from(region) * layout.stride + offset as u32)
    }

    /// Programs a waiting odd byte with 0xFF as its partner.
    fn flush(&mut self) -> Result<(), StorageError> {
        match self.pending.take() {
            Some((at, low)) => self.flash.program(at, u16::from_le_bytes([low, 0xFF])),
            None => Ok(()),
        }
    }
}

impl<F: HalfWordFlash> Storage for FlashStorage<F> {
    fn region_size(&self) -> usize {
        self.flash.layout().region as usize
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let at = self.address(region, offset, buf.len())?;
        // Whole half-words from the one at or below `at`, in chunks.
        let end = at + buf.len() as u32;
        let mut chunk = [0u8; 32];
        let mut pos = at & !1;
        while pos < end {
            let n = (end.next_multiple_of(2) - pos).min(chunk.len() as u32);
            let half_words = chunk.get_mut(..n as usize).ok_or(StorageError::OutOfRange)?;
            self.flash.read(pos, half_words)?;
            for (i, &byte) in half_words.iter().enumerate() {
                if let Some(slot) = (pos + i as u32).checked_sub(at).and_then(|j| buf.get_mut(j as usize)) {
                    *slot = byte;
                }
            }
            pos += n;
        }
        // A byte still waiting for its partner reads as what was written.
        if let Some((p, low)) = self.pending
            && let Some(byte) = p.checked_sub(at).and_then(|i| buf.get_mut(i as usize))
        {
            *byte = low;
        }
        Ok(())
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        let layout = self.flash.layout();
        let start = self.address(region, 0, 0)?;
        if self.pending.is_some_and(|(p, _)| (start..start + layout.stride).contains(&p)) {
            self.pending = None;
        }
        (0..layout.pages_per_set()).try_for_each(|page| self.flash.erase_page(start + page * layout.page))
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let mut at = self.address(region, offset, data.len())?;
        let mut bytes = data.iter().copied();
        match self.pending {
            Some((p, low)) if p + 1 == at => {
                if let Some(high) = bytes.next() {
                    self.pending = None;
                    self.flash.program(p, u16::from_le_bytes([low, high]))?;
                    at += 1;
                }
            }
            Some(_) if !data.is_empty() => self.flush()?,
            _ => {}
        }
        if at % 2 == 1 {
            // The low byte of this half-word was never written: it stays 0xFF.
            if let Some(high) = bytes.next() {
                self.flash.program(at - 1, u16::from_le_bytes([0xFF, high]))?;
                at += 1;
            }
        }
        loop {
            match (bytes.next(), bytes.next()) {
                (Some(low), Some(high)) => {
                    self.flash.program(at, u16::from_le_bytes([low, high]))?;
                    at += 2;
                }
                (Some(low), None) => {
                    self.pending = Some((at, low));
                    return Ok(());
                }
                _ => return Ok(()),
            }
        }
    }
}
