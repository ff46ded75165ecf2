//! Flash [`Storage`] for host tests and host builds, with power cuts.
//!
//! Both [`MemStorage`] (RAM only) and [`FileStorage`] (persisted in one file
//! of two regions) are the firmware's own STM32 storage adapter
//! ([`FlashStorage`], the code the STM32 images run) on [`FlashModel`], a
//! model of STM32F1 flash that enforces every rule of the part (RM0008 §3.3,
//! PM0075 §2.3) and of stm32f1xx-hal's `FlashWriter`:
//! - a read starts at an even offset and covers whole half-words;
//! - a half-word is programmed at an even offset, and only when it is
//!   erased (0xFFFF): the part sets PGERR otherwise;
//! - erase works on whole pages (1 KiB on the STM32F103C8, 2 KiB on
//!   high-density parts: [`MemStorage::with_layout`]), at page boundaries,
//!   and never outside the storage pages;
//! - the fresh device is erased (all 0xFF).
//!
//! A call that breaks a rule fails as the HAL's does and is recorded
//! ([`MemStorage::violations`]), so a test can require there were none.
//!
//! **Power cuts.** Every page erase and every half-word program is one
//! *step*, numbered by [`MemStorage::steps`]. [`MemStorage::cut_after`]`(n)`
//! makes the n-th following step fail partway: an erase sets only the first
//! half of its page to 0xFF, a program programs only the low byte. That step
//! and every later operation, reads included, return
//! [`StorageError::Failed`] until [`MemStorage::power_on`], which keeps
//! whatever the cut left behind (and forgets a byte the adapter held back
//! for its half-word, as a reset forgets RAM). So a test can run a sequence
//! once to count its steps, then cut it at every one:
//!
//! ```
//! # use hal_host::storage::MemStorage;
//! # use canopen_core::storage::Storage;
//! let mut s = MemStorage::new(64);
//! s.cut_after(2);
//! assert!(s.erase(0).is_ok()); // step 1: the page
//! assert!(s.write(0, 0, &[0; 4]).is_err()); // step 2: the first half-word, only its low byte
//! assert!(s.read(0, 0, &mut [0; 1]).is_err());
//! s.power_on();
//! assert_eq!(&s.region(0).unwrap()[..4], &[0, 0xFF, 0xFF, 0xFF]);
//! ```
//!
//! Out-of-range calls fail with [`StorageError::OutOfRange`] and are not steps.

use canopen_core::storage::{Storage, StorageError};
pub use firmware::boards::stm32f103::flash_storage::{FlashStorage, HalfWordFlash, Layout};
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::Path;

/// STM32F1 flash as far as the storage pages go: the two regions of a
/// [`Layout`], with the part's rules and power cuts (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct FlashModel {
    layout: Layout,
    /// The bytes from `layout.base` to the end of region 1.
    mem: Vec<u8>,
    steps: u64,
    /// The step number that will be cut.
    cut: Option<u64>,
    powered: bool,
    violations: Vec<String>,
}

impl FlashModel {
    /// Erased flash for `layout`; panics if the layout is not one a part can have.
    pub fn new(layout: Layout) -> FlashModel {
        assert!(layout.is_valid(), "invalid flash layout {layout:?}");
        FlashModel { layout, mem: vec![0xFF; 2 * layout.stride as usize], steps: 0, cut: None, powered: true, violations: Vec::new() }
    }

    /// The rules broken so far, one line each.
    pub fn violations(&self) -> &[String] {
        &self.violations
    }

    fn broken(&mut self, rule: String, error: StorageError) -> Result<(), StorageError> {
        self.violations.push(rule);
        Err(error)
    }

    /// Index into `mem` of `len` bytes at the flash `offset`, if they are storage pages.
    fn index(&self, offset: u32, len: usize) -> Option<usize> {
        let start = offset.checked_sub(self.layout.base)? as usize;
        (start.checked_add(len)? <= self.mem.len()).then_some(start)
    }

    /// Starts a step: whether it is the one cut.
    fn begin_step(&mut self) -> Result<bool, StorageError> {
        if !self.powered {
            return Err(StorageError::Failed);
        }
        self.steps += 1;
        if self.cut == Some(self.steps) {
            self.cut = None;
            self.powered = false;
            return Ok(true);
        }
        Ok(false)
    }
}

