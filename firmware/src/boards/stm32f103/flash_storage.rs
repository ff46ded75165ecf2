//! The core's two-region [`Storage`] on STM32F1 flash: each region is two
//! 1 KiB pages at the end of the 64 KiB flash, so the 60 KiB below them
//! stay for the program (the root `memory.x`). Two pages, because the
//! largest RAM image (b maXX 4400, 1090 bytes) plus the store header does
//! not fit one.
//!
//! STM32F1 flash is programmed a half-word at a time, and a half-word can be
//! programmed only once after an erase (RM0008 §3.3.3, PM0075 §2.3.3). The
//! core writes byte ranges of any alignment, front to back, then the header
//! at offset 0; an odd trailing byte therefore waits here until the next
//! byte of the same half-word arrives, or is programmed with 0xFF as its
//! partner before anything else happens.

use canopen_core::storage::{Storage, StorageError};

/// Bytes of a flash page (STM32F103 medium density).
pub const PAGE: usize = 1024;
/// Bytes of a region.
pub const REGION_BYTES: usize = 2 * PAGE;
/// Offset of region 0 from the start of flash: the last 4 KiB of 64 KiB.
pub const STORAGE_OFFSET: u32 = 60 * 1024;

/// Half-word flash as the chip offers it; offsets count from the start of
/// flash.
pub trait HalfWordFlash {
    /// Erases the page holding `offset`.
    fn erase_page(&mut self, offset: u32) -> Result<(), StorageError>;
    /// Programs the erased half-word at the even `offset`.
    fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError>;
    /// Reads `buf.len()` bytes at `offset`.
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError>;
}

/// Two regions of `REGION` bytes (at most [`REGION_BYTES`]) on `F`.
pub struct FlashStorage<F, const REGION: usize> {
    flash: F,
    /// A byte at an even offset whose partner has not been written yet.
    pending: Option<(u32, u8)>,
}

impl<F: HalfWordFlash, const REGION: usize> FlashStorage<F, REGION> {
    const FITS: () = assert!(REGION <= REGION_BYTES, "the RAM image does not fit a storage region");

    /// Storage on `flash`.
    pub const fn new(flash: F) -> Self {
        let () = Self::FITS;
        FlashStorage { flash, pending: None }
    }

    /// The flash, for a board that hands it its peripheral at start-up.
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    fn address(region: u8, offset: usize, len: usize) -> Result<u32, StorageError> {
        let end = offset.checked_add(len).ok_or(StorageError::OutOfRange)?;
        if region > 1 || end > REGION {
            return Err(StorageError::OutOfRange);
        }
        Ok(STORAGE_OFFSET + u32::from(region) * REGION_BYTES as u32 + offset as u32)
    }

    /// Programs a waiting odd byte with 0xFF as its partner.
    fn flush(&mut self) -> Result<(), StorageError> {
        match self.pending.take() {
            Some((at, low)) => self.flash.program(at, u16::from_le_bytes([low, 0xFF])),
            None => Ok(()),
        }
    }
}

