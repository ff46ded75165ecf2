//! Flash-like [`Storage`] for host tests and host builds, with power cuts.
//!
//! Both [`MemStorage`] (RAM only) and [`FileStorage`] (persisted in one file
//! of two regions) behave like NOR flash:
//! - erase sets every byte of a region to 0xFF;
//! - programming can only clear bits: the new byte is the old byte AND the
//!   written byte, so writing over bytes not erased is allowed but ANDs;
//! - the fresh device is erased (all 0xFF).
//!
//! **Power cuts.** Every erase and every write is one *step*, numbered by
//! [`MemStorage::steps`]. [`MemStorage::cut_after`]`(n)` makes the n-th
//! following step fail partway: an erase sets only the first half of the
//! region to 0xFF, a write programs only the first half of its bytes (or
//! `keep` bytes with [`MemStorage::cut_after_keeping`]). That step and every
//! later operation, reads included, return [`StorageError::Failed`] until
//! [`MemStorage::power_on`], which keeps whatever the cut left behind. So a
//! test can run a sequence once to count its steps, then cut it at every one:
//!
//! ```
//! # use hal_host::storage::MemStorage;
//! # use canopen_core::storage::Storage;
//! let mut s = MemStorage::new(64);
//! s.cut_after(2);
//! assert!(s.erase(0).is_ok());
//! assert!(s.write(0, 0, &[0; 8]).is_err()); // step 2: only 4 bytes programmed
//! assert!(s.read(0, 0, &mut [0; 1]).is_err());
//! s.power_on();
//! assert_eq!(&s.region(0).unwrap()[..9], &[0, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]);
//! ```
//!
//! Out-of-range calls fail with [`StorageError::OutOfRange`] and are not steps.

use canopen_core::storage::{Storage, StorageError};
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::path::Path;

/// How much of the step a power cut lets through.
#[derive(Clone, Copy, Debug)]
enum Keep {
    Half,
    Bytes(usize),
}

/// The flash semantics and power-cut state both storages share.
#[derive(Clone, Debug)]
struct Flash {
    image: Vec<u8>,
    region_size: usize,
    steps: u64,
    /// The step number that will be cut, and how much of it completes.
    cut: Option<(u64, Keep)>,
    powered: bool,
}

/// How far a step got: the bytes it touched and whether it finished.
type StepResult = (Range<usize>, Result<(), StorageError>);

impl Flash {
    fn new(image: Vec<u8>, region_size: usize) -> Flash {
        Flash { image, region_size, steps: 0, cut: None, powered: true }
    }

    fn range(&self, region: u8, offset: usize, len: usize) -> Result<Range<usize>, StorageError> {
        if region > 1 {
            return Err(StorageError::OutOfRange);
        }
        let end = offset.checked_add(len).filter(|&e| e <= self.region_size).ok_or(StorageError::OutOfRange)?;
        let base = usize::from(region) * self.region_size;
        Ok(base + offset..base + end)
    }

    /// Starts a step over `len` bytes: how many of them get done, and
    /// whether the step fails.
    fn begin_step(&mut self, len: usize) -> Result<(usize, bool), StorageError> {
        if !self.powered {
            return Err(StorageError::Failed);
        }
        self.steps += 1;
        match self.cut {
            Some((step, keep)) if step == self.steps => {
                self.cut = None;
                self.powered = false;
                let done = match keep {
                    Keep::Half => len / 2,
                    Keep::Bytes(n) => n.min(len),
                };
                Ok((done, true))
            }
            _ => Ok((len, false)),
        }
    }

    fn read(&self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let r = self.range(region, offset, buf.len())?;
        if !self.powered {
            return Err(StorageError::Failed);
        }
        buf.copy_from_slice(self.image.get(r).ok_or(StorageError::OutOfRange)?);
        Ok(())
    }

