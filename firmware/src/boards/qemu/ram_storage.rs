//! Storage for the QEMU board: two regions of RAM that behave like flash
//! (erase sets 0xFF, programming only clears bits). lm3s6965evb's flash
//! controller is not emulated by QEMU, so stored parameters last until the
//! emulator exits, unless QEMU's working directory holds the file
//! [`super::host_file::NAME`]: then every erase and write goes through to it and
//! start-up loads it, so the parameters survive a restart of QEMU (a power
//! cycle; `cargo xtask hil`).

use canopen_core::storage::{Storage, StorageError};

use super::host_file::HostFile;

/// What [`RamStorage::attach`] takes: nothing.
pub type StorageHandle = ();

/// Two regions of `REGION` bytes.
///
/// The bytes are kept inverted, so that an erased region (0xFF) is zero
/// bits: the image's node holds its storage and must be
/// ([`canopen_core::node`]).
#[derive(Clone, Debug)]
pub struct RamStorage<const REGION: usize> {
    /// Each byte's complement.
    regions: [[u8; REGION]; 2],
    /// The host file the regions are kept in, if any.
    file: Option<HostFile>,
}

impl<const REGION: usize> Default for RamStorage<REGION> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const REGION: usize> RamStorage<REGION> {
    /// Both regions erased.
    pub const fn new() -> Self {
        RamStorage { regions: [[0; REGION]; 2], file: None }
    }

    /// RAM needs no handle (the same start-up as the boards with a flash
    /// controller); loads the host file if there is one, or makes it erased.
    pub fn attach(&mut self, _handle: StorageHandle) {
        self.file = HostFile::open();
        let Some(file) = self.file else { return };
        let loaded = file.size() == 2 * REGION && self.regions.iter_mut().enumerate().all(|(i, r)| file.read_at(i * REGION, r));
        for region in &mut self.regions {
            if loaded {
                region.iter_mut().for_each(|b| *b = !*b);
            } else {
                region.fill(0);
            }
        }
        if !loaded {
            (0..2).for_each(|i| self.persist(i, 0, REGION));
        }
    }

    /// Writes `len` bytes at `offset` of `region` through to the host file.
    fn persist(&mut self, region: usize, offset: usize, len: usize) {
        let Some(file) = self.file else { return };
        let Some(cells) = self.regions.get(region).and_then(|r| r.get(offset..offset + len)) else { return };
        let mut chunk = [0u8; 64];
        for (i, part) in cells.chunks(chunk.len()).enumerate() {
            let Some(out) = chunk.get_mut(..part.len()) else { return };
            out.iter_mut().zip(part).for_each(|(o, c)| *o = !c);
            if !file.write_at(region * REGION + offset + i * 64, out) {
                self.file = None;
                return;
            }
        }
    }

    fn span(&mut self, region: u8, offset: usize, len: usize) -> Result<&mut [u8], StorageError> {
        let region = self.regions.get_mut(usize::from(region)).ok_or(StorageError::OutOfRange)?;
        region.get_mut(offset..offset.checked_add(len).ok_or(StorageError::OutOfRange)?).ok_or(StorageError::OutOfRange)
    }
}

impl<const REGION: usize> Storage for RamStorage<REGION> {
    fn region_size(&self) -> usize {
        REGION
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let cells = self.span(region, offset, buf.len())?;
        // A word at a time: every reset reads the whole stored set, and a
        // byte loop made that 11,000 instructions of a reset's 68,000.
        let mut out = buf.chunks_exact_mut(4);
        let mut inp = cells.chunks_exact(4);
        for (o, c) in (&mut out).zip(&mut inp) {
            let word = <[u8; 4]>::try_from(c).map_or(0, |b| !u32::from_ne_bytes(b));
            o.copy_from_slice(&word.to_ne_bytes());
        }
        for (byte, cell) in out.into_remainder().iter_mut().zip(inp.remainder()) {
            *byte = !cell;
        }
        Ok(())
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        self.span(region, 0, REGION)?.fill(0);
        self.persist(usize::from(region), 0, REGION);
        Ok(())
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        // Like flash: programming can only clear bits (set them in the complement).
        for (cell, &byte) in self.span(region, offset, data.len())?.iter_mut().zip(data) {
            *cell |= !byte;
        }
        self.persist(usize::from(region), offset, data.len());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    #[test]
    fn a_new_storage_is_erased() {
        let mut s = RamStorage::<8>::new();
        let mut buf = [0u8; 8];
        s.read(0, 0, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 8]);
        s.read(1, 0, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 8]);
    }

    #[test]
    fn behaves_like_flash() {
        let mut s = RamStorage::<16>::default();
        let mut buf = [0u8; 4];
        s.read(1, 12, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 4]);
        s.write(1, 12, &[0x12, 0x34, 0xF0, 0x0F]).unwrap();
        s.write(1, 14, &[0x0F, 0xF0]).unwrap();
        s.read(1, 12, &mut buf).unwrap();
        assert_eq!(buf, [0x12, 0x34, 0x00, 0x00]);
        s.erase(1).unwrap();
        s.read(1, 12, &mut buf).unwrap();
        assert_eq!(buf, [0xFF; 4]);
        assert_eq!(s.read(2, 0, &mut buf), Err(StorageError::OutOfRange));
        assert_eq!(s.write(0, 14, &[0; 4]), Err(StorageError::OutOfRange));
        assert_eq!(s.read(0, usize::MAX, &mut buf), Err(StorageError::OutOfRange));
    }
}