impl HalfWordFlash for FlashModel {
    fn layout(&self) -> Layout {
        self.layout
    }

    fn erase_page(&mut self, offset: u32) -> Result<(), StorageError> {
        let page = self.layout.page as usize;
        let Some(i) = self.index(offset, page).filter(|_| offset.is_multiple_of(self.layout.page)) else {
            return self.broken(format!("erase at {offset:#x}: not a storage page boundary"), StorageError::OutOfRange);
        };
        let cut = self.begin_step()?;
        let done = if cut { page / 2 } else { page };
        self.mem[i..i + done].fill(0xFF);
        if cut { Err(StorageError::Failed) } else { Ok(()) }
    }

    fn program(&mut self, offset: u32, half_word: u16) -> Result<(), StorageError> {
        let Some(i) = self.index(offset, 2).filter(|_| offset.is_multiple_of(2)) else {
            return self.broken(format!("program at {offset:#x}: odd or outside the storage pages"), StorageError::OutOfRange);
        };
        if self.mem[i..i + 2] != [0xFF, 0xFF] {
            // PGERR: the half-word was not erased.
            let old = u16::from_le_bytes([self.mem[i], self.mem[i + 1]]);
            return self.broken(format!("program {half_word:#06x} at {offset:#x}: holds {old:#06x}, not erased"), StorageError::Failed);
        }
        let cut = self.begin_step()?;
        let [low, high] = half_word.to_le_bytes();
        self.mem[i] = low;
        if cut {
            return Err(StorageError::Failed);
        }
        self.mem[i + 1] = high;
        Ok(())
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), StorageError> {
        let Some(i) = self.index(offset, buf.len()).filter(|_| offset.is_multiple_of(2) && buf.len().is_multiple_of(2)) else {
            let len = buf.len();
            return self.broken(
                format!("read of {len} bytes at {offset:#x}: not whole half-words in the storage pages"),
                StorageError::OutOfRange,
            );
        };
        if !self.powered {
            return Err(StorageError::Failed);
        }
        buf.copy_from_slice(&self.mem[i..i + buf.len()]);
        Ok(())
    }
}

/// The layout of a host storage of `region_size` bytes per region: 1 KiB
/// pages (the F103C8's) when a region is at least a page, else one page
/// per region.
fn host_layout(region_size: usize) -> Layout {
    let region = region_size.next_multiple_of(2) as u32;
    let page = if region >= 1024 { 1024 } else { region.max(2) };
    Layout { base: 0, page, stride: region.next_multiple_of(page), region }
}

macro_rules! power_cut_api {
    () => {
        /// Page erases and half-word programs started so far (out-of-range
        /// calls and calls while the power is off are not counted).
        pub fn steps(&self) -> u64 {
            self.flash.flash().steps
        }

        /// Cuts the power during the n-th following erase/program step
        /// (1 = the next one), which then completes partway;
        /// `n == 0` cuts the power now, before any further step.
        pub fn cut_after(&mut self, n: u64) {
            let model = self.flash.flash_mut();
            if n == 0 {
                model.powered = false;
                model.cut = None;
            } else {
                model.cut = Some(model.steps.saturating_add(n));
            }
        }

        /// Restores the power (and cancels a pending cut); the flash stays
        /// as the cut left it, and what the adapter held in RAM is gone.
        pub fn power_on(&mut self) {
            let model = self.flash.flash().clone();
            self.flash = FlashStorage::new(model);
            let model = self.flash.flash_mut();
            model.powered = true;
            model.cut = None;
        }

        /// Whether operations currently succeed.
        pub fn is_powered(&self) -> bool {
            self.flash.flash().powered
        }

        /// The raw contents of `region` (0 or 1), even with the power off.
        pub fn region(&self, region: u8) -> Option<&[u8]> {
            let model = self.flash.flash();
            let start = usize::from(region).checked_mul(model.layout.stride as usize).filter(|_| region <= 1)?;
            model.mem.get(start..start + model.layout.region as usize)
        }

        /// The flash rules broken so far (see the [module docs](self)).
        pub fn violations(&self) -> &[String] {
            self.flash.flash().violations()
        }
    };
}