impl<F: HalfWordFlash, const REGION: usize> Storage for FlashStorage<F, REGION> {
    fn region_size(&self) -> usize {
        REGION
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let at = Self::address(region, offset, buf.len())?;
        self.flash.read(at, buf)?;
        // A byte still waiting for its partner reads as what was written.
        if let Some((p, low)) = self.pending
            && let Some(byte) = p.checked_sub(at).and_then(|i| buf.get_mut(i as usize))
        {
            *byte = low;
        }
        Ok(())
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        let start = Self::address(region, 0, REGION)?;
        if self.pending.is_some_and(|(p, _)| (start..start + REGION_BYTES as u32).contains(&p)) {
            self.pending = None;
        }
        (0..REGION_BYTES / PAGE).try_for_each(|page| self.flash.erase_page(start + (page * PAGE) as u32))
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let mut at = Self::address(region, offset, data.len())?;
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

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use canopen_core::od::{Attr, ObjectDictionary};
    use canopen_core::services::store::{self, Part, Scope};

    /// Flash with the chip's rules: erase per page, program a half-word once.
    struct FakeFlash {
        mem: std::vec::Vec<u8>,
        programmed: std::vec::Vec<bool>,
    }

    impl FakeFlash {
        fn new() -> Self {
            FakeFlash { mem: std::vec![0xFF; 64 * 1024], programmed: std::vec![false; 32 * 1024] }
        }
    }

    impl HalfWordFlash for FakeFlash {
        fn erase_page(&mut self, offset: u32) -> Result<(), StorageError> {
            let start = offset as usize / PAGE * PAGE;
            self.mem[start..start + PAGE].fill(0xFF);
            self.programmed[start / 2..(start + PAGE) / 2].fill(false);
            Ok(())
        }

        fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError> {
            let at = offset as usize;
            assert_eq!(at % 2, 0, "misaligned program at {at:#x}");
            assert!(at >= STORAGE_OFFSET as usize, "program below the storage pages at {at:#x}");
            assert!(!self.programmed[at / 2], "half-word at {at:#x} programmed twice");
            self.programmed[at / 2] = true;
            self.mem[at..at + 2].copy_from_slice(&half_word.to_le_bytes());
            Ok(())
        }

        fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
            let at = offset as usize;
            buf.copy_from_slice(&self.mem[at..at + buf.len()]);
            Ok(())
        }
    }

    #[test]
    fn odd_writes_become_whole_half_words() {
        let mut s = FlashStorage::<_, 64>::new(FakeFlash::new());
        s.erase(1).unwrap();
        s.write(1, 24, &[1, 2, 3]).unwrap();
        s.write(1, 27, &[4]).unwrap();
        s.write(1, 28, &[5]).unwrap();
        s.write(1, 29, &[6, 7]).unwrap();
        let mut buf = [0u8; 7];
        s.read(1, 24, &mut buf).unwrap();
        assert_eq!(buf, [1, 2, 3, 4, 5, 6, 7], "the pending byte reads back");
        s.write(1, 0, &[9; 24]).unwrap();
        s.read(1, 24, &mut buf).unwrap();
        assert_eq!(buf, [1, 2, 3, 4, 5, 6, 7]);
        let mut head = [0u8; 24];
        s.read(1, 0, &mut head).unwrap();
        assert_eq!(head, [9; 24]);
        // A lone odd byte after a gap.
        s.write(1, 41, &[0xAB]).unwrap();
        s.write(1, 50, &[]).unwrap();
        let mut b = [0u8; 3];
        s.read(1, 40, &mut b).unwrap();
        assert_eq!(b, [0xFF, 0xAB, 0xFF]);
        assert_eq!(s.write(2, 0, &[1]), Err(StorageError::OutOfRange));
        assert_eq!(s.write(0, 63, &[1, 2]), Err(StorageError::OutOfRange));
    }

    /// The core's store/restore on this storage, with the largest image.
    #[test]
    fn the_core_saves_and_loads_the_largest_image() {
        use crate::devices::bmaxx4400::od;
        let mut s = FlashStorage::<_, { crate::boards::region_size(od::RAM_SIZE) }>::new(FakeFlash::new());
        let mut ram = od::Ram::new(1);
        let d = ram.dictionary();
        assert!(s.region_size() <= REGION_BYTES);
        // Change the last writable value that is not node-id relative.
        let e = d.entries.iter().rev().find(|e| e.writable() && !e.in_rom() && e.len > 0 && !e.attr.contains(Attr::NODE_ID)).unwrap();
        ram.image_mut()[e.range().start] ^= 0x5A;
        for _ in 0..3 {
            // Alternates regions; every load must find the newest set.
            store::save(d, ram.image(), 1, &mut s, Scope::All).unwrap();
        }
        let mut fresh = od::Ram::new(1);
        for part in [Part::Communication, Part::Application] {
            assert!(store::load(d, fresh.image_mut(), 1, &mut s, part));
        }
        assert_eq!(fresh.image(), ram.image());
    }
}