    fn erase(&mut self, region: u8) -> StepResult {
        let r = match self.range(region, 0, self.region_size) {
            Ok(r) => r,
            Err(e) => return (0..0, Err(e)),
        };
        let (done, cut) = match self.begin_step(r.len()) {
            Ok(x) => x,
            Err(e) => return (0..0, Err(e)),
        };
        let touched = r.start..r.start + done;
        if let Some(bytes) = self.image.get_mut(touched.clone()) {
            bytes.fill(0xFF);
        }
        (touched, if cut { Err(StorageError::Failed) } else { Ok(()) })
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> StepResult {
        let r = match self.range(region, offset, data.len()) {
            Ok(r) => r,
            Err(e) => return (0..0, Err(e)),
        };
        let (done, cut) = match self.begin_step(r.len()) {
            Ok(x) => x,
            Err(e) => return (0..0, Err(e)),
        };
        let touched = r.start..r.start + done;
        if let Some(bytes) = self.image.get_mut(touched.clone()) {
            for (b, d) in bytes.iter_mut().zip(data) {
                *b &= *d;
            }
        }
        (touched, if cut { Err(StorageError::Failed) } else { Ok(()) })
    }

    fn region(&self, region: u8) -> Option<&[u8]> {
        self.range(region, 0, self.region_size).ok().and_then(|r| self.image.get(r))
    }

    fn cut_after(&mut self, n: u64, keep: Keep) {
        if n == 0 {
            self.powered = false;
            self.cut = None;
        } else {
            self.cut = Some((self.steps.saturating_add(n), keep));
        }
    }

    fn power_on(&mut self) {
        self.powered = true;
        self.cut = None;
    }
}

macro_rules! power_cut_api {
    () => {
        /// Erase and write steps started so far (out-of-range calls and
        /// calls while the power is off are not counted).
        pub fn steps(&self) -> u64 {
            self.flash.steps
        }

        /// Cuts the power during the n-th following erase/write step
        /// (1 = the next one), which then completes half of its bytes;
        /// `n == 0` cuts the power now, before any further step.
        pub fn cut_after(&mut self, n: u64) {
            self.flash.cut_after(n, Keep::Half);
        }

        /// Like [`cut_after`](Self::cut_after), but the cut step completes
        /// its first `keep` bytes (at most all of them).
        pub fn cut_after_keeping(&mut self, n: u64, keep: usize) {
            self.flash.cut_after(n, Keep::Bytes(keep));
        }

        /// Restores the power (and cancels a pending cut); the contents stay
        /// as the cut left them.
        pub fn power_on(&mut self) {
            self.flash.power_on();
        }

        /// Whether operations currently succeed.
        pub fn is_powered(&self) -> bool {
            self.flash.powered
        }

        /// The raw contents of `region` (0 or 1), even with the power off.
        pub fn region(&self, region: u8) -> Option<&[u8]> {
            self.flash.region(region)
        }
    };
}

/// Two regions of flash in RAM; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct MemStorage {
    flash: Flash,
}

impl MemStorage {
    /// Erased storage with two regions of `region_size` bytes (allocated
    /// up front, like any `Vec`).
    pub fn new(region_size: usize) -> MemStorage {
        MemStorage { flash: Flash::new(vec![0xFF; region_size.saturating_mul(2)], region_size) }
    }

    power_cut_api!();
}

impl Storage for MemStorage {
    fn region_size(&self) -> usize {
        self.flash.region_size
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        self.flash.read(region, offset, buf)
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        self.flash.erase(region).1
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        self.flash.write(region, offset, data).1
    }
}

/// Two regions of flash kept in one file (region 0, then region 1), so a
/// host node keeps its stored parameters across restarts. Every step writes
/// the bytes it touched through to the file, a cut step included.
#[derive(Debug)]
pub struct FileStorage {
    flash: Flash,
    file: File,
}