/// Two regions of flash in RAM; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct MemStorage {
    flash: FlashStorage<FlashModel>,
}

impl MemStorage {
    /// Erased storage with two regions of `region_size` bytes (rounded up
    /// to a half-word) on 1 KiB pages.
    pub fn new(region_size: usize) -> MemStorage {
        MemStorage::with_layout(host_layout(region_size))
    }

    /// Erased storage on flash of `layout` (e.g. 2 KiB pages, as a
    /// high-density STM32F1 has).
    pub fn with_layout(layout: Layout) -> MemStorage {
        MemStorage { flash: FlashStorage::new(FlashModel::new(layout)) }
    }

    power_cut_api!();
}

impl Storage for MemStorage {
    fn region_size(&self) -> usize {
        self.flash.region_size()
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        self.flash.read(region, offset, buf)
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        self.flash.erase(region)
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        self.flash.write(region, offset, data)
    }
}

/// Two regions of flash kept in one file (region 0, then region 1), so a
/// host node keeps its stored parameters across restarts. Every erase and
/// write writes what the flash holds through to the file, a cut one included.
#[derive(Debug)]
pub struct FileStorage {
    flash: FlashStorage<FlashModel>,
    file: File,
}

impl FileStorage {
    /// Opens `path`, creating it erased (all 0xFF) if it does not exist.
    /// An existing file must be exactly `2 × region_size` bytes long
    /// (`region_size` rounded up to a half-word).
    pub fn open(path: impl AsRef<Path>, region_size: usize) -> io::Result<FileStorage> {
        let region = region_size.next_multiple_of(2);
        let layout = Layout { base: 0, page: region.max(2) as u32, stride: region.max(2) as u32, region: region as u32 };
        let mut model = FlashModel::new(layout);
        let total = model.mem.len();
        let mut file = OpenOptions::new().read(true).write(true).create(true).truncate(false).open(path)?;
        let len = file.metadata()?.len();
        if len == 0 {
            file.write_all(&model.mem)?;
            file.flush()?;
        } else if usize::try_from(len).ok() == Some(total) {
            model.mem.clear();
            file.read_to_end(&mut model.mem)?;
        } else {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("storage file is {len} bytes, expected {total} (2 regions of {region})"),
            ));
        }
        Ok(FileStorage { flash: FlashStorage::new(model), file })
    }

    power_cut_api!();

    fn persist(&mut self, result: Result<(), StorageError>) -> Result<(), StorageError> {
        let mem = &self.flash.flash().mem;
        let synced = self.file.seek(SeekFrom::Start(0)).and_then(|_| self.file.write_all(mem)).and_then(|()| self.file.flush());
        synced.map_err(|_| StorageError::Failed)?;
        result
    }
}