impl FileStorage {
    /// Opens `path`, creating it erased (all 0xFF) if it does not exist.
    /// An existing file must be exactly `2 × region_size` bytes long.
    pub fn open(path: impl AsRef<Path>, region_size: usize) -> io::Result<FileStorage> {
        let total = region_size.checked_mul(2).ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "region size too large"))?;
        let mut file = OpenOptions::new().read(true).write(true).create(true).truncate(false).open(path)?;
        let len = file.metadata()?.len();
        let image = if len == 0 {
            let image = vec![0xFF; total];
            file.write_all(&image)?;
            file.flush()?;
            image
        } else if usize::try_from(len).ok() == Some(total) {
            let mut image = Vec::with_capacity(total);
            file.read_to_end(&mut image)?;
            image
        } else {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("storage file is {len} bytes, expected {total} (2 regions of {region_size})"),
            ));
        };
        Ok(FileStorage { flash: Flash::new(image, region_size), file })
    }

    power_cut_api!();

    fn persist(&mut self, (touched, result): StepResult) -> Result<(), StorageError> {
        if !touched.is_empty() {
            let bytes = self.flash.image.get(touched.clone()).ok_or(StorageError::Failed)?;
            let synced = self
                .file
                .seek(SeekFrom::Start(touched.start as u64))
                .and_then(|_| self.file.write_all(bytes))
                .and_then(|()| self.file.flush());
            synced.map_err(|_| StorageError::Failed)?;
        }
        result
    }
}

impl Storage for FileStorage {
    fn region_size(&self) -> usize {
        self.flash.region_size
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        self.flash.read(region, offset, buf)
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        let step = self.flash.erase(region);
        self.persist(step)
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let step = self.flash.write(region, offset, data);
        self.persist(step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresh_storage_is_erased_and_writes_and() {
        let mut s = MemStorage::new(16);
        assert_eq!(s.region_size(), 16);
        assert_eq!(s.region(1).unwrap(), &[0xFF; 16]);
        s.write(1, 2, &[0xF0, 0x3C]).unwrap();
        s.write(1, 2, &[0x0F, 0xFF]).unwrap(); // over unerased bytes: ANDs
        let mut buf = [0; 4];
        s.read(1, 1, &mut buf).unwrap();
        assert_eq!(buf, [0xFF, 0x00, 0x3C, 0xFF]);
        assert_eq!(s.region(0).unwrap(), &[0xFF; 16], "region 0 untouched");
        s.erase(1).unwrap();
        assert_eq!(s.region(1).unwrap(), &[0xFF; 16]);
        assert_eq!(s.steps(), 3);
    }

    #[test]
    fn out_of_range_is_refused_and_not_a_step() {
        let mut s = MemStorage::new(8);
        assert_eq!(s.erase(2), Err(StorageError::OutOfRange));
        assert_eq!(s.write(0, 7, &[0, 0]), Err(StorageError::OutOfRange));
        assert_eq!(s.write(0, usize::MAX, &[0]), Err(StorageError::OutOfRange));
        assert_eq!(s.read(1, 9, &mut []), Err(StorageError::OutOfRange));
        assert_eq!(s.read(255, 0, &mut [0]), Err(StorageError::OutOfRange));
        assert_eq!(s.steps(), 0);
        assert!(s.write(0, 8, &[]).is_ok(), "an empty write at the end is in range");
        assert!(s.region(2).is_none());
    }

    #[test]
    fn a_cut_erase_leaves_the_region_half_erased() {
        let mut s = MemStorage::new(8);
        s.write(0, 0, &[0; 8]).unwrap();
        s.cut_after(1);
        assert_eq!(s.erase(0), Err(StorageError::Failed));
        assert!(!s.is_powered());
        assert_eq!(s.erase(0), Err(StorageError::Failed), "still off");
        assert_eq!(s.write(1, 0, &[0]), Err(StorageError::Failed));
        assert_eq!(s.read(0, 0, &mut [0]), Err(StorageError::Failed));
        assert_eq!(s.steps(), 2, "calls while off are not steps");
        s.power_on();
        assert_eq!(s.region(0).unwrap(), &[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]);
        assert_eq!(s.region(1).unwrap(), &[0xFF; 8]);
        s.erase(0).unwrap();
        assert_eq!(s.region(0).unwrap(), &[0xFF; 8]);
    }

    #[test]
    fn a_cut_write_programs_a_prefix() {
        let mut s = MemStorage::new(8);
        s.cut_after_keeping(3, 5);
        s.write(0, 0, &[1]).unwrap();
        s.write(0, 1, &[2]).unwrap();
        assert_eq!(s.write(1, 1, &[0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16]), Err(StorageError::Failed));
        s.power_on();
        assert_eq!(s.region(1).unwrap(), &[0xFF, 0x10, 0x11, 0x12, 0x13, 0x14, 0xFF, 0xFF]);
        let mut t = MemStorage::new(4);
        t.cut_after_keeping(1, 99);
        assert_eq!(t.write(0, 0, &[0, 0]), Err(StorageError::Failed), "even a complete step reports the cut");
        t.power_on();
        assert_eq!(t.region(0).unwrap(), &[0, 0, 0xFF, 0xFF]);
    }

    #[test]
    fn cut_now_and_cancelled_cuts() {
        let mut s = MemStorage::new(4);
        s.cut_after(0);
        assert_eq!(s.write(0, 0, &[0]), Err(StorageError::Failed));
        s.power_on();
        assert_eq!(s.region(0).unwrap(), &[0xFF; 4]);
        s.cut_after(2);
        s.power_on(); // cancels the pending cut
        for _ in 0..3 {
            s.erase(0).unwrap();
        }
    }

    /// Writes a two-region "parameter set": erase the spare region, write the
    /// payload, then a marker byte (the core's store follows this shape).
    fn store(s: &mut MemStorage, payload: &[u8]) -> Result<(), StorageError> {
        s.erase(1)?;
        s.write(1, 1, payload)?;
        s.write(1, 0, &[0xA5])
    }

    #[test]
    fn cutting_at_every_step_of_a_sequence() {
        let mut probe = MemStorage::new(8);
        store(&mut probe, &[1, 2, 3, 4]).unwrap();
        let n = probe.steps();
        assert_eq!(n, 3);
        for k in 1..=n {
            let mut s = MemStorage::new(8);
            s.write(1, 0, &[0x00, 9, 9]).unwrap(); // an old, marked set
            s.cut_after(k);
            assert_eq!(store(&mut s, &[1, 2, 3, 4]), Err(StorageError::Failed), "cut at step {k}");
            s.power_on();
            let marker = s.region(1).unwrap()[0];
            assert_ne!(marker, 0xA5, "an interrupted store is never marked valid (step {k})");
        }
    }

    fn temp_path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("hal-host-{}-{name}.bin", std::process::id()))
    }

    #[test]
    fn file_storage_persists_every_step() {
        let path = temp_path("persist");
        let _ = std::fs::remove_file(&path);
        {
            let mut s = FileStorage::open(&path, 4).unwrap();
            assert_eq!(s.region(0).unwrap(), &[0xFF; 4]);
            s.write(1, 0, &[0x12, 0x34]).unwrap();
            s.cut_after(1);
            assert_eq!(s.write(0, 0, &[0, 0, 0, 0]), Err(StorageError::Failed));
        }
        assert_eq!(std::fs::read(&path).unwrap(), [0, 0, 0xFF, 0xFF, 0x12, 0x34, 0xFF, 0xFF]);
        let mut s = FileStorage::open(&path, 4).unwrap();
        let mut buf = [0; 2];
        s.read(1, 0, &mut buf).unwrap();
        assert_eq!(buf, [0x12, 0x34]);
        s.erase(0).unwrap();
        assert_eq!(s.steps(), 1);
        drop(s);
        assert_eq!(std::fs::read(&path).unwrap(), [0xFF, 0xFF, 0xFF, 0xFF, 0x12, 0x34, 0xFF, 0xFF]);
        let err = FileStorage::open(&path, 8).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidData);
        std::fs::remove_file(&path).unwrap();
    }
}