impl Storage for FileStorage {
    fn region_size(&self) -> usize {
        self.flash.region_size()
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        self.flash.read(region, offset, buf)
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        let result = self.flash.erase(region);
        self.persist(result)
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let result = self.flash.write(region, offset, data);
        self.persist(result)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c8(region: usize) -> Layout {
        Layout::stm32f103c8(region)
    }

    #[test]
    fn the_model_enforces_the_parts_rules() {
        // The b maXX 4400's set: two pages a region, from 60 KiB.
        let mut f = FlashModel::new(c8(1114));
        let base = 60 * 1024;
        assert_eq!(f.layout().base, base);
        let mut two = [0u8; 2];
        assert_eq!(f.read(base + 1, &mut two), Err(StorageError::OutOfRange), "odd offset (the HAL's AddressMisaligned)");
        assert_eq!(f.read(base, &mut [0u8; 3]), Err(StorageError::OutOfRange), "odd length");
        assert_eq!(f.read(base - 2, &mut two), Err(StorageError::OutOfRange), "below the storage pages");
        assert_eq!(f.program(base + 3, 0x1234), Err(StorageError::OutOfRange), "odd program");
        assert_eq!(f.program(base - 2, 0x1234), Err(StorageError::OutOfRange), "program into the program");
        assert_eq!(f.erase_page(base + 2), Err(StorageError::OutOfRange), "erase off a page boundary");
        assert_eq!(f.erase_page(base - 1024), Err(StorageError::OutOfRange), "erase a program page");
        assert_eq!(f.violations().len(), 7);
        assert_eq!(f.steps, 0, "refused calls are not steps");

        f.program(base + 4, 0x1234).unwrap();
        assert_eq!(f.program(base + 4, 0x1234), Err(StorageError::Failed), "programmed twice (PGERR), even with the same value");
        assert_eq!(f.program(base + 4, 0x0000), Err(StorageError::Failed), "clearing bits without an erase is refused too");
        f.read(base + 4, &mut two).unwrap();
        assert_eq!(two, [0x34, 0x12]);
        // A page erase clears exactly its 1 KiB page.
        f.program(base + 1024, 0x5678).unwrap();
        f.erase_page(base).unwrap();
        f.read(base + 4, &mut two).unwrap();
        assert_eq!(two, [0xFF, 0xFF]);
        f.read(base + 1024, &mut two).unwrap();
        assert_eq!(two, [0x78, 0x56], "the next page stays");
        f.program(base + 4, 0x0001).unwrap();
        assert_eq!(f.violations().len(), 9);
    }

    #[test]
    fn the_adapter_keeps_every_rule_with_odd_ranges() {
        let mut s = MemStorage::with_layout(c8(64));
        s.erase(1).unwrap();
        s.write(1, 24, &[1, 2, 3]).unwrap();
        s.write(1, 27, &[4]).unwrap();
        s.write(1, 28, &[5]).unwrap();
        s.write(1, 29, &[6, 7]).unwrap();
        let mut buf = [0u8; 7];
        s.read(1, 24, &mut buf).unwrap();
        assert_eq!(buf, [1, 2, 3, 4, 5, 6, 7], "the pending byte reads back");
        s.write(1, 0, &[9; 24]).unwrap();
        for (offset, len) in [(24, 7), (25, 6), (25, 1), (30, 1), (0, 31), (1, 30)] {
            let mut got = vec![0u8; len];
            s.read(1, offset, &mut got).unwrap();
            let all: Vec<u8> = [9; 24].into_iter().chain([1, 2, 3, 4, 5, 6, 7]).collect();
            assert_eq!(got, all[offset..offset + len], "read of {len} at {offset}");
        }
        // A lone odd byte after a gap.
        s.write(1, 41, &[0xAB]).unwrap();
        s.write(1, 50, &[]).unwrap();
        let mut b = [0u8; 3];
        s.read(1, 40, &mut b).unwrap();
        assert_eq!(b, [0xFF, 0xAB, 0xFF]);
        assert_eq!(s.write(2, 0, &[1]), Err(StorageError::OutOfRange));
        assert_eq!(s.write(0, 63, &[1, 2]), Err(StorageError::OutOfRange));
        assert!(s.violations().is_empty(), "{:?}", s.violations());
    }

    #[test]
    fn a_store_erases_only_the_pages_its_set_needs() {
        for (page, region, pages) in [(1024, 1000, 1), (1024, 1024, 1), (1024, 1114, 2), (2048, 1114, 1)] {
            let layout = Layout { base: 0, page, stride: 2048.max(page), region };
            let mut s = MemStorage::with_layout(layout);
            s.erase(1).unwrap();
            assert_eq!(s.steps(), pages, "{region} bytes on {page}-byte pages");
        }
        // Region 1 starts a stride after region 0, on its own pages: on the
        // STM32F103C8 a set of one page has one-page regions at 62 and 63 KiB,
        // and the page below them is the program's.
        let mut f = FlashModel::new(c8(600));
        assert_eq!((f.layout().base, f.layout().stride), (62 * 1024, 1024));
        assert_eq!(f.erase_page(61 * 1024), Err(StorageError::OutOfRange), "a program page");
        f.erase_page(63 * 1024).unwrap();
        let mut s = MemStorage::with_layout(c8(600));
        s.write(0, 0, &[0; 600]).unwrap();
        s.erase(1).unwrap();
        assert_eq!(s.region(0).unwrap(), &[0; 600], "erasing region 1 leaves region 0");
    }

    #[test]
    fn a_cut_erase_leaves_the_page_half_erased() {
        let mut s = MemStorage::new(8);
        s.write(0, 0, &[0; 8]).unwrap();
        let before = s.steps();
        s.cut_after(1);
        assert_eq!(s.erase(0), Err(StorageError::Failed));
        assert!(!s.is_powered());
        assert_eq!(s.erase(0), Err(StorageError::Failed), "still off");
        assert_eq!(s.write(1, 0, &[0, 0]), Err(StorageError::Failed));
        assert_eq!(s.read(0, 0, &mut [0]), Err(StorageError::Failed));
        assert_eq!(s.steps(), before + 1, "calls while off are not steps");
        s.power_on();
        assert_eq!(s.region(0).unwrap(), &[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]);
        assert_eq!(s.region(1).unwrap(), &[0xFF; 8]);
        s.erase(0).unwrap();
        assert_eq!(s.region(0).unwrap(), &[0xFF; 8]);
    }

    #[test]
    fn a_cut_program_leaves_its_half_word_partly_programmed() {
        let mut s = MemStorage::new(8);
        s.cut_after(3);
        assert_eq!(s.write(1, 0, &[0x10, 0x11, 0x12, 0x13, 0x14, 0x15]), Err(StorageError::Failed));
        s.power_on();
        assert_eq!(s.region(1).unwrap(), &[0x10, 0x11, 0x12, 0x13, 0x14, 0xFF, 0xFF, 0xFF]);
        assert_eq!(s.write(1, 4, &[0x14, 0x15]), Err(StorageError::Failed), "that half-word needs an erase first");
        assert_eq!(s.violations().len(), 1);
    }

    #[test]
    fn power_on_forgets_a_byte_held_for_its_half_word() {
        let mut s = MemStorage::new(8);
        s.write(0, 0, &[1, 2, 3]).unwrap();
        let mut b = [0u8; 3];
        s.read(0, 0, &mut b).unwrap();
        assert_eq!(b, [1, 2, 3]);
        s.cut_after(0);
        s.power_on();
        s.read(0, 0, &mut b).unwrap();
        assert_eq!(b, [1, 2, 0xFF], "the third byte was still in RAM");
    }

    #[test]
    fn cut_now_and_cancelled_cuts() {
        let mut s = MemStorage::new(4);
        s.cut_after(0);
        assert_eq!(s.write(0, 0, &[0, 0]), Err(StorageError::Failed));
        s.power_on();
        assert_eq!(s.region(0).unwrap(), &[0xFF; 4]);
        s.cut_after(2);
        s.power_on(); // cancels the pending cut
        for _ in 0..3 {
            s.erase(0).unwrap();
        }
    }

    /// Writes a two-region "parameter set": erase the spare region, write the
    /// payload, then a marker half-word (the core's store follows this shape).
    fn store(s: &mut MemStorage, payload: &[u8]) -> Result<(), StorageError> {
        s.erase(1)?;
        s.write(1, 2, payload)?;
        s.write(1, 0, &[0xA5, 0xA5])
    }

    #[test]
    fn cutting_at_every_step_of_a_sequence() {
        let mut probe = MemStorage::new(8);
        store(&mut probe, &[1, 2, 3, 4]).unwrap();
        let n = probe.steps();
        assert_eq!(n, 4, "one page, three half-words");
        for k in 1..=n {
            let mut s = MemStorage::new(8);
            s.write(1, 0, &[0x00, 0x00, 9, 9]).unwrap(); // an old, marked set
            s.cut_after(k);
            assert_eq!(store(&mut s, &[1, 2, 3, 4]), Err(StorageError::Failed), "cut at step {k}");
            s.power_on();
            assert_ne!(s.region(1).unwrap()[..2], [0xA5, 0xA5], "an interrupted store is never marked valid (step {k})");
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
        assert_eq!(std::fs::read(&path).unwrap(), [0, 0xFF, 0xFF, 0xFF, 0x12, 0x34, 0xFF, 0xFF]);
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
